"""Tests of run_experiment: files, resume after interruption, failing runs, worker processes."""

from __future__ import annotations

import errno
import functools
import io
import json
import os
import socket
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import pandas as pd
import pytest
from click.testing import CliRunner
from rich.console import Console
from sweep_fakes import fail_writes, isolated_fakes, run_with_fakes
from test_loop import FakeAgent, FakeWalk

from conjure.cli.main import main
from conjure.core.errors import ResultsWriteError, RunsFailedError, RunsInterruptedError
from conjure.experiments import claims, loop, parallel, registry
from conjure.experiments.config import resolve_run
from conjure.experiments.executors import LocalExecutor
from conjure.experiments.parallel import execute_runs, run_experiment
from conjure.experiments.results import error_path, read_run, run_id, run_path
from conjure.experiments.run import TIMING_COLUMNS, run_config, run_resolved


@pytest.fixture
def fakes(monkeypatch):
    monkeypatch.setitem(registry.AGENTS, "FakeAgent", FakeAgent)
    monkeypatch.setitem(registry.DOMAINS, "FakeWalk", FakeWalk)


def fake_config(**agents):
    agents = agents or {"slow": {"step_size": 0.1}, "fast": {"step_size": 0.9}}
    return {
        "name": "fake",
        "domain": {"kind": "FakeWalk", "params": {"length": 5, "max_episode_steps": 12}},
        "agents": {label: {"kind": "FakeAgent", "params": p} for label, p in agents.items()},
        "budget_steps": 200,
        "num_policy_checks": 4,
        "seeds": 2,
    }


def path_of(out, config, label, seed):
    return run_path(out, run_id(resolve_run(config, label, seed)))


def test_experiment_writes_every_file(fakes, tmp_path):
    config = fake_config()
    outcome = run_experiment(config, tmp_path, max_workers=1, progress=False)
    assert outcome.errors == {} and outcome.num_skipped == 0
    for label in ("slow", "fast"):
        for seed in (0, 1):
            stored = read_run(path_of(tmp_path, config, label, seed))["config"]
            assert stored["agent"]["params"]["diverge_at"] is None  # defaults filled in
            assert stored["seed"] == seed and stored["label"] == label
    assert (tmp_path / "config.resolved.yaml").is_file()
    table = pd.read_parquet(tmp_path / "results.parquet")
    assert len(table) == 2 * 2 * 5
    assert {"label", "seed", "learning_steps", "return", "agent", "agent.step_size"} <= set(
        table.columns
    )
    assert sorted(table["agent.step_size"].unique()) == [0.1, 0.9]
    summary = pd.read_csv(tmp_path / "summary.csv")
    assert summary["label"].tolist() == ["slow", "fast"]
    assert (summary["num_seeds"] == 2).all()


def test_experiment_curve_equals_a_single_run(fakes, tmp_path):
    config = fake_config()
    run_experiment(config, tmp_path, max_workers=1, progress=False)
    stored = read_run(path_of(tmp_path, config, "fast", 1))["curve"]
    direct = run_config(config, agent_name="fast", seed=1).curve
    pd.testing.assert_frame_equal(
        stored.drop(columns=list(TIMING_COLUMNS)), direct.drop(columns=list(TIMING_COLUMNS))
    )


def dead_process_id() -> int:
    """The id of a process that has ended."""
    child = subprocess.Popen([sys.executable, "-c", "pass"])
    child.wait()
    return child.pid


def test_resume_skips_finished_runs_and_reruns_missing_ones(fakes, tmp_path):
    config = fake_config()
    run_experiment(config, tmp_path, max_workers=1, progress=False)
    kept = path_of(tmp_path, config, "slow", 0)
    before = kept.stat().st_mtime_ns
    path_of(tmp_path, config, "fast", 1).unlink()
    host, dead_pid = socket.gethostname(), dead_process_id()
    stale = kept.parent / f".x.json.tmp-{host}-{dead_pid}-abc"  # a killed writer's
    old_foreign = kept.parent / ".y.json.tmp-elsewhere-7-abc"
    in_progress = [  # another live driver's writes: here, and on another host, recently
        kept.parent / f".z.json.tmp-{host}-{os.getppid()}-abc",
        kept.parent / ".w.json.tmp-elsewhere-7-abc",
    ]
    for path in [stale, old_foreign, *in_progress]:
        path.write_text("half a file")
    os.utime(old_foreign, (0, 0))

    outcome = run_experiment(config, tmp_path, max_workers=1, progress=False)
    assert outcome.num_skipped == 3
    assert kept.stat().st_mtime_ns == before
    assert path_of(tmp_path, config, "fast", 1).is_file()
    assert not stale.exists() and not old_foreign.exists()
    assert all(path.exists() for path in in_progress)
    assert len(outcome.results) == 4 * 5


