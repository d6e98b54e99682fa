"""Hyperparameter search with Optuna (optional extra ``tune``): ``conjure tune CONFIG``.

A tuning YAML is a sweep YAML (`conjure.sweeps.sweep`) without ``grid`` or
``selection``, plus a ``search`` section::

    search:
      space:                                    # dotted paths, as grid keys
        agents.sarsa.params.step_size.params.alpha_0: {low: 0.01, high: 1.0, log: true}
        agents.sarsa.params.step_size.params.decay: {choices: [100, 1000, 1000000]}
        agents.sarsa.params.trace_decay: {low: 0.0, high: 0.9}
      num_trials: 20            # completed trials per method
      criterion: auc            # or final (see conjure.sweeps.selection)
      mode: max                 # or min
      sampler_seed: 0
      heartbeat_interval: 10    # seconds
      grace_period: 30          # a RUNNING trial silent this long is marked FAIL, then retried
      max_retry: 2              # reruns of a trial whose worker died

One Optuna study per method (each (domain, agent label) pair, with the search keys that
concern it), stored in ``OUT/optuna.db`` (SQLite). A trial's value is the mean over the
config's seeds of the criterion; its runs go through the sweep machinery
(`conjure.experiments.parallel.execute_runs`) into ``OUT/runs``, so they are resumable and a
retried trial reuses the runs its dead predecessor finished. Rerunning the command continues
the studies. Several ``conjure tune`` processes may share one ``OUT`` to tune in parallel.

Notes
-----
- Choice: SQLite storage with a heartbeat, because a trial whose process died is then marked
  FAIL and re-enqueued with the same parameters (`optuna.storages.RetryFailedTrialCallback`);
  with journal-file storage it would stay RUNNING forever.
- Choice: a trial with a failed run (an exception or a divergence) is marked FAIL and not
  retried: its parameters are bad, not its worker.
- Choice: ``float`` ranges with ``{low, high}``, ``int`` ranges with ``type: int``,
  categorical with ``{choices: [...]}``.
"""

from __future__ import annotations

import inspect
import math
import warnings
from collections.abc import Mapping
from pathlib import Path
from typing import Annotated, Any, Literal

import click
import pandas as pd
from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator
from rich.console import Console

from conjure.core.errors import InvalidParameterError
from conjure.core.params import did_you_mean
from conjure.experiments.config import dump_yaml, load_yaml, read_config_text
from conjure.experiments.executors import Executor, LocalExecutor
from conjure.experiments.numbers import format_number, format_value
from conjure.experiments.options import max_memory_option, max_workers_option, out_dir_option
from conjure.experiments.parallel import execute_runs, prepare_executor
from conjure.experiments.results import load_results, make_out_dir, write_atomic
from conjure.experiments.run import RunFunction, run_resolved
from conjure.sweeps.selection import score_runs
from conjure.sweeps.sweep import SweepConfig, grid_keys_for, parse_sweep, setting_runs

__all__ = ["SearchConfig", "SearchRange", "TuneConfig", "load_tune", "tune", "tune_command"]


class SearchRange(BaseModel):
    """One searched parameter: a ``[low, high]`` range (``log``, ``type: int``) or ``choices``."""

    model_config = ConfigDict(extra="forbid")

    low: float | None = None
    high: float | None = None
    log: bool = False
    type: Literal["float", "int"] = "float"
    choices: list[Any] | None = None

    @model_validator(mode="after")
    def _range_or_choices(self) -> SearchRange:
        if self.choices is not None:
            if not self.choices or self.low is not None or self.high is not None:
                raise ValueError("give either non-empty `choices` or `low` and `high`")
            return self
        if self.low is None or self.high is None or not self.low < self.high:
            raise ValueError(f"needs low < high; got low={self.low!r}, high={self.high!r}")
        if self.log and self.low <= 0:
            raise ValueError(f"a log range needs low > 0; got {self.low!r}")
        return self

    def values(self) -> list[Any]:
        """The values that bound the range (checked against the components at load time)."""
        if self.choices is not None:
            return list(self.choices)
        cast = int if self.type == "int" else float
        return [cast(self.low), cast(self.high)]


