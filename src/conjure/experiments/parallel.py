"""Run every (agent label, seed) pair of an experiment, in parallel, resumably.

`run_experiment` resolves the config, skips runs already finished under ``out_dir`` (same
resolved-config hash), runs the rest in a process pool, writes each run's files as soon as it
finishes, then combines them into ``results.parquet`` and ``summary.csv`` (see
`conjure.experiments.results`) and prints a summary table.

Notes
-----
- Choice: workers start with the "forkserver" method (or "spawn" where unavailable), never
  "fork": a forked numba or BLAS runtime can deadlock. Before starting them, the parent runs
  one tiny run per agent so numba compiles once and workers load the compiled code from its
  on-disk cache.
- Choice: ``max_workers=1`` runs everything in the calling process, with no pool (simplest to
  debug; components registered only in this process work too).
- Choice: a failed run writes ``error.txt`` (with the traceback) and does not stop the others;
  a rerun retries it.
"""

from __future__ import annotations

import concurrent.futures as cf
import multiprocessing
import os
import traceback
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pandas as pd
from rich.console import Console
from rich.progress import (
    BarColumn,
    MofNCompleteColumn,
    Progress,
    TextColumn,
    TimeElapsedColumn,
    TimeRemainingColumn,
)
from rich.table import Table

from conjure.core.errors import DivergenceError
from conjure.experiments.config import (
    ExperimentConfig,
    dump_yaml,
    parse_config,
    resolve,
    resolve_run,
)
from conjure.experiments.results import (
    RESOLVED_FILE,
    is_run_done,
    load_results,
    remove_stale_temporaries,
    run_dir,
    save_run,
    save_run_error,
    summarize,
    write_atomic,
    write_results,
)
from conjure.experiments.run import run_resolved

__all__ = ["ExperimentResult", "print_summary", "run_experiment"]

_WARMUP_STEPS = 50


@dataclass
class ExperimentResult:
    """What `run_experiment` produced.

    Attributes
    ----------
    out_dir : Path
        The experiment folder.
    results : pandas.DataFrame
        Every finished run's curve (``results.parquet``).
    summary : pandas.DataFrame
        Per label: final mean ``metric`` ± 95% CI, features, steps/s (``summary.csv``).
    errors : dict
        ``(label, seed) -> one-line message`` for the runs that failed this time.
    num_skipped : int
        Runs found finished and not rerun.
    metric : str
        The learning-curve column the summary reports.
    """

    out_dir: Path
    results: pd.DataFrame
    summary: pd.DataFrame
    errors: dict[tuple[str, int], str] = field(default_factory=dict)
    num_skipped: int = 0
    metric: str = "return"


def _execute(run_spec: dict[str, Any], directory: str) -> tuple[str, int, str | None]:
    """Run one resolved run and write its files; return (label, seed, error or None)."""
    label, seed = run_spec["label"], run_spec["seed"]
    try:
        result = run_resolved(run_spec)
    except Exception as exc:  # recorded, reported, not fatal to other runs
        partial = getattr(exc, "partial_result", None) if isinstance(exc, DivergenceError) else None
        save_run_error(directory, run_spec, traceback.format_exc(), partial)
        message = f"{type(exc).__name__}: {exc}".splitlines()[0]
        return label, seed, message
    result.config = run_spec
    save_run(result, directory)
    return label, seed, None


def _warm_up(runs: list[dict[str, Any]]) -> None:
    """Compile (and cache) numba code in this process with one tiny run per agent label."""
    seen: set[str] = set()
    for spec in runs:
        if spec["label"] in seen:
            continue
        seen.add(spec["label"])
        tiny = {**spec, "budget_steps": _WARMUP_STEPS, "num_policy_checks": 1, "eval_episodes": 1}
        try:
            run_resolved(tiny)
        except Exception:  # the real run records the error
            continue


def _pool_context() -> multiprocessing.context.BaseContext:
    methods = multiprocessing.get_all_start_methods()
    return multiprocessing.get_context("forkserver" if "forkserver" in methods else "spawn")


