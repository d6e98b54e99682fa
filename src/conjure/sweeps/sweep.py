"""Sweeps: domains × agents × parameter grids × seeds, expanded into resolved runs.

A sweep YAML extends the experiment YAML (`conjure.experiments.config`)::

    name: chain_sweep
    domains:                          # or `domain: {kind, params}` for a single domain
      chain5: {kind: ChainMDP, params: {num_states: 5}}
      chain8: {kind: ChainMDP, params: {num_states: 8}}
    agents:
      sarsa:
        kind: SARSA
        params:
          representation: {kind: Tabular}
          step_size: {kind: EpisodicDecay, params: {alpha_0: 0.1, decay: 100}}
      q: {kind: QLearning, params: {representation: {kind: Tabular}}}
    grid:                             # every combination of the listed values
      agents.sarsa.params.step_size.params.alpha_0: [0.01, 0.1, 1]
      agents.sarsa.params.step_size.params.decay: [100, 1000, 1000000]
    domain_grids:                     # grids that apply to one domain only (optional)
      chain8: {agents.q.params.step_size: [0.1, 0.5]}
    budget_steps: 2000
    num_policy_checks: 10
    seeds: 10
    max_memory: 4GiB                  # optional: each run's memory limit (default none)
    metric: return
    selection:                        # optional: pick the best setting, rerun on fresh seeds
      criterion: auc                  # auc (mean of the learning curve) or final
      fresh_seeds: 30                 # seeds after the largest grid seed, or a list (0: none)

A grid key is a dotted path into the experiment tree, as ``--set`` takes: ``agents.<label>...``
applies to that agent only, ``domain...`` (or ``domains.<label>...``) to the domain, and a
plain field (``budget_steps``) to every run. Each (domain, agent) pair is crossed only with
the keys that concern it, so a grid over SARSA's step size does not multiply the Q-learning
runs. A run config is `resolve_run`'s, plus ``domain_label`` (with ``domains``) and
``setting`` (the grid values applied, when any), and its hash is the run's id.
"""

from __future__ import annotations

import copy
import functools
import itertools
import json
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any, Literal

import click
from pydantic import (
    BaseModel,
    BeforeValidator,
    ConfigDict,
    Field,
    ValidationError,
    field_validator,
    model_validator,
)

from conjure.core.errors import InvalidParameterError, write_failure
from conjure.core.params import did_you_mean
from conjure.experiments.config import (
    BudgetSteps,
    ComponentConfig,
    EvalEpisodes,
    ExperimentConfig,
    MemorySize,
    PolicyChecks,
    Seeds,
    apply_overrides,
    load_yaml,
    parse_config,
    parse_overridden,
    read_config_text,
    resolve_run,
    set_component_value,
)
from conjure.experiments.limits import check_checks_within_budget, parse_seeds
from conjure.experiments.numbers import format_value
from conjure.experiments.options import (
    max_memory_option,
    max_workers_option,
    out_dir_option,
    overrides_option,
)
from conjure.experiments.parallel import (
    ExperimentResult,
    open_executor,
    pending_runs,
    print_summary,
    run_batch,
)
from conjure.experiments.results import SELECTED_DIR, make_out_dir, summarize, write_atomic
from conjure.experiments.run import RunFunction, run_resolved
from conjure.sweeps.selection import fresh_seeds, select_best, selected_results, selected_runs

if TYPE_CHECKING:
    import pandas as pd
    from rich.console import Console

    from conjure.experiments.executors import Executor

__all__ = [
    "SelectionConfig",
    "SweepConfig",
    "apply_sweep_overrides",
    "expand_sweep",
    "grid_keys_for",
    "load_sweep",
    "parse_sweep",
    "read_sweep_data",
    "resolve_sweep",
    "run_sweep",
    "setting_runs",
    "sweep_command",
]

_NAME_PATTERN = r"^[A-Za-z0-9][A-Za-z0-9_.\-]*$"
_PLAIN_FIELDS = ("budget_steps", "num_policy_checks", "eval_episodes")
PositiveInt = Annotated[int, Field(strict=True, ge=1)]


