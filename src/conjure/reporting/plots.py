"""Learning-curve plots: mean over seeds with a shaded 95% confidence band, one line per label.

Matplotlib's headless Agg backend is used through the object API (no pyplot state), so plots
work on servers and in worker processes.

Notes
-----
- Choice: the band is the Student-t 95% confidence interval of the mean over seeds, clipped to
  the metric's possible range (`METRIC_BOUNDS`: a failure rate lies in [0, 1], counts and
  times are non-negative): a normal interval of a 0/1 quantity over few seeds spills past its
  bounds, and the mean it brackets cannot. The legend says what the band is.
- Choice: the legend sits right of the axes, never over the curves (a sweep has many labels).
- Choice: files are named after their metric (``learning_curve_<metric>.png``), so a plot of
  one metric never replaces a plot of another.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd
import yaml
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.patches import Patch

from conjure.core.errors import InvalidParameterError
from conjure.experiments.results import (
    RESOLVED_FILE,
    RESULTS_FILE,
    has_finite_values,
    t_confidence,
)

__all__ = [
    "METRIC_BOUNDS",
    "METRIC_LABELS",
    "curve_bands",
    "curve_file_name",
    "learning_curve_figure",
    "plot_learning_curves",
    "plot_results_dir",
]

METRIC_LABELS = {
    "return": "Greedy return",
    "discounted_return": "Greedy discounted return",
    "episode_length": "Greedy episode length (steps)",
    "failure_rate": "Greedy failure rate (episodes with a failure)",
    "optimality": "Optimality (return scaled between worst and best)",
    "value_ratio": "Fraction of the optimum (return / V*)",
    "num_features": "Number of features",
    "steps_per_second": "Learning steps per second",
    "wall_time_s": "Learning wall time (s)",
    "learning_episodes": "Learning episodes",
    "learning_failures": "Failures during learning (cumulative)",
}

#: The possible range of each bounded curve column (the band is clipped to it).
METRIC_BOUNDS = {
    "failure_rate": (0.0, 1.0),
    "episode_length": (0.0, math.inf),
    "num_features": (0.0, math.inf),
    "steps_per_second": (0.0, math.inf),
    "wall_time_s": (0.0, math.inf),
    "learning_episodes": (0.0, math.inf),
    "learning_failures": (0.0, math.inf),
}
BAND_LABEL = "shaded: 95% confidence interval of the mean over seeds"


def curve_file_name(metric: str) -> str:
    """The file name of a learning-curve plot of ``metric`` (``learning_curve_<metric>.png``)."""
    return f"learning_curve_{metric}.png"


def curve_bands(results_frame: pd.DataFrame, metric: str) -> pd.DataFrame:
    """Per label and policy check: the mean of ``metric`` over seeds and its 95% interval.

    Columns ``label``, ``learning_steps``, ``mean``, ``low``, ``high``, ``num_seeds``; the
    interval is Student-t, clipped to `METRIC_BOUNDS` (a single seed has a zero-width band).

    Examples
    --------
    >>> frame = pd.DataFrame({"label": "a", "seed": [0, 1, 2], "learning_steps": 10,
    ...                       "failure_rate": [1.0, 1.0, 0.0]})
    >>> band = curve_bands(frame, "failure_rate").iloc[0]
    >>> [round(float(band[c]), 3) for c in ("mean", "low", "high")]  # t interval: ± 1.43
    [0.667, 0.0, 1.0]
    """
    low_bound, high_bound = METRIC_BOUNDS.get(metric, (-math.inf, math.inf))
    rows = []
    for label, group in results_frame.groupby("label", sort=False):
        for step, at_step in group.groupby("learning_steps", sort=True):
            mean, half = t_confidence(at_step[metric])
            half = 0.0 if pd.isna(half) else half
            low, high = np.clip([mean - half, mean + half], low_bound, high_bound)
            seeds = at_step["seed"].nunique()
            rows.append((label, step, mean, float(low), float(high), seeds))
    columns = ["label", "learning_steps", "mean", "low", "high", "num_seeds"]
    return pd.DataFrame(rows, columns=columns)


def plot_learning_curves(
    results_frame: pd.DataFrame, path: str | Path, metric: str = "return", title: str = ""
) -> Path:
    """Plot ``metric`` against learning steps: mean over seeds and its 95% band, per label.

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
    figure = learning_curve_figure(results_frame, metric, title)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    figure.savefig(path, format="png", bbox_inches="tight")
    return path


def learning_curve_figure(results_frame: pd.DataFrame, metric: str, title: str = "") -> Figure:
    """Draw `plot_learning_curves`' figure and return it unsaved (same checks, same arguments)."""
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
    bands = curve_bands(results_frame, metric)
    for label, band in bands.groupby("label", sort=False):
        num_seeds = results_frame.loc[results_frame["label"] == label, "seed"].nunique()
        steps = band["learning_steps"]
        (line,) = axes.plot(
            steps, band["mean"], marker="o", markersize=3, label=f"{label} (n={num_seeds})"
        )
        axes.fill_between(
            steps, band["low"], band["high"], color=line.get_color(), alpha=0.2, linewidth=0
        )
    axes.set_xlabel("Learning steps")
    axes.set_ylabel(METRIC_LABELS.get(metric, metric))
    if title:
        axes.set_title(title)
    axes.grid(alpha=0.3)
    handles, labels = axes.get_legend_handles_labels()
    handles.append(Patch(color="grey", alpha=0.3))
    labels.append(BAND_LABEL)
    axes.legend(
        handles,
        labels,
        loc="upper left",
        bbox_to_anchor=(1.02, 1.0),
        borderaxespad=0.0,
        fontsize="small",
    )
    figure.tight_layout()
    return figure


def plot_results_dir(results_dir: str | Path, metric: str | None = None) -> Path:
    """Plot ``results_dir/results.parquet`` to ``learning_curve_<metric>.png`` there.

    ``metric`` defaults to the one the experiment's config chose (``config.resolved.yaml``),
    else ``return``.
    """
    results_dir = Path(results_dir)
    table = results_dir / RESULTS_FILE
    if not table.is_file():
        raise InvalidParameterError(
            f"No {RESULTS_FILE} in {str(results_dir)!r}; run `conjure run CONFIG` first."
        )
    if metric is None:
        resolved = results_dir / RESOLVED_FILE
        config = yaml.safe_load(resolved.read_text()) if resolved.is_file() else None
        metric = (config or {}).get("metric", "return")
    frame = pd.read_parquet(table)
    path = results_dir / curve_file_name(metric)
    return plot_learning_curves(frame, path, metric=metric, title=results_dir.name)
