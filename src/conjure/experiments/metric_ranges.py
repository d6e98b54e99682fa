"""The range a metric's mean can take, to which confidence intervals are cut.

A 95% Student-t interval of a mean over few seeds can reach past what the mean can be: three
seeds with failure rates 1, 1 and 0 give 0.667 ± 1.43. Plots, printed tables, ``summary.csv``
and ``report.md`` cut every such interval at the metric's range (`metric_range`,
`clip_interval`) and say so.

Notes
-----
- Choice (the rule): a metric's range is the intersection of two ranges.

  1. `FIXED_RANGES`, what the metric's definition allows whatever the domain: a failure rate
     and optimality in [0, 1], V/V* at most 1, counts, times and speeds at least 0.
  2. What each run's domain declared, recorded with the run (`DOMAIN_BOUND_COLUMNS`): the
     episode length is at most the episode cap (`DomainSpec.max_episode_steps`; a pendulum
     balances at most 3,000 steps); the return lies within ``Domain.value_bounds()`` (worst,
     best) and within ``Domain.return_bounds()`` (lowest, highest: what any episode can
     return, e.g. GridWorld-1's [-1.999, 1]), and V/V* is at least worst / best.
     ``return_bounds`` cuts the return's intervals only; optimality and V/V* use
     ``value_bounds`` alone.

  Runs shown together (the seeds of a method, or several domains in one plot) take the union
  of their declared ranges. A run that declared nothing (a domain with neither bounds, or a
  run recorded before runs recorded their domain's bounds) leaves the fixed range: its
  return is not cut.
- Choice: the range bounds the expected value, which the interval is about. One evaluation
  can return more than the optimum's expected return V*; no policy's expected return can.
  The IQM's bootstrap interval is made of observed values and is not cut.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from conjure.experiments.numbers import format_number

if TYPE_CHECKING:
    import pandas as pd

__all__ = [
    "DOMAIN_BOUND_COLUMNS",
    "FIXED_RANGES",
    "clip_interval",
    "describe_range",
    "domain_bounds",
    "metric_range",
]

#: The range of each metric that holds on every domain (unlisted metrics are unbounded).
FIXED_RANGES = {
    "failure_rate": (0.0, 1.0),
    "optimality": (0.0, 1.0),
    "value_ratio": (-math.inf, 1.0),
    "episode_length": (0.0, math.inf),
    "num_features": (0.0, math.inf),
    "steps_per_second": (0.0, math.inf),
    "wall_time_s": (0.0, math.inf),
    "learning_steps": (0.0, math.inf),
    "learning_episodes": (0.0, math.inf),
    "learning_failures": (0.0, math.inf),
    "learning_cost": (0.0, math.inf),
    "cost_rate": (0.0, math.inf),
    "episode_cost": (0.0, math.inf),
}
#: The per-run columns of a results table that hold what the run's domain declared.
DOMAIN_BOUND_COLUMNS = (
    "max_episode_steps",
    "worst_return",
    "best_return",
    "lowest_return",
    "highest_return",
)


def domain_bounds(
    max_episode_steps: int,
    value_bounds: tuple[float, float] | None,
    return_bounds: tuple[float, float] | None = None,
) -> dict[str, float]:
    """Return what a run records of its domain: the episode cap, any value and return bounds.

    Examples
    --------
    >>> domain_bounds(3000, None)
    {'max_episode_steps': 3000.0}
    >>> domain_bounds(40, (-1.0, 0.5))
    {'max_episode_steps': 40.0, 'worst_return': -1.0, 'best_return': 0.5}
    >>> domain_bounds(100, None, (0.0, 3.0))
    {'max_episode_steps': 100.0, 'lowest_return': 0.0, 'highest_return': 3.0}
    """
    declared = {"max_episode_steps": float(max_episode_steps)}
    if value_bounds is not None:
        declared["worst_return"], declared["best_return"] = map(float, value_bounds)
    if return_bounds is not None:
        declared["lowest_return"], declared["highest_return"] = map(float, return_bounds)
    return declared


def _column(frame: pd.DataFrame, name: str) -> np.ndarray:
    """``frame[name]`` as floats (all NaN when the column is missing)."""
    if name not in frame.columns:
        return np.full(len(frame), math.nan)
    return np.asarray(frame[name], dtype=np.float64)


def _declared_ranges(frame: pd.DataFrame, metric: str) -> tuple[np.ndarray, np.ndarray]:
    """Per row of ``frame``, the range of ``metric`` its domain declared (NaN: none)."""
    unknown = np.full(len(frame), math.nan)
    worst, best = _column(frame, "worst_return"), _column(frame, "best_return")
    if metric == "return":  # the tighter of the two declared ranges (fmax/fmin skip a NaN)
        lowest, highest = _column(frame, "lowest_return"), _column(frame, "highest_return")
        return np.fmax(worst, lowest), np.fmin(best, highest)
    if metric == "value_ratio":
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(best > 0, worst / best, math.nan), unknown
    if metric == "episode_length":
        return unknown, _column(frame, "max_episode_steps")
    return unknown, unknown


def metric_range(frame: pd.DataFrame, metric: str) -> tuple[float, float]:
    """Return the range of the mean of ``metric`` over the runs in ``frame`` (module notes).

    Examples
    --------
    >>> import pandas as pd
    >>> runs = pd.DataFrame({"max_episode_steps": [3000.0, 3000.0]})
    >>> metric_range(runs, "episode_length"), metric_range(runs, "optimality")
    ((0.0, 3000.0), (0.0, 1.0))
    >>> metric_range(pd.DataFrame({"worst_return": [-2.0, -1.0], "best_return": [1.0, 2.0]}),
    ...              "return")
    (-2.0, 2.0)
    >>> metric_range(pd.DataFrame({"lowest_return": [-1.999], "highest_return": [1.0]}),
    ...              "return")
    (-1.999, 1.0)
    """
    low, high = FIXED_RANGES.get(metric, (-math.inf, math.inf))
    lows, highs = _declared_ranges(frame, metric)
    if lows.size and not np.isnan(lows).any():
        low = max(low, float(lows.min()))
    if highs.size and not np.isnan(highs).any():
        high = min(high, float(highs.max()))
    return low, high


def clip_interval(mean: float, half: float, bounds: tuple[float, float]) -> tuple[float, float]:
    """Return the ends of ``mean ± half`` cut at ``bounds`` (NaN ends for a NaN half-width).

    Examples
    --------
    >>> clip_interval(0.667, 1.43, (0.0, 1.0)), clip_interval(5.0, 1.0, (0.0, math.inf))
    ((0.0, 1.0), (4.0, 6.0))
    """
    if not math.isfinite(half):
        return math.nan, math.nan
    low, high = np.clip([mean - half, mean + half], *bounds)
    return float(low), float(high)


def describe_range(bounds: tuple[float, float]) -> str:
    """Return a range as text.

    Examples
    --------
    >>> describe_range((0.0, 3000.0)), describe_range((0.0, math.inf))
    ('[0, 3,000]', '[0, inf)')
    >>> describe_range((-0.625, 1.0))
    '[-0.6250, 1]'
    """
    low, high = (_bound_text(b) for b in bounds)
    return f"{'(' if low == '-inf' else '['}{low}, {high}{')' if high == 'inf' else ']'}"


def _bound_text(bound: float) -> str:
    if math.isinf(bound):
        return "inf" if bound > 0 else "-inf"
    return f"{int(bound):,}" if bound.is_integer() else format_number(bound)