class SearchConfig(BaseModel):
    """The ``search`` section of a tuning config (see the module docstring)."""

    model_config = ConfigDict(extra="forbid")

    space: Annotated[dict[str, SearchRange], Field(min_length=1)]
    num_trials: Annotated[int, Field(strict=True, ge=1)] = 20
    criterion: Literal["auc", "final"] = "auc"
    mode: Literal["max", "min"] = "max"
    sampler_seed: int | None = 0
    heartbeat_interval: Annotated[int, Field(strict=True, ge=1)] = 10
    grace_period: Annotated[int, Field(strict=True, ge=1)] | None = None
    max_retry: Annotated[int, Field(strict=True, ge=0)] = 2


class TuneConfig(BaseModel):
    """A tuning config: a sweep without grid (``sweep``) and its ``search``."""

    model_config = ConfigDict(arbitrary_types_allowed=True)

    sweep: SweepConfig
    search: SearchConfig


def parse_tune(data: Any, *, source: str = "<tune>") -> TuneConfig:
    """Validate a tuning config (a mapping); bad search keys fail with a did-you-mean."""
    if isinstance(data, TuneConfig):
        return data
    if not isinstance(data, Mapping) or "search" not in data:
        raise InvalidParameterError(
            f"{source}: a tuning config is a sweep config with a `search` section "
            f"(search.space, search.num_trials, ...)."
        )
    data = dict(data)
    raw_search = data.pop("search")
    for name in ("grid", "selection"):
        if name in data:
            raise InvalidParameterError(
                f"{source}: a tuning config has no `{name}`; put searched keys under search.space."
            )
    try:
        search = SearchConfig.model_validate(raw_search)
    except ValidationError as exc:
        messages = []
        for error in exc.errors():
            where = ".".join(str(p) for p in ("search", *error["loc"]))
            if error["type"] == "extra_forbidden":
                name, known = str(error["loc"][-1]), list(SearchConfig.model_fields)
                if len(error["loc"]) > 1:
                    known = list(SearchRange.model_fields)
                messages.append(f"{where}: unknown field.{did_you_mean(name, known)}")
            else:
                messages.append(f"{where}: {error['msg'].removeprefix('Value error, ')}")
        raise InvalidParameterError(f"{source}: " + " | ".join(messages) + ".") from None
    # The range ends (or every choice) must build: check them as a grid.
    checked = {**data, "grid": {key: spec.values() for key, spec in search.space.items()}}
    parse_sweep(checked, source=source)
    return TuneConfig(sweep=parse_sweep(data, source=source), search=search)


def load_tune(path: str | Path) -> TuneConfig:
    """Read and validate a tuning YAML."""
    path = Path(path)
    text = read_config_text(path, "config")
    return parse_tune(load_yaml(text, source=str(path)), source=str(path))


class _RunsFailed(Exception):
    """A trial's run failed: the trial is FAIL (bad parameters), not retried."""


def _suggest(trial: Any, key: str, spec: SearchRange) -> Any:
    if spec.choices is not None:
        return trial.suggest_categorical(key, spec.choices)
    if spec.type == "int":
        return trial.suggest_int(key, int(spec.low), int(spec.high), log=spec.log)
    return trial.suggest_float(key, float(spec.low), float(spec.high), log=spec.log)


def _storage(out_dir: Path, search: SearchConfig) -> Any:
    import optuna
    from optuna import storages

    parameters = inspect.signature(storages.RDBStorage).parameters
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", optuna.exceptions.ExperimentalWarning)
        if "heartbeat_stale_trial_callback" in parameters:  # Optuna >= 4.9
            retry = storages.RetryHeartbeatStaleTrialCallback(max_retry=search.max_retry)
            callback = {"heartbeat_stale_trial_callback": retry}
        else:
            retry = storages.RetryFailedTrialCallback(max_retry=search.max_retry)
            callback = {"failed_trial_callback": retry}
        return storages.RDBStorage(
            f"sqlite:///{(out_dir / 'optuna.db').resolve()}",
            engine_kwargs={"connect_args": {"timeout": 60}},
            heartbeat_interval=search.heartbeat_interval,
            grace_period=search.grace_period or 2 * search.heartbeat_interval,
            **callback,
        )


