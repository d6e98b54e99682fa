"""The cache locator of conjure's kernels (`conjure.core.kernel_cache`), registered on import."""

from __future__ import annotations

import functools
from pathlib import Path

from numba.core import caching

from conjure.core.kernel_cache import PACKAGE, layer_digest, layer_of, source_hashes

__all__ = ["KernelSourceLocator"]

#: The package's modules read and hashed once per process; each layer's digest once from them.
_package_hashes = functools.cache(source_hashes)


@functools.cache
def _layer_digest(layer: int) -> str:
    return layer_digest(_package_hashes(), layer)


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
