"""Run many resolved runs resumably on an executor: experiments and sweeps share this path.

`execute_runs` is the one execution path. It skips runs whose result file already exists
(`conjure.experiments.results`: ``runs/<run_id>.json``, the id being the hash of the run's
resolved config), warms numba's on-disk cache once in this process, maps the rest over an
`~conjure.experiments.executors.Executor`, and writes each run's file (or its error file) the
moment the run comes back, with a live count of runs done, failed and remaining and an ETA.
`run_batch` executes a list of runs and summarizes them; `run_experiment` runs every (agent,
seed) pair of an experiment. Sweeps (`conjure.sweeps.sweep.run_sweep`) build on the same two.

Notes
-----
- Choice: the driver, not the worker, writes result files: workers need no shared file system
  (a Dask or Ray node may have its own disk), and there is a single writer per folder. Killing
  the driver loses only the runs in flight; killing a worker reruns its run.
- Choice: a failed run (any exception, or a worker that died more than ``max_retries`` times)
  writes ``errors/<run_id>.txt`` and does not stop the others; a rerun of the command retries
  it. A diverged run also keeps the curve it recorded (``errors/<run_id>.partial.csv``). A
  run over its memory limit (``max_memory``) fails with a `MemoryError` whose message names
  the limit; it is not retried.
- Choice: before any run starts, each agent is set up on its domain once per distinct (domain,
  agent) pair (`conjure.experiments.preflight`): parts that cannot work together give one
  error, not one failed run per seed.
- Choice: before workers on this machine start, one tiny run per distinct component structure
  (the tree of kinds) compiles the numba kernels once and fills their on-disk cache; workers
  then load compiled code instead of compiling it again. The tiny runs run in one worker
  process (under the memory limit, if any), never in the driver.
"""

from __future__ import annotations

import functools
import math
import time
from collections import Counter
from collections.abc import Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pandas as pd
from rich.console import Console
from rich.markup import escape
from rich.progress import (
    BarColumn,
    Progress,
    TextColumn,
    TimeElapsedColumn,
    TimeRemainingColumn,
)
from rich.table import Table

from conjure.core.errors import RunsFailedError, RunsInterruptedError, write_failure
from conjure.experiments.claims import Claims, Owner
from conjure.experiments.config import ExperimentConfig, dump_yaml, parse_config, resolve_run
from conjure.experiments.display import phase
from conjure.experiments.executors import NOT_CLAIMED, Executor, LocalExecutor, TaskFailure
from conjure.experiments.limits import MAX_COMPILE_STEPS
from conjure.experiments.loop import (
    COMPILE_WORTH_STEPS,
    REAL_VALUED,
    cold_kernel,
    compile_pays,
    compile_seconds_estimate,
)
from conjure.experiments.numbers import format_interval, format_value, readable_setting
from conjure.experiments.preflight import check_runs
from conjure.experiments.results import (
    ERRORS_DIR,
    RESOLVED_FILE,
    RUNS_DIR,
    is_run_done,
    load_results,
    make_out_dir,
    remove_stale_temporaries,
    run_file_problem,
    run_id,
    run_path,
    save_run,
    save_run_error,
    summarize,
    write_atomic,
    write_planned_runs,
    write_results,
    write_run_ids,
)
from conjure.experiments.run import RunFunction, run_resolved, run_task

__all__ = [
    "ExperimentResult",
    "RunsReport",
    "execute_runs",
    "open_executor",
    "pending_runs",
    "prepare_executor",
    "print_summary",
    "run_batch",
    "run_experiment",
    "warm_up",
]

_WARMUP_STEPS = 50
#: A warm-up probe's learning steps (its second half measures the Python step).
_PROBE_STEPS = 400
_POLL_SECONDS = 2.0


