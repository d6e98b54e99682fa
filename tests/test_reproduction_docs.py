"""Generated tables of docs/reproduction.md equal the stored results; configs start at them."""

import csv
import importlib.util
import sys
from pathlib import Path

import pytest
import yaml

ROOT = Path(__file__).resolve().parents[1]
SCRIPTS = ROOT / "docs" / "reproduction"


def load(name):
    spec = importlib.util.spec_from_file_location(name, SCRIPTS / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module  # dataclasses look their module up while the class is made
    spec.loader.exec_module(module)
    return module


def test_the_stored_figures_tables_equal_what_the_stored_results_give():
    figures = load("figures")
    text = figures.DOC.read_text()
    blocks = [name for name in figures.FIGURES if f"chapter5:{name} -->" in text]
    assert blocks, "docs/reproduction.md has no generated chapter-5 block"
    assert figures.rendered(text) == text, "run `python docs/reproduction/figures.py render`"


def selections():
    return sorted((SCRIPTS / "chapter5").glob("*_selection.csv"))


@pytest.mark.parametrize("path", selections(), ids=lambda path: path.stem)
def test_each_config_starts_at_the_settings_its_search_selected(path):
    # `conjure sweep CONFIG --set 'grid={}'` must run the selected settings (issue 19).
    figure = path.name.removesuffix("_selection.csv")
    config = yaml.safe_load((ROOT / "examples" / "reproduction" / f"{figure}.yaml").read_text())
    with path.open() as handle:
        rows = [row for row in csv.DictReader(handle) if row["setting"]]
    assert rows
    for row in rows:
        for assignment in row["setting"].split(", "):
            key, value = assignment.split("=", 1)
            node = config["agents"][row["label"]]["params"]
            *parents, last = key.split(".")
            for parent in parents:
                node = node[parent]["params"]
            expected = None if value == "None" else yaml.safe_load(value)  # describe_setting
            assert node[last] == expected, f"{figure}: {row['label']} {key}"
