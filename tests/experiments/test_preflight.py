"""Tests of the pre-flight check: bad input found once, before any run starts (issue 20)."""

from __future__ import annotations

import json

import pytest
from click.testing import CliRunner

from conjure.cli.main import main
from conjure.core.errors import IncompatibleComponentsError
from conjure.experiments import preflight
from conjure.experiments.config import parse_config, resolve_run
from conjure.experiments.executors import LocalExecutor
from conjure.experiments.parallel import run_experiment
from conjure.experiments.results import RUNS_DIR, read_run, run_id, run_path
from conjure.experiments.run import TIMING_COLUMNS, run_resolved

GRID = {"kind": "GridWorld", "params": {"map_name": "4x5", "noise": 0.1}}
CALM_GRID = {"kind": "GridWorld", "params": {"map_name": "4x5", "noise": 0.0}}
SARSA = {"kind": "SARSA", "params": {"representation": {"kind": "Tabular"}}}


def icca(planner, risk=None):
    """A cooperative SARSA on the 4×5 grid with ``planner`` and ``risk``."""
    return {
        "kind": "CooperativeLearner",
        "params": {
            "learner": SARSA,
            "planner": planner,
            "risk": risk or {"kind": "NominalRiskAnalyzer"},
            "model": {"kind": "ApproximateModel", "params": {"domain": CALM_GRID}},
        },
    }


def config(seeds=10, **agents):
    return {
        "name": "preflight",
        "domain": GRID,
        "agents": agents or {"sarsa": SARSA},
        "budget_steps": 200,
        "num_policy_checks": 2,
        "seeds": seeds,
    }


def write(tmp_path, data):
    path = tmp_path / "config.yaml"
    path.write_text(json.dumps(data))  # JSON is YAML
    return path


def test_a_part_that_does_not_fit_the_domain_is_one_error_before_any_run(tmp_path):
    # Issue 20 / 21: CBBAPlanner inside a grid-world iCCA failed in each of the 10 runs, exit 1.
    data = config(sarsa=SARSA, icca=icca({"kind": "CBBAPlanner"}))
    out = tmp_path / "out"
    result = CliRunner().invoke(
        main, ["run", str(write(tmp_path, data)), "--out", str(out), "--max-workers", "1"]
    )
    assert result.exit_code == 2, result.output
    assert result.output.count("CBBAPlanner plans UAV missions") == 1
    assert "Error: agents.icca.params.planner: CBBAPlanner" in result.output
    assert "none of the 20 runs was started" in result.output and "Traceback" not in result.output
    assert not (out / RUNS_DIR).exists() and not (out / "errors").exists()


def test_an_off_map_goal_in_a_sweep_names_its_setting_once(tmp_path):
    # Issue 20: the shortest-path planner's goal off the map failed only in its runs.
    sweep = {
        **config(seeds=3, icca=icca({"kind": "ShortestPathPlanner"})),
        "grid": {"agents.icca.params.planner.params.goal": [[3, 4], [100, 100]]},
    }
    out = tmp_path / "out"
    result = CliRunner().invoke(
        main,
        ["sweep", str(write(tmp_path, sweep)), "--out", str(out), "--max-workers", "1"],
        terminal_width=400,
    )
    assert result.exit_code == 2, result.output
    assert result.output.count("off the map") == 1
    assert "agents.icca.params.planner (setting planner.goal=[100, 100])" in result.output
    assert not (out / RUNS_DIR).exists()


def test_a_risk_analyser_needing_too_many_rollouts_is_refused_when_the_config_loads(tmp_path):
    # Issue 20: `num_rollouts: 1_000_000_000` was accepted and the runs ground on silently.
    risk = {"kind": "MonteCarloRiskAnalyzer", "params": {"num_rollouts": 10**9}}
    data = config(icca=icca({"kind": "ShortestPathPlanner"}, risk))
    result = CliRunner().invoke(
        main, ["run", str(write(tmp_path, data)), "--out", str(tmp_path / "out")]
    )
    assert result.exit_code == 2, result.output
    assert "agents.icca.params.risk.params" in result.output
    assert "num_rollouts` 1,000,000,000" in result.output and "MAX_ROLLOUT_STEPS" in result.output


