"""Tests of sweeps: expansion, did-you-mean errors, resume, and kill -9 of the driver."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pandas as pd
import pytest
from click.testing import CliRunner
from sweep_fakes import fake_sweep, isolated_fakes, run_with_fakes

from conjure.core.errors import InvalidParameterError
from conjure.experiments.results import RUNS_DIR, read_run, run_id
from conjure.sweeps.sweep import (
    expand_sweep,
    load_sweep,
    parse_sweep,
    resolve_sweep,
    run_sweep,
    sweep_command,
)

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]

pytestmark = pytest.mark.usefixtures(isolated_fakes.__name__)


def test_expansion_crosses_only_the_keys_that_concern_each_pair():
    runs = expand_sweep(fake_sweep())
    assert len(runs) == 2 * (2 + 1) * 2  # domains x (a's 2 settings + b) x seeds
    assert len({run_id(r) for r in runs}) == len(runs)
    a_runs = [r for r in runs if r["label"] == "a"]
    assert {r["setting"]["agents.a.params.step_size"] for r in a_runs} == {0.1, 0.9}
    assert {r["agent"]["params"]["step_size"] for r in a_runs} == {0.1, 0.9}
    assert all("setting" not in r for r in runs if r["label"] == "b")
    assert {r["domain_label"] for r in runs} == {"short", "long"}
    assert {r["domain"]["params"]["length"] for r in runs if r["domain_label"] == "long"} == {6}


def test_domain_grids_and_plain_fields():
    sweep = fake_sweep(
        grid={"budget_steps": [30, 60]},
        domain_grids={"long": {"domains.long.params.max_episode_steps": [10, 20]}},
        seeds=[5],
    )
    runs = expand_sweep(sweep)
    assert len(runs) == 2 * 2 + 2 * 2 * 2  # short: 2 agents x 2 budgets; long: also x 2 lengths
    long_runs = [r for r in runs if r["domain_label"] == "long"]
    assert {r["domain"]["params"]["max_episode_steps"] for r in long_runs} == {10, 20}
    assert {r["budget_steps"] for r in runs} == {30, 60} and {r["seed"] for r in runs} == {5}


@pytest.mark.parametrize(
    ("grid", "expected"),
    [
        ({"agents.a.params.step_sise": [0.1]}, "Did you mean 'step_size'?"),
        ({"agents.c.params.step_size": [0.1]}, "unknown agent label 'c'"),
        ({"agent.a.params.step_size": [0.1]}, "Did you mean 'agents'?"),
        ({"domains.shrt.params.length": [3]}, "Did you mean 'short'?"),
        ({"agents.a.params.step_size": [5.0]}, "step_size"),
        ({"agents.a.params.step_size": []}, "at least one value"),
        ({"agents.a.params.step_size": [0.1, 0.1000001]}, "both print as 0.1"),  # one setting
    ],
)
def test_bad_grid_keys_are_clear(grid, expected):
    with pytest.raises(InvalidParameterError, match="grid") as info:
        parse_sweep(fake_sweep(grid=grid))
    assert expected in str(info.value)


def test_domain_grid_values_must_print_apart():
    grids = {"short": {"agents.a.params.step_size": [0.3, 0.30000004]}}
    with pytest.raises(InvalidParameterError, match=r"both print as 0\.3"):
        parse_sweep(fake_sweep(domain_grids=grids))


def test_bad_sweep_fields_are_clear():
    with pytest.raises(InvalidParameterError, match="Did you mean 'grid'"):
        parse_sweep({**fake_sweep(), "grdi": {}})
    with pytest.raises(InvalidParameterError, match="exactly one of `domain`"):
        parse_sweep(fake_sweep(domain={"kind": "FakeWalk"}))


def test_sweep_runs_resumes_and_records_failures(tmp_path):
    sweep = fake_sweep(
        agents={
            "a": {"kind": "FakeAgent", "params": {}},
            "broken": {"kind": "FakeAgent", "params": {"fail_in_setup": True}},
        }
    )
    outcome = run_sweep(sweep, tmp_path, max_workers=1, run_fn=run_with_fakes, progress=False)
    files = sorted((tmp_path / RUNS_DIR).glob("*.json"))
    assert len(files) == 2 * 2 * 2  # a's runs only: domains x settings x seeds
    assert len(outcome.errors) == 2 * 2  # broken: domains x seeds
    error = (tmp_path / "errors" / f"{next(iter(outcome.errors))}.txt").read_text()
    assert "fake setup failure" in error and "Traceback" in error and "label: broken" in error
    table = pd.read_parquet(tmp_path / "results.parquet")
    assert {"run_id", "domain_label", "label", "setting", "seed", "agent.step_size"} <= set(
        table.columns
    )
    assert set(table["label"]) == {"a"}
    before = {f.name: f.stat().st_mtime_ns for f in files}
    again = run_sweep(sweep, tmp_path, max_workers=1, run_fn=run_with_fakes, progress=False)
    assert again.num_skipped == 8 and len(again.errors) == 4
    assert {f.name: f.stat().st_mtime_ns for f in files} == before


def test_sweep_command_with_overrides(tmp_path, monkeypatch):
    config = tmp_path / "s.yaml"
    config.write_text(json.dumps(fake_sweep(grid={})))
    import conjure.experiments.parallel as parallel
    from conjure.experiments.run import run_task

    monkeypatch.setattr(parallel, "run_resolved", run_with_fakes)
    monkeypatch.setattr(run_task, "__defaults__", (run_with_fakes,))
    out = tmp_path / "out"
    result = CliRunner().invoke(
        sweep_command,
        [str(config), "--out", str(out), "--max-workers", "1", "--set", "seeds=1"],
        terminal_width=200,
    )
    assert result.exit_code == 0, result.output
    assert len(list((out / RUNS_DIR).glob("*.json"))) == 2 * 2
    with pytest.raises(InvalidParameterError, match="Did you mean 'seeds'"):
        load_sweep(config, ["sedes=2"])


def test_sweep_set_takes_the_paths_run_set_takes_and_blames_the_flag(tmp_path):
    config = tmp_path / "s.yaml"
    config.write_text(json.dumps(fake_sweep()))
    sweep = load_sweep(
        config,
        [
            "agents.b.params.step_size=0.3",  # a nested path, as `conjure run --set` takes
            "domains.long.params.length=7",
            "grid.agents.a.params.step_size=[0.2]",
            "selection.criterion=final",
            "budget_steps=40",
        ],
    )
    assert sweep.agents["b"].params["step_size"] == 0.3
    assert sweep.domains["long"].params["length"] == 7
    assert sweep.grid == {"agents.a.params.step_size": [0.2]}
    assert sweep.selection.criterion == "final" and sweep.budget_steps == 40
    # A bad value is the flag's fault, not the (valid) file's.
    with pytest.raises(InvalidParameterError) as bad:
        load_sweep(config, ["seeds=1", "agents.b.params.step_size=7"])
    assert str(bad.value).startswith("--set 'agents.b.params.step_size=7': ")
    assert str(config) not in str(bad.value)
    with pytest.raises(
        InvalidParameterError, match=r"^--set 'domains.lng.params.length=7'.*'long'"
    ):
        load_sweep(config, ["domains.lng.params.length=7"])


def test_the_sweeps_memory_limit_fails_the_greedy_run_alone(tmp_path):
    log = tmp_path / "hog_starts"
    hog = {"kind": "HogAgent", "params": {"start_log": str(log), "num_bytes": 2 * 2**30}}
    sweep = fake_sweep(
        domains={"walk": {"kind": "FakeWalk"}},
        agents={"a": {"kind": "FakeAgent"}, "hog": hog},
        grid={},
        seeds=[0, 1],
        max_memory="1.5GiB",
    )
    assert resolve_sweep(sweep)["max_memory"] == 3 * 2**29
    outcome = run_sweep(sweep, tmp_path, max_workers=2, run_fn=run_with_fakes, progress=False)
    hogs = {run_id(r) for r in outcome.runs if r["label"] == "hog"}
    assert set(outcome.errors) == hogs
    assert set(outcome.results["label"]) == {"a"} and outcome.results["run_id"].nunique() == 2
    assert all("memory limit, max_memory = 1.5 GiB" in m for m in outcome.errors.values())
    starts = log.read_text().split()
    assert len(starts) == 3 and str(os.getpid()) not in starts  # warm-up and 2 runs, in workers


def test_sweep_command_takes_the_memory_limit_from_the_option_else_the_config(
    tmp_path, monkeypatch
):
    import conjure.experiments.executors as executors

    limits = []

    def make_in_process(name, **options):
        limits.append(options.pop("max_memory"))
        return executors.LocalExecutor(max_workers=1)

    monkeypatch.setattr(executors, "make_executor", make_in_process)
    config = tmp_path / "s.yaml"
    config.write_text(json.dumps(fake_sweep(grid={}, seeds=1, max_memory="3GiB")))
    for extra in ([], ["--max-memory", "1GiB"]):
        out = str(tmp_path / f"out{len(extra)}")
        result = CliRunner().invoke(sweep_command, [str(config), "--out", out, "--quiet", *extra])
        assert result.exit_code == 0, result.output
    assert limits == [3 * 2**30, 2**30]
    bad = CliRunner().invoke(sweep_command, [str(config), "--max-memory", "4 lots"])
    assert bad.exit_code == 2 and "'--max-memory'" in bad.output


DRIVER = textwrap.dedent(
    """
    import sys
    from sweep_fakes import fake_sweep, run_with_fakes, register_fakes
    from conjure.experiments.executors import LocalExecutor
    from conjure.sweeps.sweep import run_sweep
    register_fakes()
    sweep = fake_sweep(
        domains={"slow": {"kind": "SlowWalk", "params": {"sleep_s": 0.002}}},
        grid={"agents.a.params.step_size": [0.1, 0.5, 0.9]},
        seeds=3,
    )
    run_sweep(sweep, sys.argv[1], executor=LocalExecutor(max_workers=2),
              run_fn=run_with_fakes, progress=False)
    """
)


@pytest.mark.slow
def test_driver_killed_with_sigkill_then_resumed(tmp_path):
    out = tmp_path / "out"
    fakes = ROOT / "tests" / "experiments"  # sweep_fakes and test_loop
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(fakes), str(ROOT / "src")])}
    driver = subprocess.Popen(
        [sys.executable, "-c", DRIVER, str(out)], env=env, start_new_session=True
    )
    try:
        deadline = time.monotonic() + 60
        while len(list((out / RUNS_DIR).glob("*.json"))) < 2:
            assert driver.poll() is None, "the driver ended before it was killed"
            assert time.monotonic() < deadline
            time.sleep(0.05)
        driver.send_signal(signal.SIGKILL)
        driver.wait()
        time.sleep(2.5)  # the orphaned pool workers notice and exit
        assert not _processes_in_group(driver.pid), "workers outlived the killed driver"
    finally:
        if driver.poll() is None:
            driver.kill()
        for pid in _processes_in_group(driver.pid):
            os.kill(pid, signal.SIGKILL)
    num_before = len(list((out / RUNS_DIR).glob("*.json")))
    exec(
        compile(
            DRIVER.replace("sys.argv[1]", repr(str(out))).replace("max_workers=2", "max_workers=1"),
            "driver",
            "exec",
        ),
        {},
    )
    expected = {run_id(r) for r in expand_sweep(_driver_sweep())}
    files = sorted((out / RUNS_DIR).glob("*.json"))
    assert len(expected) == (3 + 1) * 3 and 0 < num_before < len(expected)
    assert {f.stem for f in files} == expected and len(files) == len(expected)
    for f in files:
        record = read_run(f)
        assert record["run_id"] == f.stem == run_id(record["config"])
        assert len(record["curve"]) == 4
    assert not list(out.rglob("*.tmp-*"))
    assert not (out / "errors").exists() or not list((out / "errors").iterdir())


def _driver_sweep():
    return fake_sweep(
        domains={"slow": {"kind": "SlowWalk", "params": {"sleep_s": 0.002}}},
        grid={"agents.a.params.step_size": [0.1, 0.5, 0.9]},
        seeds=3,
    )


def _processes_in_group(group: int) -> list[int]:
    """Pool workers (not the forkserver) still alive in the driver's process group."""
    found = []
    for status in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = status.read_text().rsplit(")", 1)[1].split()
            cmdline = (status.parent / "cmdline").read_bytes()
        except OSError:
            continue
        if int(fields[2]) == group and fields[0] != "Z":
            found.append((int(status.parent.name), cmdline))
    return [pid for pid, cmd in found if b"forkserver" in cmd]


