"""The safe-RL comparison across its three domains: interval estimates, improvement, profiles.

    python docs/reproduction/safe_rl.py compute         # stored finals -> CSVs and plots
    python docs/reproduction/safe_rl.py render [--check]

``compute`` reads the stored finals of the three ``safe_rl_*`` figures
(docs/reproduction/chapter5/FIGURE_finals.csv, written by ``figures.py store``) and writes:

- ``chapter5/safe_rl_summary.csv``: per domain and method, the final return's IQM with its 95%
  stratified-bootstrap interval, the final episodic cost (mean) and the share of runs within
  the cost limit d, the cost while learning (mean Σ c_t over the learning steps) and the
  return per unit of cost while learning (mean final return / mean cost while learning);
- ``chapter5/safe_rl_improvement.csv``: per domain, P(X > Y) of the best cooperative learner
  X (by mean final return) over every other method Y, on the final return and on the cost
  while learning (lower is better, so P(X's cost < Y's)), each with its 95% interval;
- ``chapter5/safe_rl_profiles.csv``: performance profiles of the final return on one scale
  (UAV 7-2's optimality, a GridWorld's (r + 1) / 2: `normalized`) of the methods present on
  all three domains, the domains as tasks;
- ``safe_rl_return_vs_cost.png`` (final return against cost while learning, per domain) and
  ``safe_rl_profiles.png``.

All statistics are rliable's (`conjure.reporting.statistics`, 2,000 resamples, seed 0).
``render`` rewrites the block between ``<!-- safe_rl -->`` and ``<!-- /safe_rl -->`` of
docs/reproduction/safe_rl.md from those CSVs; ``--check`` changes nothing and exits 1 when the
page differs (tests/test_reproduction_docs.py runs it).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from conjure.experiments.numbers import format_estimate, format_number
from conjure.reporting.plots import plot_performance_profiles
from conjure.reporting.statistics import (
    iqm_interval,
    performance_profile,
    probability_of_improvement,
)

HERE = Path(__file__).resolve().parent
STORE = HERE / "chapter5"
PAGE = HERE / "safe_rl.md"
#: Each domain's cost limit d and its heading (the configs' selection.cost_limit).
DOMAINS = {
    "safe_rl_gridworld_1": ("GridWorld-1", 0.15),
    "safe_rl_gridworld_2": ("GridWorld-2", 0.05),
    "safe_rl_uav_7_2": ("UAV 7-2, 5% failures", 0.1),
}
#: The figures whose runs the statistics pool (`conjure reproduce safe_rl` also runs the 1e5 check).
FIGURES = tuple(DOMAINS)
#: iCCA's boxes: the best of them by final return is X in the improvement table.
COOPERATIVE = ("csarsa", "icca", "am_icca")
SUMMARY, IMPROVEMENT, PROFILES = (
    STORE / "safe_rl_summary.csv",
    STORE / "safe_rl_improvement.csv",
    STORE / "safe_rl_profiles.csv",
)
START, END = "<!-- safe_rl -->", "<!-- /safe_rl -->"


def finals(figure: str) -> pd.DataFrame:
    """A figure's stored finals (one row per method and seed)."""
    return pd.read_csv(STORE / f"{figure}_finals.csv")


def summary_rows(figure: str) -> list[dict]:
    """Per method: IQM of the final return, costs against d, return per unit of cost."""
    domain, limit = DOMAINS[figure]
    rows = []
    for label, runs in finals(figure).groupby("label", sort=False):
        iqm, low, high = iqm_interval(runs["return"].to_numpy())
        learning_cost = float(runs["learning_cost"].mean())
        rows.append(
            {
                "domain": domain,
                "method": label,
                "runs": len(runs),
                "return_iqm": iqm,
                "return_low": low,
                "return_high": high,
                "episode_cost": float(runs["episode_cost"].mean()),
                "cost_limit": limit,
                "within_limit": float((runs["episode_cost"] <= limit).mean()),
                "learning_cost": learning_cost,
                "return_per_cost": float(runs["return"].mean()) / learning_cost
                if learning_cost > 0
                else np.nan,
            }
        )
    return rows


def improvement_rows(figure: str) -> list[dict]:
    """P(X > Y) of the best cooperative learner X over every other method Y."""
    frame = finals(figure)
    labels = list(dict.fromkeys(frame["label"]))
    boxes = [label for label in labels if label in COOPERATIVE]
    best = max(boxes, key=lambda label: frame.loc[frame["label"] == label, "return"].mean())
    rows = []
    for other in labels:
        if other == best:
            continue
        x, y = (frame.loc[frame["label"] == label] for label in (best, other))
        ret = probability_of_improvement(x["return"].to_numpy(), y["return"].to_numpy())
        cost = probability_of_improvement(
            -x["learning_cost"].to_numpy(), -y["learning_cost"].to_numpy()
        )
        rows.append(
            {
                "domain": DOMAINS[figure][0],
                "x": best,
                "y": other,
                "higher_return": ret[0],
                "higher_return_low": ret[1],
                "higher_return_high": ret[2],
                "lower_cost": cost[0],
                "lower_cost_low": cost[1],
                "lower_cost_high": cost[2],
            }
        )
    return rows


def normalized(frame: pd.DataFrame) -> pd.Series:
    """The final return on one scale: the run's optimality, or (r + 1) / 2 on a GridWorld.

    A GridWorld declares no value bounds (its optimality is NaN); its returns run from −1 (a
    pit at once) to +1 (the goal at once), which (r + 1) / 2 maps onto [0, 1].
    """
    if frame["optimality"].notna().all():
        return frame["optimality"]
    return (frame["return"] + 1.0) / 2.0


