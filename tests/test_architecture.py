"""Layering (import-linter contracts in pyproject.toml), no import cycle, a test file per module."""

import ast
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


#: Underscored names that are public APIs of other libraries: namedtuple's methods,
#: ``os._exit`` (a worker's exit), numba's cache index (`conjure.compiled.stepper.is_warm`
#: reads it knowingly, falling back to "cold" if it changes) and the value of numba's struct
#: proxies (``cgutils.create_struct_proxy(...)._getvalue()``, numba's extension API), and
#: numba's cache locators (their base and list, which ``NUMBA_CACHE_LOCATOR_CLASSES`` names;
#: `conjure.core.kernel_locator`).
_FOREIGN_PUBLIC = {"_replace", "_asdict", "_fields", "_make", "_exit", "_cache", "_cache_file"}
_FOREIGN_PUBLIC |= {"_load_index", "_getvalue", "_CacheLocator", "_locator_classes"}


def _defined_names(tree: ast.Module) -> set[str]:
    """Names a module defines: functions, classes, assignments and ``self.``/``cls.`` attributes."""
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            names.add(node.name)
        elif isinstance(node, ast.Name) and isinstance(node.ctx, ast.Store):
            names.add(node.id)
        elif isinstance(node, ast.Attribute) and _is_own(node.value):
            names.add(node.attr)
    return names


def _is_own(node: ast.expr) -> bool:
    """``self``, ``cls`` or ``super()``."""
    if isinstance(node, ast.Name):
        return node.id in ("self", "cls")
    return isinstance(node, ast.Call) and getattr(node.func, "id", None) == "super"


def test_no_private_access_across_modules():
    # Issue 22: components meet through public contracts (compiled forms, state arrays), never
    # through another module's underscored attributes.
    found = []
    for path in sorted(PACKAGE.rglob("*.py")):
        tree = ast.parse(path.read_text())
        own = _defined_names(tree) | _FOREIGN_PUBLIC
        for node in ast.walk(tree):
            is_private = isinstance(node, ast.Attribute) and node.attr.startswith("_")
            if is_private and not node.attr.startswith("__") and not _is_own(node.value):
                if node.attr not in own:
                    found.append(f"{path.relative_to(ROOT)}:{node.lineno}: {ast.unparse(node)}")
    assert not found, "Private attributes read across modules:\n" + "\n".join(found)


def test_no_private_import_across_layers():
    found = []
    for path in sorted(PACKAGE.rglob("*.py")):
        layer = path.relative_to(PACKAGE).parts[0]
        for node in ast.walk(ast.parse(path.read_text())):
            if not isinstance(node, ast.ImportFrom) or not (node.module or "").startswith(
                "conjure."
            ):
                continue
            parts = node.module.split(".")
            names = [alias.name for alias in node.names]
            private = any(p.startswith("_") for p in parts[2:]) or any(
                n.startswith("_") and not n.startswith("__") for n in names
            )
            if private and parts[1] != layer:
                found.append(f"{path.relative_to(ROOT)}:{node.lineno}: from {node.module}")
    assert not found, "Private modules or names imported from another layer:\n" + "\n".join(found)