def test_changed_config_reruns(fakes, tmp_path):
    run_experiment(fake_config(), tmp_path, max_workers=1, progress=False)
    changed = fake_config(slow={"step_size": 0.2}, fast={"step_size": 0.9})
    outcome = run_experiment(changed, tmp_path, max_workers=1, progress=False)
    assert outcome.num_skipped == 2  # only the unchanged label is reused
    stored = read_run(path_of(tmp_path, changed, "slow", 0))["config"]
    assert stored["agent"]["params"]["step_size"] == 0.2


def test_a_failing_run_records_error_and_others_finish(fakes, tmp_path):
    config = fake_config(good={}, broken={"fail_in_setup": True}, wild={"diverge_at": 120})
    outcome = run_experiment(config, tmp_path, max_workers=1, progress=False)
    ids = {
        (label, seed): run_id(resolve_run(config, label, seed))
        for label in ("broken", "wild")
        for seed in (0, 1)
    }
    assert set(outcome.errors) == set(ids.values())
    error_text = error_path(tmp_path, ids["broken", 0]).read_text()
    assert "Traceback" in error_text and "fake setup failure" in error_text
    assert not path_of(tmp_path, config, "broken", 0).exists()
    partial = pd.read_csv(error_path(tmp_path, ids["wild", 0]).with_suffix(".partial.csv"))
    assert partial["learning_steps"].tolist() == [0, 50, 100]
    assert "step size" in error_path(tmp_path, ids["wild", 0]).read_text()
    assert set(outcome.results["label"]) == {"good"}
    # A rerun retries the failed runs only.
    again = run_experiment(config, tmp_path, max_workers=1, progress=False)
    assert again.num_skipped == 2 and len(again.errors) == 4


def test_failures_are_listed_one_line_per_method_and_setting(fakes, tmp_path):
    config = fake_config(good={}, broken={"fail_in_setup": True})
    stream = io.StringIO()
    console = Console(file=stream, width=60)
    run_experiment(config, tmp_path, max_workers=1, progress=True, console=console)
    lines = stream.getvalue().splitlines()
    listed = [line for line in lines if line.startswith("  broken: ")]
    assert listed == [listed[0]] and listed[0].startswith("  broken: 2 failed: ")
    assert len(listed[0]) <= 60 and "2 run(s) failed" in stream.getvalue()
    assert sum("failed:" in line for line in lines) == 3  # two as they fail, one summed up


def test_an_experiment_with_no_finished_run_raises(fakes, tmp_path):
    config = fake_config(broken={"fail_in_setup": True})
    with pytest.raises(RunsFailedError, match=r"No run of fake finished: 2 of 2 failed .*setup"):
        run_experiment(config, tmp_path, max_workers=1, progress=False)
    assert len(list((tmp_path / "errors").glob("*.txt"))) == 2


def test_process_pool_matches_in_process_runs(tmp_path):
    pytest.importorskip("conjure.agents")
    config = {
        "name": "chain",
        "domain": {"kind": "ChainMDP", "params": {"num_states": 5, "num_actions": 2}},
        "agents": {
            "q": {
                "kind": "QLearning",
                "params": {"representation": {"kind": "Tabular"}, "step_size": 0.5},
            },
            "sarsa": {
                "kind": "SARSA",
                "params": {"representation": {"kind": "Tabular"}, "step_size": 0.5},
            },
        },
        "budget_steps": 300,
        "num_policy_checks": 3,
        "seeds": 2,
    }
    outcome = run_experiment(config, tmp_path, max_workers=2, progress=False)
    assert outcome.errors == {}
    for label in ("q", "sarsa"):
        for seed in (0, 1):
            stored = read_run(path_of(tmp_path, config, label, seed))["curve"]
            direct = run_config(config, agent_name=label, seed=seed).curve
            pd.testing.assert_frame_equal(
                stored.drop(columns=list(TIMING_COLUMNS)),
                direct.drop(columns=list(TIMING_COLUMNS)),
            )
    assert read_run(path_of(tmp_path, config, "q", 1))["config"] == resolve_run(config, "q", 1)


