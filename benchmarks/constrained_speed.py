"""A constrained learner's compiled step against the same learner's without the constraint.

Usage: ``python benchmarks/constrained_speed.py [--steps N] [--repeats R]``

Workloads (`WORKLOADS`): SARSA + tile coding on the inverted pendulum (every episode ends in a
fall, so λ moves every episode), SARSA and Q-Learning + a table on GridWorld-1 and the
advantage actor-critic (V critic, log-policy actor) on GridWorld-1, each plain and with each
`conjure.agents.constraints` rule (`Lagrangian`, `PIDLagrangian`). Every learner runs
``steps`` learning steps through `conjure.compiled.for_combination` (warm kernels: a short
run compiles first), interleaved repeat by repeat; the median µs per step and its ratio to
the plain learner's are printed with the CPU model and the load average (the machine may be
shared).
"""

from __future__ import annotations

import argparse
import os
import statistics
import time
from collections.abc import Callable

from call_cost import cpu_model
from rich.console import Console
from rich.table import Table

from conjure.agents import SARSA, ActorCritic, QLearning
from conjure.agents.constraints import CostConstraint, Lagrangian, PIDLagrangian
from conjure.compiled import for_combination
from conjure.domains import GridWorld, InvertedPendulum
from conjure.policies import Gibbs
from conjure.representations import Tabular, TileCoding

RULES: dict[str, Callable[[], CostConstraint | None]] = {
    "plain": lambda: None,
    "Lagrangian": lambda: Lagrangian(cost_limit=0.1),
    "PID-Lagrangian": lambda: PIDLagrangian(cost_limit=0.1, kp=0.5, ki=0.2, kd=0.1),
}
WORKLOADS: dict[str, tuple[Callable, Callable]] = {
    "pendulum SARSA + tiles": (
        InvertedPendulum,
        lambda c: SARSA(
            representation=TileCoding(num_tilings=8, tiles_per_dim=10), step_size=0.05, constraint=c
        ),
    ),
    "GridWorld-1 SARSA + table": (
        GridWorld.gridworld_1,
        lambda c: SARSA(representation=Tabular(), step_size=0.5, constraint=c),
    ),
    "GridWorld-1 Q-Learning + table": (
        GridWorld.gridworld_1,
        lambda c: QLearning(representation=Tabular(), step_size=0.5, constraint=c),
    ),
    "GridWorld-1 advantage actor-critic": (
        GridWorld.gridworld_1,
        lambda c: ActorCritic(
            representation=Tabular(),
            step_size=0.5,
            critic="v",
            actor_update="log_policy",
            policy=Gibbs(),
            constraint=c,
        ),
    ),
}


def seconds_per_step(workload: str, rule: str, steps: int, seed: int = 0) -> float:
    """One compiled run of ``steps`` learning steps (set-up excluded); seconds per step."""
    make_domain, make_agent = WORKLOADS[workload]
    domain = make_domain()
    agent = make_agent(RULES[rule]()).setup(domain.domain_spec, seed)
    stepper = for_combination(domain, agent, seed=seed)
    stepper.advance(100)  # the kernel loaded (from the cache or compiled) and the first call
    started = time.perf_counter()
    stepper.advance(steps)
    return (time.perf_counter() - started) / steps


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=200_000)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    console = Console(width=150)
    console.print(f"CPU: {cpu_model()}; load average at start: {os.getloadavg()}")
    for workload in WORKLOADS:  # warm every kernel before timing
        for rule in RULES:
            seconds_per_step(workload, rule, 1_000)
    times = {(w, r): [] for w in WORKLOADS for r in RULES}
    for _ in range(args.repeats):
        for workload in WORKLOADS:
            for rule in RULES:
                times[workload, rule].append(seconds_per_step(workload, rule, args.steps))
    table = Table(title=f"Compiled learning step, median of {args.repeats} x {args.steps:,}")
    table.add_column("workload")
    for rule in RULES:
        table.add_column(f"{rule} µs/step", justify="right")
    for rule in list(RULES)[1:]:
        table.add_column(f"{rule} / plain", justify="right")
    for workload in WORKLOADS:
        medians = {r: statistics.median(times[workload, r]) * 1e6 for r in RULES}
        ratios = [f"{medians[r] / medians['plain']:.2f}x" for r in list(RULES)[1:]]
        table.add_row(workload, *(f"{medians[r]:.3f}" for r in RULES), *ratios)
    console.print(table)
    console.print(f"CPU: {cpu_model()}; load average at end: {os.getloadavg()}")


if __name__ == "__main__":
    main()