@pytest.mark.parametrize(
    ("change", "message"),
    [({"fuel": [10**6, 7]}, "fuel [1000000, 7]"), ({"horizon": 10**6}, "horizon 1,000,000 ×")],
)
def test_a_mission_too_large_to_solve_is_one_error_naming_the_domain(tmp_path, change, message):
    # Issue 20: huge fuel failed in every run (value_bounds); a huge horizon ground on.
    from conjure.domains import UAVMission

    graph = {**UAVMission().graph_.to_dict(), **change}
    data = {
        **config(seeds=3),
        "domain": {"kind": "UAVMission", "params": {"graph": graph}},
        "agents": {
            "sarsa": {"kind": "SARSA", "params": {"representation": {"kind": "HashedTabular"}}}
        },
    }
    result = CliRunner().invoke(
        main, ["run", str(write(tmp_path, data)), "--out", str(tmp_path / "out")]
    )
    assert result.exit_code == 2, result.output
    assert result.output.count("UAVMission.exact_solution") == 1
    assert "Error: domain (for agents.sarsa): UAVMission.exact_solution" in result.output
    assert message in result.output


def test_the_check_also_runs_in_a_worker_process():
    experiment = parse_config(config(seeds=2, icca=icca({"kind": "CBBAPlanner"})))
    runs = [resolve_run(experiment, "icca", seed) for seed in (0, 1)]
    with pytest.raises(IncompatibleComponentsError, match=r"^agents\.icca\.params\.planner: CBBA"):
        preflight.check_runs(runs, LocalExecutor(max_workers=2))


def test_one_check_per_distinct_pair_and_no_run_or_id_changes(tmp_path, monkeypatch):
    data = config(seeds=3, sarsa=SARSA, icca=icca({"kind": "ShortestPathPlanner"}))
    experiment = parse_config(data)
    runs = [resolve_run(experiment, label, s) for label in ("sarsa", "icca") for s in range(3)]
    expected = {run_id(spec): run_resolved(spec).curve for spec in runs}  # without a check
    check, checked = preflight.check_problem, []

    def spy(spec):
        checked.append((spec["label"], spec["seed"]))
        return check(spec)

    monkeypatch.setattr(preflight, "check_problem", spy)
    outcome = run_experiment(data, tmp_path, max_workers=1, progress=False)
    assert checked == [("sarsa", 0), ("icca", 0)]  # once per (domain, agent), not per seed
    assert outcome.errors == {} and sorted(outcome.results["run_id"].unique()) == sorted(expected)
    for identifier, curve in expected.items():
        stored = read_run(run_path(tmp_path, identifier))["curve"]
        columns = [c for c in curve.columns if c not in TIMING_COLUMNS]
        assert stored[columns].equals(curve[columns]), identifier


def test_only_bad_input_stops_the_runs(monkeypatch):
    from test_loop import FakeAgent, FakeWalk

    from conjure.experiments import registry

    assert preflight.check_problem(resolve_run(parse_config(config()), "sarsa", 0)) is None
    bad = resolve_run(parse_config(config(icca=icca({"kind": "CBBAPlanner"}))), "icca", 0)
    kind, part, message = preflight.check_problem(bad)
    assert (kind, part) == ("IncompatibleComponentsError", "agent") and "\n" not in message
    # Any other error (here a RuntimeError in setup) is the runs' to record, with its traceback.
    monkeypatch.setitem(registry.AGENTS, "FakeAgent", FakeAgent)
    monkeypatch.setitem(registry.DOMAINS, "FakeWalk", FakeWalk)
    broken = {"kind": "FakeAgent", "params": {"fail_in_setup": True}}
    experiment = parse_config({**config(broken=broken), "domain": {"kind": "FakeWalk"}})
    runs = [resolve_run(experiment, "broken", 0)]
    assert preflight.check_runs(runs, LocalExecutor(max_workers=1)) == 1
