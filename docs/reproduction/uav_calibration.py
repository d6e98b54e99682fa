"""Calibration of the UAV 7-2 and 10-2 reconstructions against spec 2.2's targets (issue 19).

    python docs/reproduction/uav_calibration.py                 # the shipped graphs
    python docs/reproduction/uav_calibration.py --spec          # spec 2.2's first reconstruction
    python docs/reproduction/uav_calibration.py --refuel        # Algorithm 27's two readings
    python docs/reproduction/uav_calibration.py --search 7-2 --candidates 400 --steps 50

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

``--search`` samples target rewards, probabilities, windows and fuel on the spec graph's edges
(often with a one-step-window target next to the base, the motif that gives CBBA room),
scores each candidate by its distance to the targets (`distance`), then changes one reward,
probability, window or fuel of the best at a time, keeping changes that do not score worse,
and prints the result as a `MissionGraph.from_dict` mapping. The shipped graphs were found this
way: about a thousand random candidates for 7-2 and 250 for 10-2, scored by a coarser form
of `distance`, then 40-60 one-change steps from the best few.
"""

from __future__ import annotations

import argparse
import json
import math
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from types import SimpleNamespace
from typing import Any

import numpy as np

from conjure.domains.mission_graph import (
    MissionGraph,
    sample_mission,
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


# ------------------------------------------------------------------------------------ search


def outside(x: float, low: float, high: float) -> float:
    """How far ``x`` lies outside [low, high]."""
    return max(low - x, 0.0, x - high)


def distance(graph: MissionGraph, noise_free: dict[str, Any], noisy: dict[str, Any]) -> float:
    """Weighted distance of a candidate's reports at η = 0 and 0.05 to the targets (issue 19).

    Aimed inside the ranges: noise-free CBBA 0.80-0.89 V/V* with its room early and in few
    states; at 5% failures the optimum crashing <= 3%, aggressive CBBA 0.76-0.86 with 23-27%
    crashes, conservative CBBA 4-6% below it with <= 2% crashes; Π_i (F_i + 1) no larger
    than spec 2.2's (7-2: 64, 10-2: 81).
    """
    _, cbba, _ = noise_free["rows"]
    best, aggressive, conservative = noisy["rows"]
    fuel_levels = math.prod(f + 1 for f in graph.fuel)
    return (
        0.002 * max(fuel_levels - (64 if graph.num_nodes == 7 else 81), 0)
        + 0.02 * max(cbba.states - 5, 0)
        + 4 * outside(cbba.ratio, 0.80, 0.89)
        + 4 * outside(best.crash, 0.0, 0.03)
        + 3 * outside(aggressive.ratio, 0.76, 0.86)
        + 6 * outside(aggressive.crash, 0.23, 0.27)
        + 3 * outside(aggressive.ratio - conservative.ratio, 0.04, 0.06)
        + 3 * outside(conservative.crash, 0.0, 0.02)
        + 0.3 * outside(cbba.early, 0.85, 1.0)
        + 0.2 * outside(aggressive.early, 0.6, 1.0)
        + 0.2 * outside(conservative.early, 0.5, 1.0)
    )


def sample_targets(rng: np.random.Generator, graph: MissionGraph) -> dict[str, Any]:
    """A random mission on ``graph``'s edges (`sample_mission`), often with the motif planted."""
    return sample_mission(rng, graph, base_target_rate=0.7).to_dict()


def mutate(rng: np.random.Generator, data: dict[str, Any]) -> dict[str, Any]:
    """``data`` with one reward (±50, ±100), probability (±0.1), window or fuel changed."""
    data = json.loads(json.dumps(data))
    targets = {int(node): target for node, target in data["targets"].items()}
    kind = rng.choice(["reward", "probability", "window", "fuel"])
    if kind == "fuel":
        uav, low = int(rng.integers(len(data["fuel"]))), 5 if data["num_nodes"] == 7 else 7
        data["fuel"][uav] = int(np.clip(data["fuel"][uav] + rng.choice([-1, 1]), low, low + 3))
        return data
    node = int(rng.integers(1, data["num_nodes"]))
    target = targets.setdefault(node, {"reward": 0.0, "probability": 1.0})
    if kind == "reward":
        reward = target["reward"] + rng.choice([-100, -50, 50, 100])
        target["reward"] = float(np.clip(reward, 0, 700))
    elif kind == "probability":
        p = round(target["probability"] + rng.choice([-0.1, 0.1]), 1)
        target["probability"] = float(np.clip(p, 0.1, 1.0))
    elif "window" in target and rng.random() < 0.3:
        del target["window"]
    else:
        start, end = target.get("window", [0, data["horizon"]])
        start = int(np.clip(start + rng.integers(-1, 2), 0, data["horizon"]))
        target["window"] = [start, int(np.clip(end + rng.integers(-1, 2), start, data["horizon"]))]
    data["targets"] = {n: t for n, t in targets.items() if t["reward"] > 0}
    return data


def search(graph: MissionGraph, candidates: int, steps: int, seed: int) -> dict[str, Any]:
    """Random candidates, then ``steps`` one-change steps from the best; print and return it."""
    rng = np.random.default_rng(seed)

    def score(data: dict[str, Any]) -> float:
        return distance(MissionGraph.from_dict(data), assess(data, 0.0), assess(data, 0.05))

    best, best_score = graph.to_dict(), np.inf
    for k in range(candidates):
        data = sample_targets(rng, graph)
        if not 0.75 <= assess(data, 0.0)["rows"][1].ratio <= 0.92:
            continue  # no room, or too much: skip the noisy solve
        value = score(data)
        if value < best_score:
            best, best_score = data, value
            print(f"candidate {k}: distance {value:.3f}", flush=True)
    for k in range(steps):
        data = mutate(rng, best)
        value = score(data)
        if value <= best_score:
            best, best_score = data, value
            print(f"step {k}: distance {value:.3f}", flush=True)
    print(json.dumps(best))
    return best


def main() -> None:
    """Parse the command line and print the tables (or run the search)."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--spec", action="store_true", help="spec 2.2's first reconstruction")
    parser.add_argument("--refuel", action="store_true", help="Algorithm 27's two readings")
    parser.add_argument("--skip-10-2", action="store_true", help="UAV 7-2 only")
    parser.add_argument("--quick", action="store_true", help="a smoke run: UAV 7-2 only")
    parser.add_argument("--search", choices=["7-2", "10-2"], help="search a new calibration")
    parser.add_argument("--candidates", type=int, default=400, help="random candidates")
    parser.add_argument("--steps", type=int, default=50, help="one-change steps after them")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    if args.search:
        spec_graph = uav_7_2_spec() if args.search == "7-2" else uav_10_2_spec()
        search(spec_graph, args.candidates, args.steps, args.seed)
        return
    scenarios = [("UAV 7-2", uav_7_2()), ("UAV 10-2", uav_10_2())]
    spec = [("UAV 7-2 (spec)", uav_7_2_spec()), ("UAV 10-2 (spec)", uav_10_2_spec())]
    if args.spec:
        scenarios = spec
    elif args.refuel:
        scenarios = spec + scenarios
    if args.skip_10_2 or args.quick:
        scenarios = [(name, graph) for name, graph in scenarios if graph.num_nodes == 7]
    for name, graph in scenarios:
        if args.refuel:
            print_refuel(name, graph)
        else:
            print_table(name, graph)


if __name__ == "__main__":
    main()