def test_the_summary_table_keeps_long_labels_whole_at_80_columns():
    from rich.console import Console

    from conjure.experiments.parallel import ExperimentResult, print_summary

    labels = [f"sarsa_ifdd_plus_threshold_discovery_{end}" for end in ("first", "second")]
    summary = pd.DataFrame(
        {
            "label": labels,
            "setting": [f"step_size.alpha_0={v}, step_size.n_0=1000000" for v in (0.1, 1.0)],
            "num_seeds": 5,
            "final_return_mean": -1.0,
            "final_return_ci95": 1.674e-16,
            "final_return_low": -1.0 - 1.674e-16,
            "final_return_high": -1.0 + 1.674e-16,
            "final_num_features": 1234.0,
            "mean_steps_per_second": 45678.0,
        }
    )
    console = Console(width=80, record=True)
    print_summary(ExperimentResult(Path("out"), pd.DataFrame(), summary), console)
    text = console.export_text()
    rows = [line.split("│") for line in text.splitlines() if line.startswith("│")]
    flat = "".join(cells[1].strip() for cells in rows)  # the label column, unwrapped
    settings = "".join(cells[2].strip() for cells in rows)
    assert "…" not in text
    for label in labels:
        assert label in flat
    assert "-1.000 ± 0.000" in text
    # Issue 21: a grid value 1000000 (or 2e5, read as 200000.0) printed without separators.
    assert "step_size.n_0=1,000,000" in settings and "1000000" not in settings


def test_the_summary_table_cuts_an_interval_at_the_metrics_range():
    # Issue 21: `0.300 ± 1.271` for a probability.
    from rich.console import Console

    from conjure.experiments.parallel import ExperimentResult, print_summary

    summary = pd.DataFrame(
        {
            "label": ["a", "b"],
            "num_seeds": 3,
            "final_failure_rate_mean": [0.3, 0.5],
            "final_failure_rate_ci95": [1.271, 0.25],
            "final_failure_rate_low": [0.0, 0.25],
            "final_failure_rate_high": [1.0, 0.75],
            "final_num_features": 200000.0,
            "mean_steps_per_second": 45678.0,
        }
    )
    console = Console(width=100, record=True)
    outcome = ExperimentResult(Path("out"), pd.DataFrame(), summary, metric="failure_rate")
    print_summary(outcome, console)
    text = console.export_text()
    assert "0.300 [0.000, 1.000]" in text and "1.271" not in text
    assert "0.5000 ± 0.2500" in text  # an interval inside the range keeps its ±
    assert "mean [low, high]: a 95% CI cut at what the metric can be" in text
    assert "200,000" in text and "e+05" not in text


def test_a_full_disk_keeps_the_writable_runs_and_says_so_in_one_line(fakes, tmp_path, monkeypatch):
    # Issue 20: ENOSPC printed two tracebacks and dropped runs other workers had finished.
    config = fake_config()
    doomed = run_id(resolve_run(config, "slow", 0))
    save = parallel.save_run

    def full_disk(out_dir, spec, curve, meta=None):
        if run_id(spec) == doomed:
            raise OSError(errno.ENOSPC, "No space left on device", str(tmp_path / "runs" / "x"))
        return save(out_dir, spec, curve, meta)

    monkeypatch.setattr(parallel, "save_run", full_disk)
    with pytest.raises(ResultsWriteError) as caught:
        run_experiment(config, tmp_path, max_workers=1, progress=False)
    message = str(caught.value)
    assert "No space left on device" in message and "errno 28" in message
    assert "1 finished run(s) could not be saved, 3 saved this time" in message
    assert str(tmp_path) in message and "\n" not in message
    saved = {p.stem for p in (tmp_path / "runs").glob("*.json")}
    assert len(saved) == 3 and doomed not in saved
    monkeypatch.setattr(parallel, "save_run", save)
    assert run_experiment(config, tmp_path, max_workers=1, progress=False).num_skipped == 3


def test_the_command_line_exits_with_status_2_on_a_full_disk(fakes, tmp_path, monkeypatch):
    def no_space(*args, **kwargs):
        raise OSError(errno.ENOSPC, "No space left on device", "results.parquet")

    monkeypatch.setattr(parallel, "write_results", no_space)
    config = tmp_path / "fake.yaml"
    config.write_text(json.dumps(fake_config()))
    result = CliRunner().invoke(
        main, ["run", str(config), "--out", str(tmp_path / "out"), "--max-workers", "1"]
    )
    assert result.exit_code == 2, result.output
    last = result.output.strip().splitlines()[-1]
    assert last.startswith("Error: Could not write results.parquet: No space left on device")
    assert "Traceback" not in result.output


