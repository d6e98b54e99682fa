"""Learning steps per second of the cooperative learners (iCCA, Chapter 5) on GridWorld-2.

Usage: ``python benchmarks/safety_speed.py [--steps N] [--repeats R]``

Workloads: SARSA alone; CooperativeLearner + SARSA (CSARSA, Algorithm 24) with the
Monte-Carlo risk analyser (Algorithm 25: 𝓜 = 5 rollouts, ε = 0.2) following the conservative
policy, with the analyser's compiled tabular rollouts and with its Python rollouts (a model
whose domain hides its noise decomposition); and AdaptiveCooperativeLearner (AM-iCCA,
Algorithm 26) with the conservative → aggressive switch. Each is measured after a 5,000-step
warm-up (numba compilation, and most visited pairs known: the learner is consulted and its
actions analysed) as the median of ``repeats`` timed ``LearningLoop.advance`` calls, exactly
as ``conjure run`` executes them.
"""

from __future__ import annotations

import argparse
import statistics
import time

from rich.console import Console
from rich.table import Table

from conjure.agents import SARSA
from conjure.domains import GridWorld
from conjure.experiments.loop import LearningLoop
from conjure.models.approximate_model import ApproximateModel
from conjure.planners import ShortestPathPlanner, SwitchingPlanner
from conjure.policies import EpsilonGreedy
from conjure.representations import Tabular
from conjure.safety import AdaptiveCooperativeLearner, CooperativeLearner, MonteCarloRiskAnalyzer


class PythonRollouts(GridWorld):
    """GridWorld-2 without its noise decomposition: the analyser rolls out in Python."""

    def noise_decomposition(self):
        return None


def sarsa():
    return SARSA(representation=Tabular(), policy=EpsilonGreedy(epsilon=0.1), step_size=0.1)


def csarsa(model_domain):
    return CooperativeLearner(
        learner=sarsa(),
        planner=ShortestPathPlanner.conservative(),
        risk=MonteCarloRiskAnalyzer(num_rollouts=5, risk_tolerance=0.2),
        model=ApproximateModel(domain=model_domain, initial_noise=0.4),
        num_known_visits=10,
    )


def workloads():
    yield "SARSA + Tabular (no safety)", sarsa()
    yield "CSARSA + MonteCarloRiskAnalyzer, compiled rollouts", csarsa(GridWorld.gridworld_2())
    yield (
        "CSARSA + MonteCarloRiskAnalyzer, Python rollouts",
        csarsa(PythonRollouts(map_name="gridworld2", step_reward=-0.01, noise=0.2)),
    )
    yield (
        "AM-iCCA (AdaptiveCooperativeLearner + SARSA), compiled rollouts",
        AdaptiveCooperativeLearner(
            learner=sarsa(),
            planner=SwitchingPlanner(
                conservative=ShortestPathPlanner.conservative(),
                aggressive=ShortestPathPlanner.aggressive(),
            ),
            risk=MonteCarloRiskAnalyzer(),
            model=ApproximateModel(
                domain=GridWorld.gridworld_2(), initial_noise=0.4, is_adaptive=True
            ),
        ),
    )


def measure(agent, num_steps: int, repeats: int) -> float:
    domain = GridWorld.gridworld_2()
    agent.setup(domain.domain_spec, seed=0)
    loop = LearningLoop(domain, agent, seed=0)
    loop.advance(5_000)  # warm-up: compilation, and the visited pairs become known
    rates = []
    for _ in range(repeats):
        start = time.perf_counter()
        loop.advance(num_steps)
        rates.append(num_steps / (time.perf_counter() - start))
    return statistics.median(rates)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=20_000)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    table = Table(title=f"GridWorld-2 (median of {args.repeats} x {args.steps:,} steps)")
    table.add_column("workload")
    table.add_column("steps/s", justify="right")
    table.add_column("us/step", justify="right")
    for name, agent in workloads():
        rate = measure(agent, args.steps, args.repeats)
        table.add_row(name, f"{rate:,.0f}", f"{1e6 / rate:.1f}")
    Console().print(table)


if __name__ == "__main__":
    main()
