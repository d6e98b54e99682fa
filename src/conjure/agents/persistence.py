"""The saved-agent format: JSON metadata plus numpy arrays, no pickle, checked on load.

A saved agent is a directory holding

- ``agent.json``: ``{"format": "conjure-agent", "version": 1, "component": C, "spec": S,
  "state": {...}}`` where C is a component tree ``{"class": "conjure.agents.sarsa.SARSA",
  "params": {...}}`` (nested components are trees too), S is the `DomainSpec` as a dict and
  ``state`` holds counters and generator states (JSON);
- ``arrays.npz``: the weights, traces, samples and representation arrays, read with
  ``allow_pickle=False``. Eligibility traces are sparse (``trace_features``,
  ``trace_actions``, ``trace_values``) for every representation; the dense ``traces`` array
  earlier conjure saved for real-valued features (RBF with λ > 0) is still read, converted to
  its non-zero entries.

Loading trusts nothing in the files:

- only *component classes* are rebuilt: a public class, defined in a module of one of the
  `COMPONENT_PACKAGES` (never ``conjure.experiments`` or ``conjure.testing``), that subclasses
  `Configurable`; anything else (a function such as ``conjure.cli.main.main``, a
  foreign class) is refused before its module is imported;
- every array is checked against what the agent, set up from the saved spec and parameters,
  expects: its shape, its dtype and, for floats, that it is finite (`SavedAgent.array`);
- each ``.npy`` header in ``arrays.npz`` is checked against the bytes the member stores before
  any array is read, and an array is read only when the agent asks for it (`NpzArrays`);
- a damaged save (truncated ``arrays.npz``, broken or too deeply nested ``agent.json``,
  missing keys or arrays, a forged header) raises one `InvalidParameterError` naming the file,
  never a raw ``BadZipFile``, ``JSONDecodeError``, ``RecursionError`` or ``MemoryError``.

Both files are written by `conjure.core.files.write_atomic`, as results are (same mode).

Agents implement ``state_metadata()``, ``state_arrays()`` and ``load_state(saved)`` and
delegate ``save`` and ``restore`` to `save_agent` and `restore_agent`.
"""

from __future__ import annotations

import importlib
import io
import json
import math
import zipfile
from collections.abc import Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TypeVar

import numpy as np

from conjure.core.errors import IncompatibleComponentsError, InvalidParameterError
from conjure.core.files import write_atomic
from conjure.core.interfaces import Agent, DomainSpec
from conjure.core.params import Configurable

__all__ = [
    "COMPONENT_PACKAGES",
    "FORMAT",
    "VERSION",
    "NpzArrays",
    "SavedAgent",
    "component_from_dict",
    "component_to_dict",
    "prefixed",
    "read",
    "read_agent",
    "restore_agent",
    "save_agent",
    "write",
    "write_agent",
]

FORMAT = "conjure-agent"
VERSION = 1
METADATA_FILE = "agent.json"
ARRAYS_FILE = "arrays.npz"
#: The packages whose `Configurable` classes a saved agent may name (its parts: agents,
#: representations, policies, step-size schedules, domains and models a planner
#: plans in, planners and safety components).
COMPONENT_PACKAGES = (
    "conjure.agents",
    "conjure.core.schedules",
    "conjure.domains",
    "conjure.models",
    "conjure.planners",
    "conjure.policies",
    "conjure.representations",
    "conjure.safety",
)

AgentType = TypeVar("AgentType", bound=Agent)


# ---------------------------------------------------------------------------------- components


def component_to_dict(component: Configurable) -> dict[str, Any]:
    """Return ``{"class": qualified name, "params": {...}}`` with nested components expanded."""
    cls = type(component)
    params = {name: _to_json(value) for name, value in component.get_params().items()}
    return {"class": f"{cls.__module__}.{cls.__qualname__}", "params": params}


