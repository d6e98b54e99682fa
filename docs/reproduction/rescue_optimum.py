"""The optimal expected return of the (reconstructed) Rescue Mission, by exact expectimax.

    python docs/reproduction/rescue_optimum.py
    python docs/reproduction/rescue_optimum.py --quick   # a smoke run: horizon 4, not 10

The mission lasts at most H = 10 steps from one start state, so backward induction over the
states reachable from the start is exact: each step is deterministic except the rescue at the
medic's node, which succeeds with the node's probability. Uses the domain's own step kernel.
Prints V*(s0), the number of reachable states and the optimal plan's first actions.
"""

from __future__ import annotations

import sys
from functools import cache

import numpy as np

from conjure.domains import RescueMission
from conjure.domains._uav_kernels import rescue_legal_actions, rescue_step


def main() -> None:
    """Solve the default Rescue Mission and print V*(s0)."""
    sys.setrecursionlimit(10_000)
    domain = RescueMission(horizon=4) if "--quick" in sys.argv[1:] else RescueMission()
    start, _ = domain.reset(seed=0)
    graph = (domain.neighbours_, domain._degrees, domain._is_near)
    people, success = domain._people, domain._success
    horizon, fuel_penalty, failure_penalty = domain._scalars
    mask = np.zeros(20, dtype=np.int8)

    def outcome(state: tuple, action: int, uniform: float) -> tuple[tuple, float, bool]:
        ints = np.array(state, dtype=np.int64)
        _, reward, done, _ = rescue_step(
            ints, action, uniform, *graph, people, success,
            horizon, fuel_penalty, failure_penalty, mask,
        )  # fmt: skip
        return tuple(ints.tolist()), float(reward), bool(done)

    @cache
    def value(state: tuple) -> tuple[float, int]:
        legal, _ = rescue_legal_actions(
            np.array(state, dtype=np.float64), domain._high, graph[0], graph[1]
        )
        best, best_action = -np.inf, -1
        for action in legal.tolist():
            hit = outcome(state, action, 0.0)
            miss = outcome(state, action, 1.0)
            p = success[hit[0][0]] if hit[0] != miss[0] else 1.0
            total = 0.0
            for weight, (following, reward, done) in ((p, hit), (1.0 - p, miss)):
                if weight > 0.0:
                    total += weight * (reward + (0.0 if done else value(following)[0]))
            if total > best:
                best, best_action = total, action
        return best, best_action

    s0 = tuple(int(v) for v in start)
    v0, _ = value(s0)
    print(f"V*(s0) = {v0:.4f} over {value.cache_info().currsize:,} reachable decision states")
    state, plan = s0, []
    for _ in range(int(horizon)):  # the plan while every rescue succeeds
        _, action = value(state)
        plan.append(domain.describe_action(action))
        state, _, done = outcome(state, action, 0.0)
        if done:
            break
    print("plan if every rescue succeeds:", *plan, sep="\n  ")


if __name__ == "__main__":
    main()