def tune(
    config: TuneConfig | Mapping[str, Any],
    out_dir: str | Path,
    *,
    executor: Executor | None = None,
    max_workers: int | None = None,
    num_trials: int | None = None,
    run_fn: RunFunction = run_resolved,
    progress: bool = True,
    console: Console | None = None,
) -> pd.DataFrame:
    """Tune every method of ``config`` with Optuna; return each method's best parameters.

    Parameters
    ----------
    config : TuneConfig or mapping
        The tuning config (see the module docstring).
    out_dir : str or Path
        Holds ``optuna.db``, the runs, ``trials.csv`` and ``best.yaml``.
    executor : Executor or None
        Where each trial's seeds run; default a `LocalExecutor` (with the sweep's
        ``max_memory``).
    max_workers : int or None
        For the default executor.
    num_trials : int or None
        Completed trials wanted per method (default ``search.num_trials``).
    run_fn : callable, default `run_resolved`
        See `conjure.experiments.parallel.execute_runs`.
    progress : bool, default True
        Print one line per trial and the best parameters.
    console : rich.console.Console or None
        Where to print.

    Returns
    -------
    pandas.DataFrame
        One row per method: ``study``, ``best_value``, ``num_complete``, ``num_failed`` and
        the best parameters.
    """
    try:
        import optuna
    except ImportError:
        raise InvalidParameterError(
            "`conjure tune` needs Optuna; install it with `pip install -e '.[tune]'` in the "
            "conjure checkout."
        ) from None
    config = parse_tune(config)
    sweep, search = config.sweep, config.search
    wanted = num_trials or search.num_trials
    out_dir = make_out_dir(out_dir)
    console = console or Console()
    executor = executor or LocalExecutor(
        max_workers=max_workers or sweep.max_workers, max_memory=sweep.max_memory
    )
    storage = _storage(out_dir, search)
    optuna.logging.set_verbosity(optuna.logging.WARNING)
    state = optuna.trial.TrialState
    rows, trial_rows = [], []
    first = {key: spec.values()[0] for key, spec in search.space.items()}
    samples = [
        run
        for d in sweep.domain_specs()
        for a in sweep.agents
        for run in setting_runs(sweep, d, a, {k: first[k] for k in grid_keys_for(first, d, a)})
    ]
    prepare_executor(executor, samples, run_fn)
    with executor:
        for domain_label in sweep.domain_specs():
            for agent_label in sweep.agents:
                keys = grid_keys_for(list(search.space), domain_label, agent_label)
                name = ".".join(
                    [sweep.name, *([domain_label] if sweep.domains else []), agent_label]
                )

                def objective(
                    trial: Any,
                    d: str = domain_label,
                    a: str = agent_label,
                    keys: list[str] = keys,
                ) -> float:
                    setting = {key: _suggest(trial, key, search.space[key]) for key in keys}
                    runs = setting_runs(sweep, d, a, setting)
                    report = execute_runs(
                        runs, out_dir, executor=executor, run_fn=run_fn, progress=False
                    )
                    trial.set_user_attr("run_ids", report.run_ids)
                    if report.errors:
                        first = next(iter(report.errors.values()))
                        raise _RunsFailed(f"{len(report.errors)} run(s) failed: {first}")
                    results = load_results(out_dir, report.run_ids)
                    return float(score_runs(results, sweep.metric, search.criterion).mean())

                def announce(study: Any, trial: Any, name: str = name) -> None:
                    if progress:
                        value = (
                            "" if trial.value is None else f" value {format_number(trial.value)}"
                        )
                        params = ", ".join(
                            f"{k}={format_value(v)}" for k, v in trial.params.items()
                        )
                        console.print(
                            f"{name} trial {trial.number}: {trial.state.name}{value} {params}"
                        )

                study = optuna.create_study(
                    study_name=name,
                    storage=storage,
                    direction="maximize" if search.mode == "max" else "minimize",
                    sampler=optuna.samplers.TPESampler(seed=search.sampler_seed),
                    load_if_exists=True,
                )
                complete = len(study.get_trials(deepcopy=False, states=(state.COMPLETE,)))
                if complete < wanted:
                    study.optimize(
                        objective,
                        n_trials=wanted - complete,
                        catch=(_RunsFailed,),
                        callbacks=[
                            optuna.study.MaxTrialsCallback(wanted, states=(state.COMPLETE,)),
                            announce,
                        ],
                        gc_after_trial=False,
                    )
                trials = study.get_trials(deepcopy=False)
                for trial in trials:
                    trial_rows.append(
                        {
                            "study": name,
                            "number": trial.number,
                            "state": trial.state.name,
                            "value": trial.value,
                            "retry_of": trial.system_attrs.get("failed_trial"),
                            **{f"param.{k}": v for k, v in trial.params.items()},
                        }
                    )
                done = [t for t in trials if t.state == state.COMPLETE]
                best = study.best_trial if done else None
                rows.append(
                    {
                        "study": name,
                        "best_value": best.value if best else math.nan,
                        "num_complete": len(done),
                        "num_failed": sum(t.state == state.FAIL for t in trials),
                        **(best.params if best else {}),
                    }
                )
    table = pd.DataFrame(rows)
    write_atomic(out_dir / "trials.csv", pd.DataFrame(trial_rows).to_csv(index=False))
    best_grid = {
        row["study"]: {k: v for k, v in row.items() if k in search.space and not _isnan(v)}
        for row in rows
    }
    write_atomic(out_dir / "best.yaml", dump_yaml(best_grid))
    if progress:
        formats = {key: format_value for key in search.space if key in table.columns}
        console.print(
            table.to_string(index=False, formatters={"best_value": format_number, **formats})
        )
        console.print(f"Trials in {out_dir / 'trials.csv'}; best settings in {out_dir}/best.yaml")
    return table


