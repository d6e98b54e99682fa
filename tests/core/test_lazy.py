"""Lazy package exports: a name loads its own submodule, not its siblings (fresh interpreters)."""

from __future__ import annotations

import json
import sys
import types
from pathlib import Path

import pytest

from conjure.core.lazy import lazy_exports
from fresh_python import python

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
LOADED = (
    "print(json.dumps(sorted(m for m in {modules!r} if m in sys.modules)))"
)  # fmt: skip


def loaded_after(code: str, modules: tuple[str, ...]) -> list[str]:
    result = python(f"import json, sys\n{code}\n" + LOADED.format(modules=modules))
    assert result.returncode == 0, result.stderr
    return json.loads(result.stdout)


def test_importing_sarsa_loads_neither_the_batch_learners_nor_scipy_sparse():
    heavy = ("conjure.agents.batch", "conjure.agents.lspi", "scipy.sparse", "conjure.planners")
    assert loaded_after("from conjure.agents import SARSA", heavy) == []
    assert loaded_after("from conjure.agents import LSPI", heavy) == [
        "conjure.agents.batch",
        "conjure.agents.lspi",
        "scipy.sparse",
    ]


def test_a_blocksworld_sarsa_config_imports_only_its_components():
    code = (
        "from conjure.experiments.config import load_config, resolve_run\n"
        f"resolve_run(load_config({str(EXAMPLES / 'blocksworld.yaml')!r}), 'ifdd_plus', 0)"
    )
    unused = ("conjure.planners", "conjure.safety", "conjure.agents.batch", "conjure.models")
    assert loaded_after(code, unused) == []


def fake_package(monkeypatch: pytest.MonkeyPatch) -> types.ModuleType:
    package = types.ModuleType("fake_layer")
    package.__path__ = []
    monkeypatch.setitem(sys.modules, "fake_layer", package)
    monkeypatch.setitem(sys.modules, "fake_layer.things", types.ModuleType("fake_layer.things"))
    sys.modules["fake_layer.things"].Thing = object
    package.__getattr__, package.__dir__ = lazy_exports("fake_layer", {"Thing": "things"})
    return package


def test_a_name_is_imported_once_and_kept_on_the_package(monkeypatch):
    package = fake_package(monkeypatch)
    assert "Thing" not in vars(package) and "Thing" in package.__dir__()
    assert package.Thing is object
    assert vars(package)["Thing"] is object  # later lookups skip __getattr__


def test_an_unknown_name_raises_attribute_error_naming_it(monkeypatch):
    package = fake_package(monkeypatch)
    with pytest.raises(AttributeError, match="'fake_layer' has no attribute 'Thingy'"):
        package.Thingy  # noqa: B018
