"""Experiment configs: a typed, validated YAML tree of ``{kind, params}`` components (STYLE §3).

An experiment YAML looks like::

    name: pendulum
    domain: {kind: InvertedPendulum, params: {}}
    agents:                       # several agents compared in one experiment, by label
      tile_coding:
        kind: SARSA
        params:
          representation: {kind: TileCoding, params: {num_tilings: 8}}
          policy: {kind: EpsilonGreedy, params: {epsilon: 0.1}}
          step_size: 0.0625
    budget_steps: 30000
    num_policy_checks: 10         # default 10
    eval_episodes: 1              # default 1
    seeds: 4                      # a count (seeds 0..3) or an explicit list [0, 7, 9]
    max_workers: 2                # optional
    max_memory: 4GiB              # optional: each run's memory limit (default none)
    metric: episode_length        # the curve column summarised and plotted; default return

`load_config` reads it, applies ``--set dotted.path=value`` overrides, validates the tree
(pydantic) and builds every component once so that a bad kind, parameter, type or range fails
at load time with the field path. `resolve` fills in every default.

Notes
-----
- Choice: YAML is read with a `yaml.SafeLoader` subclass that also reads ``1e-3`` as a float
  (plain YAML 1.1 reads it as a string, a classic trap for step sizes); nothing else differs.
"""

from __future__ import annotations

import copy
import hashlib
import json
import re
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Annotated, Any

import yaml
from pydantic import BaseModel, BeforeValidator, ConfigDict, Field, ValidationError, field_validator

from conjure.core.errors import InvalidParameterError
from conjure.core.params import Configurable, did_you_mean
from conjure.experiments import registry
from conjure.experiments.loop import CURVE_COLUMNS
from conjure.experiments.memory import parse_memory_size

__all__ = [
    "CURVE_COLUMNS",
    "ComponentConfig",
    "ExperimentConfig",
    "apply_overrides",
    "check_not_a_sweep",
    "config_hash",
    "dump_yaml",
    "load_config",
    "load_yaml",
    "parse_config",
    "parse_overridden",
    "resolve",
    "resolve_run",
    "set_component_value",
]


_NAME_PATTERN = r"^[A-Za-z0-9][A-Za-z0-9_.\-]*$"


class _SafeLoader(yaml.SafeLoader):
    """`yaml.SafeLoader` that also resolves ``1e-3`` and ``1E5`` as floats."""


_SafeLoader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(r"^[-+]?(?:[0-9][0-9_]*)(?:\.[0-9_]*)?[eE][-+]?[0-9]+$"),
    list("-+0123456789"),
)


def load_yaml(text: str, *, source: str = "<string>") -> Any:
    """Parse YAML safely; a syntax error becomes `InvalidParameterError` naming file and line."""
    try:
        return yaml.load(text, Loader=_SafeLoader)  # a SafeLoader subclass: safe
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f"{source}:{mark.line + 1}:{mark.column + 1}" if mark is not None else source
        problem = getattr(exc, "problem", None) or str(exc)
        context = getattr(exc, "context", None)
        detail = f"{problem} ({context})" if context else problem
        raise InvalidParameterError(f"{where}: malformed YAML: {detail}.") from exc


def dump_yaml(data: Any) -> str:
    """Return ``data`` as block-style YAML, keys in insertion order."""
    return yaml.safe_dump(data, sort_keys=False, default_flow_style=False, allow_unicode=True)


