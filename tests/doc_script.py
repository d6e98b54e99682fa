"""Import a script under docs/reproduction/ as a module (its tests call its functions)."""

import importlib.util
import sys
from pathlib import Path
from types import ModuleType

REPRODUCTION = Path(__file__).resolve().parents[1] / "docs" / "reproduction"


def load_doc_script(name: str) -> ModuleType:
    """The module of ``docs/reproduction/<name>.py``, registered as ``name``."""
    spec = importlib.util.spec_from_file_location(name, REPRODUCTION / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module  # its dataclasses and worker processes look it up by name
    spec.loader.exec_module(module)
    return module
