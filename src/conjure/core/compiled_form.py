"""The contract between a component and the compiled learning loop (`conjure.compiled`).

A component with a numba kernel exposes it through one public method, ``compiled_form()``,
that returns a named tuple of typed fields (its constants, and the arrays its kernel updates in
place) which its own layer's kernels read by name; the compiled loop only composes those
kernels. A component without one returns None (the run takes the Python path).

Two class attributes complete the contract:

- ``compiled_methods``: the Python methods the kernel stands in for (a domain's ``step`` and
  ``reset``). `compiled_form` below answers None when a subclass overrides one of them, so a
  user's subclass never has its override skipped silently.
- ``compiled_irrelevant_params``: the ``get_params()`` keys the kernel does not need (for
  example a parameter only ``setup`` reads, already folded into the tables). The shipped common
  check `conjure.testing.checks.check_compiled_form_covers_params` asserts that changing any
  other key changes the compiled form.
"""

from __future__ import annotations

from typing import Any

__all__ = ["compiled_form"]


def compiled_form(component: Any) -> Any | None:
    """``component.compiled_form()``, or None when it has none or a subclass overrode its kernel.

    Examples
    --------
    >>> from conjure.policies import EpsilonGreedy
    >>> compiled_form(EpsilonGreedy(epsilon=0.2)).parameter
    0.2
    >>> class Mine(EpsilonGreedy):
    ...     def select(self, values, rng, legal_actions):
    ...         return 0
    >>> compiled_form(Mine()) is None
    True
    """
    method = getattr(component, "compiled_form", None)
    if method is None:
        return None
    cls = type(component)
    owner = _owner(cls, "compiled_form")
    for name in getattr(component, "compiled_methods", ()):
        if not issubclass(owner, _owner(cls, name)):
            return None  # overridden below the class whose kernel stands in for it
    return method()


def _owner(cls: type, name: str) -> type:
    """The class of ``cls``'s method resolution order that defines ``name``."""
    return next(klass for klass in cls.__mro__ if name in vars(klass))
