"""Learning-curve plots: mean over seeds with a shaded 95% confidence band, one line per label.

Matplotlib's headless Agg backend is used through the object API (no pyplot state), so plots
work on servers and in worker processes.

Notes
-----
- Choice: the band is the Student-t 95% confidence interval of the mean over seeds, cut at
  the metric's range (`conjure.experiments.metric_ranges`: a failure rate in [0, 1], an
  episode no longer than the domain's cap, a return within the value or return bounds the
  domain declares): an interval over few seeds spills past what the mean it brackets can
  be. The legend says what the band is and where it was cut, or that it was not (a return
  on a domain that declares no bounds).
- Choice: the legend sits right of the axes, never over the curves, and the figure grows
  around it instead of shrinking the axes: they keep at least `AXES_INCHES`, grow as tall as
  the legend when it is taller (a sweep's 29 labels) and as wide as `AXES_ASPECT` then asks.
- Choice: lines differ from their neighbours in colour, line style and marker at once
  (`LINE_STYLES`, `MARKERS`), so two curves that coincide (a cooperative learner following
  its planner) both show: the dashes of the one drawn on top leave the other visible.
- Choice: a plot is titled by what it shows and the metric, ``fig_5_12: return``; a results
  folder's plots by its config's name (`conjure.experiments.results.results_name`).
- Choice: a sweep's lines are labelled ``label [setting]`` with each parameter by its own
  name when that is unambiguous within the setting (``icca [alpha_0=0.1, n_0=100]`` for
  ``learner.step_size.alpha_0=0.1, ...``), so the legend stays narrow; a label's number of
  seeds is shown only when the labels differ in it.
- Choice: files are named after their metric (``learning_curve_<metric>.png``), so a plot of
  one metric never replaces a plot of another.
- Choice: performance profiles are drawn by rliable's own
  `rliable.plot_utils.plot_performance_profiles` on conjure's axes, colours, line styles,
  side legend and layout.
"""

from __future__ import annotations

import io
import math
import re
from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.legend import Legend
from matplotlib.patches import Patch
from matplotlib.ticker import StrMethodFormatter

from conjure.core.errors import InvalidParameterError
from conjure.experiments.metric_ranges import clip_interval, describe_range, metric_range
from conjure.experiments.numbers import readable_setting
from conjure.experiments.results import (
    RESULTS_FILE,
    has_finite_values,
    read_resolved,
    results_name,
    t_confidence,
    write_atomic,
)
from conjure.reporting.statistics import PROFILE_COLUMNS

__all__ = [
    "METRIC_LABELS",
    "curve_bands",
    "curve_file_name",
    "learning_curve_figure",
    "method_labels",
    "panel_figure",
    "performance_profile_figure",
    "plot_learning_curves",
    "plot_performance_profiles",
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
    "learning_cost": "Cost during learning (cumulative)",
    "cost_rate": "Cost rate while learning (cost per step)",
    "episode_cost": "Greedy episodic cost",
}
#: Line styles and markers, cycled beside the ten colours (lines 0 and 1 differ in all three).
LINE_STYLES = ("-", "--", ":", "-.")
MARKERS = ("o", "s", "^", "D", "v", "P", "X")
#: The least size of the axes (width, height), in inches.
AXES_INCHES = (6.5, 4.0)
#: Width over height of axes made taller than `AXES_INCHES` for a tall legend.
AXES_ASPECT = 2.0
#: Room around the axes, in inches: left (tick labels), right, bottom, top (title), and the
#: gap between the axes and the legend.
MARGIN_INCHES = {"left": 0.9, "right": 0.1, "bottom": 0.6, "top": 0.4, "gap": 0.15}
#: A parameter path of a setting's text, after its start (written as "[") or a ", ".
_KEY = re.compile(r"(?:(?<=\[)|(?<=, ))([A-Za-z_][\w.]*)=")


def curve_file_name(metric: str) -> str:
    """The file name of a learning-curve plot of ``metric`` (``learning_curve_<metric>.png``)."""
    return f"learning_curve_{metric}.png"


