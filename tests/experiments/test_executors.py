"""Tests of the executors: the same sweep on a local pool, a Dask LocalCluster and local Ray.

Each engine runs runs that succeed, a run that raises (it fails alone) and a run whose first
attempt SIGKILLs its worker process (it is retried and finishes).
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
from conjure.experiments.sweep import expand_sweep

pytestmark = pytest.mark.usefixtures(isolated_fakes.__name__)


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


def test_in_process_executor_and_names():
    with LocalExecutor(max_workers=1) as executor:
        assert sorted(executor.map_unordered(abs, [-1, -2])) == [(0, 1), (1, 2)]
    with pytest.raises(InvalidParameterError, match="Did you mean 'dask'"):
        make_executor("dusk")
    with pytest.raises(InvalidParameterError, match="no address"):
        LocalExecutor(address="tcp://x:1").start()


@pytest.mark.slow
def test_dask_local_cluster(tmp_path):
    pytest.importorskip("distributed")
    pickle_fakes_by_value()
    marker = tmp_path / "killed"
    runs = mixed_runs(marker)
    with DaskExecutor(max_workers=2) as executor:
        assert len(executor.client.scheduler_info()["workers"]) == 2
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
