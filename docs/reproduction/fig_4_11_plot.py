"""Fig. 4-11's layout from the sweep's results.parquet (written by `conjure report`).

    python docs/reproduction/fig_4_11_plot.py /tmp/repro/fig_4_11 docs/reproduction/fig_4_11.png
    python docs/reproduction/fig_4_11_plot.py docs/reproduction/fig_4_11.csv \
        docs/reproduction/fig_4_11.png     # again from the table the first form wrote

x: initial tiles per dimension; y: steps balanced by the greedy policy after 10,000, 20,000
and 100,000 learning steps (mean over seeds, 95% t-interval cut at [0, 3,000]: no episode
balances longer than the cap), one panel per checkpoint, the legend beside the panels. The
first form also writes the table next to the PNG as CSV.
"""

import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
from scipy import stats

TILE_COLUMNS = (
    "agent.representation.initial_tiles_per_dim",
    "agent.representation.base.num_buckets",
    "agent.representation.num_buckets",
)
STEPS = (10000, 20000, 100000)
#: The pendulum's episode cap (steps balanced).
CAP = 3000


def main() -> None:
    """Write the Fig. 4-11 plot and its table."""
    results, png = Path(sys.argv[1]), Path(sys.argv[2])
    table = pd.read_csv(results) if results.suffix == ".csv" else tabulate(results, png)
    plot(table, png)


def tabulate(results: Path, png: Path) -> pd.DataFrame:
    """The mean and 95% t half-width per label, tile count and checkpoint; written as CSV."""
    frame = pd.read_parquet(results / "results.parquet")
    tiles = np.full(len(frame), np.nan)
    for column in TILE_COLUMNS:  # ARiFDD first: its base has no num_buckets column
        if column in frame.columns:
            values = pd.to_numeric(frame[column], errors="coerce").to_numpy()
            tiles = np.where(np.isnan(tiles), values, tiles)
    frame = frame.assign(tiles=tiles.astype(int))
    rows = []
    for (label, tile, step), group in frame[frame["learning_steps"].isin(STEPS)].groupby(
        ["label", "tiles", "learning_steps"]
    ):
        v = group["episode_length"].to_numpy(dtype=float)
        half = stats.t.ppf(0.975, len(v) - 1) * v.std(ddof=1) / np.sqrt(len(v))
        rows.append(
            {
                "label": label,
                "tiles": tile,
                "steps": step,
                "mean": v.mean(),
                "ci95": half,
                "n": len(v),
            }
        )
    table = pd.DataFrame(rows)
    table.to_csv(png.with_suffix(".csv"), index=False)
    return table


def plot(table: pd.DataFrame, png: Path) -> None:
    """Draw the three panels and print the table."""
    fig, axes = plt.subplots(1, len(STEPS), figsize=(13, 3.8), sharey=True)
    for ax, step in zip(axes, STEPS, strict=True):
        for i, label in enumerate(["arifdd", "ifdd", "initial", "tabular"]):
            part = table[(table["label"] == label) & (table["steps"] == step)].sort_values("tiles")
            low = part["mean"] - np.clip(part["mean"] - part["ci95"], 0, CAP)
            high = np.clip(part["mean"] + part["ci95"], 0, CAP) - part["mean"]
            ax.errorbar(
                part["tiles"] + (i - 1.5) * 0.08,
                part["mean"],
                yerr=[low, high],
                marker="o",
                capsize=3,
                label=label,
            )
        ax.set_title(f"after {step:,} steps")
        ax.set_xlabel("initial tiles per dimension")
    axes[0].set_ylabel("steps balanced (cap 3,000)")
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="center right")
    n = int(table["n"].min())
    fig.suptitle(
        f"Fig. 4-11: SARSA on the inverted pendulum ({n} seeds, 95% t-intervals cut at 3,000)"
    )
    fig.tight_layout(rect=(0, 0, 0.92, 1))
    fig.savefig(png, dpi=100)
    print(
        table.pivot_table(index=["label", "tiles"], columns="steps", values=["mean", "ci95"])
        .round(0)
        .to_string()
    )


if __name__ == "__main__":
    main()
