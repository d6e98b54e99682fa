"""Learning-curve plots: mean over seeds with a shaded 95% Student-t band, one line per label.

Matplotlib's headless Agg backend is used through the object API (no pyplot state), so plots
work on servers and in worker processes.
"""

from __future__ import annotations

from pathlib import Path

import pandas as pd
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from conjure.core.errors import InvalidParameterError
from conjure.experiments.results import RESULTS_FILE, has_finite_values, t_confidence

__all__ = ["METRIC_LABELS", "plot_learning_curves", "plot_results_dir"]

METRIC_LABELS = {
    "return": "Greedy return",
    "discounted_return": "Greedy discounted return",
    "episode_length": "Greedy episode length (steps)",
    "failure_rate": "Greedy failure rate (episodes with a failure)",
    "optimality": "Optimality (return scaled between worst and best)",
    "num_features": "Number of features",
    "steps_per_second": "Learning steps per second",
    "wall_time_s": "Learning wall time (s)",
    "learning_episodes": "Learning episodes",
    "learning_failures": "Failures during learning (cumulative)",
}


def plot_learning_curves(
    results_frame: pd.DataFrame, path: str | Path, metric: str = "return", title: str = ""
) -> Path:
    """Plot ``metric`` against learning steps, mean over seeds ± 95% t band, per label.

    Parameters
    ----------
    results_frame : pandas.DataFrame
        Columns ``label``, ``seed``, ``learning_steps`` and ``metric`` (``results.parquet``).
    path : str or Path
        The PNG to write.
    metric : str, default "return"
        Any numeric curve column.
    title : str, default ""
        The figure title.

    Returns
    -------
    Path
        ``path``.
    """
    needed = {"label", "seed", "learning_steps", metric}
    missing = needed - set(results_frame.columns)
    known = ", ".join(c for c in METRIC_LABELS if has_finite_values(results_frame, c))
    if missing:
        raise InvalidParameterError(
            f"Cannot plot {metric!r}: the results lack column(s) {', '.join(sorted(missing))}."
            f" Plottable metrics: {known or '(none)'}."
        )
    if results_frame.empty:
        raise InvalidParameterError("Cannot plot an empty results table (no finished runs).")
    if not has_finite_values(results_frame, metric):
        raise InvalidParameterError(
            f"Cannot plot {metric!r}: it has no finite value in these results (optimality "
            f"needs a domain with value_bounds()). Plottable metrics: {known or '(none)'}."
        )
    figure = Figure(figsize=(7, 4.5), dpi=120)
    FigureCanvasAgg(figure)
    axes = figure.add_subplot()
    for label, group in results_frame.groupby("label", sort=False):
        steps, means, lows, highs = [], [], [], []
        for step, at_step in group.groupby("learning_steps", sort=True):
            mean, half = t_confidence(at_step[metric])
            half = 0.0 if pd.isna(half) else half
            steps.append(step)
            means.append(mean)
            lows.append(mean - half)
            highs.append(mean + half)
        num_seeds = group["seed"].nunique()
        (line,) = axes.plot(
            steps, means, marker="o", markersize=3, label=f"{label} (n={num_seeds})"
        )
        axes.fill_between(steps, lows, highs, color=line.get_color(), alpha=0.2, linewidth=0)
    axes.set_xlabel("Learning steps")
    axes.set_ylabel(METRIC_LABELS.get(metric, metric))
    if title:
        axes.set_title(title)
    axes.grid(alpha=0.3)
    axes.legend(loc="best", fontsize="small")
    figure.tight_layout()
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    figure.savefig(path, format="png")
    return path


def plot_results_dir(results_dir: str | Path, metric: str = "return") -> Path:
    """Plot ``results_dir/results.parquet`` to ``learning_curve[_<metric>].png`` there."""
    results_dir = Path(results_dir)
    table = results_dir / RESULTS_FILE
    if not table.is_file():
        raise InvalidParameterError(
            f"No {RESULTS_FILE} in {str(results_dir)!r}; run `conjure run CONFIG` first."
        )
    frame = pd.read_parquet(table)
    name = "learning_curve.png" if metric == "return" else f"learning_curve_{metric}.png"
    return plot_learning_curves(frame, results_dir / name, metric=metric, title=results_dir.name)
