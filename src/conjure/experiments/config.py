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
  (plain YAML 1.1 reads it as a string, a classic trap for step sizes), and refuses a key given
  twice, nesting deeper than 100 levels and integer literals over 40 characters; a file must be
  UTF-8. Each failure is one line naming the file.
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
from pydantic import (
    BaseModel,
    BeforeValidator,
    ConfigDict,
    Field,
    ValidationError,
    field_validator,
    model_validator,
)

from conjure.core.errors import InvalidParameterError
from conjure.core.params import Configurable, did_you_mean
from conjure.experiments import registry
from conjure.experiments.limits import (
    MAX_BUDGET_STEPS,
    MAX_EVAL_EPISODES,
    MAX_POLICY_CHECKS,
    check_checks_within_budget,
    parse_seeds,
)
from conjure.experiments.loop import CURVE_COLUMNS
from conjure.experiments.memory import parse_memory_limit

__all__ = [
    "CURVE_COLUMNS",
    "BudgetSteps",
    "ComponentConfig",
    "EvalEpisodes",
    "ExperimentConfig",
    "PolicyChecks",
    "Seeds",
    "apply_overrides",
    "check_not_a_sweep",
    "config_hash",
    "dump_yaml",
    "load_config",
    "load_yaml",
    "parse_config",
    "parse_overridden",
    "read_config_text",
    "resolve",
    "resolve_run",
    "set_component_value",
]


_NAME_PATTERN = r"^[A-Za-z0-9][A-Za-z0-9_.\-]*$"


#: The deepest nesting of YAML collections a config may have; PyYAML composes recursively.
MAX_YAML_DEPTH = 100
#: The longest integer literal read, in characters (int64 needs 19 digits and a sign).
MAX_INT_DIGITS = 40


class _SafeLoader(yaml.SafeLoader):
    """`yaml.SafeLoader` that reads ``1e-3`` as a float and refuses what it cannot read safely.

    Refused: a key given twice in one mapping, collections nested deeper than
    `MAX_YAML_DEPTH`, and integer literals longer than `MAX_INT_DIGITS` characters.
    """

    def __init__(self, stream: str) -> None:
        super().__init__(stream)
        self._depth = 0

    def compose_node(self, parent: Any, index: Any) -> Any:
        self._depth += 1
        try:
            if self._depth > MAX_YAML_DEPTH:
                raise yaml.composer.ComposerError(
                    None,
                    None,
                    f"collections nested deeper than {MAX_YAML_DEPTH} levels",
                    self.peek_event().start_mark,
                )
            return super().compose_node(parent, index)
        finally:
            self._depth -= 1

    def construct_mapping(self, node: Any, deep: bool = False) -> Any:
        if isinstance(node, yaml.MappingNode):
            seen: set[Any] = set()
            for key_node, _ in node.value:
                key = self.construct_object(key_node, deep=True)
                try:
                    repeated = key in seen
                    seen.add(key)
                except TypeError:  # an unhashable key; SafeLoader reports it below
                    continue
                if repeated:
                    raise yaml.constructor.ConstructorError(
                        None, None, f"key {key!r} is given twice", key_node.start_mark
                    )
        return super().construct_mapping(node, deep=deep)

    def construct_yaml_int(self, node: Any) -> int:
        if len(str(node.value)) > MAX_INT_DIGITS:
            raise yaml.constructor.ConstructorError(
                None,
                None,
                f"an integer literal of {len(str(node.value)):,} characters (at most "
                f"{MAX_INT_DIGITS})",
                node.start_mark,
            )
        return super().construct_yaml_int(node)


_SafeLoader.add_constructor("tag:yaml.org,2002:int", _SafeLoader.construct_yaml_int)
_SafeLoader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(r"^[-+]?(?:[0-9][0-9_]*)(?:\.[0-9_]*)?[eE][-+]?[0-9]+$"),
    list("-+0123456789"),
)


def load_yaml(text: str, *, source: str = "<string>") -> Any:
    """Parse YAML safely; any failure becomes one `InvalidParameterError` naming file and line."""
    try:
        return yaml.load(text, Loader=_SafeLoader)  # a SafeLoader subclass: safe
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f"{source}:{mark.line + 1}:{mark.column + 1}" if mark is not None else source
        problem = getattr(exc, "problem", None) or str(exc)
        context = getattr(exc, "context", None)
        detail = f"{problem} ({context})" if context else problem
        raise InvalidParameterError(f"{where}: malformed YAML: {detail}.") from None
    except (RecursionError, MemoryError, ValueError, OverflowError) as exc:
        raise InvalidParameterError(
            f"{source}: unreadable YAML: {type(exc).__name__}: {str(exc)[:200]}."
        ) from None


def read_config_text(path: Path, what: str = "config") -> str:
    """Return the text of a config file; an unreadable or non-UTF-8 file raises one line."""
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise InvalidParameterError(f"Cannot read {what} {str(path)!r}: {exc.strerror}.") from None
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise InvalidParameterError(
            f"{path}: not a UTF-8 text file (byte 0x{data[exc.start]:02x} at offset "
            f"{exc.start:,}); a config is YAML text."
        ) from None


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
#: The sense bounds of `conjure.experiments.limits` as field types.
BudgetSteps = Annotated[int, Field(strict=True, ge=1, le=MAX_BUDGET_STEPS)]
PolicyChecks = Annotated[int, Field(strict=True, ge=1, le=MAX_POLICY_CHECKS)]
EvalEpisodes = Annotated[int, Field(strict=True, ge=1, le=MAX_EVAL_EPISODES)]
#: Seeds: a count, a list, or a range ``"START..END"`` (inclusive), `limits.parse_seeds`.
Seeds = Annotated[int | list[int], BeforeValidator(parse_seeds)]
#: A memory size in bytes, ``4GiB`` or a byte count, at least 1 GiB (`parse_memory_limit`).
MemorySize = Annotated[int | None, BeforeValidator(parse_memory_limit)]


class ExperimentConfig(BaseModel):
    """An experiment: one domain, several labelled agents, a step budget and seeds."""

    model_config = ConfigDict(extra="forbid")

    name: Annotated[str, Field(pattern=_NAME_PATTERN)]
    domain: ComponentConfig
    agents: Annotated[dict[str, ComponentConfig], Field(min_length=1)]
    budget_steps: BudgetSteps
    num_policy_checks: PolicyChecks = 10
    eval_episodes: EvalEpisodes = 1
    seeds: Seeds = 1
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

    @model_validator(mode="after")
    def _checks_within_budget(self) -> ExperimentConfig:
        check_checks_within_budget(self.num_policy_checks, self.budget_steps)
        return self

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
            message = error["msg"].removeprefix("Value error, ").rstrip(".")
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
    data = load_yaml(read_config_text(path), source=str(path))
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
    if not isinstance(params, dict):
        raise InvalidParameterError(
            f"--set {override!r}: `{where}.params` must be a mapping of parameters; got {params!r}."
        )
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