def curve_bands(results_frame: pd.DataFrame, metric: str) -> pd.DataFrame:
    """Per label and policy check: the mean of ``metric`` over seeds and its 95% interval.

    Columns ``label``, ``learning_steps``, ``mean``, ``low``, ``high``, ``num_seeds``; the
    interval is Student-t, cut at the label's `metric_range` (a single seed has a zero-width
    band).

    Examples
    --------
    >>> frame = pd.DataFrame({"label": "a", "seed": [0, 1, 2], "learning_steps": 10,
    ...                       "failure_rate": [1.0, 1.0, 0.0]})
    >>> band = curve_bands(frame, "failure_rate").iloc[0]
    >>> [round(float(band[c]), 3) for c in ("mean", "low", "high")]  # t interval: ± 1.43
    [0.667, 0.0, 1.0]
    """
    rows = []
    for label, group in results_frame.groupby("label", sort=False):
        bounds = metric_range(group, metric)
        for step, at_step in group.groupby("learning_steps", sort=True):
            mean, half = t_confidence(at_step[metric])
            low, high = clip_interval(mean, 0.0 if pd.isna(half) else half, bounds)
            rows.append((label, step, mean, low, high, at_step["seed"].nunique()))
    columns = ["label", "learning_steps", "mean", "low", "high", "num_seeds"]
    return pd.DataFrame(rows, columns=columns)


def method_labels(results: pd.DataFrame, *, abbreviate: bool = True) -> pd.Series:
    """A name per row for its method: ``label [setting]``.

    With ``abbreviate`` each parameter goes by its own name when that is unique in the setting
    (the legend's choice); with several domains the domain comes first (``chain5 / sarsa``).

    Examples
    --------
    >>> frame = pd.DataFrame({"label": ["icca", "sarsa"], "setting": [
    ...     "learner.step_size.alpha_0=0.1, learner.step_size.n_0=100", ""]})
    >>> method_labels(frame).tolist()
    ['icca [alpha_0=0.1, n_0=100]', 'sarsa']
    >>> method_labels(pd.DataFrame({"label": ["sarsa"], "setting": ["n_0=200000.0"]})).tolist()
    ['sarsa [n_0=200,000]']
    """
    labels = results["label"].astype(str)
    if "domain_label" in results.columns and results["domain_label"].nunique() > 1:
        labels = results["domain_label"].astype(str) + " / " + labels
    if "setting" not in results.columns:
        return labels
    setting = results["setting"].fillna("").astype(str)
    if abbreviate:
        setting = setting.map(_short_setting)
    setting = setting.map(readable_setting)
    return labels + np.where(setting != "", " [" + setting + "]", "")


def _short_setting(setting: str) -> str:
    """``setting`` with each parameter path cut to its last name, if those are unique."""
    paths = _KEY.findall(f"[{setting}")
    names = [path.rsplit(".", 1)[-1] for path in paths]
    if len(set(names)) < len(names):
        return setting
    return _KEY.sub(lambda match: f"{match.group(1).rsplit('.', 1)[-1]}=", f"[{setting}")[1:]


def plot_learning_curves(
    results_frame: pd.DataFrame,
    path: str | Path,
    metric: str = "return",
    title: str = "",
    panels: bool = False,
) -> Path:
    """Plot ``metric`` against learning steps: mean over seeds and its 95% band, per label.

    Parameters
    ----------
    results_frame : pandas.DataFrame
        Columns ``label``, ``seed``, ``learning_steps`` and ``metric`` (``results.parquet``);
        the columns of `conjure.experiments.metric_ranges.DOMAIN_BOUND_COLUMNS`, when there,
        bound the band.
    path : str or Path
        The PNG to write.
    metric : str, default "return"
        Any numeric curve column.
    title : str, default ""
        What the curves are of (a config's name); the plot is titled ``"<title>: <metric>"``.
    panels : bool, default False
        One panel per method, its band over the other methods' means in grey, for when the
        bands overlap (`panel_figure`); False draws every method on one axes.

    Returns
    -------
    Path
        ``path``.
    """
    draw = panel_figure if panels else learning_curve_figure
    figure = draw(results_frame, metric, title)
    image = io.BytesIO()
    figure.savefig(image, format="png", bbox_inches="tight")
    return write_atomic(path, image.getvalue())


def _check_plottable(results_frame: pd.DataFrame, metric: str) -> None:
    """Raise `InvalidParameterError` naming the plottable metrics if ``metric`` is not one."""
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