@pytest.mark.parametrize("code", [errno.ENOSPC, errno.EFBIG])
@pytest.mark.parametrize("name", ["config.resolved.yaml", "planned.csv", "claim"])
def test_a_write_failure_before_the_first_run_is_one_line_with_status_2(
    fakes, tmp_path, monkeypatch, name, code
):
    # Issue 20 audit: these writes gave two tracebacks and status 1, and left an empty claim.
    settings, out = fake_config(), tmp_path / "out"
    if name == "claim":
        name = f"claims/{run_id(resolve_run(settings, 'slow', 0))}.claim"  # the first run's
        monkeypatch.setattr(claims.json, "dump", functools.partial(full, code))
    else:
        fail_writes(monkeypatch, name, code)
    config = tmp_path / "fake.yaml"
    config.write_text(json.dumps(settings))
    result = CliRunner().invoke(main, ["run", str(config), "--out", str(out), "--max-workers", "1"])
    assert result.exit_code == 2, result.output
    assert "Traceback" not in result.output
    (line,) = [text for text in result.output.splitlines() if text.startswith("Error:")]
    cause = f"{os.strerror(code)} (errno {code})"
    assert line.startswith(f"Error: Could not write {out / name}: {cause};"), line
    assert "rerun the same command" in line
    assert not [*out.glob("runs/*"), *out.glob("errors/*"), *out.glob("claims/*")]


def full(code: int, *args: object) -> None:
    """A write that fails with ``code`` (28: disk full, 27: file-size limit)."""
    raise OSError(code, os.strerror(code))


def test_ctrl_c_inside_a_run_stops_the_batch_and_is_not_a_failure(fakes, tmp_path):
    # Issue 20: SIGINT inside a compiled kernel surfaced as SystemError, was recorded as the
    # run's failure, and the sweep went on to the next run.
    config = fake_config()
    runs = [resolve_run(config, label, seed) for label in ("slow", "fast") for seed in (0, 1)]
    started = []

    def interrupted_second(spec):
        started.append(spec)
        if len(started) == 2:
            try:
                raise KeyboardInterrupt
            except KeyboardInterrupt as exc:
                raise SystemError("CPUDispatcher returned a result with an exception set") from exc
        return run_resolved(spec)

    with pytest.raises(RunsInterruptedError) as caught:
        execute_runs(
            runs,
            tmp_path,
            executor=LocalExecutor(max_workers=1),
            run_fn=interrupted_second,
            progress=False,
        )
    assert len(started) == 2  # nothing ran after the interrupt
    assert str(caught.value).startswith(f"Interrupted: 1 of 4 runs are saved in {tmp_path}")
    assert "the same command resumes" in str(caught.value)
    assert not (tmp_path / "errors").exists()
    assert not (tmp_path / "claims").exists()


@pytest.mark.usefixtures(isolated_fakes.__name__)
def test_a_worker_death_is_announced_and_kept_in_the_run_metadata(tmp_path):
    marker = tmp_path / "killed"
    config = fake_config()
    config["agents"] = {"killer": {"kind": "KillerAgent", "params": {"kill_marker": str(marker)}}}
    config["seeds"] = 1
    runs = [resolve_run(config, "killer", 0)]
    output = io.StringIO()
    execute_runs(
        runs,
        tmp_path,
        executor=LocalExecutor(max_workers=2, in_process=False),
        run_fn=run_with_fakes,
        console=Console(file=output, width=200),
    )
    text = output.getvalue()
    assert "its worker killed by SIGKILL" in text and "running it again (attempt 2)" in text
    record = read_run(run_path(tmp_path, run_id(runs[0])))
    assert len(record["meta"]["worker_deaths"]) == 1


def test_the_summary_says_which_path_each_method_learned_on(fakes, tmp_path):
    output = io.StringIO()
    run_experiment(fake_config(), tmp_path, max_workers=1, console=Console(file=output, width=200))
    text = output.getvalue()
    for label in ("slow", "fast"):
        assert f"{label}: learned on the Python path (the domain FakeWalk has no compiled" in text
    recorded = read_run(path_of(tmp_path, fake_config(), "slow", 0))["meta"]["path"]
    assert recorded == "python: the domain FakeWalk has no compiled kernel"


