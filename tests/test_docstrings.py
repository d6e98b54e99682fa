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