def learning_curve_figure(results_frame: pd.DataFrame, metric: str, title: str = "") -> Figure:
    """Draw `plot_learning_curves`' figure and return it unsaved (same checks, same arguments)."""
    _check_plottable(results_frame, metric)
    figure = Figure(figsize=(10, 6), dpi=120)
    FigureCanvasAgg(figure)
    axes = figure.add_subplot()
    seeds = results_frame.groupby("label", sort=False)["seed"].nunique()
    same_seeds = seeds.nunique() == 1
    bands = curve_bands(results_frame, metric)
    alpha = max(0.05, 0.2 * min(1.0, 6 / len(seeds)))  # many bands would stack to a smear
    for index, (label, band) in enumerate(bands.groupby("label", sort=False)):
        steps = band["learning_steps"]
        (line,) = axes.plot(
            steps,
            band["mean"],
            color=f"C{index % 10}",
            linestyle=LINE_STYLES[index % len(LINE_STYLES)],
            marker=MARKERS[index % len(MARKERS)],
            markersize=3.5,
            label=str(label) if same_seeds else f"{label} (n={seeds[label]})",
        )
        axes.fill_between(
            steps, band["low"], band["high"], color=line.get_color(), alpha=alpha, linewidth=0
        )
    axes.set_xlabel("Learning steps")
    axes.xaxis.set_major_formatter(StrMethodFormatter("{x:,.0f}"))
    axes.set_ylabel(METRIC_LABELS.get(metric, metric))
    axes.set_title(f"{title}: {metric}" if title else metric)
    axes.grid(alpha=0.3)
    band_text = _band_text(metric_range(results_frame, metric), seeds)
    _lay_out(figure, axes, _side_legend(axes, band_text))
    return figure


def panel_figure(results_frame: pd.DataFrame, metric: str, title: str = "") -> Figure:
    """One panel per method, up to 3 a row on shared axes, for overlapping bands.

    Each panel draws its method's mean and 95% band in colour over the other methods' means
    in grey; same checks and arguments as `learning_curve_figure`.
    """
    _check_plottable(results_frame, metric)
    seeds = results_frame.groupby("label", sort=False)["seed"].nunique()
    bands = curve_bands(results_frame, metric)
    by_label = dict(tuple(bands.groupby("label", sort=False)))
    columns = min(3, len(by_label))
    rows = math.ceil(len(by_label) / columns)
    figure = Figure(figsize=(4.0 * columns, 3.0 * rows + 0.8), dpi=120, layout="constrained")
    FigureCanvasAgg(figure)
    grid = figure.subplots(rows, columns, sharex=True, sharey=True, squeeze=False)
    for index, (label, band) in enumerate(by_label.items()):
        axes = grid.flat[index]
        for other, theirs in by_label.items():
            if other != label:
                axes.plot(theirs["learning_steps"], theirs["mean"], color="0.7", linewidth=0.8)
        steps, color = band["learning_steps"], f"C{index % 10}"
        axes.plot(steps, band["mean"], color=color, marker=MARKERS[index % len(MARKERS)])
        axes.fill_between(steps, band["low"], band["high"], color=color, alpha=0.25, linewidth=0)
        axes.set_title(f"{label} (n={seeds[label]})", fontsize="medium")
        axes.xaxis.set_major_formatter(StrMethodFormatter("{x:,.0f}"))
        axes.grid(alpha=0.3)
    for axes in grid.flat[len(by_label) :]:
        axes.set_visible(False)
    figure.suptitle(f"{title}: {metric}" if title else metric)
    figure.supxlabel("Learning steps")
    figure.supylabel(METRIC_LABELS.get(metric, metric))
    band_text = _band_text(metric_range(results_frame, metric), seeds).replace("\n", " ")
    figure.text(0.5, -0.01, f"{band_text}; grey: the other methods' means", ha="center",
                va="top", fontsize="small")  # fmt: skip
    return figure


def _band_text(bounds: tuple[float, float], seeds: pd.Series) -> str:
    """The legend entry of the shaded band: what it is, over how many seeds, where it is cut."""
    over = f"{seeds.iloc[0]} seeds" if seeds.nunique() == 1 else "n seeds"
    text = f"shaded: 95% confidence interval\nof the mean over {over}"
    if all(math.isinf(b) for b in bounds):
        return f"{text},\nnot cut (no range declared)"
    return f"{text},\ncut at the range {describe_range(bounds)}"


def _side_legend(axes: Axes, band_text: str) -> Legend:
    """The legend right of ``axes``: every line, then the band's entry."""
    handles, labels = axes.get_legend_handles_labels()
    handles.append(Patch(color="grey", alpha=0.3))
    labels.append(band_text)
    return axes.legend(
        handles,
        labels,
        loc="upper left",
        bbox_to_anchor=(1.0, 1.0),
        borderaxespad=0.0,
        fontsize="small",
    )