class SelectionConfig(BaseModel):
    """How to choose a method's best grid setting and report it (Geramifard 2012, §4.3)."""

    model_config = ConfigDict(extra="forbid")

    criterion: Literal["auc", "final"] = "auc"
    mode: Literal["max", "min"] = "max"
    cost_limit: Annotated[float, Field(gt=0, allow_inf_nan=False)] | None = None
    fresh_seeds: Annotated[
        int | list[int], BeforeValidator(functools.partial(parse_seeds, allow_zero=True))
    ] = 30


def _check_values_read_apart(key: str, values: list[Any]) -> None:
    """Refuse grid values that print alike: a setting is named by its printed values."""
    seen: dict[str, Any] = {}
    for value in values:
        text = format_value(value)
        if text in seen and seen[text] != value:
            raise ValueError(
                f"grid key {key!r}: {seen[text]!r} and {value!r} both print as {text} (6 "
                f"significant digits), so their runs would read as one setting; use values "
                f"that differ sooner"
            )
        seen[text] = value


class SweepConfig(BaseModel):
    """A sweep: domains × labelled agents × parameter grids × seeds (see the module docstring)."""

    model_config = ConfigDict(extra="forbid")

    name: Annotated[str, Field(pattern=_NAME_PATTERN)]
    domain: ComponentConfig | None = None
    domains: dict[str, ComponentConfig] | None = None
    agents: Annotated[dict[str, ComponentConfig], Field(min_length=1)]
    grid: dict[str, list[Any]] = Field(default_factory=dict)
    domain_grids: dict[str, dict[str, list[Any]]] = Field(default_factory=dict)
    budget_steps: BudgetSteps
    num_policy_checks: PolicyChecks = 10
    eval_episodes: EvalEpisodes = 1
    seeds: Seeds = 1
    max_workers: PositiveInt | None = None
    max_memory: MemorySize = None
    metric: str = "return"
    selection: SelectionConfig | None = None

    @model_validator(mode="after")
    def _checks_within_budget(self) -> SweepConfig:
        check_checks_within_budget(self.num_policy_checks, self.budget_steps)
        return self

    @field_validator("grid")
    @classmethod
    def _values_are_lists(cls, grid: dict[str, list[Any]]) -> dict[str, list[Any]]:
        for key, values in grid.items():
            if not values:
                raise ValueError(f"grid key {key!r} needs at least one value")
            _check_values_read_apart(key, values)
        return grid

    @field_validator("domain_grids")
    @classmethod
    def _domain_values_read_apart(
        cls, grids: dict[str, dict[str, list[Any]]]
    ) -> dict[str, dict[str, list[Any]]]:
        for grid in grids.values():
            for key, values in grid.items():
                _check_values_read_apart(key, values)
        return grids

    def domain_specs(self) -> dict[str, ComponentConfig]:
        """Return the domains by label (a single ``domain`` is labelled by its kind)."""
        if self.domains:
            return dict(self.domains)
        assert self.domain is not None  # checked by parse_sweep
        return {self.domain.kind: self.domain}

    def seed_list(self) -> list[int]:
        """Return the seeds: ``0 .. N-1`` for a count, else the list given."""
        return list(range(self.seeds)) if isinstance(self.seeds, int) else list(self.seeds)


_SWEEP_FIELDS = list(SweepConfig.model_fields)