def _isnan(value: Any) -> bool:
    return isinstance(value, float) and math.isnan(value)


@click.command("tune")
@click.argument("config", type=click.Path(dir_okay=False, path_type=Path))
@out_dir_option("Folder of optuna.db and the runs (default results/<name>-tune); reruns continue.")
@click.option(
    "--trials",
    type=click.IntRange(min=1),
    default=None,
    help="Trials per method (default: the config's search.num_trials).",
)
@click.option(
    "--executor",
    type=click.Choice(["local", "dask", "ray"]),
    default="local",
    show_default=True,
    help="Where each trial's seeds run.",
)
@click.option(
    "--address",
    default=None,
    help="A Dask scheduler or Ray cluster address (default: local).",
)
@max_workers_option
@max_memory_option
@click.option("--quiet", is_flag=True, help="No per-trial lines (default: shown).")
def tune_command(
    config: Path,
    out_dir: Path | None,
    trials: int | None,
    executor: str,
    address: str | None,
    max_workers: int | None,
    max_memory: int | None,
    quiet: bool,
) -> None:
    """Tune the methods of CONFIG (a sweep YAML with a `search` section) with Optuna."""
    from conjure.experiments.executors import make_executor

    parsed = load_tune(config)
    out_dir = out_dir or Path("results") / f"{parsed.sweep.name}-tune"
    engine = make_executor(
        executor,
        address=address,
        max_workers=max_workers or parsed.sweep.max_workers,
        max_memory=max_memory or parsed.sweep.max_memory,
    )
    tune(parsed, out_dir, executor=engine, num_trials=trials, progress=not quiet)
