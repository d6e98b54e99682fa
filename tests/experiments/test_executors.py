"""Tests of the executors: the same sweep on a local pool, a Dask LocalCluster and local Ray.

Each engine runs runs that succeed, a run that raises (it fails alone) and a run whose first
attempt SIGKILLs its worker process (it is retried and finishes). On the local pool, a run
that kills its worker every time, or outgrows its memory limit, fails alone: the runs beside
it in the pool finish, once each.
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from sweep_fakes import (
    fake_sweep,
    isolated_fakes,
    kill_self,
    pickle_fakes_by_value,
    run_with_fakes,
)

from conjure.core.errors import InvalidParameterError
from conjure.experiments.executors import (
    DaskExecutor,
    LocalExecutor,
    RayExecutor,
    TaskFailure,
    make_executor,
)
from conjure.experiments.parallel import execute_runs
from conjure.experiments.results import RUNS_DIR, error_path, run_id
from conjure.sweeps.sweep import expand_sweep

pytestmark = pytest.mark.usefixtures(isolated_fakes.__name__)
GiB = 2**30


def mixed_runs(marker):
    sweep = fake_sweep(
        domains={"walk": {"kind": "FakeWalk", "params": {"length": 4}}},
        agents={
            "good": {"kind": "FakeAgent", "params": {}},
            "broken": {"kind": "FakeAgent", "params": {"fail_in_setup": True}},
            "killer": {
                "kind": "KillerAgent",
                "params": {"kill_marker": str(marker), "spare_pid": os.getpid()},
            },
        },
        grid={},
        seeds=[0, 1],
    )
    return expand_sweep(sweep)


def check_mixed_outcome(tmp_path, runs, report, marker):
    assert marker.exists(), "the killer never ran on a worker"
    broken = {run_id(r) for r in runs if r["label"] == "broken"}
    assert set(report.errors) == broken
    assert "fake setup failure" in error_path(tmp_path, next(iter(broken))).read_text()
    done = {p.stem for p in (tmp_path / RUNS_DIR).glob("*.json")}
    assert done == {run_id(r) for r in runs} - broken  # the killed run was retried


def test_local_pool_retries_a_killed_worker_and_isolates_a_raising_run(tmp_path):
    marker = tmp_path / "killed"
    runs = mixed_runs(marker)
    report = execute_runs(
        runs,
        tmp_path,
        executor=LocalExecutor(max_workers=2),
        run_fn=run_with_fakes,
        progress=False,
    )
    check_mixed_outcome(tmp_path, runs, report, marker)


def test_local_pool_reports_a_task_that_keeps_killing_its_worker(tmp_path):
    with LocalExecutor(max_workers=2, max_retries=1) as executor:
        outcomes = dict(executor.map_unordered(kill_self, [0, 1]))
    assert all(isinstance(o, TaskFailure) for o in outcomes.values())
    assert "worker died 2 times" in outcomes[0].message


def guilty_beside_innocents(tmp_path, guilty):
    """Two slow innocent runs and two runs of ``guilty``; on 3 workers, the first three together."""
    starts = tmp_path / "starts"
    starts.mkdir()
    innocent = {"kind": "LoggedAgent", "params": {"start_log": str(starts / "innocent")}}
    sweep = fake_sweep(
        domains={"slow": {"kind": "SlowWalk", "params": {"length": 4, "sleep_s": 0.02}}},
        agents={"innocent": innocent, "guilty": guilty},
        grid={},
        seeds=[0, 1],
    )
    return expand_sweep(sweep), starts


def check_guilty_failed_alone(out, runs, report, starts):
    guilty = {run_id(r) for r in runs if r["label"] == "guilty"}
    innocent = {run_id(r) for r in runs} - guilty
    assert set(report.errors) == guilty
    assert {p.stem for p in (out / RUNS_DIR).glob("*.json")} == innocent
    assert len((starts / "innocent").read_text().splitlines()) == 2  # each started once
    return [report.errors[i] + error_path(out, i).read_text() for i in sorted(guilty)]


def test_a_run_that_kills_its_worker_fails_alone(tmp_path):
    guilty = {"kind": "KillerAgent", "params": {"kill_every_time": True}}
    runs, starts = guilty_beside_innocents(tmp_path, guilty)
    out = tmp_path / "out"
    with LocalExecutor(max_workers=3) as executor:  # started: no warm-up in this process
        report = execute_runs(runs, out, executor=executor, run_fn=run_with_fakes, progress=False)
    for error in check_guilty_failed_alone(out, runs, report, starts):
        assert "worker died 4 times" in error and "SIGKILL" in error
        assert "out-of-memory killer" in error


def test_a_run_over_its_memory_limit_fails_alone_and_is_not_retried(tmp_path):
    hog_log = tmp_path / "hog_starts"
    guilty = {"kind": "HogAgent", "params": {"start_log": str(hog_log), "num_bytes": 2 * GiB}}
    runs, starts = guilty_beside_innocents(tmp_path, guilty)
    out = tmp_path / "out"
    with LocalExecutor(max_workers=3, max_memory=int(1.5 * GiB)) as executor:
        report = execute_runs(runs, out, executor=executor, run_fn=run_with_fakes, progress=False)
    for error in check_guilty_failed_alone(out, runs, report, starts):
        assert "exceeded its memory limit" in error and "1.5 GiB" in error
        assert "MemoryError" in error
    assert len(hog_log.read_text().splitlines()) == 2  # not retried
    assert str(os.getpid()) not in hog_log.read_text().split()


def test_in_process_executor_and_names():
    with LocalExecutor(max_workers=1) as executor:
        assert sorted(executor.map_unordered(abs, [-1, -2])) == [(0, 1), (1, 2)]
    with pytest.raises(InvalidParameterError, match="Did you mean 'dask'"):
        make_executor("dusk")
    with pytest.raises(InvalidParameterError, match="no address"):
        LocalExecutor(address="tcp://x:1").start()


def test_memory_limits_are_checked_and_unenforceable_ones_warn():
    with pytest.raises(InvalidParameterError, match=r"LocalExecutor.max_memory`: .*'lots'"):
        LocalExecutor(max_memory="lots")
    with pytest.raises(InvalidParameterError, match="in_process=True cannot take max_memory"):
        LocalExecutor(in_process=True, max_memory="1GiB")
    assert make_executor("local", max_memory="1GiB").max_memory == GiB
    with pytest.warns(UserWarning, match="does not enforce max_memory"):
        RayExecutor(max_memory="1GiB")
    with pytest.warns(UserWarning, match="keeps its workers' memory limit"):
        DaskExecutor(address="tcp://head:8786", max_memory="1GiB")


@pytest.mark.slow
def test_dask_local_cluster(tmp_path):
    pytest.importorskip("distributed")
    pickle_fakes_by_value()
    marker = tmp_path / "killed"
    runs = mixed_runs(marker)
    with DaskExecutor(max_workers=2, max_memory="2GiB") as executor:
        workers = executor.client.scheduler_info()["workers"].values()
        assert [w["memory_limit"] for w in workers] == [2 * GiB, 2 * GiB]
        report = execute_runs(
            runs, tmp_path, executor=executor, run_fn=run_with_fakes, progress=False
        )
    check_mixed_outcome(tmp_path, runs, report, marker)


@pytest.mark.slow
def test_ray_local_cluster(tmp_path, monkeypatch):
    pytest.importorskip("ray")
    pickle_fakes_by_value()
    here = str(Path(__file__).resolve().parent)  # Ray workers import the fakes from here
    monkeypatch.setenv("PYTHONPATH", os.pathsep.join([here, os.environ.get("PYTHONPATH", "")]))
    marker = tmp_path / "killed"
    runs = mixed_runs(marker)
    with RayExecutor(max_workers=2) as executor:
        report = execute_runs(
            runs, tmp_path, executor=executor, run_fn=run_with_fakes, progress=False
        )
    check_mixed_outcome(tmp_path, runs, report, marker)
