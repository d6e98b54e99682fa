"""Per-step cost of the cooperative learners on the Python path (Algorithms 23, 24, 26).

Usage: ``python benchmarks/python_box_speed.py [--steps N] [--repeats R]``

Prints the CPU model and the load average beside every figure (the machine may be shared).
Each workload is a shipped reproduction config's agent at its base settings
(`cooperative_speed.py`), stepped by the Python `Stepper` (never the compiled loop): after a
warm-up of ``--steps`` / 5 steps, R windows of ``--steps`` learning steps of one agent,
median steps/s and µs/step; then `profile_steps` (timers around every call, so slower) gives
the µs per ``act`` and ``learn`` call (median over seeds 0 .. R − 1). Run it at two commits
to see what a change to the box's Python ``act`` / ``learn`` costs per step.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
from pathlib import Path

from rich.console import Console
from rich.table import Table

sys.path.insert(0, str(Path(__file__).resolve().parent))

from call_cost import WORKLOADS as CALL_COST_WORKLOADS
from call_cost import cpu_model, python_call_cost
from cooperative_speed import seconds_per_step, stepper_for

#: (name, config, agent label): `call_cost.py`'s cooperative workloads, and GridWorld-2's AM-iCCA.
WORKLOADS = (
    *(workload for workload in CALL_COST_WORKLOADS if workload[2] not in (None, "sarsa")),
    ("AM-iCCA + Monte-Carlo risk, GridWorld-2", "fig_5_12.yaml", "am_icca"),
)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=5_000)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    console = Console(width=160)
    console.print(f"CPU: {cpu_model()}; load average at start: {os.getloadavg()}")
    table = Table(title=f"Python path, median of {args.repeats} (window: {args.steps:,} steps)")
    columns = ("workload", "config, agent", "steps/s", "µs/step", "act µs", "learn µs")
    for column in columns:
        table.add_column(column, justify="left" if column == "workload" else "right")
    for name, config_name, label in WORKLOADS:
        stepper = stepper_for(config_name, label, args.steps // 5, python=True)
        per_step = statistics.median(
            seconds_per_step(stepper, args.steps) for _ in range(args.repeats)
        )
        calls = python_call_cost(config_name, label, args.steps, args.repeats)
        table.add_row(
            name,
            f"{config_name}, {label}",
            f"{1 / per_step:,.0f}",
            f"{1e6 * per_step:.2f}",
            f"{calls['act_us']:.2f}",
            f"{calls['learn_us']:.2f}",
        )
    console.print(table)
    console.print(f"CPU: {cpu_model()}; load average at end: {os.getloadavg()}")


if __name__ == "__main__":
    main()
