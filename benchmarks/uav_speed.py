"""UAV mission speed: steps/s, simulate calls/s and the exact DP's wall time (Section 5.3.5).

Usage: ``python benchmarks/uav_speed.py [--steps N] [--repeats R] [--skip-10-2]``

Measured after a warm-up (numba compilation excluded), median of ``repeats`` runs:

1. `UAVMission.step` with random legal actions (``legal_actions`` + a uniform pick + ``step``,
   resetting at the end of each mission), and ``step`` alone in a fixed action sequence;
2. the compiled kernel ``mission_step`` called from a compiled loop (what a compiled learner
   gets), in steps/s;
3. `UAVMission.simulate` calls per second from the start state (the risk analyser's rollouts);
4. the wall time of `exact_solution` (backward induction over reachable states) for UAV 7-2
   at η = 0 and η = 0.05, and for UAV 10-2 unless skipped. The thesis reports about a day for
   UAV 7-2 (footnote 4) and calls 10-2 infeasible.
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np
from numba import njit
from rich.console import Console
from rich.table import Table

from conjure.domains import UAVMission
from conjure.domains import uav_mission as uav_module
from conjure.domains._mission_kernels import is_terminal, legal_actions, mission_step


@njit(cache=True)
def compiled_random_walk(start, layout, adjacency, node_table, eta, rng, num_steps):
    """Random legal actions through ``mission_step`` without leaving numba."""
    state = start.copy()
    total = 0.0
    for _ in range(num_steps):
        if is_terminal(state, layout):
            state = start.copy()
        legal = legal_actions(state, layout, adjacency)
        action = legal[rng.integers(0, legal.shape[0])]
        state, reward, _, _ = mission_step(state, action, layout, node_table, eta, rng)
        total += reward
    return total


def random_legal_steps(domain: UAVMission, num_steps: int) -> float:
    rng = np.random.default_rng(0)
    obs, _ = domain.reset(seed=0)
    start = time.perf_counter()
    for _ in range(num_steps):
        legal = domain.legal_actions(obs)
        obs, _, terminated, _, _ = domain.step(int(legal[rng.integers(legal.size)]))
        if terminated:
            obs, _ = domain.reset()
    return num_steps / (time.perf_counter() - start)


def plain_steps(domain: UAVMission, num_steps: int) -> float:
    # out and back, then wait at the base: 2 fuel units per 4 steps
    tour = [domain.graph_.encode_action(p) for p in ([1, 2], [0, 0], [0, 0], [0, 0])]
    domain.reset(seed=0)
    start = time.perf_counter()
    for k in range(num_steps):
        _, _, terminated, _, _ = domain.step(tour[k % 4])
        if terminated:
            domain.reset()
    return num_steps / (time.perf_counter() - start)


def compiled_steps(domain: UAVMission, num_steps: int) -> float:
    args = (
        domain.graph_.initial_state().astype(np.int64),
        domain._layout,
        domain._adjacency,
        domain._node_table,
        float(domain.traverse_failure),
        np.random.default_rng(0),
    )
    start = time.perf_counter()
    compiled_random_walk(*args, num_steps)
    return num_steps / (time.perf_counter() - start)


def simulate_calls(domain: UAVMission, num_calls: int) -> float:
    rng = np.random.default_rng(0)
    state = domain.graph_.initial_state()
    action = domain.graph_.encode_action([1, 2])
    start = time.perf_counter()
    for _ in range(num_calls):
        domain.simulate(state, action, 0.05, rng)
    return num_calls / (time.perf_counter() - start)


def solve_seconds(domain: UAVMission) -> tuple[float, object]:
    uav_module._SOLUTIONS.clear()  # time the solve, not the cache
    start = time.perf_counter()
    solution = domain.exact_solution()
    return time.perf_counter() - start, solution


def median(measure, repeats: int) -> float:
    return statistics.median(measure() for _ in range(repeats))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=100_000)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--skip-10-2", action="store_true")
    args = parser.parse_args()
    console = Console()

    domain = UAVMission(traverse_failure=0.05)
    for measure in (random_legal_steps, plain_steps, compiled_steps, simulate_calls):
        measure(domain, 100)  # warm-up: compile and load the kernels
    speeds = Table(title="UAV 7-2, η = 0.05 (median of repeats)")
    speeds.add_column("measurement")
    speeds.add_column("per second", justify="right")
    speeds.add_column("µs each", justify="right")
    for label, measure in (
        ("step, random legal actions (with legal_actions)", random_legal_steps),
        ("step alone", plain_steps),
        ("mission_step in a compiled loop", compiled_steps),
        ("simulate", simulate_calls),
    ):
        rate = median(lambda m=measure: m(domain, args.steps), args.repeats)
        speeds.add_row(label, f"{rate:,.0f}", f"{1e6 / rate:.2f}")
    console.print(speeds)

    solve_seconds(UAVMission(graph=UAVMission().graph_.to_dict()))  # warm-up: compile
    solves = Table(title="exact_solution (backward induction over reachable states)")
    for column in ("scenario", "η", "seconds", "reachable states", "worst", "optimal"):
        solves.add_column(column, justify="right")
    scenarios = ["uav-7-2"] + ([] if args.skip_10_2 else ["uav-10-2"])
    for scenario in scenarios:
        for eta in (0.0, 0.05):
            seconds, solution = solve_seconds(UAVMission(scenario=scenario, traverse_failure=eta))
            solves.add_row(
                scenario,
                f"{eta:g}",
                f"{seconds:.2f}",
                f"{solution.num_states:,}",
                f"{solution.worst_return:.2f}",
                f"{solution.optimal_return:.2f}",
            )
    console.print(solves)


if __name__ == "__main__":
    main()