@dataclass
class RunsReport:
    """What `execute_runs` did.

    Attributes
    ----------
    run_ids : list of str
        Every requested run's id, in request order (duplicates removed).
    num_skipped : int
        Runs found finished and not rerun.
    errors : dict
        ``run_id -> one-line message`` for the runs that failed this time.
    redone : dict
        ``run_id -> reason`` for the runs whose file was present but unusable (a checksum
        mismatch, `conjure.experiments.results.run_file_problem`) and which were run again.
    """

    run_ids: list[str]
    num_skipped: int = 0
    errors: dict[str, str] = field(default_factory=dict)
    redone: dict[str, str] = field(default_factory=dict)


@dataclass
class ExperimentResult:
    """What `run_experiment` or `conjure.sweeps.sweep.run_sweep` produced.

    Attributes
    ----------
    out_dir : Path
        The results folder.
    results : pandas.DataFrame
        Every finished run's curve (``results.parquet``).
    summary : pandas.DataFrame
        Per method: final mean ``metric`` ± 95% CI, features, steps/s (``summary.csv``).
    errors : dict
        ``run_id -> one-line message`` for the runs that failed this time.
    num_skipped : int
        Runs found finished and not rerun.
    metric : str
        The learning-curve column the summary reports.
    runs : list of dict
        Every run's resolved config.
    selection : pandas.DataFrame or None
        With a sweep's ``selection``: each method's best setting (``selection.csv``).
    selected : ExperimentResult or None
        With a sweep's ``selection``: the best settings rerun on fresh seeds (``selected/``),
        or with ``fresh_seeds: 0`` their runs on the search seeds.
    """

    out_dir: Path
    results: pd.DataFrame
    summary: pd.DataFrame
    errors: dict[str, str] = field(default_factory=dict)
    num_skipped: int = 0
    metric: str = "return"
    runs: list[dict[str, Any]] = field(default_factory=list, repr=False)
    selection: pd.DataFrame | None = None
    selected: ExperimentResult | None = None


def _structure(spec: Any) -> Any:
    """The tree of component kinds in a config (what numba compiles for)."""
    if isinstance(spec, Mapping):
        if "kind" in spec:
            params = spec.get("params") or {}
            return (spec["kind"], tuple((k, _structure(v)) for k, v in sorted(params.items())))
        return tuple((k, _structure(v)) for k, v in sorted(spec.items()))
    return None


def warm_up(
    runs: Sequence[Mapping[str, Any]],
    run_fn: RunFunction = run_resolved,
    max_memory: int | None = None,
    console: Console | None = None,
) -> int:
    """Compile (and cache) the loop's compilations that the whole command's steps pay for.

    First one short probe run per component structure (what numba compiles for) learns on
    the Python path, or finds its compilation warm, and measures its Python step's seconds
    (from the probe's second half). Then, for each cold compilation
    (`conjure.experiments.loop.cold_kernel`), all the steps of ``runs`` that would run on it,
    at their methods' measured Python cost, are weighed against its compile
    (`conjure.experiments.loop.compile_pays`); where it pays, one tiny run compiles it (its
    ``compile_steps`` at the maximum) into numba's disk cache, and the command's runs find it
    warm. The tiny runs run one after another in one worker process (under ``max_memory``, if
    given): one that crashes or outgrows memory must not take the driver down; their errors
    and deaths are ignored (the real runs record them). ``console``: where the measuring and
    compiling phases are shown (None: nowhere). Returns the number of tiny runs.
    """
    steps: dict[Any, int] = Counter()
    probes: dict[Any, dict[str, Any]] = {}
    for spec in runs:
        key = (_structure(spec.get("domain")), _structure(spec.get("agent")))
        steps[key] += int(spec.get("budget_steps", 0))
        if key not in probes:
            changes = {"budget_steps": _PROBE_STEPS, "num_policy_checks": 2, "eval_episodes": 1}
            probes[key] = {**{k: v for k, v in spec.items() if k != "compile_steps"}, **changes}
    keys = list(probes)
    with LocalExecutor(
        max_workers=1, max_retries=0, max_memory=max_memory, in_process=False
    ) as executor:
        cold: dict[str, list[tuple[Any, float]]] = {}
        with phase(console, "measuring each method's Python step"):
            for index, outcome in executor.map_unordered(run_fn, list(probes.values())):
                kernel = cold_kernel(getattr(outcome, "path", "") or "")
                seconds = _python_step_seconds(getattr(outcome, "rows", None))
                if kernel is not None and seconds is not None:
                    cold.setdefault(kernel, []).append((keys[index], seconds))
        paying = [
            kernel
            for kernel, found in cold.items()
            if _compile_pays(kernel, [(steps[key], seconds) for key, seconds in found])
        ]
        changes = {"budget_steps": _WARMUP_STEPS, "num_policy_checks": 1}
        compile_runs = [
            {**probes[cold[kernel][0][0]], **changes, "compile_steps": MAX_COMPILE_STEPS}
            for kernel in paying
        ]
        if compile_runs:
            about = sum(compile_seconds_estimate(k == REAL_VALUED) for k in paying)
            with phase(console, f"compiling kernels, first run only: about {about:.0f} s"):
                for _ in executor.map_unordered(run_fn, compile_runs):
                    pass
    return len(probes) + len(compile_runs)


