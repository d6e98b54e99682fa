"""Tests of run_experiment: files, resume after interruption, failing runs, worker processes."""

from __future__ import annotations

import pandas as pd
import pytest
import yaml
from test_loop import FakeAgent, FakeWalk

from conjure.experiments import registry
from conjure.experiments.config import resolve_run
from conjure.experiments.parallel import run_experiment
from conjure.experiments.results import (
    run_dir,
)
from conjure.experiments.run import TIMING_COLUMNS, run_config


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


def test_experiment_writes_every_file(fakes, tmp_path):
    outcome = run_experiment(fake_config(), tmp_path, max_workers=1, progress=False)
    assert outcome.errors == {} and outcome.num_skipped == 0
    for label in ("slow", "fast"):
        for seed in (0, 1):
            directory = run_dir(tmp_path, label, seed)
            assert (directory / "curve.csv").is_file()
            stored = yaml.safe_load((directory / "config.resolved.yaml").read_text())
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
    stored = pd.read_csv(run_dir(tmp_path, "fast", 1) / "curve.csv")
    direct = run_config(config, agent_name="fast", seed=1).curve
    pd.testing.assert_frame_equal(
        stored.drop(columns=list(TIMING_COLUMNS)), direct.drop(columns=list(TIMING_COLUMNS))
    )


def test_resume_skips_finished_runs_and_reruns_missing_ones(fakes, tmp_path):
    config = fake_config()
    run_experiment(config, tmp_path, max_workers=1, progress=False)
    kept = run_dir(tmp_path, "slow", 0) / "curve.csv"
    before = kept.stat().st_mtime_ns
    (run_dir(tmp_path, "fast", 1) / "curve.csv").unlink()
    stale = run_dir(tmp_path, "fast", 1) / ".curve.csv.tmp-999"
    stale.write_text("half a file")

    outcome = run_experiment(config, tmp_path, max_workers=1, progress=False)
    assert outcome.num_skipped == 3
    assert kept.stat().st_mtime_ns == before
    assert (run_dir(tmp_path, "fast", 1) / "curve.csv").is_file()
    assert not stale.exists()
    assert len(outcome.results) == 4 * 5


def test_changed_config_reruns(fakes, tmp_path):
    run_experiment(fake_config(), tmp_path, max_workers=1, progress=False)
    changed = fake_config(slow={"step_size": 0.2}, fast={"step_size": 0.9})
    outcome = run_experiment(changed, tmp_path, max_workers=1, progress=False)
    assert outcome.num_skipped == 2  # only the unchanged label is reused
    stored = yaml.safe_load((run_dir(tmp_path, "slow", 0) / "config.resolved.yaml").read_text())
    assert stored["agent"]["params"]["step_size"] == 0.2


def test_a_failing_run_records_error_and_others_finish(fakes, tmp_path):
    config = fake_config(good={}, broken={"fail_in_setup": True}, wild={"diverge_at": 120})
    outcome = run_experiment(config, tmp_path, max_workers=1, progress=False)
    assert set(outcome.errors) == {("broken", 0), ("broken", 1), ("wild", 0), ("wild", 1)}
    error_text = (run_dir(tmp_path, "broken", 0) / "error.txt").read_text()
    assert "Traceback" in error_text and "fake setup failure" in error_text
    assert not (run_dir(tmp_path, "broken", 0) / "curve.csv").exists()
    partial = pd.read_csv(run_dir(tmp_path, "wild", 0) / "curve.partial.csv")
    assert partial["learning_steps"].tolist() == [0, 50, 100]
    assert "step size" in (run_dir(tmp_path, "wild", 0) / "error.txt").read_text()
    assert set(outcome.results["label"]) == {"good"}
    # A rerun retries the failed runs only.
    again = run_experiment(config, tmp_path, max_workers=1, progress=False)
    assert again.num_skipped == 2 and len(again.errors) == 4


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
            stored = pd.read_csv(run_dir(tmp_path, label, seed) / "curve.csv")
            direct = run_config(config, agent_name=label, seed=seed).curve
            pd.testing.assert_frame_equal(
                stored.drop(columns=list(TIMING_COLUMNS)),
                direct.drop(columns=list(TIMING_COLUMNS)),
            )
    stored_spec = yaml.safe_load((run_dir(tmp_path, "q", 1) / "config.resolved.yaml").read_text())
    assert stored_spec == resolve_run(config, "q", 1)
