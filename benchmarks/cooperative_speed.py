"""Per-step cost of the cooperative learners (Chapter 5) as a ratio to compiled SARSA.

Usage: ``python benchmarks/cooperative_speed.py [--steps N] [--repeats R]``

Each workload is a shipped reproduction config's agent at the config's base settings (the
selected ones), run through the stepper ``conjure run`` learns with (`learning_stepper`; the
path is shown), one process, after numba's compilation (or cache load). Two costs per step:

- **run**: a whole run of the config's ``budget_steps`` from a fresh agent (seeds 0 .. R − 1,
  median): what a run pays, the first plans of every new state and the iFDD discoveries of
  the early episodes included;
- **window**: ``--steps`` steps after a warm-up of ``--steps`` / 5 (median of R windows of one
  agent): the start of a run, where new states are most frequent; also on the Python path
  (`Stepper`), what the same steps cost without the compiled loop.

Each ratio is that cost over the cost of compiled SARSA + tabular on GridWorld-1
(`fig_5_8.yaml`'s ``sarsa``) timed in alternation with it, so both see the same machine
(absolute speeds vary between machines; the targets are ratios of the run cost):

=====================================================================  ===========  ======
workload (config, agent label)                                          before       target
=====================================================================  ===========  ======
cooperative actor-critic, GridWorld-1 (``fig_5_5.yaml``, ``icca``)      35x          ≤ 4x
CSARSA + fuel risk + CBBA, UAV 7-2 5% (``fig_5_9_13.yaml``, ``csarsa``)  73x          ≤ 12x
AM-iCCA + Monte-Carlo risk, UAV 7-2 5% (``fig_5_9_13.yaml``, ``am_icca``) 146x        ≤ 35x
CSARSA + iFDD⁺, UAV 10-2 5% (``ifdd_csarsa.yaml``, ``csarsa_ifdd``)     148x         ≤ 35x
=====================================================================  ===========  ======

and, beside them, CSARSA on GridWorld-1 (``fig_5_8.yaml``, ``csarsa``: Algorithm 24's box),
Fig. 5-6's iCCA, whose advantage actor-critic has eligibility traces (``fig_5_6.yaml``,
``icca``), and the grid-world boxes with Algorithm 25's rollouts of Figs. 5-12 and 5-14
(``icca`` and ``am_icca`` on GridWorld-2, ``am_icca_switch_off`` on GridWorld-3).
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

from rich.console import Console
from rich.table import Table

from conjure.experiments.config import build_components, load_yaml, parse_config
from conjure.experiments.loop import Stepper, learning_stepper

ROOT = Path(__file__).resolve().parents[1] / "examples" / "reproduction"
#: The reference: compiled SARSA + tabular on GridWorld-1.
REFERENCE = ("fig_5_8.yaml", "sarsa")
WORKLOADS = (
    ("cooperative actor-critic, GridWorld-1", "fig_5_5.yaml", "icca", 4.0),
    ("CSARSA + nominal risk + VI, GridWorld-1", "fig_5_8.yaml", "csarsa", None),
    ("CSARSA + fuel risk + CBBA, UAV 7-2 5%", "fig_5_9_13.yaml", "csarsa", 12.0),
    ("AM-iCCA + Monte-Carlo risk, UAV 7-2 5%", "fig_5_9_13.yaml", "am_icca", 35.0),
    ("CSARSA + iFDD⁺, UAV 10-2 5%", "ifdd_csarsa.yaml", "csarsa_ifdd", 35.0),
    ("iCCA with eligibility traces, UAV 7-2", "fig_5_6.yaml", "icca", None),
    ("iCCA + Monte-Carlo risk (static model), GridWorld-2", "fig_5_12.yaml", "icca", None),
    ("AM-iCCA + Monte-Carlo risk, GridWorld-2", "fig_5_12.yaml", "am_icca", None),
    ("AM-iCCA, check off when trusted, GridWorld-3", "fig_5_14.yaml", "am_icca_switch_off", None),
)
#: The sweep-only keys of a reproduction config; the rest is an experiment at base settings.
SWEEP_KEYS = ("grid", "selection")


def _experiment(config_name: str):
    data = load_yaml((ROOT / config_name).read_text(), source=config_name)
    for key in SWEEP_KEYS:
        data.pop(key, None)
    return parse_config(data, source=config_name)


def stepper_for(config_name: str, label: str, steps: int, seed: int = 0, python: bool = False):
    """The run's stepper for ``label`` of a shipped config at its base settings, warmed up.

    ``python``: the Python `Stepper` instead (what the run would cost without the compiled
    path).
    """
    domain, agents = build_components(_experiment(config_name))
    agent = agents[label].setup(domain.domain_spec, seed=seed)
    if python:
        stepper = Stepper(domain, agent, seed=seed)
    else:
        stepper = learning_stepper(domain, agent, seed=seed, budget_steps=10**9)
    stepper.advance(steps)
    return stepper


def seconds_per_step(stepper, steps: int) -> float:
    started = time.perf_counter()
    stepper.advance(steps)
    return (time.perf_counter() - started) / steps


def run_cost(config_name: str, label: str, seed: int) -> float:
    """Seconds per step of a whole run (the config's budget) from a fresh agent."""
    budget = _experiment(config_name).budget_steps
    return seconds_per_step(stepper_for(config_name, label, 0, seed), budget)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=20_000)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    reference = stepper_for(*REFERENCE, 20 * args.steps)

    def reference_cost() -> float:
        return seconds_per_step(reference, 100 * args.steps)

    table = Table(title=f"Cooperative learners, median of {args.repeats} (window: {args.steps:,})")
    columns = ("workload", "config, agent", "path", "us/step run", "ratio run", "target",
               "us/step window", "ratio window", "us/step window, Python path")  # fmt: skip
    for column in columns:
        table.add_column(column, justify="left" if column in ("workload", "path") else "right")
    for name, config_name, label, target in WORKLOADS:
        stepper = stepper_for(config_name, label, args.steps // 5)
        python = stepper_for(config_name, label, args.steps // 5, python=True)
        window, window_ratios, run, run_ratios, python_window = [], [], [], [], []
        for seed in range(args.repeats):
            window.append(seconds_per_step(stepper, args.steps))
            python_window.append(seconds_per_step(python, args.steps))
            window_ratios.append(window[-1] / reference_cost())
            run.append(run_cost(config_name, label, seed))
            run_ratios.append(run[-1] / reference_cost())
        table.add_row(
            name,
            f"{config_name}, {label}",
            stepper.path.split(":")[0],
            f"{1e6 * statistics.median(run):.2f}",
            f"{statistics.median(run_ratios):.0f}x",
            "" if target is None else f"≤ {target:g}x",
            f"{1e6 * statistics.median(window):.2f}",
            f"{statistics.median(window_ratios):.0f}x",
            f"{1e6 * statistics.median(python_window):.1f}",
        )
    cost = statistics.median(reference_cost() for _ in range(3))
    table.add_row(
        "reference: compiled SARSA + tabular, GridWorld-1",
        f"{REFERENCE[0]}, {REFERENCE[1]}",
        reference.path,
        "",
        "",
        "",
        f"{1e6 * cost:.2f}",
        "1x",
        "",
    )
    Console(width=180).print(table)


if __name__ == "__main__":
    main()
