"""The locator of conjure's kernels: numba's own place, a stamp of the sources they reach."""

import gc
import importlib
import pkgutil

from numba import njit
from numba.core import caching
from numba.core.registry import CPUDispatcher

import conjure
from conjure.compiled import stepper
from conjure.core.kernel_cache import kernel_sources_digest
from conjure.core.kernel_locator import KernelSourceLocator

COMPILED = 3  # the layer of `conjure.compiled` in `conjure.core.kernel_cache.LAYERS`


def test_the_loop_is_stamped_with_the_layers_it_may_reach():
    # run_loop inlines kernels of other modules: its own file alone would not see them change.
    locator = stepper.run_loop._cache._impl._locator
    assert isinstance(locator, KernelSourceLocator)
    own, reached = locator.get_source_stamp()
    assert reached == kernel_sources_digest(COMPILED) and own  # numba's own stamp kept too
    numba_own = next(
        located
        for cls in caching.CacheImpl._locator_classes[1:]
        if (located := cls.from_function(stepper.run_loop.py_func, stepper.__file__))
    )
    assert locator.get_cache_path() == numba_own.get_cache_path()  # where: numba's choice


def test_functions_outside_conjure_keep_numba_s_locator():
    @njit(cache=True)
    def twice(x):
        return 2 * x

    assert twice(2) == 4
    assert not isinstance(twice._cache._impl._locator, KernelSourceLocator)


def test_every_kernel_of_the_package_is_stamped_by_its_layers():
    # conjure.core registers the locator before any kernel is defined: a module importing
    # numba before conjure.core would leave its kernels keyed on their own file alone.
    for module in pkgutil.walk_packages(conjure.__path__, "conjure."):
        importlib.import_module(module.name)
    cached = [
        d for d in gc.get_objects()
        if type(d) is CPUDispatcher and type(d._cache).__name__ == "FunctionCache"
        and d.py_func.__module__.startswith("conjure.")
    ]  # fmt: skip
    assert len(cached) > 100
    assert [d for d in cached if not isinstance(d._cache._impl._locator, KernelSourceLocator)] == []