def run_experiment(
    config: ExperimentConfig | dict[str, Any],
    out_dir: str | Path,
    max_workers: int | None = None,
    progress: bool = True,
    console: Console | None = None,
) -> ExperimentResult:
    """Run every (agent label, seed) pair of ``config`` and write results under ``out_dir``.

    Parameters
    ----------
    config : ExperimentConfig or dict
        The experiment.
    out_dir : str or Path
        The experiment folder (created if needed; finished runs in it are skipped).
    max_workers : int or None
        Worker processes; default ``config.max_workers``, else the CPU count (never more than
        the runs to do). 1 runs in this process.
    progress : bool, default True
        Show a progress bar and print the summary table.
    console : rich.console.Console or None
        Where to print (default: standard output).

    Returns
    -------
    ExperimentResult
    """
    config = parse_config(config)
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    remove_stale_temporaries(out_dir)
    resolved = resolve(config)
    write_atomic(out_dir / RESOLVED_FILE, dump_yaml(resolved))
    console = console or Console()

    all_runs = [
        resolve_run(config, label, seed) for label in config.agents for seed in resolved["seeds"]
    ]
    todo = [
        spec
        for spec in all_runs
        if not is_run_done(run_dir(out_dir, spec["label"], spec["seed"]), spec)
    ]
    num_skipped = len(all_runs) - len(todo)
    workers = max_workers or config.max_workers or os.cpu_count() or 1
    workers = max(1, min(workers, len(todo)))
    errors: dict[tuple[str, int], str] = {}

    with Progress(
        TextColumn("[bold]{task.description}"),
        BarColumn(),
        MofNCompleteColumn(),
        TextColumn("runs"),
        TimeElapsedColumn(),
        TextColumn("ETA"),
        TimeRemainingColumn(),
        console=console,
        disable=not progress,
    ) as bar:
        task = bar.add_task(config.name, total=len(all_runs), completed=num_skipped)

        def finished(label: str, seed: int, error: str | None) -> None:
            if error is not None:
                errors[(label, seed)] = error
                bar.console.print(f"[red]run {label}/seed_{seed} failed:[/red] {error}")
            bar.advance(task)

        if workers == 1:
            for spec in todo:
                directory = run_dir(out_dir, spec["label"], spec["seed"])
                finished(*_execute(spec, str(directory)))
        elif todo:
            _warm_up(todo)
            with cf.ProcessPoolExecutor(workers, mp_context=_pool_context()) as pool:
                futures = {
                    pool.submit(
                        _execute, spec, str(run_dir(out_dir, spec["label"], spec["seed"]))
                    ): spec
                    for spec in todo
                }
                try:
                    for future in cf.as_completed(futures):
                        spec = futures[future]
                        try:
                            finished(*future.result())
                        except Exception as exc:  # e.g. a killed worker
                            directory = run_dir(out_dir, spec["label"], spec["seed"])
                            save_run_error(
                                directory, spec, "".join(traceback.format_exception(exc))
                            )
                            finished(spec["label"], spec["seed"], f"{type(exc).__name__}: {exc}")
                except BaseException:
                    pool.shutdown(wait=False, cancel_futures=True)
                    raise

    finished_runs = [(spec["label"], spec["seed"]) for spec in all_runs]
    results = load_results(out_dir, finished_runs)
    summary = summarize(results, metric=config.metric)
    write_results(out_dir, results, summary)
    outcome = ExperimentResult(out_dir, results, summary, errors, num_skipped, config.metric)
    if progress:
        print_summary(outcome, console)
    return outcome


def print_summary(outcome: ExperimentResult, console: Console | None = None) -> None:
    """Print the per-label summary table (final metric ± 95% CI, features, steps/s)."""
    console = console or Console()
    metric = outcome.metric
    table = Table(title=f"{outcome.out_dir}: final policy check, mean over seeds")
    for name, justify in (
        ("label", "left"),
        ("seeds", "right"),
        (f"final {metric.replace('_', ' ')} ± 95% CI", "right"),
        ("features", "right"),
        ("steps/s", "right"),
    ):
        table.add_column(name, justify=justify)  # type: ignore[arg-type]
    for row in outcome.summary.to_dict("records"):
        half = row[f"final_{metric}_ci95"]
        ci = "" if pd.isna(half) else f" ± {half:.4g}"
        table.add_row(
            str(row["label"]),
            str(row["num_seeds"]),
            f"{row[f'final_{metric}_mean']:.4g}{ci}",
            f"{row['final_num_features']:,.0f}",
            "n/a"
            if pd.isna(row["mean_steps_per_second"])
            else f"{row['mean_steps_per_second']:,.0f}",
        )
    console.print(table)
    if outcome.num_skipped:
        console.print(f"{outcome.num_skipped} finished run(s) were reused (not rerun).")
    for (label, seed), message in outcome.errors.items():
        console.print(
            f"[red]failed:[/red] {label}/seed_{seed}: {message} "
            f"(see {run_dir(outcome.out_dir, label, seed) / 'error.txt'})"
        )