def _lay_out(figure: Figure, axes: Axes, legend: Legend) -> None:
    """Size ``figure`` so that ``axes`` keep their size and ``legend`` fits at their right."""
    box = legend.get_window_extent(figure.canvas.get_renderer())
    legend_width, legend_height = box.width / figure.dpi, box.height / figure.dpi
    height = max(AXES_INCHES[1], legend_height)
    width = max(AXES_INCHES[0], AXES_ASPECT * height if height > AXES_INCHES[1] else 0.0)
    margin = MARGIN_INCHES
    figure_width = margin["left"] + width + margin["gap"] + legend_width + margin["right"]
    figure_height = margin["bottom"] + height + margin["top"]
    figure.set_size_inches(figure_width, figure_height)
    axes.set_position(
        [
            margin["left"] / figure_width,
            margin["bottom"] / figure_height,
            width / figure_width,
            height / figure_height,
        ]
    )
    legend.set_bbox_to_anchor((1.0 + margin["gap"] / width, 1.0), transform=axes.transAxes)


def plot_results_dir(
    results_dir: str | Path, metric: str | None = None, panels: bool = False
) -> Path:
    """Plot ``results_dir/results.parquet`` to ``learning_curve_<metric>.png`` there.

    One line per method (``label [setting]``, `method_labels`); ``metric`` defaults to the
    one the experiment's config chose (``config.resolved.yaml``), else ``return``. The plot is
    titled by the config's name; ``panels`` as `plot_learning_curves`.
    """
    results_dir = Path(results_dir)
    table = results_dir / RESULTS_FILE
    if not table.is_file():
        raise InvalidParameterError(
            f"No {RESULTS_FILE} in {str(results_dir)!r}; run `conjure run CONFIG` first."
        )
    metric = metric or read_resolved(results_dir).get("metric") or "return"
    frame = pd.read_parquet(table)
    path = results_dir / curve_file_name(metric)
    frame = frame.assign(label=method_labels(frame))
    return plot_learning_curves(
        frame, path, metric=metric, title=results_name(results_dir), panels=panels
    )


def plot_performance_profiles(
    profiles: pd.DataFrame, path: str | Path, *, score: str = "score", title: str = ""
) -> Path:
    """Plot performance profiles: per method, the fraction of runs scoring above τ.

    Parameters
    ----------
    profiles : pandas.DataFrame
        `conjure.reporting.statistics.performance_profile`'s table (`PROFILE_COLUMNS`).
    path : str or Path
        The PNG to write.
    score : str, default "score"
        What the runs scored (the x axis reads ``<score> (τ)``).
    title : str, default ""
        The plot's title.

    Returns
    -------
    Path
        ``path``.
    """
    figure = performance_profile_figure(profiles, score=score, title=title)
    image = io.BytesIO()
    figure.savefig(image, format="png", bbox_inches="tight")
    return write_atomic(path, image.getvalue())


def performance_profile_figure(
    profiles: pd.DataFrame, *, score: str = "score", title: str = ""
) -> Figure:
    """Draw `plot_performance_profiles`' figure and return it unsaved (same arguments)."""
    missing = [c for c in PROFILE_COLUMNS if c not in profiles.columns]
    if missing or profiles.empty:
        raise InvalidParameterError(
            "Cannot plot performance profiles: expected the table of performance_profile "
            f"(columns {', '.join(PROFILE_COLUMNS)}); got "
            + (f"no column(s) {', '.join(missing)}." if missing else "an empty table.")
        )
    # Imported when used: rliable's plotting module loads pyplot and seaborn.
    from rliable import plot_utils

    figure = Figure(figsize=(10, 6), dpi=120)
    FigureCanvasAgg(figure)
    axes = figure.add_subplot()
    by_method = dict(tuple(profiles.groupby("method", sort=False)))
    thresholds = next(iter(by_method.values()))["threshold"].to_numpy()
    plot_utils.plot_performance_profiles(
        {m: t["fraction"].to_numpy() for m, t in by_method.items()},
        thresholds,
        performance_profile_cis={m: (t["low"], t["high"]) for m, t in by_method.items()},
        ax=axes,
        colors={m: f"C{i % 10}" for i, m in enumerate(by_method)},
        linestyles={m: LINE_STYLES[i % len(LINE_STYLES)] for i, m in enumerate(by_method)},
        xlabel=f"{score} (τ)",
        ylabel="Fraction of runs scoring above τ",
        labelsize="medium",
        ticklabelsize="medium",
    )
    axes.set_title(title)
    band = "shaded: 95% stratified-bootstrap\ninterval (rliable)"
    _lay_out(figure, axes, _side_legend(axes, band))
    return figure
