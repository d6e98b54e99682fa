"""A corpus of malformed chapter-5 configs: each is one clean line, status 2, before any run.

Every case changes one thing in a shipped config (`examples/reproduction/fig_5_*.yaml`,
`examples/uav_icca.yaml`), cut to the agent the change concerns, one seed and a tiny budget:
a config that slipped through would start (and finish) a run, which the test sees.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
import yaml
from click.testing import CliRunner

from conjure.cli.main import main
from conjure.experiments.results import RUNS_DIR

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"

Change = Callable[[dict[str, Any]], None]


def shipped(name: str, agent: str) -> dict[str, Any]:
    """``examples/<name>.yaml`` with agent ``agent`` only, one seed and 50 learning steps."""
    data = yaml.safe_load((EXAMPLES / f"{name}.yaml").read_text())
    data = {k: v for k, v in data.items() if k not in ("grid", "selection")}
    data["agents"] = {agent: data["agents"][agent]}
    data.update(seeds=1, budget_steps=50, num_policy_checks=1, eval_episodes=1)
    return json.loads(json.dumps(data))  # YAML anchors share objects: unshare them


def at(*path: str | int, value: Any) -> Change:
    """Set ``value`` at ``path`` (keys and list indices) of a config."""

    def change(data: dict[str, Any]) -> None:
        node: Any = data
        for key in path[:-1]:
            node = node[key]
        node[path[-1]] = value

    return change


def uav_graph(**changes: Any) -> Change:
    """Replace the UAV scenario by its graph with ``changes`` (e.g. ``fuel=[0, 0]``)."""

    def change(data: dict[str, Any]) -> None:
        from conjure.domains import UAVMission

        graph = {**UAVMission(scenario=data["domain"]["params"]["scenario"]).graph_.to_dict()}
        graph.update(changes)
        data["domain"]["params"] = {"graph": graph}

    return change


SARSA_12 = ("reproduction/fig_5_12", "sarsa")
ICCA_12 = ("reproduction/fig_5_12", "icca")
AM_ICCA_12 = ("reproduction/fig_5_12", "am_icca")
CAC_5 = ("reproduction/fig_5_5", "icca")
CSARSA_UAV = ("uav_icca", "csarsa")
AM_ICCA_UAV = ("uav_icca", "am_icca")
CBBA_UAV = ("uav_icca", "cbba_aggressive")
SARSA_UAV = ("uav_icca", "sarsa")
ICCA_P = ("agents", "icca", "params")
AM_P = ("agents", "am_icca", "params")
CS_P = ("agents", "csarsa", "params")

#: (id, base config and agent, change, text the one line must contain).
CASES: list[tuple[str, tuple[str, str], Change, str]] = [
    ("unknown domain kind", SARSA_12, at("domain", "kind", value="GridWorl"), "GridWorl"),
    ("unknown agent kind", SARSA_12, at("agents", "sarsa", "kind", value="SARS"), "SARS"),
    ("planner as agent", SARSA_12, at("agents", "sarsa", "kind", value="ShortestPathPlanner"),
     "ShortestPathPlanner"),
    ("unknown top-level key", SARSA_12, at("budget_step", value=10), "budget_step"),
    ("unknown agent param", SARSA_12, at("agents", "sarsa", "params", "stepsize", value=0.1),
     "stepsize"),
    ("budget a string", SARSA_12, at("budget_steps", value="many"), "many"),
    ("budget negative", SARSA_12, at("budget_steps", value=-5), "-5"),
    ("budget zero", SARSA_12, at("budget_steps", value=0), "budget_steps"),
    ("no seeds", SARSA_12, at("seeds", value=0), "seeds"),
    ("no eval episodes", SARSA_12, at("eval_episodes", value=0), "eval_episodes"),
    ("epsilon above 1", SARSA_12,
     at("agents", "sarsa", "params", "policy", "params", "epsilon", value=1.5), "1.5"),
    ("alpha_0 negative", SARSA_12,
     at("agents", "sarsa", "params", "step_size", "params", "alpha_0", value=-1.0), "-1.0"),
    ("lambda above 1", SARSA_12, at("agents", "sarsa", "params", "trace_decay", value=2.0), "2.0"),
    ("unknown map", SARSA_12, at("domain", "params", "map_name", value="gridworld9"),
     "gridworld9"),
    ("noise above 1", SARSA_12, at("domain", "params", "noise", value=1.5), "1.5"),
    ("episode cap zero", SARSA_12, at("domain", "params", "max_episode_steps", value=0),
     "max_episode_steps"),
    ("off-map goal", ICCA_12, at(*ICCA_P, "planner", "params", "goal", value=[99, 99]), "(99, 99)"),
    ("goal of one coordinate", ICCA_12, at(*ICCA_P, "planner", "params", "goal", value=[0]),
     "[0]"),
    ("off-map switching goal", AM_ICCA_12,
     at(*AM_P, "planner", "params", "aggressive", "params", "goal", value=[-1, 0]), "(-1, 0)"),
    ("no rollouts", ICCA_12, at(*ICCA_P, "risk", "params", "num_rollouts", value=0), "0"),
    ("1e9 rollouts", ICCA_12, at(*ICCA_P, "risk", "params", "num_rollouts", value=10**9),
     "1,000,000,000"),
    ("risk tolerance negative", ICCA_12,
     at(*ICCA_P, "risk", "params", "risk_tolerance", value=-0.1), "-0.1"),
    ("known visits negative", ICCA_12, at(*ICCA_P, "num_known_visits", value=-1), "-1"),
    ("model noise above 1", ICCA_12, at(*ICCA_P, "model", "params", "initial_noise", value=2.0),
     "2.0"),
    ("switch threshold above 1", AM_ICCA_12,
     at(*AM_P, "planner", "params", "noise_threshold", value=1.5), "1.5"),
    ("CBBA on a grid", ICCA_12, at(*ICCA_P, "planner", value={"kind": "CBBAPlanner"}), "CBBA"),
    ("fuel rule on a grid", ICCA_12, at(*ICCA_P, "risk", value={"kind": "FuelRiskAnalyzer"}),
     "FuelRiskAnalyzer"),
    ("unknown model planner", CAC_5,
     at("agents", "icca", "params", "planner", "params", "planner", value={"kind": "Nope"}),
     "Nope"),
    ("shortest path on a mission", CSARSA_UAV,
     at(*CS_P, "planner", value={"kind": "ShortestPathPlanner", "params": {"goal": [0, 0]}}),
     "ShortestPathPlanner"),
    ("unknown scenario", SARSA_UAV, at("domain", "params", "scenario", value="uav-9-9"),
     "uav-9-9"),
    ("failure probability negative", SARSA_UAV,
     at("domain", "params", "traverse_failure", value=-0.1), "-0.1"),
    ("unknown CBBA variant", CBBA_UAV,
     at("agents", "cbba_aggressive", "params", "planner", "params", "variant", value="reckless"),
     "reckless"),
    ("index capacity zero", SARSA_UAV,
     at("agents", "sarsa", "params", "representation", "params", "capacity", value=0), "0"),
    ("veto reward a string", CSARSA_UAV, at(*CS_P, "veto_reward", value="minus one"),
     "minus one"),
    ("model of another domain", CSARSA_UAV,
     at(*CS_P, "model", "params", "domain", value={"kind": "GridWorld"}), "GridWorld"),
    ("fuel 0", SARSA_UAV, uav_graph(fuel=[0, 0]), "fuel"),
    ("huge fuel", SARSA_UAV, uav_graph(fuel=[10**6, 10**6]), "fuel"),
    ("huge horizon", SARSA_UAV, uav_graph(horizon=10**6), "horizon"),
    ("1e6-node graph", SARSA_UAV, uav_graph(num_nodes=10**6), "1000000"),
    ("1e9 rollouts on a mission", AM_ICCA_UAV,
     at(*AM_P, "risk", "params", "num_rollouts", value=10**9), "1,000,000,000"),
]  # fmt: skip


@pytest.mark.parametrize(
    ("base", "change", "expected"), [case[1:] for case in CASES], ids=[case[0] for case in CASES]
)
def test_a_malformed_chapter_5_config_is_one_line_before_any_run(tmp_path, base, change, expected):
    data = shipped(*base)
    change(data)
    config, out = tmp_path / "bad.yaml", tmp_path / "out"
    config.write_text(json.dumps(data))
    result = CliRunner().invoke(main, ["run", str(config), "--out", str(out), "--quiet"])
    assert result.exit_code == 2, result.output
    assert isinstance(result.exception, SystemExit), result.output  # no other exception
    assert "Traceback" not in result.output
    lines = result.output.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("Error: "), result.output
    assert expected in lines[0], lines[0]
    assert not list(out.glob(f"{RUNS_DIR}/*")) and not list(out.glob("errors/*"))