def _python_step_seconds(rows: Any) -> float | None:
    """A probe's Python step seconds: its second half's wall time over its steps."""
    try:
        half, end = rows[-2], rows[-1]
        return (end["wall_time_s"] - half["wall_time_s"]) / (
            end["learning_steps"] - half["learning_steps"]
        )
    except (TypeError, IndexError, KeyError, ZeroDivisionError):
        return None


def _compile_pays(kernel: str, runs: Sequence[tuple[int, float]]) -> bool:
    """Whether ``runs`` ((steps, Python step seconds) on one cold compilation) pay its compile."""
    total = sum(n for n, _ in runs)
    mean = sum(n * seconds for n, seconds in runs) / total if total else 0.0
    return compile_pays(total, mean, real_valued=kernel == REAL_VALUED)


def _describe(spec: Mapping[str, Any]) -> str:
    parts = [str(spec.get(k)) for k in ("domain_label", "label") if k in spec]
    setting = spec.get("setting")
    if setting:
        parts.append(
            ",".join(f"{k.rsplit('.', 1)[-1]}={format_value(v)}" for k, v in setting.items())
        )
    return "/".join(parts) + f"/seed_{spec.get('seed')}"


def pending_runs(
    out_dir: Path, resolved: Mapping[str, Any], runs: Sequence[dict[str, Any]]
) -> list[dict[str, Any]]:
    """Write the resolved config into ``out_dir`` and return the runs not finished there yet.

    A rerun of the same command therefore resumes: finished runs are never run again. A
    config that cannot be written raises `ResultsWriteError` (before any run starts).
    """
    pending = [spec for spec in runs if not is_run_done(out_dir, spec)]
    try:
        write_atomic(out_dir / RESOLVED_FILE, dump_yaml(dict(resolved)))
    except OSError as exc:
        raise write_failure(exc, _nothing_started(out_dir, len(runs) - len(pending))) from None
    return pending


def _nothing_started(out_dir: Path, num_finished: int) -> str:
    """What a write failure before the first run keeps."""
    return f"no run has started ({num_finished} finished before are safe in {out_dir})."


