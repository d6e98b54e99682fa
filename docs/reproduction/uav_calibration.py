"""Calibration of the UAV 7-2 and 10-2 reconstructions against spec 2.2's targets (issue 19).

    python docs/reproduction/uav_calibration.py                 # the shipped graphs
    python docs/reproduction/uav_calibration.py --spec          # spec 2.2's first reconstruction
    python docs/reproduction/uav_calibration.py --refuel        # Algorithm 27's two readings
    python docs/reproduction/uav_calibration.py --search 7-2 --candidates 400 --seed 0

Every number is exact: the optimum and the worst policy by backward induction
(`UAVMission.exact_solution`), aggressive and conservative CBBA replanned at every step
(Section 5.5.2) by a forward pass over the states they reach (`UAVMission.evaluate_policy`).
For each scenario and traverse failure η ∈ {0, 0.05} it prints V*, V_worst and, per policy, its
value, V/V*, the worst-to-best scale (V − V_worst)/(V* − V_worst) of Figure 5-6b, the crash
probability and the learnability diagnostic:

- room: Σ_s Pr_π(s) · (max_{a safe} Q*(s, a) − Q*(s, π(s))) over the states s the planner
  reaches, "safe" being the fuel rule of `FuelRiskAnalyzer` (Section 5.3.5). With π* safe it
  is V* − V^π (performance difference lemma), so it is what a learner that starts from the
  planner and keeps to the fuel rule can gain;
- early: the share of the room in states at t <= 2;
- states: how many states hold 80% of the room (few states = the learner meets them often).

``--search`` samples target rewards, probabilities, windows and fuel on the scenario's edges
and prints the candidates closest to the targets; it is how the shipped graphs were found.
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from types import SimpleNamespace
from typing import Any

import numpy as np

from conjure.domains.mission_graph import (
    MissionGraph,
    uav_7_2,
    uav_7_2_spec,
    uav_10_2,
    uav_10_2_spec,
)
from conjure.domains.uav_mission import MissionSolution, PolicyEvaluation, UAVMission
from conjure.planners.cbba_planner import CBBAPlanner
from conjure.safety.fuel_risk import FuelRiskAnalyzer

ETAS = (0.0, 0.05)
EARLY = 2  # "early": t <= EARLY
CONCENTRATION = 0.8  # states holding this share of the room


@dataclass(frozen=True)
class Row:
    """One policy's exact evaluation and learnability diagnostic at one η."""

    policy: str
    value: float
    ratio: float  # V / V*
    scaled: float  # (V − V_worst) / (V* − V_worst)
    crash: float
    room: float
    early: float
    states: int


def planner(domain: UAVMission, **params: Any) -> CBBAPlanner:
    """A CBBAPlanner on ``domain``'s own graph (CBBA's model ignores η)."""
    return CBBAPlanner(**params).setup(SimpleNamespace(domain_=domain), seed=0)


def learnability(
    domain: UAVMission, solution: MissionSolution, result: PolicyEvaluation
) -> tuple[float, float, int]:
    """(room, early share, states holding 80% of the room) of a planner's evaluation."""
    graph = domain.graph_
    gaps = np.zeros(result.actions.shape[0])
    for k, (state, action) in enumerate(zip(result.states, result.actions, strict=True)):
        actions, q = solution.q_values(state)
        safe = [
            not FuelRiskAnalyzer.is_unsafe_outcome(graph, domain.nominal_next_state(state, a))
            for a in actions
        ]
        best = q[safe].max() if any(safe) else q.max()
        gaps[k] = max(best - q[actions == action][0], 0.0)
    weighted = result.reach_probabilities * gaps
    room = float(weighted.sum())
    if room <= 1e-9:
        return 0.0, 0.0, 0
    early = float(weighted[result.states[:, -1] <= EARLY].sum() / room)
    share = np.cumsum(np.sort(weighted)[::-1]) / room
    return room, early, int(np.searchsorted(share, CONCENTRATION - 1e-12) + 1)