def component_from_dict(tree: dict[str, Any]) -> Configurable:
    """Rebuild a component from `component_to_dict`'s output (component classes only).

    Examples
    --------
    >>> component_from_dict({"class": "conjure.policies.epsilon_greedy.EpsilonGreedy",
    ...                      "params": {"epsilon": 0.2}})
    EpsilonGreedy(epsilon=0.2)
    >>> component_from_dict({"class": "conjure.cli.main.main", "params": {}})
    Traceback (most recent call last):
    ...
    conjure.core.errors.InvalidParameterError: A saved agent may only name conjure component classes (in conjure.agents, conjure.core.schedules, conjure.domains, conjure.models, conjure.planners, conjure.policies, conjure.representations, conjure.safety); got 'conjure.cli.main.main'.
    """  # noqa: E501
    if not isinstance(tree, dict) or set(tree) != {"class", "params"}:
        raise InvalidParameterError(
            f"A saved component must be {{'class': ..., 'params': {{...}}}}; got {tree!r}."
        )
    cls = _component_class(tree["class"])
    params = tree["params"]
    if not isinstance(params, dict) or not set(params) <= set(cls.param_names()):
        raise InvalidParameterError(
            f"The saved parameters of {cls.__name__} must be a subset of "
            f"{cls.param_names()}; got {params!r}."
        )
    return cls(**{name: _from_json(value) for name, value in params.items()})


def _component_class(qualified: Any) -> type[Configurable]:
    refused = InvalidParameterError(
        f"A saved agent may only name conjure component classes (in "
        f"{', '.join(COMPONENT_PACKAGES)}); got {qualified!r}."
    )
    if not isinstance(qualified, str):
        raise refused
    module_name, _, class_name = qualified.rpartition(".")
    in_package = any(
        module_name == package or module_name.startswith(f"{package}.")
        for package in COMPONENT_PACKAGES
    )
    if not in_package or not class_name.isidentifier() or class_name.startswith("_"):
        raise refused
    try:
        module = importlib.import_module(module_name)
    except ImportError:
        raise refused from None
    cls = getattr(module, class_name, None)
    is_component = (
        isinstance(cls, type)
        and issubclass(cls, Configurable)
        and cls.__module__ == module_name
        and cls.__qualname__ == class_name
    )
    if not is_component:
        raise refused
    return cls