@dataclass
class _ProbeResult:
    """What `warm_up` reads of a tiny run: its path and its curve's rows."""

    path: str
    rows: list


def _record_tiny_run(spec):
    """A run function for `warm_up`'s worker: records the tiny run, answers a cold probe.

    Its Python steps take ``spec["step_seconds"]`` (on the wall clock the curve records).
    """
    with open(spec["record_to"], "a") as out:
        out.write(f"{spec['budget_steps']} {spec.get('compile_steps')}\n")
    if spec.get("compile_steps") is not None:
        raise RuntimeError("only recording")  # the compiling tiny run
    steps = spec["budget_steps"]
    rows = [
        {"learning_steps": n, "wall_time_s": n * spec["step_seconds"]}
        for n in (0, steps // 2, steps)
    ]
    path = f"python: {loop._COLD.format(kernel=loop.BINARY)} and {steps} steps would not ..."
    return _ProbeResult(path, rows)


@pytest.mark.parametrize("num_runs", [30, 3])
def test_the_warm_up_compiles_when_the_whole_commands_steps_pay(monkeypatch, tmp_path, num_runs):
    # A first `conjure run examples/uav_icca.yaml` learned every method on the Python path: no
    # run alone earned the compile back, but all its runs on the kernel together did.
    from conjure.experiments.limits import MAX_COMPILE_STEPS
    from conjure.experiments.parallel import warm_up

    record = tmp_path / "record.txt"
    step_seconds = 1e-4
    runs = [
        {"domain": {"kind": "ChainMDP"}, "agent": {"kind": "SARSA"}, "budget_steps": 10**5,
         "record_to": str(record), "step_seconds": step_seconds}
        for _ in range(num_runs)
    ]  # fmt: skip
    monkeypatch.setattr(loop, "COMPILE_SECONDS", {False: 100.0, True: 100.0})
    monkeypatch.setattr(loop, "COMPILED_SHARE", 0.5)
    pays = loop.compile_pays(num_runs * 10**5, step_seconds)
    assert pays is (num_runs == 30)  # 3 · 10⁵ steps at 0.1 ms save 15 s, 3 · 10⁶ save 150 s
    output = io.StringIO()
    tiny = warm_up(runs, _record_tiny_run, console=Console(file=output, width=200))
    assert tiny == (2 if pays else 1)  # one structure: its probe, then its compile if it pays
    probe = f"{parallel._PROBE_STEPS} None"
    compiling = f"{parallel._WARMUP_STEPS} {MAX_COMPILE_STEPS}"
    assert record.read_text().splitlines() == ([probe, compiling] if pays else [probe])
    about = "compiling kernels, first run only: about 100 s"
    assert "measuring each method's Python step: " in output.getvalue()
    assert (about in output.getvalue()) is pays


def test_the_phases_of_a_run_appear_in_its_display_and_not_when_quiet(fakes, tmp_path):
    shown = io.StringIO()
    run_experiment(fake_config(), tmp_path / "a", max_workers=1, console=Console(file=shown))
    assert "setting up: each method on its domain:" in shown.getvalue()
    quiet = io.StringIO()
    run_experiment(
        fake_config(), tmp_path / "b", max_workers=1, console=Console(file=quiet), progress=False
    )
    assert quiet.getvalue() == ""


def test_a_started_executor_is_warmed_too(monkeypatch):
    # `conjure sweep` and `conjure reproduce` open their executor with `with engine:`, which
    # starts it; the warm-up was skipped for started executors, so on a fresh machine every
    # run of a thesis-scale sweep took the Python path.
    from conjure.experiments import parallel
    from conjure.experiments.executors import LocalExecutor

    warmed = []
    monkeypatch.setattr(parallel, "warm_up", lambda runs, *args: warmed.append(len(runs)))
    spec = {
        "name": "x", "label": "sarsa", "seed": 0, "domain": {"kind": "ChainMDP"},
        "agent": {"kind": "SARSA", "params": {"representation": {"kind": "Tabular"}}},
        "budget_steps": loop.COMPILE_WORTH_STEPS // 2 + 1, "num_policy_checks": 1,
        "eval_episodes": 1,
    }  # fmt: skip
    with LocalExecutor(max_workers=1) as engine:
        assert engine.is_started
        with parallel.open_executor(engine, [spec, {**spec, "seed": 1}]) as opened:
            assert opened is engine
    assert warmed == [2]  # their steps together earn the compile back
