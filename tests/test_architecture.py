"""Layering (import-linter contracts in pyproject.toml), no import cycle, a test file per module."""

import subprocess
import sys
from pathlib import Path

import grimp

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "src" / "conjure"


def test_import_linter_contracts_hold():
    linter = Path(sys.executable).with_name("lint-imports")
    result = subprocess.run(
        [str(linter), "--config", str(ROOT / "pyproject.toml")],
        cwd=ROOT,
        capture_output=True,
        text=True,
        check=False,
    )
    assert result.returncode == 0, result.stdout + result.stderr
    assert "0 broken" in result.stdout


def test_no_module_imports_one_that_imports_it_back():
    # grimp counts every import, including those inside functions: a lazy import still ties
    # the two modules together (config <-> run through CURVE_COLUMNS was one such cycle).
    graph = grimp.build_graph("conjure")
    cycles = [
        f"{importer} -> {imported}"
        for importer in sorted(graph.modules)
        for imported in sorted(graph.find_modules_directly_imported_by(importer))
        if graph.chain_exists(importer=imported, imported=importer)
    ]
    assert not cycles, f"Import cycles (each edge lies on one): {cycles}"


def test_every_module_has_a_test_file():
    missing = []
    for module in PACKAGE.rglob("*.py"):
        if module.name == "__init__.py" or module.name.startswith("_"):
            continue  # kernels are tested through the module that calls them
        layer = module.parent.relative_to(PACKAGE)
        if not (ROOT / "tests" / layer / f"test_{module.stem}.py").exists():
            missing.append(str(module.relative_to(ROOT)))
    assert not missing, f"Modules without tests/<layer>/test_<module>.py: {missing}"