def parse_sweep(data: Any, *, source: str = "<sweep>") -> SweepConfig:
    """Validate a plain dict as a `SweepConfig`; check every grid key and every run config.

    An `ExperimentConfig` (or its dict) is a sweep with one domain and no grid.

    Raises
    ------
    InvalidParameterError
        Naming ``source`` and the field or grid key at fault, with a did-you-mean.
    """
    if isinstance(data, SweepConfig):
        sweep = data
    elif isinstance(data, ExperimentConfig):
        sweep = SweepConfig.model_validate(data.model_dump())
    else:
        if not isinstance(data, Mapping):
            raise InvalidParameterError(f"{source}: a sweep config must be a mapping.")
        unknown = [key for key in data if key not in _SWEEP_FIELDS]
        if unknown:
            name = str(unknown[0])
            raise InvalidParameterError(
                f"{source}: unknown field {name!r}.{did_you_mean(name, _SWEEP_FIELDS)} "
                f"Known: {', '.join(_SWEEP_FIELDS)}."
            )
        try:
            sweep = SweepConfig.model_validate(dict(data))
        except ValidationError as exc:
            messages = []
            for error in exc.errors():
                where = ".".join(str(p) for p in error["loc"]) or "<root>"
                message = error["msg"].removeprefix("Value error, ")
                messages.append(f"{where}: {message}")
            raise InvalidParameterError(f"{source}: " + " | ".join(messages) + ".") from None
    if (sweep.domain is None) == (sweep.domains is None) or sweep.domains == {}:
        raise InvalidParameterError(
            f"{source}: give exactly one of `domain` (one component) or `domains` (components "
            f"by label)."
        )
    labels = list(sweep.domain_specs())
    for label in sweep.domain_grids:
        if label not in labels:
            raise InvalidParameterError(
                f"{source}: domain_grids: unknown domain label {label!r}."
                f"{did_you_mean(label, labels)} Known: {', '.join(labels)}."
            )
    for key in sweep.grid:
        _check_key(sweep, key, None, source)
    for label, grid in sweep.domain_grids.items():
        for key in grid:
            _check_key(sweep, key, label, source)
    for domain_label in labels:  # builds every setting once: bad values fail here
        for agent_label in sweep.agents:
            for setting in _settings(sweep, domain_label, agent_label):
                _experiment(sweep, domain_label, agent_label, setting, source)
    return sweep


def _check_key(sweep: SweepConfig, key: str, domain_label: str | None, source: str) -> None:
    where = f"{source}: grid key {key!r}"
    parts = key.split(".")
    head = parts[0]
    heads = ["agents", "domain", "domains", *_PLAIN_FIELDS]
    if head not in heads:
        raise InvalidParameterError(
            f"{where}: unknown field {head!r}.{did_you_mean(head, heads)} Known: "
            f"{', '.join(heads)}."
        )
    if head in _PLAIN_FIELDS and len(parts) > 1:
        raise InvalidParameterError(f"{where}: `{head}` is a plain value; use the key {head!r}.")
    for kind, known in (("agents", list(sweep.agents)), ("domains", list(sweep.domain_specs()))):
        if head == kind:
            if len(parts) < 3:
                raise InvalidParameterError(
                    f"{where}: expected {kind}.<label>.params.<name>..., e.g. "
                    f"agents.sarsa.params.step_size."
                )
            if parts[1] not in known:
                raise InvalidParameterError(
                    f"{where}: unknown {kind[:-1]} label {parts[1]!r}."
                    f"{did_you_mean(parts[1], known)} Known: {', '.join(known)}."
                )
            if kind == "domains" and domain_label is not None and parts[1] != domain_label:
                raise InvalidParameterError(
                    f"{where}: under domain_grids.{domain_label} a key may name that domain only."
                )


def _concerns(key: str, domain_label: str, agent_label: str) -> bool:
    parts = key.split(".")
    if parts[0] == "agents":
        return parts[1] == agent_label
    if parts[0] == "domains":
        return parts[1] == domain_label
    return True


def _settings(sweep: SweepConfig, domain_label: str, agent_label: str) -> list[dict[str, Any]]:
    grid = {**sweep.grid, **sweep.domain_grids.get(domain_label, {})}
    keys = [k for k in grid if _concerns(k, domain_label, agent_label)]
    combinations = itertools.product(*(grid[k] for k in keys))
    return [dict(zip(keys, values, strict=True)) for values in combinations]


