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
module or numba's user-wide one) stays numba's choice. `conjure.core` calls `watch_numba`
first, so the locator (`conjure.core.kernel_locator`) is in place before any conjure kernel
is defined.
"""

from __future__ import annotations

import hashlib
import importlib.abc
import importlib.util
import sys
from pathlib import Path

__all__ = [
    "LAYERS",
    "kernel_sources_digest",
    "layer_digest",
    "layer_of",
    "source_hashes",
    "watch_numba",
]

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


def source_hashes(root: Path = PACKAGE) -> tuple[tuple[str, int, bytes], ...]:
    """(path, layer, SHA-256 of the contents) of every module under ``root``, by path."""
    return tuple(
        (path.relative_to(root).as_posix(), layer_of(path, root),
         hashlib.sha256(path.read_bytes()).digest())
        for path in sorted(root.rglob("*.py"))
    )  # fmt: skip


def layer_digest(hashes: tuple[tuple[str, int, bytes], ...], layer: int) -> str:
    """SHA-256 over the modules of ``hashes`` a kernel in ``layer`` may reach.

    Those of ``layer`` and the layers below it; every module for -1.
    """
    digest = hashlib.sha256()
    for path, module_layer, content in hashes:
        if layer < 0 or module_layer >= layer:
            digest.update(path.encode())
            digest.update(content)
    return digest.hexdigest()


def kernel_sources_digest(layer: int = -1, root: Path = PACKAGE) -> str:
    """`layer_digest` of the modules under ``root`` as they are now (read each call)."""
    return layer_digest(source_hashes(root), layer)


class _AfterNumbaCaching(importlib.abc.MetaPathFinder):
    """Imports `conjure.core.kernel_locator` as soon as numba's caching module has loaded."""

    def find_spec(self, name, path, target=None):
        if name != _NUMBA_CACHING:
            return None
        sys.meta_path.remove(self)
        spec = importlib.util.find_spec(name)
        run = spec.loader.exec_module

        def exec_module(module):
            run(module)
            importlib.import_module(_LOCATOR)

        spec.loader.exec_module = exec_module
        return spec


_NUMBA_CACHING, _LOCATOR = "numba.core.caching", "conjure.core.kernel_locator"


def watch_numba() -> None:
    """Register `conjure.core.kernel_locator` now if numba is loaded, else when it loads.

    Choice: an import hook, so that importing conjure (``conjure --help``) loads no numba.
    """
    if _NUMBA_CACHING in sys.modules:
        importlib.import_module(_LOCATOR)
    elif not any(isinstance(finder, _AfterNumbaCaching) for finder in sys.meta_path):
        sys.meta_path.insert(0, _AfterNumbaCaching())
