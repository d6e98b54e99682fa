"""Numba's cache of conjure's kernels is keyed on every kernel source, not one file."""

from pathlib import Path

from numba import njit
from numba.core import caching

from conjure.compiled import stepper
from conjure.core import kernel_cache
from conjure.core.kernel_cache import KernelSourceLocator, kernel_sources_digest


def _package(root: Path) -> None:
    (root / "kernels.py").write_text("from numba import njit\n")
    (root / "cli.py").write_text("import click\n")


def test_an_edit_to_any_kernel_source_changes_the_digest(tmp_path):
    _package(tmp_path)
    before = kernel_sources_digest(tmp_path)
    (tmp_path / "kernels.py").write_text("from numba import njit  # edited\n")
    assert kernel_sources_digest(tmp_path) != before


def test_an_edit_to_a_module_without_kernels_keeps_the_digest(tmp_path):
    _package(tmp_path)
    before = kernel_sources_digest(tmp_path)
    (tmp_path / "cli.py").write_text("import click  # edited\n")
    assert kernel_sources_digest(tmp_path) == before


def test_the_loop_is_stamped_with_every_kernel_source():
    # run_loop inlines kernels of other modules: its own file alone would not see them change.
    locator = stepper.run_loop._cache._impl._locator
    assert isinstance(locator, KernelSourceLocator)
    own, package = locator.get_source_stamp()
    assert package == kernel_sources_digest() and own  # numba's own stamp is kept beside it
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
    assert kernel_cache.PACKAGE == Path(stepper.__file__).resolve().parent.parent