def _experiment(
    sweep: SweepConfig,
    domain_label: str,
    agent_label: str,
    setting: Mapping[str, Any],
    source: str,
) -> ExperimentConfig:
    data = {
        "name": sweep.name,
        "domain": sweep.domain_specs()[domain_label].model_dump(),
        "agents": {agent_label: sweep.agents[agent_label].model_dump()},
        "budget_steps": sweep.budget_steps,
        "num_policy_checks": sweep.num_policy_checks,
        "eval_episodes": sweep.eval_episodes,
        "seeds": sweep.seeds,
        "metric": sweep.metric,
    }
    overrides = []
    for key, value in setting.items():
        parts = key.split(".")
        path = ".".join(["domain", *parts[2:]]) if parts[0] == "domains" else key
        overrides.append(f"{path}={json.dumps(value)}")
    where = f"{source}: grid setting {dict(setting)!r}" if setting else source
    try:
        data = apply_overrides(data, overrides)
    except InvalidParameterError as exc:
        raise InvalidParameterError(str(exc).replace("--set ", "grid key ", 1)) from None
    return parse_config(data, source=where)


def expand_sweep(
    sweep: SweepConfig | Mapping[str, Any], seeds: Sequence[int] | None = None
) -> list[dict[str, Any]]:
    """Return every run of ``sweep`` as a resolved run config, domain-major then agent, setting, seed.

    Parameters
    ----------
    sweep : SweepConfig or mapping
        The sweep.
    seeds : sequence of int, optional
        Other seeds than the sweep's (the fresh seeds of a selection rerun).
    """  # noqa: E501
    sweep = parse_sweep(sweep)
    runs = []
    for domain_label in sweep.domain_specs():
        for agent_label in sweep.agents:
            for setting in _settings(sweep, domain_label, agent_label):
                runs.extend(setting_runs(sweep, domain_label, agent_label, setting, seeds))
    return runs


def grid_keys_for(keys: Sequence[str], domain_label: str, agent_label: str) -> list[str]:
    """Return the grid (or search) keys that concern one (domain, agent) pair."""
    return [key for key in keys if _concerns(key, domain_label, agent_label)]


def setting_runs(
    sweep: SweepConfig,
    domain_label: str,
    agent_label: str,
    setting: Mapping[str, Any],
    seeds: Sequence[int] | None = None,
) -> list[dict[str, Any]]:
    """Return the runs (one per seed) of one agent on one domain with grid values ``setting``."""
    experiment = _experiment(sweep, domain_label, agent_label, setting, "<sweep>")
    runs = []
    for seed in list(seeds) if seeds is not None else sweep.seed_list():
        spec = resolve_run(experiment, agent_label, seed)
        if sweep.domains:
            spec["domain_label"] = domain_label
        if setting:
            spec["setting"] = dict(setting)
        runs.append(spec)
    return runs


def resolve_sweep(sweep: SweepConfig | Mapping[str, Any]) -> dict[str, Any]:
    """Return the sweep as a plain dict (seeds as a list), for ``config.resolved.yaml``."""
    sweep = parse_sweep(sweep)
    resolved = sweep.model_dump(exclude_none=True)
    resolved["seeds"] = sweep.seed_list()
    return resolved


def load_sweep(path: str | Path, overrides: Sequence[str] = ()) -> SweepConfig:
    """Read a sweep YAML, apply ``dotted.path=value`` overrides and validate it.

    Overrides take the paths of `apply_sweep_overrides`; a value that makes the file invalid is
    reported against its ``--set`` flag (`conjure.experiments.config.parse_overridden`).
    """
    data = read_sweep_data(path)
    return parse_overridden(data, overrides, apply_sweep_overrides, parse_sweep, source=str(path))


def read_sweep_data(path: str | Path) -> dict[str, Any]:
    """Return the raw mapping of the sweep YAML at ``path``, not yet validated.

    Raises
    ------
    InvalidParameterError
        When the file cannot be read, is not YAML, or does not hold a mapping.
    """
    path = Path(path)
    text = read_config_text(path, "sweep")
    data = load_yaml(text, source=str(path))
    if not isinstance(data, Mapping):
        raise InvalidParameterError(f"{path}: a sweep config must be a mapping.")
    return dict(data)