def execute_runs(
    runs: Sequence[dict[str, Any]],
    out_dir: str | Path,
    *,
    executor: Executor | None = None,
    run_fn: RunFunction = run_resolved,
    progress: bool = True,
    console: Console | None = None,
    description: str = "runs",
) -> RunsReport:
    """Run every not-yet-finished run of ``runs``, writing ``OUT/runs/<run_id>.json`` for each.

    Parameters
    ----------
    runs : sequence of dict
        Resolved run configs (`conjure.sweeps.sweep.expand_sweep`, `resolve_run`).
    out_dir : str or Path
        The results folder (created if needed).
    executor : Executor or None
        Where to run; default a `LocalExecutor` with one worker per CPU. Started here if it is
        not yet (and then shut down here).
    run_fn : callable, default `run_resolved`
        Runs one resolved config and returns a `Result`; must be importable by the workers. A
        function that registers your own components before calling `run_resolved` makes them
        available on every worker.
    progress : bool, default True
        Show the live progress bar (done, failed, remaining, ETA).
    console : rich.console.Console or None
        Where to print.
    description : str, default "runs"
        The progress bar's title.

    Returns
    -------
    RunsReport
    """
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    remove_stale_temporaries(out_dir)
    by_id: dict[str, dict[str, Any]] = {}
    for spec in runs:
        by_id.setdefault(run_id(spec), spec)
    problems = {i: run_file_problem(out_dir, spec) for i, spec in by_id.items()}
    todo = [(i, spec) for i, spec in by_id.items() if problems[i] is not None]
    redone = {i: p for i, p in problems.items() if p not in (None, "missing")}
    report = RunsReport(list(by_id), num_skipped=len(by_id) - len(todo), redone=redone)
    if redone:  # printed even with --quiet: a resume never silently replaces a result
        reasons = ", ".join(f"{n} {r}" for r, n in Counter(redone.values()).most_common())
        console = console or Console()
        console.print(
            f"Resume: redoing {len(redone)} run(s) whose file in {out_dir / RUNS_DIR} was "
            f"unusable ({reasons}).",
            highlight=False,
            soft_wrap=True,
        )
    if not todo:
        return report
    executor = executor or LocalExecutor()
    owns = not executor.is_started
    console = console or Console()
    if owns:
        prepare_executor(
            executor, [spec for _, spec in todo], run_fn, console if progress else None
        )
    batch = _Batch(out_dir, todo, report, run_fn)
    try:
        with Claims(out_dir) as claims, _progress(console, progress, report) as bar:
            batch.run(executor, claims, bar, description)
    except OSError:
        if batch.claim_error is None:
            raise
    except KeyboardInterrupt:
        raise RunsInterruptedError(
            f"Interrupted: {batch.num_saved()} of {len(by_id)} runs are saved in {out_dir}; "
            "the same command resumes (finished runs are not rerun)."
        ) from None
    finally:
        if owns:
            executor.shutdown()
    batch.raise_write_errors()
    return report


def _progress(console: Console, progress: bool, report: RunsReport) -> Progress:
    """The live bar: runs done, failed, remaining (and held by other drivers), ETA."""
    return Progress(
        TextColumn("[bold]{task.description}"),
        BarColumn(),
        TextColumn(
            "{task.fields[done]} done · [red]{task.fields[failed]} failed[/red] · "
            "{task.fields[remaining]} remaining"
            + (f" · {report.num_skipped} reused" if report.num_skipped else "")
        ),
        TimeElapsedColumn(),
        TextColumn("ETA"),
        TimeRemainingColumn(),
        console=console,
        disable=not progress,
    )


