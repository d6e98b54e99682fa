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


def raise_if_interrupted(exc: BaseException) -> None:
    """Re-raise Ctrl-C that ``exc`` wraps, so that an interrupt is never recorded as a failure.

    Python runs its SIGINT handler between bytecodes; a signal that lands inside a compiled
    (numba) call surfaces when the call returns, as a ``SystemError`` whose cause is the
    ``KeyboardInterrupt``.
    """
    seen = exc
    while seen is not None:
        if isinstance(seen, KeyboardInterrupt):
            raise KeyboardInterrupt from exc
        seen = seen.__cause__ or seen.__context__


class RunsInterruptedError(ConjureError):
    """Ctrl-C stopped a sweep or experiment; the message says what is saved (exit status 130)."""

    exit_status = 130


class RunsFailedError(ConjureError, RuntimeError):
    """No run of an experiment finished: every one failed (exit status 1)."""

    exit_status = 1


class ResultsWriteError(ConjureError, OSError):
    """A result file could not be written (disk full, file-size limit); exit status 2."""

    exit_status = 2


def write_failure(exc: OSError, kept: str) -> ResultsWriteError:
    """One line for a failed write: the file, the cause and its errno, then what is ``kept``.

    Examples
    --------
    >>> import errno
    >>> cause = OSError(errno.EFBIG, "File too large", "out/planned.csv")
    >>> print(write_failure(cause, "no run has started."))
    Could not write out/planned.csv: File too large (errno 27); no run has started. Free space (or raise the file-size limit) and rerun the same command: it resumes.
    """  # noqa: E501
    return ResultsWriteError(
        f"Could not write {exc.filename}: {exc.strerror or exc} (errno {exc.errno}); {kept} "
        "Free space (or raise the file-size limit) and rerun the same command: it resumes."
    )