def prefixed(prefix: str, arrays: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """``arrays`` with every name prefixed (``representation.`` + name)."""
    return {prefix + name: value for name, value in arrays.items()}


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


# ---------------------------------------------------------------------------------- files


@dataclass
class SavedAgent:
    """The contents of a saved agent (a learner of Algorithms 10-16): JSON document and arrays.

    Parameters
    ----------
    directory : Path
        The saved agent's directory.
    document : dict
        ``agent.json``.
    arrays : dict of str to ndarray
        ``arrays.npz``.
    """

    directory: Path
    document: dict[str, Any]
    arrays: Mapping[str, np.ndarray]

    @property
    def state(self) -> dict[str, Any]:
        """The ``state`` section of ``agent.json`` (counters and generator states)."""
        state = self.document.get("state")
        if not isinstance(state, dict):
            raise self.damaged(METADATA_FILE, "its 'state' section is missing")
        return state

    def array(
        self,
        name: str,
        shape: Sequence[int | None],
        dtype: Any = np.float64,
        *,
        is_finite: bool = True,
    ) -> np.ndarray:
        """Return a writable copy of array ``name`` after checking it.

        Parameters
        ----------
        name : str
            The array's key in ``arrays.npz``.
        shape : sequence of int or None
            The expected shape; ``None`` leaves a dimension free.
        dtype : numpy dtype, default float64
            The exact expected dtype.
        is_finite : bool, default True
            Whether float values must be finite.
        """
        if name not in self.arrays:
            raise self.damaged(ARRAYS_FILE, f"array {name!r} is missing")
        header = getattr(self.arrays, "header", None)
        # The shape and dtype its header declares are checked before the array is read.
        value = header(name) if header is not None else self.arrays[name]
        wanted = tuple(shape)
        fits = value.ndim == len(wanted) and all(
            want is None or have == want for have, want in zip(value.shape, wanted, strict=True)
        )
        shown = "(" + ", ".join("n" if w is None else str(w) for w in wanted)
        shown += ",)" if len(wanted) == 1 else ")"
        if not fits or value.dtype != np.dtype(dtype):
            raise self.damaged(
                ARRAYS_FILE,
                f"array {name!r} is {value.dtype} of shape {value.shape}, but the agent set up "
                f"from the saved spec and parameters expects {np.dtype(dtype)} of shape {shown}",
            )
        value = self.arrays[name]
        if is_finite and value.dtype.kind == "f" and not np.all(np.isfinite(value)):
            raise self.damaged(ARRAYS_FILE, f"array {name!r} holds NaN or infinite values")
        return np.array(value, copy=True)

    def indices(self, name: str, shape: Sequence[int | None], upper: int) -> np.ndarray:
        """Return int64 array ``name`` (checked as `array`) whose values must lie in [0, upper)."""
        value = self.array(name, shape, np.int64)
        if value.size and (value.min() < 0 or value.max() >= upper):
            raise self.damaged(
                ARRAYS_FILE, f"array {name!r} holds values outside [0, {upper}) (indices)"
            )
        return value

    def with_prefix(self, prefix: str) -> dict[str, np.ndarray]:
        """The arrays whose key starts with ``prefix``, with the prefix removed."""
        return {k[len(prefix) :]: v for k, v in self.arrays.items() if k.startswith(prefix)}

    def damaged(self, file: str, problem: str) -> InvalidParameterError:
        """The error for a damaged save: names the file and what is wrong with it."""
        return InvalidParameterError(
            f"The saved agent file {str(self.directory / file)!r} is damaged or from another "
            f"conjure version: {problem}."
        )

    @contextmanager
    def loading(self) -> Iterator[None]:
        """Turn any error raised while rebuilding the agent into one naming the saved files."""
        try:
            yield
        except IncompatibleComponentsError:
            raise
        except (
            InvalidParameterError,
            KeyError,
            TypeError,
            ValueError,
            IndexError,
            OverflowError,
            MemoryError,
            RecursionError,
        ) as exc:
            if str(self.directory) in str(exc):
                raise
            raise InvalidParameterError(
                f"The saved agent in {str(self.directory)!r} ({METADATA_FILE}, {ARRAYS_FILE}) "
                f"cannot be loaded: {type(exc).__name__}: {str(exc)[:300]}"
            ) from None


def write(path: str | Path, metadata: dict[str, Any], arrays: dict[str, np.ndarray]) -> Path:
    """Write ``agent.json`` and ``arrays.npz`` into directory ``path`` atomically per file."""
    directory = Path(path)
    directory.mkdir(parents=True, exist_ok=True)
    document = {"format": FORMAT, "version": VERSION, **metadata}
    write_atomic(directory / METADATA_FILE, json.dumps(document, indent=2))
    buffer = io.BytesIO()
    np.savez(buffer, **arrays)
    write_atomic(directory / ARRAYS_FILE, buffer.getvalue())
    return directory


def read(path: str | Path) -> SavedAgent:
    """Read and check a saved agent's metadata and arrays (format, version, readability)."""
    directory = Path(path)
    saved = SavedAgent(directory, {}, {})
    metadata_path = directory / METADATA_FILE
    if not metadata_path.is_file():
        raise InvalidParameterError(
            f"No saved agent at {str(directory)!r}: {metadata_path.name} is missing."
        )
    try:
        document = json.loads(metadata_path.read_text())
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise saved.damaged(METADATA_FILE, f"it is not valid JSON ({exc})") from exc
    except RecursionError:
        raise saved.damaged(METADATA_FILE, "its JSON is nested too deeply") from None
    if not isinstance(document, dict):
        raise saved.damaged(METADATA_FILE, "it is not a JSON object")
    if document.get("format") != FORMAT or document.get("version") != VERSION:
        raise InvalidParameterError(
            f"{str(metadata_path)!r} is not a conjure agent of format version {VERSION}; "
            f"got format {document.get('format')!r} version {document.get('version')!r}."
        )
    return SavedAgent(directory, document, NpzArrays(directory / ARRAYS_FILE, saved.damaged))


#: Deflate expands at most 1032-fold; a member declaring more bytes than that is forged.
_MAX_DEFLATE_RATIO = 1032


class NpzArrays(Mapping[str, np.ndarray]):
    """A saved learner's arrays (Algorithms 10-16), read from ``arrays.npz`` as they are used.

    Opening reads only the zip directory and each member's ``.npy`` header, and refuses a
    member whose declared shape and dtype do not match the bytes it stores, or whose stored
    size is more than deflate can expand its compressed bytes to. So a forged header never
    allocates, and a member the agent does not ask for is never read.

    Parameters
    ----------
    path : Path
        The ``arrays.npz`` file.
    damaged : callable
        ``(file, problem) -> InvalidParameterError``, the error naming the save
        (`SavedAgent.damaged`).
    """

    def __init__(self, path: Path, damaged: Any):
        self.path, self._damaged = path, damaged
        self._headers: dict[str, np.ndarray] = {}
        self._cache: dict[str, np.ndarray] = {}
        try:
            archive_size = path.stat().st_size
            with zipfile.ZipFile(path) as archive:
                for info in archive.infolist():
                    self._check_member(archive, info, archive_size)
        except FileNotFoundError:
            raise damaged(ARRAYS_FILE, "the file is missing") from None
        except Exception as exc:
            problem = f"{type(exc).__name__}: {str(exc)[:200]}"
            raise damaged(ARRAYS_FILE, f"it cannot be read ({problem})") from None

    def _check_member(self, archive: zipfile.ZipFile, info: zipfile.ZipInfo, size: int) -> None:
        name = info.filename.removesuffix(".npy")
        if name == info.filename:
            raise ValueError(f"member {info.filename!r} is not a .npy array")
        stored = info.compress_size
        if stored > size or (
            info.file_size > _MAX_DEFLATE_RATIO * stored + 1024
            if info.compress_type != zipfile.ZIP_STORED
            else info.file_size != stored
        ):
            raise ValueError(
                f"member {info.filename!r} declares {info.file_size:,} bytes from {stored:,} "
                f"stored bytes"
            )
        with archive.open(info) as handle:
            version = np.lib.format.read_magic(handle)
            if version == (1, 0):
                shape, _fortran, dtype = np.lib.format.read_array_header_1_0(handle)
            elif version == (2, 0):
                shape, _fortran, dtype = np.lib.format.read_array_header_2_0(handle)
            else:
                raise ValueError(f"member {info.filename!r} has .npy version {version}")
            header_bytes = handle.tell()
        if dtype.hasobject:
            raise ValueError(f"array {name!r} holds Python objects")
        declared = math.prod(shape) * dtype.itemsize
        if declared != info.file_size - header_bytes:
            raise ValueError(
                f"array {name!r} declares shape {shape} of {dtype} ({declared:,} bytes) but "
                f"stores {info.file_size - header_bytes:,} bytes"
            )
        self._headers[name] = np.lib.stride_tricks.as_strided(
            np.zeros(1, dtype=dtype), shape=shape, strides=(0,) * len(shape)
        )

    def header(self, name: str) -> np.ndarray:
        """A zero-byte stand-in with the shape and dtype member ``name`` declares."""
        return self._headers[name]

    def __getitem__(self, name: str) -> np.ndarray:
        if name not in self._cache:
            if name not in self._headers:
                raise KeyError(name)
            try:
                with np.load(self.path, allow_pickle=False) as data:
                    self._cache[name] = data[name]
            except Exception as exc:
                raise self._damaged(
                    ARRAYS_FILE, f"array {name!r} cannot be read ({str(exc)[:200]})"
                ) from None
        return self._cache[name]

    def __contains__(self, name: object) -> bool:
        return name in self._headers

    def __iter__(self) -> Iterator[str]:
        return iter(self._headers)

    def __len__(self) -> int:
        return len(self._headers)


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


def read_agent(cls: type[AgentType], saved: SavedAgent) -> AgentType:
    """Rebuild the agent in ``saved`` as a ``cls`` set up for its spec with seed 0.

    Call inside ``saved.loading()``; the caller then loads the saved state into it, checking
    each array with `SavedAgent.array`.
    """
    agent = component_from_dict(saved.document.get("component"))
    if not isinstance(agent, cls):
        raise IncompatibleComponentsError(
            f"{str(saved.directory)!r} holds a {type(agent).__name__}, not a {cls.__name__}."
        )
    spec = saved.document.get("spec")
    if not isinstance(spec, dict):
        raise saved.damaged(METADATA_FILE, "its 'spec' section is missing")
    agent.setup(DomainSpec.from_dict(spec), seed=0)
    return agent


def save_agent(agent: Any, path: str | Path) -> Path:
    """Write a set-up linear agent: component tree, spec, ``state_metadata`` and arrays.

    The arrays are the representation's (``representation.*``) and the agent's own
    (``state_arrays``).
    """
    arrays = prefixed("representation.", agent.representation_.state_arrays())
    arrays.update(agent.state_arrays())
    return write_agent(path, agent, agent.state_metadata(), arrays)


def restore_agent(cls: type[AgentType], path: str | Path) -> AgentType:
    """Rebuild a linear agent of class ``cls`` saved by `save_agent`, checking what it loads.

    The agent is built from the saved component tree, set up for the saved spec, given the
    representation's arrays and then its own state (``agent.load_state(saved)``).
    """
    saved = read(path)
    with saved.loading():
        agent = read_agent(cls, saved)
        agent.representation_.load_state_arrays(saved.with_prefix("representation."))
        agent.load_state(saved)
    return agent