SPINNING_DRIVER = textwrap.dedent(
    """
    import sys
    from sweep_fakes import spin
    from conjure.experiments.executors import LocalExecutor
    with LocalExecutor(max_workers=2) as executor:
        for _ in executor.map_unordered(spin, [sys.argv[1]] * 2):
            pass
    """
)


@pytest.mark.slow
def test_workers_inside_a_compiled_call_die_with_their_driver(tmp_path):
    # Issue 20: a worker holding the GIL in numba never ran its watcher thread and outlived a
    # driver killed with -9 by minutes; the kernel's parent-death signal stops it.
    fakes = ROOT / "tests" / "experiments"
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(fakes), str(ROOT / "src")])}
    driver = subprocess.Popen(
        [sys.executable, "-c", SPINNING_DRIVER, str(tmp_path)], env=env, start_new_session=True
    )
    try:
        deadline = time.monotonic() + 60
        while len(list(tmp_path.iterdir())) < 2:
            assert driver.poll() is None and time.monotonic() < deadline
            time.sleep(0.05)
        time.sleep(1.0)  # both deep in the compiled loop
        assert len(_processes_in_group(driver.pid)) >= 2  # the workers (and the forkserver)
        driver.send_signal(signal.SIGKILL)
        driver.wait()
        killed = time.monotonic()
        while _processes_in_group(driver.pid) and time.monotonic() < killed + 10:
            time.sleep(0.05)
        outlived = time.monotonic() - killed
        assert not _processes_in_group(driver.pid), "workers outlived the killed driver"
        assert outlived < 3.0, f"workers outlived the driver by {outlived:.1f} s"
    finally:
        if driver.poll() is None:
            driver.kill()
        for pid in _processes_in_group(driver.pid):
            os.kill(pid, signal.SIGKILL)
