"""Lazy package exports: a name is imported from its submodule on first use (PEP 562).

A layer's package (``conjure.agents``, ``conjure.planners``, ...) lists its public names and
the submodule defining each; ``from conjure.agents import SARSA`` then imports
``conjure.agents.sarsa`` alone, not the batch learners and SciPy with it. This keeps
``conjure --help`` and a run's memory to what the command uses.
"""

from __future__ import annotations

import importlib
import sys
from collections.abc import Callable, Mapping
from typing import Any

__all__ = ["lazy_exports"]


def lazy_exports(
    package: str, exports: Mapping[str, str]
) -> tuple[Callable[[str], Any], Callable[[], list[str]]]:
    """Return the ``__getattr__`` and ``__dir__`` of ``package`` exporting ``exports`` lazily.

    Parameters
    ----------
    package : str
        The package's ``__name__``.
    exports : mapping of str to str
        Each public name and the submodule (relative to ``package``) that defines it.

    Examples
    --------
    >>> import conjure.agents as agents
    >>> agents.SARSA.__module__
    'conjure.agents.sarsa'
    """

    def __getattr__(name: str) -> Any:
        if name not in exports:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(f"{package}.{exports[name]}"), name)
        setattr(sys.modules[package], name, value)
        return value

    def __dir__() -> list[str]:
        return sorted({*vars(sys.modules[package]), *exports})

    return __getattr__, __dir__