def assess(graph: MissionGraph | Mapping[str, Any], eta: float, **cbba: Any) -> dict[str, Any]:
    """V*, V_worst and the rows of the optimum, aggressive and conservative CBBA at ``eta``."""
    data = graph.to_dict() if isinstance(graph, MissionGraph) else dict(graph)
    domain = UAVMission(graph=data, traverse_failure=eta)
    solution = domain.exact_solution()
    best, worst = solution.optimal_return, solution.worst_return
    policies: dict[str, Callable[[np.ndarray], int]] = {
        "optimum": solution.action,
        "aggressive CBBA": planner(domain, variant="aggressive", **cbba).action,
        "conservative CBBA": planner(domain, variant="conservative", **cbba).action,
    }
    rows = []
    for name, policy in policies.items():
        result = domain.evaluate_policy(policy)
        room, early, states = learnability(domain, solution, result)
        rows.append(
            Row(
                policy=name,
                value=result.value,
                ratio=result.value / best,
                scaled=(result.value - worst) / (best - worst),
                crash=result.crash_probability,
                room=room,
                early=early,
                states=states,
            )
        )
    return {"eta": eta, "best": best, "worst": worst, "rows": rows}


def print_table(name: str, graph: MissionGraph, **cbba: Any) -> None:
    """Print the calibration table of one scenario at η = 0 and 0.05."""
    print(
        f"\n{name}: {graph.num_nodes} nodes, fuel {list(graph.fuel)}, horizon {graph.horizon}, "
        f"|S×A| = {graph.state_action_count():.3g}, crash penalty {graph.crash_penalty:g}"
    )
    header = "η     policy             value    V/V*  scaled  crash   room   early states"
    print(header)
    print("-" * len(header))
    for eta in ETAS:
        start = time.perf_counter()
        report = assess(graph, eta, **cbba)
        seconds = time.perf_counter() - start
        best, worst = report["best"], report["worst"]
        print(f"{eta:<5} V* = {best:.1f}, V_worst = {worst:.1f} ({seconds:.1f} s)")
        for row in report["rows"]:
            print(
                f"      {row.policy:<17} {row.value:7.1f}  {row.ratio:5.3f}  {row.scaled:5.3f}  "
                f"{row.crash:5.3f}  {row.room:6.1f}  {row.early:4.2f}  {row.states:5d}"
            )


def print_refuel(name: str, graph: MissionGraph, eta: float = 0.05) -> None:
    """Conservative CBBA's value and crash probability under Algorithm 27's two readings."""
    domain = UAVMission(graph=graph.to_dict(), traverse_failure=eta)
    best = domain.exact_solution().optimal_return
    print(f"\n{name}, η = {eta}: conservative CBBA (V* = {best:.1f})")
    print("refuel      reserve   value    V/V*  crash")
    for refuel in ("empty_plan", "home"):
        for reserve in (3, 4, 5):
            policy = planner(domain, refuel=refuel, fuel_reserve=reserve).action
            result = domain.evaluate_policy(policy)
            print(
                f"{refuel:<11} {reserve:7d} {result.value:7.1f}  {result.value / best:5.3f}  "
                f"{result.crash_probability:5.3f}"
            )


def main() -> None:
    """Parse the command line and print the tables (or run the search)."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--spec", action="store_true", help="spec 2.2's first reconstruction")
    parser.add_argument("--refuel", action="store_true", help="Algorithm 27's two readings")
    parser.add_argument("--skip-10-2", action="store_true", help="UAV 7-2 only")
    args = parser.parse_args()
    scenarios = (
        [("UAV 7-2 (spec)", uav_7_2_spec()), ("UAV 10-2 (spec)", uav_10_2_spec())]
        if args.spec or args.refuel
        else [("UAV 7-2", uav_7_2()), ("UAV 10-2", uav_10_2())]
    )
    if args.skip_10_2:
        scenarios = scenarios[:1]
    for name, graph in scenarios:
        if args.refuel:
            print_refuel(name, graph)
        else:
            print_table(name, graph)


if __name__ == "__main__":
    main()
