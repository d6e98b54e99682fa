"""CBBA planner speed on UAV 7-2 and 10-2: µs per uncached plan and per cached lookup.

Run: ``python benchmarks/cbba_speed.py [--episodes 200] [--repeats 5]``.

The states are those met while following each planner on the mission (noise-free moves,
random visit draws, and a random legal move instead of the planner's 20% of the time, so
that off-plan states are timed too). "uncached" is ``CBBAPlanner.action`` with
``cache_size=0`` (a full CBBA plan, Algorithm 27's loop included, per call); "plan" is
``CBBAPlanner.plan`` (the same plus the `MissionPlan` object); "cached" is ``action`` on a
warm cache. Each number is the best of ``--repeats`` passes over all states.
"""

from __future__ import annotations

import argparse
import time
from types import SimpleNamespace

import numpy as np

from conjure.domains.mission_graph import MissionGraph, uav_7_2, uav_10_2
from conjure.planners import CBBAPlanner


def follow(graph: MissionGraph, planner: CBBAPlanner, episodes: int, seed: int) -> list:
    """Distinct states met while (mostly) following ``planner``."""
    rng = np.random.default_rng(seed)
    n = graph.num_uavs
    seen: dict[bytes, np.ndarray] = {}
    for _ in range(episodes):
        state = graph.initial_state()
        for _ in range(graph.horizon):
            seen.setdefault(state.tobytes(), state.copy())
            destinations = graph.decode_action(planner.action(state))
            if rng.random() < 0.2:
                here = graph.locations(state)
                for i in range(n):
                    row = graph.neighbours[here[i]]
                    destinations[i] = rng.choice([here[i], *row[row >= 0]])
            state = step(graph, state, destinations, rng)
    return list(seen.values())


def step(graph: MissionGraph, state: np.ndarray, destinations, rng) -> np.ndarray:
    n, nxt = graph.num_uavs, state.copy()
    for i, node in enumerate(destinations):
        if not (node == state[2 * i] == graph.base):
            nxt[2 * i + 1] = max(nxt[2 * i + 1] - 1, 0)
        nxt[2 * i] = node
    nxt[-1] += 1
    for node in destinations:
        a, b = graph.windows[node]
        if a <= nxt[-1] <= b and nxt[2 * n + node] < 0.5:
            nxt[2 * n + node] = float(rng.random() < graph.probabilities[node])
    return nxt


def best_us(call, states: list, repeats: int) -> float:
    best = np.inf
    for _ in range(repeats):
        started = time.perf_counter()
        for state in states:
            call(state)
        best = min(best, (time.perf_counter() - started) / len(states))
    return best * 1e6


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=200)
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    print(
        f"{'mission':>8} {'variant':>12} {'states':>7} {'uncached µs':>12} {'plan µs':>8} "
        f"{'cached µs':>10} {'CBBA runs':>9} {'rounds':>7}"
    )
    for name, make in (("7-2", uav_7_2), ("10-2", uav_10_2)):
        graph = make()
        model = SimpleNamespace(domain_=SimpleNamespace(graph_=graph))
        for variant in ("aggressive", "conservative"):
            uncached = CBBAPlanner(variant=variant, cache_size=0).setup(model)
            cached = CBBAPlanner(variant=variant).setup(model)
            states = follow(graph, cached, args.episodes, seed=0)  # compiles and warms
            plans = [uncached.plan(s) for s in states]
            runs = np.mean([p.cbba_runs for p in plans])
            rounds = np.mean([p.allocation.rounds for p in plans])
            print(
                f"{name:>8} {variant:>12} {len(states):>7} "
                f"{best_us(uncached.action, states, args.repeats):>12.1f} "
                f"{best_us(uncached.plan, states, args.repeats):>8.1f} "
                f"{best_us(cached.action, states, args.repeats):>10.2f} "
                f"{runs:>9.2f} {rounds:>7.2f}"
            )


if __name__ == "__main__":
    main()