class _Batch:
    """The runs one `execute_runs` call still has to finish, and what became of them.

    Runs are claimed just before they start (`conjure.experiments.claims`); a run another
    live driver holds is waited for (polled every `_POLL_SECONDS`) and counted as reused
    when its result appears, or run here if its owner dies. A result that cannot be written
    is counted, not fatal: the other runs go on (`raise_write_errors` reports it at the end).
    A claim that cannot be written stops the batch (no further run can start safely).
    """

    def __init__(
        self,
        out_dir: Path,
        todo: list[tuple[str, dict[str, Any]]],
        report: RunsReport,
        run_fn: RunFunction,
    ):
        self.out_dir, self.report, self.run_fn = out_dir, report, run_fn
        self.waiting = list(todo)
        self.retries: dict[str, list[str]] = {}
        self.write_errors: list[OSError] = []
        self.claim_error: OSError | None = None
        self.counts = {"done": 0, "failed": 0, "remaining": len(todo)}

    def run(self, executor: Executor, claims: Claims, bar: Progress, description: str) -> None:
        """Run the waiting runs this driver can claim; wait for those others hold."""
        task = bar.add_task(description, total=len(self.waiting), **self.counts)
        said_held = False
        while self.waiting:
            held = self._run_wave(executor, claims, bar, task)
            if not held:
                return
            if not said_held:
                said_held = _say_held(claims.holders([i for i, _ in held]), bar.console)
            self.waiting = self._wait_for_others(held, claims, bar, task)

    def _run_wave(
        self, executor: Executor, claims: Claims, bar: Progress, task: Any
    ) -> list[tuple[str, dict[str, Any]]]:
        """Map the waiting runs over ``executor``; return those another driver held."""
        wave, held = self.waiting, []

        def claim(index: int) -> bool:
            identifier, spec = wave[index]
            try:
                taken = claims.take(identifier)
            except OSError as exc:
                self.claim_error = exc
                raise
            return taken and not is_run_done(self.out_dir, spec)

        def on_retry(index: int, cause: str) -> None:
            identifier, spec = wave[index]
            self.retries.setdefault(identifier, []).append(cause)
            bar.console.print(
                f"[yellow]run {_describe(spec)}: its worker {cause}; running it again "
                f"(attempt {len(self.retries[identifier]) + 1}).[/yellow]"
            )

        task_fn = functools.partial(run_task, run_fn=self.run_fn)
        specs = [spec for _, spec in wave]
        for index, outcome in executor.map_unordered(
            task_fn, specs, claim=claim, on_retry=on_retry
        ):
            identifier, spec = wave[index]
            if outcome is NOT_CLAIMED:
                if is_run_done(self.out_dir, spec):
                    claims.release(identifier)
                    self._count_other(bar, task)
                else:
                    held.append(wave[index])
                continue
            self._record(identifier, spec, outcome, bar)
            claims.release(identifier)
            bar.update(task, advance=1, **self.counts)
        return held

    def _record(self, identifier: str, spec: dict[str, Any], outcome: Any, bar: Progress) -> None:
        """Write one run's result or error file and count it."""
        if self.retries.get(identifier) and isinstance(outcome, dict):
            outcome["meta"]["worker_deaths"] = self.retries[identifier]
        self.counts["remaining"] -= 1
        try:
            message = _record(self.out_dir, spec, outcome)
        except OSError as exc:
            self.write_errors.append(exc)
            self.counts["failed"] += 1
            return
        if message is None:
            self.counts["done"] += 1
            return
        self.counts["failed"] += 1
        self.report.errors[identifier] = message
        bar.console.print(
            f"[red]run {escape(_describe(spec))} failed:[/red] {escape(_first_line(message))}",
            no_wrap=True,
            overflow="ellipsis",
        )

    def _count_other(self, bar: Progress, task: Any) -> None:
        """A run another driver finished: reused, not run here."""
        self.counts["remaining"] -= 1
        self.report.num_skipped += 1
        bar.update(task, advance=1, **self.counts)

    def _wait_for_others(
        self, held: list[tuple[str, dict[str, Any]]], claims: Claims, bar: Progress, task: Any
    ) -> list[tuple[str, dict[str, Any]]]:
        """Poll ``held`` until one is free to take; return the ones not finished by others."""
        while True:
            time.sleep(_POLL_SECONDS)
            still = []
            for identifier, spec in held:
                if is_run_done(self.out_dir, spec):
                    self._count_other(bar, task)
                else:
                    still.append((identifier, spec))
            if not still:
                return []
            owners = claims.holders([identifier for identifier, _ in still])
            if sum(owners.values()) < len(still):
                return still

    def num_saved(self) -> int:
        """Runs of this call (finished before it or by it) whose result file exists."""
        return sum(run_path(self.out_dir, i).is_file() for i in self.report.run_ids)

    def raise_write_errors(self) -> None:
        """Report results (or a claim) that could not be written, in one line."""
        errors = [*self.write_errors, *([self.claim_error] if self.claim_error else [])]
        if not errors:
            return
        lost = f"{len(self.write_errors)} finished run(s) could not be saved, "
        stopped = "no further run could start, " if self.claim_error else ""
        raise write_failure(
            errors[0],
            f"{lost if self.write_errors else ''}{stopped}{self.counts['done']} saved this "
            f"time and {self.report.num_skipped} before are safe in {self.out_dir}.",
        )


