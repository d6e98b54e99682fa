"""Numba's on-disk cache of conjure's kernels, invalidated by any kernel module's source.

Numba keys a cached function on its own file only: after an edit to a kernel in another file
(`conjure.agents.compiled_agent`'s TD update, say), the cached loop that inlined the old one
(`conjure.compiled.learning_loop`) loads and runs the old code, and a function compiled anew
beside it can read a stale environment (numba: "'descr' is NULL"). A researcher changing a
kernel in an editable install would measure code that is no longer there.

`KernelSourceLocator` stamps every conjure kernel with the contents of all of conjure's
kernel sources, so an edit to any of them recompiles every kernel on its next call. Choice:
"kernel sources" are the package's modules that mention ``numba`` (a kernel may inline, call
or overload code from any of them); editing another module recompiles nothing. Where a
kernel is cached (the folder beside its module or numba's user-wide one) stays numba's choice.
Importing this module registers the locator; `conjure.core` imports it before anything else,
so it is in place before any conjure kernel is defined.
"""

from __future__ import annotations

import functools
import hashlib
from pathlib import Path

from numba.core import caching

__all__ = ["KernelSourceLocator", "kernel_sources_digest"]

PACKAGE = Path(__file__).resolve().parent.parent


def kernel_sources_digest(root: Path = PACKAGE) -> str:
    """SHA-256 over the path and contents of every module under ``root`` that mentions numba."""
    digest = hashlib.sha256()
    for path in sorted(root.rglob("*.py")):
        source = path.read_bytes()
        if b"numba" in source:
            digest.update(path.relative_to(root).as_posix().encode())
            digest.update(source)
    return digest.hexdigest()


_package_digest = functools.cache(kernel_sources_digest)


class KernelSourceLocator(caching._CacheLocator):
    """Numba's own locator for a conjure function, with the kernel sources in its stamp."""

    def __init__(self, located: caching._CacheLocator) -> None:
        self._located = located

    @classmethod
    def from_function(cls, py_func, py_file):
        """A locator for functions of the conjure package; None (numba's own) for others."""
        if not Path(py_file).resolve().is_relative_to(PACKAGE):
            return None
        for numba_class in caching.CacheImpl._locator_classes:
            if numba_class is not cls:
                located = numba_class.from_function(py_func, py_file)
                if located is not None:
                    return cls(located)
        return None

    def get_cache_path(self) -> str:
        return self._located.get_cache_path()

    def get_disambiguator(self) -> str:
        return self._located.get_disambiguator()

    def get_source_stamp(self) -> tuple:
        return self._located.get_source_stamp(), _package_digest()


if KernelSourceLocator not in caching.CacheImpl._locator_classes:
    caching.CacheImpl._locator_classes.insert(0, KernelSourceLocator)
