"""Learning steps per second of the online learners, through the library's own run loop.

Usage: ``python benchmarks/learning_speed.py [--steps N] [--repeats R] [--python]``

Workloads: SARSA + tile coding on InvertedPendulum and on GridWorld-1, iCCA's
learner alone on GridWorld-1 (Fig. 5-5's ``actor_critic_advantage``: tabular Actor-Critic with
a V critic and the log-policy actor), and SARSA and SARSA(λ) + tile coding on Gymnasium's
MountainCar-v0 through ``from_gymnasium``. Each is
measured after a warm-up (numba compilation excluded) as the median of ``repeats`` timed
``advance`` calls of the stepper ``conjure run`` learns with (`learning_stepper`: the compiled
loop when every part has a kernel, a Gymnasium environment's own ``step`` called back from it;
the path is shown; ``--python`` forces the Python `Stepper` for comparison), i.e. domain step +
feature activation + action selection + TD update. A
user's environment is usually the slow part, so the MountainCar rows are also given as a
ratio to Gymnasium's own ``MountainCar-v0`` (``gymnasium.make``, its wrappers included)
stepping with a fixed action and no learner, timed in alternation with them so that both see
the same machine (conjure's share should be small, at most 1.5x at λ = 0; the
λ = 0.9 row says what SARSA(λ)'s traces cost on top).
"""

from __future__ import annotations

import argparse
import statistics
import time

import gymnasium as gym
from rich.console import Console
from rich.table import Table

from conjure.agents import SARSA, ActorCritic
from conjure.core.schedules import EpisodicDecay
from conjure.domains import GridWorld, InvertedPendulum, from_gymnasium
from conjure.experiments.loop import Stepper, learning_stepper
from conjure.policies import EpsilonGreedy
from conjure.representations import Tabular, TileCoding


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
        "Actor-Critic (V critic, log-policy actor) + Tabular, GridWorld-1 (Fig. 5-5's learner)",
        GridWorld(map_name="gridworld1", step_reward=-0.001, noise=0.3),
        ActorCritic(
            representation=Tabular(),
            step_size=EpisodicDecay(alpha_0=1.0, n_0=100),
            actor_step_size=EpisodicDecay(alpha_0=1.0, n_0=1000),
            critic="v",
            actor_update="log_policy",
        ),
    )
    for trace_decay in (0.0, 0.9):
        yield (
            f"SARSA({trace_decay:g}) + TileCoding(10 tilings of 10x10), MountainCar-v0 via "
            "from_gymnasium",
            from_gymnasium("MountainCar-v0", discount=1.0),
            SARSA(
                representation=TileCoding(num_tilings=10, tiles_per_dim=10),
                policy=EpsilonGreedy(epsilon=0.0),
                step_size=0.1 / 10,
                trace_decay=trace_decay,
            ),
        )


def measure(
    domain, agent, num_steps: int, repeats: int, python: bool = False
) -> tuple[float, float | None, str]:
    """Median steps/s, for a Gymnasium domain the median ratio of its per-step cost to
    Gymnasium's own ``env.step`` timed in alternation with it (``None`` otherwise), and the
    path taken."""
    agent.setup(domain.domain_spec, seed=0)
    if python:
        loop = Stepper(domain, agent, seed=0)
    else:
        loop = learning_stepper(domain, agent, seed=0, budget_steps=num_steps * repeats)
    loop.advance(2_000)  # warm-up: numba compilation or cache loading
    is_gymnasium = hasattr(domain, "env_")
    rates, ratios = [], []
    for _ in range(repeats):
        start = time.perf_counter()
        loop.advance(num_steps)
        rates.append(num_steps / (time.perf_counter() - start))
        if is_gymnasium:
            ratios.append(environment_alone(num_steps) / rates[-1])
    return statistics.median(rates), statistics.median(ratios) if ratios else None, loop.path


def environment_alone(num_steps: int) -> float:
    """Steps/s of ``gymnasium.make("MountainCar-v0")`` alone, action 1, resets included."""
    env = gym.make("MountainCar-v0")
    env.reset(seed=0)
    start = time.perf_counter()
    for _ in range(num_steps):
        _, _, terminated, truncated, _ = env.step(1)
        if terminated or truncated:
            env.reset()
    return num_steps / (time.perf_counter() - start)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=100_000)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--python", action="store_true", help="force the Python path")
    args = parser.parse_args()
    table = Table(title=f"Learning speed (median of {args.repeats} x {args.steps:,} steps)")
    table.add_column("workload")
    table.add_column("path")
    table.add_column("steps/s", justify="right")
    table.add_column("us/step", justify="right")
    table.add_column("x env.step alone", justify="right")
    for name, domain, agent in workloads():
        rate, ratio, path = measure(domain, agent, args.steps, args.repeats, args.python)
        shown = "" if ratio is None else f"{ratio:.2f}"
        table.add_row(name, path, f"{rate:,.0f}", f"{1e6 / rate:.2f}", shown)
    rate = statistics.median(environment_alone(args.steps) for _ in range(args.repeats))
    table.add_row(
        "reference: MountainCar-v0 env.step alone", "", f"{rate:,.0f}", f"{1e6 / rate:.2f}", "1.00"
    )
    Console().print(table)


if __name__ == "__main__":
    main()