def _say_held(owners: Mapping[Owner, int], console: Console) -> bool:
    """Print how many runs other drivers hold, from one look at the claims; whether it did.

    Nothing is printed when no run is held any more (their owners finished them meanwhile).
    """
    total = sum(owners.values())
    if not total:
        return False
    who = ", ".join(f"{owner} holds {n}" for owner, n in owners.items())
    drivers = "another driver" if len(owners) == 1 else f"{len(owners)} other drivers"
    console.print(
        f"{total} run(s) are held by {drivers} ({who}); waiting for them (this driver runs "
        "any whose owner stops)."
    )
    return True


def prepare_executor(
    executor: Executor,
    todo: Sequence[dict[str, Any]],
    run_fn: RunFunction = run_resolved,
    console: Console | None = None,
) -> None:
    """Warm numba's cache for ``todo`` if workers are local processes (`warm_up`); start it.

    Done when more than one worker shares the runs, or when one worker's short runs could
    earn a compile back only together (`conjure.experiments.loop.COMPILE_WORTH_STEPS`); else
    each run weighs its own steps (`conjure.experiments.loop.learning_stepper`). An executor
    already started (``with executor:``) is warmed too: the warm-up runs in its own process
    and the workers load the cached code on their first run. ``console``: where the phases
    are shown.
    """
    steps = [int(spec.get("budget_steps", 0)) for spec in todo]
    is_many = min(executor.num_workers, len(todo)) > 1
    # Short runs that earn a compile back only together (a long run compiles for itself).
    is_shared = bool(steps) and sum(steps) >= COMPILE_WORTH_STEPS > min(steps)
    if todo and executor.is_local and (is_many or is_shared):
        warm_up(todo, run_fn, executor.max_memory, console)
    if not executor.is_started:
        executor.start()


def _record(out_dir: Path, spec: dict[str, Any], outcome: Any) -> str | None:
    """Write a run's result or error file; return the error message or ``None``."""
    if isinstance(outcome, TaskFailure):
        save_run_error(out_dir, spec, outcome.traceback)
        return outcome.message
    if outcome["error"] is not None:
        save_run_error(out_dir, spec, outcome["error"], outcome["partial"])
        return outcome["message"]
    save_run(out_dir, spec, outcome["curve"], outcome["meta"])
    return None


def run_batch(
    runs: list[dict[str, Any]],
    out_dir: Path,
    *,
    executor: Executor,
    metric: str,
    run_fn: RunFunction = run_resolved,
    progress: bool = True,
    console: Console | None = None,
    description: str = "runs",
) -> ExperimentResult:
    """Execute ``runs`` (`execute_runs`), then collect, summarize and write their results.

    Writes ``planned.csv`` first, then ``run_ids.txt``, ``results.parquet`` and
    ``summary.csv``; prints the summary when ``progress``. A result table that cannot be
    written raises `ResultsWriteError` (the run files stay).
    """
    console = console or Console()
    try:
        write_planned_runs(out_dir, runs)
    except OSError as exc:
        done = sum(is_run_done(out_dir, spec) for spec in runs)
        raise write_failure(exc, _nothing_started(out_dir, done)) from None
    report = execute_runs(
        runs,
        out_dir,
        executor=executor,
        run_fn=run_fn,
        progress=progress,
        console=console,
        description=description,
    )
    results = load_results(out_dir, report.run_ids)
    summary = summarize(results, metric=metric)
    try:
        write_run_ids(out_dir, report.run_ids)
        write_results(out_dir, results, summary)
    except OSError as exc:
        saved = results["run_id"].nunique() if not results.empty else 0
        raise write_failure(exc, f"the {saved} finished run(s) are safe in {out_dir}.") from None
    outcome = ExperimentResult(
        out_dir, results, summary, report.errors, report.num_skipped, metric, runs
    )
    if progress:
        print_summary(outcome, console)
    return outcome


