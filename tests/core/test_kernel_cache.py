"""Numba's cache of conjure's kernels is keyed on the sources each kernel may reach."""

from pathlib import Path

import tomllib
from numba import njit
from numba.core import caching

from conjure.compiled import stepper
from conjure.core import kernel_cache
from conjure.core.kernel_cache import LAYERS, kernel_sources_digest
from conjure.core.kernel_locator import KernelSourceLocator

CLI, COMPILED, CORE = 0, 3, 8


def _package(root: Path) -> None:
    for name in ("cli", "compiled", "core"):
        (root / name).mkdir()
        (root / name / "module.py").write_text(f"# {name}\n")
    (root / "environments.py").write_text("# outside the layers\n")


def _edit(root: Path, name: str) -> None:
    path = root / name / "module.py"
    path.write_text(path.read_text() + "# edited\n")


def test_an_edit_below_a_layer_changes_its_digest(tmp_path):
    _package(tmp_path)
    before = {layer: kernel_sources_digest(layer, tmp_path) for layer in (COMPILED, -1)}
    _edit(tmp_path, "core")
    assert all(kernel_sources_digest(k, tmp_path) != v for k, v in before.items())


def test_an_edit_above_a_layer_keeps_its_digest(tmp_path):
    _package(tmp_path)
    before = kernel_sources_digest(COMPILED, tmp_path)
    everything = kernel_sources_digest(-1, tmp_path)
    _edit(tmp_path, "cli")
    (tmp_path / "environments.py").write_text("# edited\n")
    assert kernel_sources_digest(COMPILED, tmp_path) == before
    assert kernel_sources_digest(-1, tmp_path) != everything  # outside the layers: all


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


def test_the_layers_are_import_linter_s():
    pyproject = kernel_cache.PACKAGE.parent.parent / "pyproject.toml"
    contract = tomllib.loads(pyproject.read_text())["tool"]["importlinter"]["contracts"][0]
    names = [tuple(n.strip().removeprefix("conjure.") for n in layer.split("|"))
             for layer in contract["layers"]]  # fmt: skip
    assert tuple(names) == LAYERS
    assert (LAYERS[CLI], LAYERS[COMPILED], LAYERS[CORE]) == (("cli",), ("compiled",), ("core",))


def test_every_kernel_of_the_package_is_stamped_by_its_layers():
    # conjure.core registers the locator before any kernel is defined: a module importing
    # numba before conjure.core would leave its kernels keyed on their own file alone.
    import gc
    import importlib
    import pkgutil

    from numba.core.registry import CPUDispatcher

    import conjure

    for module in pkgutil.walk_packages(conjure.__path__, "conjure."):
        importlib.import_module(module.name)
    cached = [
        d for d in gc.get_objects()
        if type(d) is CPUDispatcher and type(d._cache).__name__ == "FunctionCache"
        and d.py_func.__module__.startswith("conjure.")
    ]  # fmt: skip
    assert len(cached) > 100
    assert [d for d in cached if not isinstance(d._cache._impl._locator, KernelSourceLocator)] == []