def config_hash(data: Mapping[str, Any]) -> str:
    """Return a short SHA-256 of a resolved config (stable across key order)."""
    text = json.dumps(data, sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


# ---------------------------------------------------------------------------------------------
# The typed tree


class ComponentConfig(BaseModel):
    """One component: its registry ``kind`` and its ``params`` (nested components allowed)."""

    model_config = ConfigDict(extra="forbid")

    kind: str
    params: dict[str, Any] = Field(default_factory=dict)

    @field_validator("params", mode="before")
    @classmethod
    def _none_is_empty(cls, value: Any) -> Any:
        return {} if value is None else value


PositiveInt = Annotated[int, Field(strict=True, ge=1)]
#: A memory size in bytes, written as ``4GiB``, ``512MiB`` or a byte count (`parse_memory_size`).
MemorySize = Annotated[int | None, BeforeValidator(parse_memory_size)]


class ExperimentConfig(BaseModel):
    """An experiment: one domain, several labelled agents, a step budget and seeds."""

    model_config = ConfigDict(extra="forbid")

    name: Annotated[str, Field(pattern=_NAME_PATTERN)]
    domain: ComponentConfig
    agents: Annotated[dict[str, ComponentConfig], Field(min_length=1)]
    budget_steps: PositiveInt
    num_policy_checks: PositiveInt = 10
    eval_episodes: PositiveInt = 1
    seeds: int | list[int] = 1
    max_workers: PositiveInt | None = None
    max_memory: MemorySize = None
    metric: str = "return"

    @field_validator("metric")
    @classmethod
    def _metric_is_a_curve_column(cls, metric: str) -> str:
        if metric not in CURVE_COLUMNS:
            raise ValueError(
                f"metric must be a learning-curve column, one of {', '.join(CURVE_COLUMNS)}; "
                f"got {metric!r}"
            )
        return metric

    @field_validator("agents")
    @classmethod
    def _labels_are_names(cls, agents: dict[str, ComponentConfig]) -> dict[str, ComponentConfig]:
        for label in agents:
            if not re.match(_NAME_PATTERN, label):
                raise ValueError(
                    f"agent label {label!r} must be usable as a folder name "
                    f"(letters, digits, '_', '-', '.')"
                )
        return agents

    @field_validator("seeds", mode="before")
    @classmethod
    def _check_seeds(cls, value: Any) -> Any:
        def is_int(v: Any) -> bool:
            return isinstance(v, int) and not isinstance(v, bool)

        if is_int(value):
            if value < 1:
                raise ValueError(f"a seed count must be >= 1; got {value!r}")
            return value
        if isinstance(value, list) and value and all(is_int(v) and v >= 0 for v in value):
            if len(set(value)) != len(value):
                raise ValueError(f"seeds must be distinct; got {value!r}")
            return value
        raise ValueError(
            "seeds must be a count (int >= 1, seeds 0..N-1) or a non-empty list of distinct "
            f"ints >= 0; got {value!r}"
        )

    def seed_list(self) -> list[int]:
        """Return the seeds: ``0 .. N-1`` for a count, else the list given."""
        return list(range(self.seeds)) if isinstance(self.seeds, int) else list(self.seeds)


_COMPONENT_FIELDS = list(ComponentConfig.model_fields)
_EXPERIMENT_FIELDS = list(ExperimentConfig.model_fields)


def _format_location(loc: Sequence[Any]) -> str:
    parts = [str(p) for p in loc if not (isinstance(p, str) and p.startswith("function-"))]
    return ".".join(parts) or "<root>"


def _format_validation_error(exc: ValidationError, source: str) -> str:
    messages = []
    for error in exc.errors():
        loc = error["loc"]
        where = _format_location(loc)
        if error["type"] == "extra_forbidden":
            name = str(loc[-1])
            known = _EXPERIMENT_FIELDS if len(loc) == 1 else _COMPONENT_FIELDS
            messages.append(
                f"{where}: unknown field {name!r}.{did_you_mean(name, known)} "
                f"Known: {', '.join(known)}."
            )
        elif error["type"] == "missing":
            messages.append(f"{where}: required field is missing.")
        else:
            message = error["msg"].removeprefix("Value error, ")
            got = repr(error.get("input"))
            if " got " in message or len(got) > 120:  # the validator already named the value
                messages.append(f"{where}: {message}.")
            else:
                messages.append(f"{where}: {message}; got {got}.")
    return f"{source}: " + " | ".join(messages)


def parse_config(data: Any, *, source: str = "<config>") -> ExperimentConfig:
    """Validate a plain dict as an `ExperimentConfig` and check every component builds.

    Raises
    ------
    InvalidParameterError
        Naming ``source`` and the field path of the first problem(s).
    """
    if isinstance(data, ExperimentConfig):
        config = data
    else:
        if not isinstance(data, Mapping):
            raise InvalidParameterError(
                f"{source}: an experiment config must be a mapping with fields "
                f"{', '.join(_EXPERIMENT_FIELDS)}; got {type(data).__name__}."
            )
        try:
            config = ExperimentConfig.model_validate(dict(data))
        except ValidationError as exc:
            raise InvalidParameterError(_format_validation_error(exc, source)) from None
    try:
        build_components(config)
    except InvalidParameterError as exc:
        raise InvalidParameterError(f"{source}: {exc}") from None
    return config


def build_components(config: ExperimentConfig) -> tuple[Configurable, dict[str, Configurable]]:
    """Build the domain and every agent of ``config`` (parameters validated, nothing set up)."""
    domain = registry.build("domain", config.domain.model_dump(), path="domain")
    agents = {
        label: registry.build("agent", spec.model_dump(), path=f"agents.{label}")
        for label, spec in config.agents.items()
    }
    return domain, agents


def load_config(path: str | Path, overrides: Sequence[str] = ()) -> ExperimentConfig:
    """Read an experiment YAML, apply ``dotted.path=value`` overrides, and validate it.

    Parameters
    ----------
    path : str or Path
        The YAML file.
    overrides : sequence of str
        ``--set`` overrides such as ``agents.tile.params.step_size=0.05``; values are parsed as
        YAML; paths are checked against the config fields and each component's parameters.

    Returns
    -------
    ExperimentConfig
    """
    path = Path(path)
    try:
        text = path.read_text()
    except OSError as exc:
        raise InvalidParameterError(f"Cannot read config {str(path)!r}: {exc.strerror}.") from None
    data = load_yaml(text, source=str(path))
    check_not_a_sweep(data, str(path))
    if not overrides:
        return parse_config(data, source=str(path))
    if not isinstance(data, Mapping):
        raise InvalidParameterError(f"{path}: an experiment config must be a mapping.")
    return parse_overridden(data, overrides, apply_overrides, parse_config, source=str(path))


#: Top-level fields a sweep config (`conjure sweep`, docs/sweeps.md) has and an experiment lacks.
_SWEEP_ONLY_FIELDS = ("grid", "domains", "domain_grids", "selection")


def check_not_a_sweep(data: Any, source: str) -> None:
    """Raise `InvalidParameterError` with the right command if ``data`` is a sweep or tuning config.

    Examples
    --------
    >>> check_not_a_sweep({"name": "x", "grid": {}}, "fig.yaml")
    Traceback (most recent call last):
    ...
    conjure.core.errors.InvalidParameterError: fig.yaml is a sweep config (it has `grid`), not \
an experiment; run it with `conjure sweep fig.yaml`.
    """
    if not isinstance(data, Mapping):
        return
    if "search" in data:
        raise InvalidParameterError(
            f"{source} is a tuning config (it has `search`), not an experiment; run it with "
            f"`conjure tune {source}`."
        )
    fields = [name for name in _SWEEP_ONLY_FIELDS if name in data]
    if fields:
        raise InvalidParameterError(
            f"{source} is a sweep config (it has `{fields[0]}`), not an experiment; run it with "
            f"`conjure sweep {source}`."
        )


# ---------------------------------------------------------------------------------------------
# Overrides


def parse_overridden(
    data: Mapping[str, Any],
    overrides: Sequence[str],
    apply: Callable[[Mapping[str, Any], Sequence[str]], dict[str, Any]],
    parse: Callable[..., Any],
    *,
    source: str,
) -> Any:
    """Apply ``--set`` overrides to a config file's ``data`` and validate: blame who is at fault.

    An invalid path is reported by ``apply`` (naming the flag). An invalid value is reported
    against the first override that makes the valid file invalid (``--set 'path=value': ...``);
    when the file itself is invalid, against the file (``source``).
    """
    try:
        return parse(apply(data, overrides), source=source)
    except InvalidParameterError:
        if not _parses(parse, data):
            raise
    culprit = next(
        override
        for count, override in enumerate(overrides, 1)
        if not _parses(parse, apply(data, overrides[:count]))
    )
    return parse(apply(data, overrides), source=f"--set {culprit!r}")  # raises


def _parses(parse: Callable[..., Any], data: Mapping[str, Any]) -> bool:
    try:
        parse(data, source="")
    except InvalidParameterError:
        return False
    return True


def apply_overrides(data: Mapping[str, Any], overrides: Sequence[str]) -> dict[str, Any]:
    """Return a copy of raw config ``data`` with each ``dotted.path=value`` override applied."""
    result = copy.deepcopy(dict(data))
    for override in overrides:
        key, sep, text = override.partition("=")
        key = key.strip()
        if not sep or not key:
            raise InvalidParameterError(
                f"--set {override!r}: expected dotted.path=value, e.g. "
                f"agents.sarsa.params.step_size=0.05."
            )
        value = load_yaml(text, source=f"--set {key}")
        _set_experiment(result, key.split("."), value, override)
    return result


def _set_experiment(node: dict[str, Any], keys: list[str], value: Any, override: str) -> None:
    head, rest = keys[0], keys[1:]
    if head not in _EXPERIMENT_FIELDS:
        raise InvalidParameterError(
            f"--set {override!r}: unknown field {head!r}.{did_you_mean(head, _EXPERIMENT_FIELDS)}"
            f" Known: {', '.join(_EXPERIMENT_FIELDS)}."
        )
    if not rest:
        node[head] = value
    elif head == "domain":
        set_component_value(node.setdefault("domain", {}), rest, value, override, "domain")
    elif head == "agents":
        agents = node.get("agents")
        labels = list(agents) if isinstance(agents, Mapping) else []
        label = rest[0]
        if label not in labels:
            raise InvalidParameterError(
                f"--set {override!r}: unknown agent label {label!r}."
                f"{did_you_mean(label, labels)} Known: {', '.join(labels) or '(none)'}."
            )
        if len(rest) == 1:
            agents[label] = value
        else:
            set_component_value(agents[label], rest[1:], value, override, f"agents.{label}")
    else:
        raise InvalidParameterError(
            f"--set {override!r}: `{head}` is a plain value; use --set {head}=VALUE."
        )


def set_component_value(node: Any, keys: list[str], value: Any, override: str, where: str) -> None:
    """Set ``value`` at the path ``keys`` (``params.<name>...``) inside the component ``node``.

    Each name is checked against the component's fields and its kind's parameters; errors name
    the ``--set`` ``override`` and ``where`` (the component's path).
    """
    if not isinstance(node, dict):
        raise InvalidParameterError(
            f"--set {override!r}: `{where}` is not a {{kind, params}} component."
        )
    head, rest = keys[0], keys[1:]
    if head not in _COMPONENT_FIELDS:
        raise InvalidParameterError(
            f"--set {override!r}: `{where}` has no field {head!r}."
            f"{did_you_mean(head, _COMPONENT_FIELDS)} A component has `kind` and `params`."
        )
    if not rest:
        node[head] = value
        return
    if head == "kind":
        raise InvalidParameterError(f"--set {override!r}: `{where}.kind` is a plain value.")
    cls = registry.find_kind(node.get("kind"), path=f"--set {override!r}: {where}.kind")
    params = node.get("params")
    if params is None:
        params = node["params"] = {}
    name, rest = rest[0], rest[1:]
    known = cls.param_names()
    if name not in known:
        raise InvalidParameterError(
            f"--set {override!r}: {cls.__name__} has no parameter {name!r}."
            f"{did_you_mean(name, known)} Known: {', '.join(known)}."
        )
    if not rest:
        params[name] = value
        return
    inner = params.get(name)
    if inner is None:
        default = cls.param_defaults()[name]
        inner = registry.to_spec(default) if isinstance(default, Configurable) else {}
        params[name] = inner
    if isinstance(inner, dict) and rest[0] in _COMPONENT_FIELDS and ("kind" in inner or not inner):
        set_component_value(inner, rest, value, override, f"{where}.params.{name}")
    elif isinstance(inner, dict):  # a plain mapping parameter, e.g. env_kwargs
        for key in rest[:-1]:
            inner = inner.setdefault(key, {})
            if not isinstance(inner, dict):
                raise InvalidParameterError(f"--set {override!r}: {key!r} is not a mapping.")
        inner[rest[-1]] = value
    else:
        raise InvalidParameterError(
            f"--set {override!r}: `{cls.__name__}.{name}` is a plain value "
            f"({inner!r}); it has no field {rest[0]!r}."
        )


# ---------------------------------------------------------------------------------------------
# Resolution


def resolve(config: ExperimentConfig | Mapping[str, Any]) -> dict[str, Any]:
    """Return the experiment as a plain dict with every default filled in (recursively).

    Seeds become an explicit list.
    """
    config = config if isinstance(config, ExperimentConfig) else parse_config(config)
    domain, agents = build_components(config)
    return {
        "name": config.name,
        "domain": registry.to_spec(domain),
        "agents": {label: registry.to_spec(agent) for label, agent in agents.items()},
        "budget_steps": config.budget_steps,
        "num_policy_checks": config.num_policy_checks,
        "eval_episodes": config.eval_episodes,
        "seeds": config.seed_list(),
        "max_workers": config.max_workers,
        "max_memory": config.max_memory,
    }


def resolve_run(
    config: ExperimentConfig | Mapping[str, Any], label: str, seed: int
) -> dict[str, Any]:
    """Return the resolved config of one run (one agent label, one seed).

    Its `config_hash` identifies the run for resume; `run_config` accepts it.
    """
    resolved = resolve(config)
    if label not in resolved["agents"]:
        labels = list(resolved["agents"])
        raise InvalidParameterError(
            f"Unknown agent label {label!r}.{did_you_mean(label, labels)} "
            f"Known: {', '.join(labels)}."
        )
    return {
        "name": resolved["name"],
        "label": label,
        "seed": int(seed),
        "domain": resolved["domain"],
        "agent": resolved["agents"][label],
        "budget_steps": resolved["budget_steps"],
        "num_policy_checks": resolved["num_policy_checks"],
        "eval_episodes": resolved["eval_episodes"],
    }