@contextmanager
def open_executor(
    executor: Executor | None,
    pending: Sequence[dict[str, Any]],
    *,
    max_workers: int | None = None,
    max_memory: int | str | None = None,
    run_fn: RunFunction = run_resolved,
    console: Console | None = None,
) -> Iterator[Executor]:
    """Yield ``executor`` (default a `LocalExecutor`), started here and shut down after if not yet.

    First every agent of the ``pending`` runs is set up on its domain, once per distinct pair
    (`conjure.experiments.preflight.check_runs`): a config whose parts cannot work together
    raises one error before any run starts. Then numba's cache is warmed with the ``pending``
    runs' structures and the executor started if it was not (`prepare_executor`); a started
    one keeps its own workers and limits. ``console``: where these set-up phases are shown
    (None: nowhere).
    """
    executor = executor or LocalExecutor(max_workers=max_workers, max_memory=max_memory)
    with phase(console, "setting up: each method on its domain"):
        check_runs(pending, executor)
    owns = not executor.is_started
    try:
        prepare_executor(executor, pending, run_fn, console)
        yield executor
    finally:
        if owns:
            executor.shutdown()


def run_experiment(
    config: ExperimentConfig | dict[str, Any],
    out_dir: str | Path,
    max_workers: int | None = None,
    progress: bool = True,
    console: Console | None = None,
    executor: Executor | None = None,
    max_memory: int | str | None = None,
    run_fn: RunFunction = run_resolved,
) -> ExperimentResult:
    """Run every (agent label, seed) pair of an experiment under ``out_dir``.

    Parameters
    ----------
    config : ExperimentConfig or dict
        The experiment.
    out_dir : str or Path
        The results folder (created if needed; finished runs in it are skipped).
    max_workers : int or None
        Worker processes; default ``config.max_workers``, else the CPU count. 1 runs in this
        process.
    progress : bool, default True
        Show a progress bar and print the summary table.
    console : rich.console.Console or None
        Where to print (default: standard output).
    executor : Executor or None
        Where to run (default a `LocalExecutor`); a started one keeps its own limits.
    max_memory : int, str or None
        Each run's memory limit, e.g. ``"4GiB"``; default ``config.max_memory``, else none. A
        run that exceeds it fails alone (`conjure.experiments.memory`).
    run_fn : callable, default `run_resolved`
        See `execute_runs`.

    Returns
    -------
    ExperimentResult
        Some runs may have failed (``errors``); when none finished, `RunsFailedError` is
        raised instead, naming the first failure.
    """
    experiment = parse_config(config)
    console = console or Console()
    out_dir = make_out_dir(out_dir)
    runs = [
        resolve_run(experiment, label, seed)
        for label in experiment.agents
        for seed in experiment.seed_list()
    ]
    resolved = experiment.model_dump(exclude_none=True)
    resolved["seeds"] = experiment.seed_list()
    pending = pending_runs(out_dir, resolved, runs)
    with open_executor(
        executor,
        pending,
        max_workers=max_workers or experiment.max_workers,
        max_memory=max_memory or experiment.max_memory,
        run_fn=run_fn,
        console=console if progress else None,
    ) as engine:
        outcome = run_batch(
            runs,
            out_dir,
            executor=engine,
            metric=experiment.metric,
            run_fn=run_fn,
            progress=progress,
            console=console,
            description=experiment.name,
        )
    if outcome.results.empty:
        first = next(iter(outcome.errors.values()), "no run was recorded")
        raise RunsFailedError(
            f"No run of {experiment.name} finished: {len(outcome.errors)} of {len(runs)} failed "
            f"(first: {first}); the tracebacks are in {out_dir / 'errors'}."
        )
    return outcome


