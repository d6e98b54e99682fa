"""Learning steps per second of the online learners, through the library's own run loop.

Usage: ``python benchmarks/learning_speed.py [--steps N] [--repeats R]``

Workloads (issue 2): SARSA + tile coding on InvertedPendulum and on GridWorld-1, and
SARSA(λ) + tile coding on Gymnasium's MountainCar-v0 through ``from_gymnasium``. Each is
measured after a warm-up (numba compilation excluded) as the median of ``repeats`` timed
``LearningLoop.advance`` calls, i.e. domain step + feature activation + action selection + TD
update, exactly as ``conjure run`` executes them. A reference row times Gymnasium's own
``MountainCar-v0`` (``gymnasium.make``, its wrappers included) stepping with a fixed action
and no learner, the floor of the MountainCar row: the environment's Python step is shared by
every library that learns on it.
"""

from __future__ import annotations

import argparse
import statistics
import time

import gymnasium as gym
from rich.console import Console
from rich.table import Table

from conjure.agents import SARSA
from conjure.domains import GridWorld, InvertedPendulum, from_gymnasium
from conjure.experiments.loop import LearningLoop
from conjure.policies import EpsilonGreedy
from conjure.representations import TileCoding


def workloads():
    yield (
        "SARSA + TileCoding(8 tilings of 10x10), InvertedPendulum",
        InvertedPendulum(),
        SARSA(
            representation=TileCoding(num_tilings=8, tiles_per_dim=10),
            policy=EpsilonGreedy(epsilon=0.1),
            step_size=0.05,
        ),
    )
    yield (
        "SARSA + TileCoding(8 tilings of 10x7), GridWorld-1",
        GridWorld.gridworld_1(),
        SARSA(representation=TileCoding(num_tilings=8, tiles_per_dim=[10, 7]), step_size=0.05),
    )
    yield (
        "SARSA(0.9) + TileCoding(10 tilings of 10x10), MountainCar-v0 via from_gymnasium",
        from_gymnasium("MountainCar-v0", discount=1.0),
        SARSA(
            representation=TileCoding(num_tilings=10, tiles_per_dim=10),
            policy=EpsilonGreedy(epsilon=0.0),
            step_size=0.1 / 10,
            trace_decay=0.9,
        ),
    )


def measure(domain, agent, num_steps: int, repeats: int) -> float:
    agent.setup(domain.domain_spec, seed=0)
    loop = LearningLoop(domain, agent, seed=0)
    loop.advance(2_000)  # warm-up: numba compilation or cache loading
    rates = []
    for _ in range(repeats):
        start = time.perf_counter()
        loop.advance(num_steps)
        rates.append(num_steps / (time.perf_counter() - start))
    return statistics.median(rates)


def environment_alone(num_steps: int, repeats: int) -> float:
    """Median steps/s of ``gymnasium.make("MountainCar-v0")`` alone, action 1, resets included."""
    env = gym.make("MountainCar-v0")
    env.reset(seed=0)
    rates = []
    for _ in range(repeats):
        start = time.perf_counter()
        for _ in range(num_steps):
            _, _, terminated, truncated, _ = env.step(1)
            if terminated or truncated:
                env.reset()
        rates.append(num_steps / (time.perf_counter() - start))
    return statistics.median(rates)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=100_000)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    table = Table(title=f"Learning speed (median of {args.repeats} x {args.steps:,} steps)")
    table.add_column("workload")
    table.add_column("steps/s", justify="right")
    table.add_column("us/step", justify="right")
    for name, domain, agent in workloads():
        rate = measure(domain, agent, args.steps, args.repeats)
        table.add_row(name, f"{rate:,.0f}", f"{1e6 / rate:.2f}")
    rate = environment_alone(args.steps, args.repeats)
    table.add_row("reference: MountainCar-v0 env.step alone", f"{rate:,.0f}", f"{1e6 / rate:.2f}")
    Console().print(table)


if __name__ == "__main__":
    main()
