"""Numba's on-disk cache of conjure's kernels, invalidated by the sources each may reach.

Numba keys a cached function on its own file only: after an edit to a kernel in another file
(`conjure.agents.compiled_agent`'s TD update, say), the cached loop that inlined the old one
(`conjure.compiled.learning_loop`) loads and runs the old code, and a function compiled anew
beside it can read a stale environment (numba: "'descr' is NULL"). A researcher changing a
kernel in an editable install would measure code that is no longer there.

`KernelSourceLocator` stamps a kernel with the contents of every module it could call,
inline or read a constant from: by the package's layers (``[tool.importlinter]`` in
pyproject.toml, `LAYERS` here), every module of its own layer and the layers below; for a
module outside the layers (`conjure.testing`, `conjure.examples`, the package's own files),
every module. An edit recompiles the kernels above it on their next call and no others (an
edit to `conjure.cli` recompiles nothing). Where a kernel is cached (the folder beside its
module or numba's user-wide one) stays numba's choice. Importing this module registers the
locator; `conjure.core` imports it before anything else, so it is in place before any
conjure kernel is defined.
"""

from __future__ import annotations

import functools
import hashlib
from pathlib import Path

from numba.core import caching

__all__ = ["LAYERS", "KernelSourceLocator", "kernel_sources_digest", "layer_of"]

PACKAGE = Path(__file__).resolve().parent.parent
#: The package's layers, top to bottom, as in pyproject.toml's import-linter contract.
LAYERS = (
    ("cli",),
    ("reporting", "sweeps"),
    ("experiments",),
    ("compiled",),
    ("safety",),
    ("agents", "planners"),
    ("domains", "representations", "policies"),
    ("models",),
    ("core",),
)


def layer_of(path: Path, root: Path = PACKAGE) -> int:
    """The index in `LAYERS` of the module at ``path``, or -1 outside the layers."""
    name = path.relative_to(root).parts[0].removesuffix(".py")
    return next((i for i, layer in enumerate(LAYERS) if name in layer), -1)


def kernel_sources_digest(layer: int = -1, root: Path = PACKAGE) -> str:
    """SHA-256 over the paths and contents of the modules a kernel in ``layer`` may reach.

    Those of ``layer`` and the layers below it, under ``root``; every module for -1.
    """
    digest = hashlib.sha256()
    for path in sorted(root.rglob("*.py")):
        if layer < 0 or layer_of(path, root) >= layer:
            digest.update(path.relative_to(root).as_posix().encode())
            digest.update(path.read_bytes())
    return digest.hexdigest()


_layer_digest = functools.cache(kernel_sources_digest)


class KernelSourceLocator(caching._CacheLocator):
    """Numba's own locator for a conjure function, with the kernel sources in its stamp."""

    def __init__(self, located: caching._CacheLocator, layer: int) -> None:
        self._located = located
        self._layer = layer

    @classmethod
    def from_function(cls, py_func, py_file):
        """A locator for functions of the conjure package; None (numba's own) for others."""
        path = Path(py_file).resolve()
        if not path.is_relative_to(PACKAGE):
            return None
        for numba_class in caching.CacheImpl._locator_classes:
            if numba_class is not cls:
                located = numba_class.from_function(py_func, py_file)
                if located is not None:
                    return cls(located, layer_of(path))
        return None

    def get_cache_path(self) -> str:
        return self._located.get_cache_path()

    def get_disambiguator(self) -> str:
        return self._located.get_disambiguator()

    def get_source_stamp(self) -> tuple:
        return self._located.get_source_stamp(), _layer_digest(self._layer)


if KernelSourceLocator not in caching.CacheImpl._locator_classes:
    caching.CacheImpl._locator_classes.insert(0, KernelSourceLocator)
