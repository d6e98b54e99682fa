"""Numba's cache of conjure's kernels is keyed on the sources each kernel may reach."""

from pathlib import Path

import tomllib

from conjure.core import kernel_cache
from conjure.core.kernel_cache import LAYERS, kernel_sources_digest

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


def test_the_layers_are_import_linter_s():
    pyproject = kernel_cache.PACKAGE.parent.parent / "pyproject.toml"
    contract = tomllib.loads(pyproject.read_text())["tool"]["importlinter"]["contracts"][0]
    names = [tuple(n.strip().removeprefix("conjure.") for n in layer.split("|"))
             for layer in contract["layers"]]  # fmt: skip
    assert tuple(names) == LAYERS
    assert (LAYERS[CLI], LAYERS[COMPILED], LAYERS[CORE]) == (("cli",), ("compiled",), ("core",))