def _path_lines(results: pd.DataFrame) -> list[str]:
    """One line per method and path: where its runs' learning steps ran (and why not compiled)."""
    if results.empty or "path" not in results.columns:
        return []
    paths = results.drop_duplicates("run_id").groupby("label", sort=False)["path"].unique()
    lines = []
    for label, taken in paths.items():
        for path in (p for p in taken if p):
            why = path.removeprefix("python: ")
            how = "compiled path" if path == "compiled" else f"Python path ({why})"
            lines.append(f"{label}: learned on the {how}")
    return lines


def _cell(row: Mapping[str, Any], key: str) -> str:
    """A summary row's ``key`` as the table shows it (a setting: readable, one value a line)."""
    if key == "setting":
        return readable_setting(row[key]).replace(", ", ",\n")
    return str(row[key])


def print_summary(
    outcome: ExperimentResult, console: Console | None = None, title: str | None = None
) -> None:
    """Print the per-method summary table (final metric and its 95% CI, features, steps/s).

    An interval cut at the metric's range (``summary.csv``'s ``_low`` and ``_high`` columns)
    reads ``mean [low, high]``; ``title`` defaults to the folder and what the table shows.
    """
    console = console or Console()
    metric = outcome.metric
    summary = outcome.summary
    keys = [c for c in ("domain_label", "label", "setting") if c in summary.columns]
    table = Table(title=title or f"{outcome.out_dir}: final policy check, mean over seeds")
    for name in keys:  # labels wrap (fold) but are never cut: sweeps differ at their ends
        table.add_column(name.replace("_", " "), justify="left", overflow="fold")
    for name in ("seeds", f"final {metric.replace('_', ' ')}\n± 95% CI", "features", "steps/s"):
        table.add_column(name, justify="right", no_wrap=True)
    for row in summary.to_dict("records"):
        rate = row["mean_steps_per_second"]
        mean, half = row[f"final_{metric}_mean"], row[f"final_{metric}_ci95"]
        low, high = row[f"final_{metric}_low"], row[f"final_{metric}_high"]  # the CI, cut
        if low > mean - half or high < mean + half:
            table.caption = escape("mean [low, high]: a 95% CI cut at what the metric can be")
        table.add_row(
            *(_cell(row, key) for key in keys),
            str(row["num_seeds"]),
            format_interval(mean, half, (low, high)),
            f"{row['final_num_features']:,.0f}",
            "n/a" if pd.isna(rate) or math.isinf(rate) else f"{rate:,.0f}",
        )
    console.print(table)
    for line in _path_lines(outcome.results):
        console.print(line)
    if outcome.num_skipped:
        console.print(f"{outcome.num_skipped} finished run(s) were reused (not rerun).")
    _print_failures(outcome, console)


def _first_line(message: str) -> str:
    """A failure message's first line (the traceback stays in the run's error file)."""
    return next(iter(message.strip().splitlines()), "")


def _print_failures(outcome: ExperimentResult, console: Console) -> None:
    """One line per method and setting with failed runs: how many, and the first message."""
    if not outcome.errors:
        return
    specs = {run_id(spec): spec for spec in outcome.runs}
    groups: dict[str, list[str]] = {}
    for identifier, message in outcome.errors.items():
        spec = specs.get(identifier)
        where = _describe(spec).rpartition("/seed_")[0] if spec else f"run {identifier}"
        groups.setdefault(where, []).append(message)
    console.print(
        f"[red]{len(outcome.errors)} run(s) failed[/red]; their tracebacks are in "
        f"{escape(str(outcome.out_dir / ERRORS_DIR))}/<run id>.txt:"
    )
    for where, messages in groups.items():
        console.print(
            f"  {escape(where)}: {len(messages)} failed: {escape(_first_line(messages[0]))}",
            no_wrap=True,
            overflow="ellipsis",
        )