def apply_sweep_overrides(data: Mapping[str, Any], overrides: Sequence[str]) -> dict[str, Any]:
    """Return a copy of raw sweep ``data`` with each ``dotted.path=value`` override applied.

    The paths of ``conjure run --set`` (``agents.<label>.params...``, ``domain.params...``,
    plain fields), plus ``domains.<label>.params...``, ``selection.<field>``,
    ``grid.<grid key>`` and ``domain_grids.<label>.<grid key>``.
    """
    result = copy.deepcopy(dict(data))
    for override in overrides:
        key, sep, text = override.partition("=")
        parts = key.strip().split(".")
        head, rest = parts[0], parts[1:]
        if not sep or head not in _SWEEP_FIELDS:
            raise InvalidParameterError(
                f"--set {override!r}: expected dotted.path=value starting with a sweep field."
                f"{did_you_mean(head, _SWEEP_FIELDS)} Known: {', '.join(_SWEEP_FIELDS)}."
            )
        if head in ("domain", "agents", *_PLAIN_FIELDS, "seeds", "metric", "name"):
            result = apply_overrides(result, [override])
            continue
        value = load_yaml(text, source=f"--set {key}")
        if not rest:
            result[head] = value
        elif head == "domains":
            domains = result.get("domains")
            labels = list(domains) if isinstance(domains, Mapping) else []
            if rest[0] not in labels:
                raise InvalidParameterError(
                    f"--set {override!r}: unknown domain label {rest[0]!r}."
                    f"{did_you_mean(rest[0], labels)} Known: {', '.join(labels) or '(none)'}."
                )
            set_component_value(domains[rest[0]], rest[1:], value, override, f"domains.{rest[0]}")
        elif head == "grid":
            result.setdefault("grid", {})[".".join(rest)] = value
        elif head == "domain_grids" and len(rest) > 1:
            result.setdefault("domain_grids", {}).setdefault(rest[0], {})[".".join(rest[1:])] = (
                value
            )
        elif head == "selection" and len(rest) == 1:
            result.setdefault("selection", {})[rest[0]] = value
        else:
            raise InvalidParameterError(
                f"--set {override!r}: `{head}` takes {head}=VALUE"
                + (" or domain_grids.<label>.<grid key>=[...]." if head == "domain_grids" else ".")
            )
    return result


@click.command("sweep")
@click.argument("config", type=click.Path(dir_okay=False, path_type=Path))
@out_dir_option("Results folder (default results/<sweep name>); finished runs in it are reused.")
@click.option(
    "--executor",
    type=click.Choice(["local", "dask", "ray"]),
    default="local",
    show_default=True,
    help="Where runs execute.",
)
@click.option(
    "--address", default=None, help="A Dask scheduler or Ray cluster address (default: local)."
)
@max_workers_option
@max_memory_option
@overrides_option(
    "Override a config value, e.g. seeds=3 or agents.sarsa.params.step_size=0.05 (repeatable; "
    "default: none)."
)
@click.option("--quiet", is_flag=True, help="No progress bar or summary table (default: shown).")
def sweep_command(
    config: Path,
    out_dir: Path | None,
    executor: str,
    address: str | None,
    max_workers: int | None,
    max_memory: int | None,
    overrides: tuple[str, ...],
    quiet: bool,
) -> None:
    """Run the sweep CONFIG (YAML); rerunning the same command resumes it."""
    from rich.console import Console

    from conjure.experiments.executors import make_executor
    from conjure.experiments.shipped import find_config

    sweep = load_sweep(find_config(config), overrides)
    out_dir = out_dir or Path("results") / sweep.name
    console = Console()
    engine = make_executor(
        executor,
        address=address,
        max_workers=max_workers or sweep.max_workers,
        max_memory=max_memory or sweep.max_memory,
    )
    with engine:
        outcome = run_sweep(sweep, out_dir, executor=engine, progress=not quiet, console=console)
    console.print(f"Results in {out_dir}; `conjure report {out_dir}` writes the report.")
    if outcome.errors:
        raise click.exceptions.Exit(1)


