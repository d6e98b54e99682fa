"""Learning speed of AM-iCCA on UAV 7-2 with Monte-Carlo risk and CBBA replanning (Chapter 5).

Usage: ``python benchmarks/uav_safety_speed.py [--steps N] [--seed S]``

One whole run as Section 5.5.2 sets it up: `AdaptiveCooperativeLearner` (Algorithm 26) with
SARSA on `HashedTabular`, a `SwitchingPlanner` over conservative and aggressive `CBBAPlanner`
(switch below η̂ = 25%, prior 0.4 with weight 100), `MonteCarloRiskAnalyzer` (𝓜 = 5, ε = 0.2)
calling CBBA at every rollout step (plans cached by state), on UAV 7-2 with 5% traverse
failures. Reports the wall time of ``LearningLoop.advance(N)`` from a fresh agent (numba
compilation excluded by a 200-step warm-up of a separate agent), steps/s and µs/step, and the
share of time spent in risk analysis and in CBBA.
"""

from __future__ import annotations

import argparse
import cProfile
import pstats
import time

from rich.console import Console
from rich.table import Table

from conjure.agents import SARSA
from conjure.domains import UAVMission
from conjure.experiments.loop import LearningLoop
from conjure.models.approximate_model import ApproximateModel
from conjure.planners import CBBAPlanner, SwitchingPlanner
from conjure.policies import EpsilonGreedy
from conjure.representations import HashedTabular
from conjure.safety import AdaptiveCooperativeLearner, MonteCarloRiskAnalyzer


def am_icca() -> AdaptiveCooperativeLearner:
    return AdaptiveCooperativeLearner(
        learner=SARSA(
            representation=HashedTabular(), policy=EpsilonGreedy(epsilon=0.1), step_size=0.1
        ),
        planner=SwitchingPlanner(
            conservative=CBBAPlanner(variant="conservative"),
            aggressive=CBBAPlanner(variant="aggressive"),
        ),
        risk=MonteCarloRiskAnalyzer(num_rollouts=5, risk_tolerance=0.2),
        model=ApproximateModel(domain=UAVMission(), initial_noise=0.4, is_adaptive=True),
        num_known_visits=10,
    )


def learning_loop(seed: int) -> tuple[LearningLoop, AdaptiveCooperativeLearner]:
    domain = UAVMission(traverse_failure=0.05)
    agent = am_icca().setup(domain.domain_spec, seed=seed)
    return LearningLoop(domain, agent, seed=seed), agent


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=100_000)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    learning_loop(args.seed + 1)[0].advance(200)  # compile the kernels
    loop, agent = learning_loop(args.seed)
    start = time.perf_counter()
    loop.advance(args.steps)
    seconds = time.perf_counter() - start
    profiler = cProfile.Profile()  # where the time goes: 10,000 more steps, profiled
    profiler.enable()
    loop.advance(10_000)
    profiler.disable()
    stats = pstats.Stats(profiler).stats
    total = max(row[3] for row in stats.values())

    def share(function: str) -> str:
        times = [row[3] for key, row in stats.items() if key[2] == function]
        return f"{100 * max(times, default=0.0) / total:.0f}%"

    table = Table(title=f"AM-iCCA on UAV 7-2 (η = 0.05), {args.steps:,} learning steps")
    for column in ("wall time (s)", "steps/s", "µs/step", "risk analysis", "CBBA (uncached)"):
        table.add_column(column, justify="right")
    table.add_row(
        f"{seconds:.1f}",
        f"{args.steps / seconds:,.0f}",
        f"{1e6 * seconds / args.steps:.1f}",
        share("risk"),
        share("_plan"),
    )
    Console().print(table)
    planners = (agent.planner_.conservative_, agent.planner_.aggressive_)
    print(
        f"aggressive CBBA in use: {agent.planner_.is_aggressive_}; η̂ = {agent.model_.noise_:.3f}; "
        f"plans cached: {sum(planner.num_cached_ for planner in planners):,}"
    )


if __name__ == "__main__":
    main()
