"""The fixed cost of one compiled call, and the Python path's per-call `act` / `learn` cost.

Usage: ``python benchmarks/call_cost.py [--calls N] [--steps S] [--repeats R]``

Prints the CPU model and the load average beside every figure (the machine may be shared).

- **fixed cost of one compiled call** (issue 33's target: at most 20 µs): a warm compiled
  stepper's ``advance(1)`` (one kernel call of one step, with everything the stepper packs
  around it and the counters it writes back), minus one step of that stepper's ``advance(S)``
  (the per-step cost of long calls). Median of ``--repeats`` batches of ``--calls`` calls.
- **Python path**: `profile_steps` (a timed learning `Stepper`) over ``--steps`` steps: the
  microseconds per call of ``act`` and ``learn`` (issue 33's target: at most 20% above the
  figures before its refactor).

Workloads: SARSA + TileCoding (8 x 10x10) on the inverted pendulum (`benchmarks/compiled_loop.py`'s
agent), and shipped reproduction configs at their base settings (`cooperative_speed.py`).
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

from compiled_loop import make_agent
from cooperative_speed import _experiment

from conjure.domains import InvertedPendulum
from conjure.experiments.config import build_components
from conjure.experiments.loop import learning_stepper, profile_steps

#: (name, config, agent label); None: the pendulum SARSA + tiles agent.
WORKLOADS = (
    ("SARSA + tiles, InvertedPendulum", None, None),
    ("SARSA + tabular, GridWorld-1", "fig_5_8.yaml", "sarsa"),
    ("cooperative actor-critic (iCCA), GridWorld-1", "fig_5_5.yaml", "icca"),
    ("CSARSA + nominal risk + VI, GridWorld-1", "fig_5_8.yaml", "csarsa"),
    ("CSARSA + fuel risk + CBBA, UAV 7-2 5%", "fig_5_9_13.yaml", "csarsa"),
    ("AM-iCCA + Monte-Carlo risk, UAV 7-2 5%", "fig_5_9_13.yaml", "am_icca"),
)


def cpu_model() -> str:
    """The ``model name`` of /proc/cpuinfo (the platform's processor string elsewhere)."""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    import platform

    return platform.processor() or "unknown"


def components(config_name: str | None, label: str | None, seed: int = 0):
    """A set-up (domain, agent) of one workload."""
    if config_name is None:
        domain = InvertedPendulum()
        return domain, make_agent("tiles").setup(domain.domain_spec, seed=seed)
    domain, agents = build_components(_experiment(config_name))
    return domain, agents[label].setup(domain.domain_spec, seed=seed)


def fixed_call_cost(config_name, label, calls: int, steps: int, repeats: int) -> tuple[float, str]:
    """Median µs of one compiled call beyond its one step, and the stepper's path."""
    domain, agent = components(config_name, label)
    stepper = learning_stepper(domain, agent, seed=0, budget_steps=10**9)
    stepper.advance(steps)  # compile (or load the cache), then warm the tables
    costs = []
    for _ in range(repeats):
        started = time.perf_counter()
        stepper.advance(steps)
        per_step = (time.perf_counter() - started) / steps
        started = time.perf_counter()
        for _ in range(calls):
            stepper.advance(1)
        per_call = (time.perf_counter() - started) / calls
        costs.append(per_call - per_step)
    return 1e6 * statistics.median(costs), stepper.path.split(":")[0]


def python_call_cost(config_name, label, steps: int, repeats: int) -> dict[str, float]:
    """Median µs per call of ``act`` and ``learn`` on the Python path."""
    samples = []
    for seed in range(repeats):
        domain, agent = components(config_name, label, seed)
        samples.append(profile_steps(domain, agent, num_steps=steps, seed=seed))
    return {key: statistics.median(s[key] for s in samples) for key in ("act_us", "learn_us")}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--calls", type=int, default=2_000)
    parser.add_argument("--steps", type=int, default=20_000)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    console = Console(width=160)
    console.print(f"CPU: {cpu_model()}; load average at start: {os.getloadavg()}")
    table = Table(title=f"Per-call costs, median of {args.repeats}")
    columns = ("workload", "path", "fixed µs per compiled call", "python act µs", "python learn µs")
    for column in columns:
        table.add_column(column, justify="left" if column in ("workload", "path") else "right")
    for name, config_name, label in WORKLOADS:
        fixed, path = fixed_call_cost(config_name, label, args.calls, args.steps, args.repeats)
        python = python_call_cost(config_name, label, args.steps, args.repeats)
        table.add_row(
            name, path, f"{fixed:.1f}", f"{python['act_us']:.2f}", f"{python['learn_us']:.2f}"
        )
    console.print(table)
    console.print(f"CPU: {cpu_model()}; load average at end: {os.getloadavg()}")


if __name__ == "__main__":
    main()
