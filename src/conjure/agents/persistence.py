"""The saved-agent format: JSON metadata plus numpy arrays, no pickle.

A saved agent is a directory holding

- ``agent.json``: ``{"format": "conjure-agent", "version": 1, "component": C, "spec": S,
  "state": {...}}`` where C is a component tree ``{"class": "conjure.agents.sarsa.SARSA",
  "params": {...}}`` (nested components are trees too), S is the `DomainSpec` as a dict and
  ``state`` holds counters and generator states (JSON);
- ``arrays.npz``: the weights, traces and representation arrays, read with
  ``allow_pickle=False``.

Only classes from ``conjure.*`` modules are rebuilt, so loading a file never runs foreign code.
"""

from __future__ import annotations

import importlib
import json
import os
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

from conjure.core.errors import IncompatibleComponentsError, InvalidParameterError
from conjure.core.interfaces import DomainSpec
from conjure.core.params import Configurable

__all__ = [
    "FORMAT",
    "VERSION",
    "component_from_dict",
    "component_to_dict",
    "prefixed",
    "read",
    "read_agent",
    "unprefixed",
    "write",
    "write_agent",
]

FORMAT = "conjure-agent"
VERSION = 1


def component_to_dict(component: Configurable) -> dict[str, Any]:
    """Return ``{"class": qualified name, "params": {...}}`` with nested components expanded."""
    cls = type(component)
    params = {name: _to_json(value) for name, value in component.get_params().items()}
    return {"class": f"{cls.__module__}.{cls.__qualname__}", "params": params}


def component_from_dict(tree: dict[str, Any]) -> Configurable:
    """Rebuild a component from `component_to_dict`'s output (``conjure.*`` classes only)."""
    qualified = tree["class"]
    module_name, _, class_name = qualified.rpartition(".")
    if not module_name.startswith("conjure."):
        raise InvalidParameterError(
            f"A saved agent may only name conjure classes; got {qualified!r}."
        )
    cls = getattr(importlib.import_module(module_name), class_name)
    params = {name: _from_json(value) for name, value in tree["params"].items()}
    return cls(**params)


def write(path: str | Path, metadata: dict[str, Any], arrays: dict[str, np.ndarray]) -> Path:
    """Write ``agent.json`` and ``arrays.npz`` into directory ``path`` atomically per file."""
    directory = Path(path)
    directory.mkdir(parents=True, exist_ok=True)
    document = {"format": FORMAT, "version": VERSION, **metadata}
    _atomic_write(directory / "agent.json", json.dumps(document, indent=2).encode())
    with tempfile.NamedTemporaryFile(dir=directory, suffix=".npz", delete=False) as handle:
        np.savez(handle, **arrays)
        handle.flush()
        os.fsync(handle.fileno())
    os.replace(handle.name, directory / "arrays.npz")
    return directory


def read(path: str | Path) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    """Read a saved agent's metadata and arrays, checking the format and version."""
    directory = Path(path)
    metadata_path = directory / "agent.json"
    if not metadata_path.is_file():
        raise InvalidParameterError(
            f"No saved agent at {str(directory)!r}: {metadata_path.name} is missing."
        )
    document = json.loads(metadata_path.read_text())
    if document.get("format") != FORMAT or document.get("version") != VERSION:
        raise InvalidParameterError(
            f"{str(metadata_path)!r} is not a conjure agent of format version {VERSION}; "
            f"got format {document.get('format')!r} version {document.get('version')!r}."
        )
    with np.load(directory / "arrays.npz", allow_pickle=False) as data:
        arrays = {name: data[name] for name in data.files}
    return document, arrays


def write_agent(
    path: str | Path, agent: Any, state: dict[str, Any], arrays: dict[str, np.ndarray]
) -> Path:
    """Write a set-up agent: its component tree, its ``spec_``, ``state`` (JSON) and ``arrays``."""
    metadata = {
        "component": component_to_dict(agent),
        "spec": agent.spec_.to_dict(),
        "state": state,
    }
    return write(path, metadata, arrays)


def read_agent(path: str | Path, cls: type) -> tuple[Any, dict[str, Any], dict[str, np.ndarray]]:
    """Rebuild the agent `write_agent` saved, as a ``cls`` set up for its spec with seed 0.

    Returns the agent, the saved ``state`` and the arrays; the caller loads them into it.
    """
    document, arrays = read(path)
    agent = component_from_dict(document["component"])
    if not isinstance(agent, cls):
        raise IncompatibleComponentsError(
            f"{str(path)!r} holds a {type(agent).__name__}, not a {cls.__name__}."
        )
    agent.setup(DomainSpec.from_dict(document["spec"]), seed=0)
    return agent, document["state"], arrays


def prefixed(prefix: str, arrays: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """``arrays`` with every name prefixed (``representation.`` + name)."""
    return {prefix + name: value for name, value in arrays.items()}


def unprefixed(prefix: str, arrays: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """The arrays whose names start with ``prefix``, with the prefix removed."""
    return {k[len(prefix) :]: v for k, v in arrays.items() if k.startswith(prefix)}


def _to_json(value: Any) -> Any:
    if isinstance(value, Configurable):
        return component_to_dict(value)
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, (list, tuple)):
        return [_to_json(item) for item in value]
    if isinstance(value, dict):
        return {str(key): _to_json(item) for key, item in value.items()}
    return value


def _from_json(value: Any) -> Any:
    if isinstance(value, dict) and set(value) == {"class", "params"}:
        return component_from_dict(value)
    if isinstance(value, list):
        return [_from_json(item) for item in value]
    return value


def _atomic_write(path: Path, payload: bytes) -> None:
    with tempfile.NamedTemporaryFile(dir=path.parent, delete=False) as handle:
        handle.write(payload)
        handle.flush()
        os.fsync(handle.fileno())
    os.replace(handle.name, path)