def run_sweep(
    sweep: SweepConfig | ExperimentConfig | Mapping[str, Any],
    out_dir: str | Path,
    *,
    executor: Executor | None = None,
    max_workers: int | None = None,
    max_memory: int | str | None = None,
    run_fn: RunFunction = run_resolved,
    progress: bool = True,
    console: Console | None = None,
) -> ExperimentResult:
    """Run every run of a sweep under ``out_dir``; with ``selection``, rerun the best settings.

    Parameters
    ----------
    sweep : SweepConfig, ExperimentConfig or dict
        The sweep.
    out_dir : str or Path
        The results folder; finished runs in it are reused. The fresh-seed rerun of the
        selected settings goes to ``out_dir/selected``, the choice to ``selection.csv``; with
        ``fresh_seeds: 0`` the result's ``selected`` holds the chosen settings' search runs.
    executor : Executor or None
        Default a `LocalExecutor` with ``max_workers`` (else the sweep's, else the CPU count)
        and ``max_memory`` (else the sweep's). A given executor keeps its own limits.
    max_workers : int or None
        See ``executor``.
    max_memory : int, str or None
        Each run's memory limit (``"4GiB"``; `conjure.experiments.memory`); see ``executor``.
    run_fn : callable, default `run_resolved`
        See `conjure.experiments.parallel.execute_runs`.
    progress : bool, default True
        Show progress and print the summary tables.
    console : rich.console.Console or None
        Where to print.

    Returns
    -------
    ExperimentResult
    """
    from rich.console import Console

    sweep = parse_sweep(sweep)
    out_dir = make_out_dir(out_dir)
    console = console or Console()
    runs = expand_sweep(sweep)
    pending = pending_runs(out_dir, resolve_sweep(sweep), runs)
    with open_executor(
        executor,
        pending,
        max_workers=max_workers or sweep.max_workers,
        max_memory=max_memory or sweep.max_memory,
        run_fn=run_fn,
    ) as engine:
        batch = functools.partial(
            run_batch, executor=engine, metric=sweep.metric, run_fn=run_fn, progress=progress
        )
        outcome = batch(runs, out_dir, console=console, description=sweep.name)
        if sweep.selection is None or outcome.results.empty:
            return outcome
        choice = sweep.selection
        best = select_best(
            outcome.results,
            metric=sweep.metric,
            criterion=choice.criterion,
            mode=choice.mode,
            cost_limit=choice.cost_limit,
        )
        try:
            write_atomic(out_dir / "selection.csv", best.to_csv(index=False))
        except OSError as exc:
            raise write_failure(exc, f"the search's runs are safe in {out_dir}.") from None
        if progress:
            console.print(
                f"Best setting per method by {choice.criterion} of {sweep.metric} "
                f"({choice.mode}): see {out_dir / 'selection.csv'}"
            )
        outcome.selection = best
        seeds = fresh_seeds(sweep.seed_list(), choice.fresh_seeds)
        if not seeds:
            outcome.selected = _on_search_seeds(outcome, best)
            if progress:
                print_summary(
                    outcome.selected,
                    console,
                    title=f"{out_dir}: the best settings on the search seeds (fresh_seeds: 0, "
                    "so no rerun; the choice biases these upward)",
                )
            return outcome
        final_runs = selected_runs(runs, best, seeds)
        outcome.selected = batch(
            final_runs,
            out_dir / SELECTED_DIR,
            console=console,
            description=f"{sweep.name}: best settings, fresh seeds",
        )
        outcome.errors.update(outcome.selected.errors)
        return outcome


def _on_search_seeds(outcome: ExperimentResult, best: pd.DataFrame) -> ExperimentResult:
    """The search runs of the chosen settings, as the result of a rerun with no fresh seeds."""
    results = selected_results(outcome.results, best)
    return ExperimentResult(
        outcome.out_dir, results, summarize(results, metric=outcome.metric), metric=outcome.metric
    )
