"""Every public class of the algorithm layers cites the thesis (STYLE §5)."""

import importlib
import inspect
import pkgutil
import re

import pytest

import conjure

LAYERS = ["agents", "representations", "planners", "safety", "domains"]
CITATION = re.compile(r"(Algorithm|Eq\.|Equation|Section|Fig\.|Figure)s? \d")


def public_classes():
    for layer in LAYERS:
        try:
            package = importlib.import_module(f"conjure.{layer}")
        except ModuleNotFoundError:
            continue
        for info in pkgutil.iter_modules(package.__path__, f"{package.__name__}."):
            if info.name.rsplit(".", 1)[1].startswith("_"):
                continue
            module = importlib.import_module(info.name)
            for name, cls in inspect.getmembers(module, inspect.isclass):
                if cls.__module__ == module.__name__ and not name.startswith("_"):
                    yield pytest.param(cls, id=f"{module.__name__}.{name}")


@pytest.mark.parametrize("cls", list(public_classes()))
def test_public_class_cites_the_thesis(cls):
    doc = inspect.getdoc(cls) or ""
    assert CITATION.search(doc), f"{cls.__qualname__}'s docstring cites no Algorithm/Eq./Section"
    assert "Parameters" in doc or not inspect.signature(cls).parameters, (
        f"{cls.__qualname__}'s docstring has no Parameters section"
    )


def test_package_has_a_version():
    assert re.fullmatch(r"\d+\.\d+\.\d+", conjure.__version__)


def test_source_comments_and_docstrings_carry_no_dates_or_issue_numbers():
    # Docstrings state what holds; dated history and issue numbers belong in CHANGELOG.md.
    from pathlib import Path

    dated = re.compile(r"\b20\d\d-\d\d-\d\d\b|\b[Ii]ssues? \d+|\bissue-\d+|\d\d:\d\d UTC")
    source = Path(conjure.__file__).parent
    for path in sorted(source.rglob("*.py")):
        for number, line in enumerate(path.read_text().splitlines(), 1):
            assert not dated.search(line), f"{path.relative_to(source)}:{number}: {line}"
