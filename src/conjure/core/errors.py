"""The one error hierarchy of conjure.

Every error conjure raises on purpose is a :class:`ConjureError`. The subclasses also derive
from the built-in exception a Python user would expect (``ValueError`` for a bad value), so
``except ValueError`` keeps working.
"""

from __future__ import annotations


class ConjureError(Exception):
    """Base class of every error raised on purpose by conjure."""


class InvalidParameterError(ConjureError, ValueError):
    """A parameter, config field or domain input has a bad value or type."""


class NotSetUpError(ConjureError, RuntimeError):
    """A component was used before ``setup`` built its state."""


class IncompatibleComponentsError(ConjureError, TypeError):
    """Two components cannot work together (e.g. a dense representation where binary is needed)."""


class DivergenceError(ConjureError, ArithmeticError):
    """A learner produced a non-finite value (the TD error or a weight)."""
