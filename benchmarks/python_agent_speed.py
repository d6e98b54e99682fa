"""Microseconds per Python-path ``act`` and ``learn`` call of the TD learners and Actor-Critic.

Usage: ``python benchmarks/python_agent_speed.py [--steps N] [--repeats R]``

Each workload learns for ``--steps`` steps through `profile_steps` (a timed learning
`Stepper`, a timer around every call) after a warm-up run of the same length (numba
compilation excluded); the figures are the medians over ``--repeats`` seeds, and the fastest
seed's (less disturbed by other processes on a shared machine). A last column times ``learn``
alone on one transition repeated (the first two states of a seeded episode, φ and Q cached by
``act``; reward 0, so θ stays 0 whatever α and nothing diverges or is discovered): the least
mean over 7 batches of 5,000 calls, the figure least moved by other processes. Prints the CPU
model and the load average beside them.

Workloads: SARSA, SARSA(λ) with replacing and accumulating traces, Q-Learning (Algorithms 10,
11) with tile coding on InvertedPendulum, SARSA with online iFDD on GridWorld-1; Actor-Critic
(Algorithm 12) with a Q or V critic, the features or log-policy actor, λ traces and an actor on
its own features, tabular on GridWorld-1.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from pathlib import Path

from rich.console import Console
from rich.table import Table

sys.path.insert(0, str(Path(__file__).resolve().parent))

from call_cost import cpu_model

from conjure.agents import SARSA, ActorCritic, QLearning
from conjure.core.interfaces import Transition
from conjure.domains import GridWorld, InvertedPendulum
from conjure.experiments.loop import profile_steps
from conjure.representations import IndependentDiscretization, OnlineIFDD, Tabular, TileCoding


def _tiles() -> TileCoding:
    return TileCoding(num_tilings=8, tiles_per_dim=10)


def _grid() -> GridWorld:
    return GridWorld(map_name="gridworld1", step_reward=-0.001, noise=0.3)


WORKLOADS = {
    "SARSA + tiles, InvertedPendulum": (InvertedPendulum, lambda: SARSA(representation=_tiles())),
    "SARSA(0.9) replacing + tiles, InvertedPendulum": (
        InvertedPendulum,
        lambda: SARSA(representation=_tiles(), trace_decay=0.9),
    ),
    "SARSA(0.9) accumulating + tiles, InvertedPendulum": (
        InvertedPendulum,
        lambda: SARSA(representation=_tiles(), trace_decay=0.9, trace_kind="accumulating"),
    ),
    "Q-Learning + tiles, InvertedPendulum": (
        InvertedPendulum,
        lambda: QLearning(representation=_tiles()),
    ),
    "SARSA + online iFDD, GridWorld-1": (
        _grid,
        lambda: SARSA(
            representation=OnlineIFDD(base=IndependentDiscretization(), discovery_threshold=0.1)
        ),
    ),
    "Actor-Critic (Q critic) + tabular, GridWorld-1": (
        _grid,
        lambda: ActorCritic(representation=Tabular()),
    ),
    "Actor-Critic (V, log-policy) + tabular, GridWorld-1": (
        _grid,
        lambda: ActorCritic(representation=Tabular(), critic="v", actor_update="log_policy"),
    ),
    "Actor-Critic (V, log-policy, λ=1) + tabular, GridWorld-1": (
        _grid,
        lambda: ActorCritic(
            representation=Tabular(), critic="v", actor_update="log_policy", trace_decay=1.0
        ),
    ),
    "Actor-Critic, actor on its own features, GridWorld-1": (
        _grid,
        lambda: ActorCritic(
            representation=Tabular(), actor_representation=IndependentDiscretization()
        ),
    ),
}


def per_call(make_domain, make_agent, steps: int, repeats: int) -> dict[str, float]:
    """Median and least µs per ``act`` and ``learn`` call over ``repeats`` seeds (warmed up)."""
    samples = []
    for seed in range(repeats + 1):
        domain = make_domain()
        agent = make_agent().setup(domain.domain_spec, seed=seed)
        profiled = profile_steps(domain, agent, num_steps=steps, seed=seed)
        if seed > 0:  # the first run compiles the kernels
            samples.append(profiled)
    keys = ("act_us", "learn_us")
    figures = {key: statistics.median(s[key] for s in samples) for key in keys}
    return figures | {f"least_{key}": min(s[key] for s in samples) for key in keys}


def repeated_learn_us(make_domain, make_agent, calls: int = 5_000, batches: int = 7) -> float:
    """The least mean µs of ``learn`` over ``batches`` batches of one transition repeated."""
    domain = make_domain()
    agent = make_agent().setup(domain.domain_spec, seed=0)
    agent.begin_episode()
    state = domain.reset(seed=0)[0]
    action = agent.act(state)
    next_state = domain.step(action)[0]
    transition = Transition(state, action, 0.0, next_state, agent.act(next_state), False)
    agent.learn(transition)  # compiles (or loads) the kernels
    least = float("inf")
    for _ in range(batches):
        started = time.perf_counter()
        for _ in range(calls):
            agent.learn(transition)
        least = min(least, (time.perf_counter() - started) / calls)
    return 1e6 * least


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=20_000)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    console = Console(width=160)
    console.print(f"CPU: {cpu_model()}; load average at start: {os.getloadavg()}")
    table = Table(title=f"Python path, µs per call, median of {args.repeats} runs of {args.steps}")
    columns = ("workload", "act µs", "learn µs", "least act µs", "least learn µs", "learn alone µs")
    for column in columns:
        table.add_column(column, justify="left" if column == "workload" else "right")
    keys = ("act_us", "learn_us", "least_act_us", "least_learn_us")
    for name, (make_domain, make_agent) in WORKLOADS.items():
        figures = per_call(make_domain, make_agent, args.steps, args.repeats)
        alone = repeated_learn_us(make_domain, make_agent)
        table.add_row(name, *(f"{figures[key]:.2f}" for key in keys), f"{alone:.2f}")
    console.print(table)
    console.print(f"CPU: {cpu_model()}; load average at end: {os.getloadavg()}")


if __name__ == "__main__":
    main()