def profiles() -> pd.DataFrame:
    """Performance profiles of the final return on one scale (`normalized`), domains as tasks."""
    frames = [finals(figure) for figure in FIGURES]
    common = [
        label
        for label in dict.fromkeys(frames[0]["label"])
        if all(label in set(frame["label"]) for frame in frames)
    ]
    scores = {}
    for label in common:
        columns = [normalized(frame.loc[frame["label"] == label]).to_numpy() for frame in frames]
        runs = min(len(column) for column in columns)
        scores[label] = np.column_stack([column[:runs] for column in columns])
    return performance_profile(scores, np.linspace(0.0, 1.0, 41))


def plot_return_vs_cost(summary: pd.DataFrame, path: Path) -> None:
    """Final return (IQM, 95% interval) against the mean cost while learning, per domain."""
    figure = Figure(figsize=(15, 4.8), dpi=110)
    FigureCanvasAgg(figure)
    for i, (domain, rows) in enumerate(summary.groupby("domain", sort=False)):
        axes = figure.add_subplot(1, len(DOMAINS), i + 1)
        for j, row in enumerate(rows.itertuples()):
            error = [[row.return_iqm - row.return_low], [row.return_high - row.return_iqm]]
            axes.errorbar(row.learning_cost, row.return_iqm, yerr=error, fmt="o", color=f"C{j}")
            axes.annotate(row.method, (row.learning_cost, row.return_iqm), fontsize=7,
                          xytext=(4, 4), textcoords="offset points")  # fmt: skip
        axes.set_xscale("symlog")
        axes.set_xlabel("cost while learning (failures, mean over runs)")
        axes.set_ylabel("final return (IQM, 95% interval)")
        axes.set_title(domain)
    figure.tight_layout()
    figure.savefig(path)


def compute() -> None:
    """Write the three CSVs and two plots from the stored finals."""
    summary = pd.DataFrame([row for figure in FIGURES for row in summary_rows(figure)])
    summary.to_csv(SUMMARY, index=False)
    improvement = pd.DataFrame([row for figure in FIGURES for row in improvement_rows(figure)])
    improvement.to_csv(IMPROVEMENT, index=False)
    table = profiles()
    table.to_csv(PROFILES, index=False)
    plot_return_vs_cost(summary, HERE / "safe_rl_return_vs_cost.png")
    plot_performance_profiles(
        table, HERE / "safe_rl_profiles.png", score="final return on [0, 1]",
        title="Performance profiles over GridWorld-1, GridWorld-2 and UAV 7-2",
    )  # fmt: skip
    print(f"wrote {SUMMARY.name}, {IMPROVEMENT.name}, {PROFILES.name} and two plots")


def block() -> str:
    """The page's generated text: the summary and the improvement tables, the plots."""
    summary, improvement = pd.read_csv(SUMMARY), pd.read_csv(IMPROVEMENT)
    lines = []
    for domain, rows in summary.groupby("domain", sort=False):
        limit = rows["cost_limit"].iloc[0]
        lines += [
            f"### {domain} (d = {limit:g})",
            "",
            "| method | runs | final return, IQM [95%] | final episodic cost | runs within d "
            "| cost while learning | return per unit of cost while learning |",
            "|---|---|---|---|---|---|---|",
        ]
        for row in rows.itertuples():
            lines.append(
                f"| {row.method} | {row.runs} | "
                f"{format_estimate(row.return_iqm, row.return_low, row.return_high)} | "
                f"{format_number(row.episode_cost)} | {row.within_limit:.0%} | "
                f"{format_number(row.learning_cost)} | {format_number(row.return_per_cost)} |"
            )
        chosen = improvement[improvement["domain"] == domain]
        lines += [
            "",
            f"P(X > Y) for X = {chosen['x'].iloc[0]}, the best cooperative learner by final "
            "return:",
            "",
            "| Y | P(X's final return > Y's) [95%] | P(X's cost while learning < Y's) [95%] |",
            "|---|---|---|",
        ]
        for row in chosen.itertuples():
            higher = format_estimate(
                row.higher_return, row.higher_return_low, row.higher_return_high
            )
            lower = format_estimate(row.lower_cost, row.lower_cost_low, row.lower_cost_high)
            lines.append(f"| {row.y} | {higher} | {lower} |")
        lines.append("")
    lines += [
        "![Final return against cost while learning](safe_rl_return_vs_cost.png)",
        "",
        "![Performance profiles of the final return on [0, 1]](safe_rl_profiles.png)",
    ]
    return "\n".join(lines)


def render(check: bool) -> int:
    """Rewrite the page's block (or, with ``check``, say whether it is up to date)."""
    text = PAGE.read_text()
    head, rest = text.split(START, 1)
    _, tail = rest.split(END, 1)
    new = f"{head}{START}\n{block()}\n{END}{tail}"
    if new == text:
        print(f"{PAGE.name} equals what the stored CSVs give")
        return 0
    if check:
        print(f"{PAGE} differs from the stored CSVs; run `python {Path(__file__).name} render`.")
        return 1
    PAGE.write_text(new)
    print(f"rewrote {PAGE.name} from the stored CSVs")
    return 0


def main() -> None:
    """``compute`` or ``render [--check]`` (the module docstring)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("command", choices=("compute", "render"))
    parser.add_argument("--check", action="store_true")
    args = parser.parse_args()
    if args.command == "compute":
        compute()
        sys.exit(0)
    sys.exit(render(args.check))


if __name__ == "__main__":
    main()
