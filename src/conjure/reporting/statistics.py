"""Aggregate statistics over runs, by rliable: IQM, probability of improvement, profiles.

The thesis reports means with 95% confidence intervals (Sections 3.3.1, 4.1.4 and 5.3.5);
the report adds the estimators that Agarwal et al. (2021), "Deep reinforcement learning at
the edge of the statistical precipice", recommend for few runs, computed by their library
``rliable`` (`rliable.metrics`, `rliable.library`), not re-implemented here.

Scores are one number per run (a 1-D sequence: one task) or a matrix of shape
``(runs, tasks)`` (each task a stratum: GridWorld-1, UAV 7-2, ...), every entry finite.

Notes
-----
- Choice: intervals are percentile intervals of rliable's stratified bootstrap, which
  resamples runs with replacement within each task separately, with ``reps`` resamples
  (default `DEFAULT_REPS`, rather than rliable's 50,000, so a report stays quick).
- Choice: an interval needs at least two runs of each task; with one it is NaN, not the
  zero-width interval a bootstrap of one run gives.
- Choice: seeding. rliable 1.2's bootstraps draw their indices from numpy's global
  ``RandomState`` (``np.random.choice``) whatever ``random_state`` they are given, so each
  function here seeds that global state from its ``seed`` for the call and restores the
  previous state afterwards: the same seed gives the same interval, and no state leaks out.
  Not safe to call from several threads at once.
- Choice: a performance profile is rliable's score distribution: the fraction of all runs
  (over every task) whose score is above a threshold τ, strictly.
"""

from __future__ import annotations

import contextlib
import math
from collections.abc import Callable, Iterator, Mapping, Sequence

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike
from rliable import library, metrics

from conjure.core.errors import InvalidParameterError
from conjure.core.seeding import Seed, as_seed_sequence, seed_to_int

__all__ = [
    "DEFAULT_REPS",
    "iqm",
    "iqm_interval",
    "performance_profile",
    "probability_of_improvement",
    "score_matrix",
]

#: Bootstrap resamples per interval.
DEFAULT_REPS = 2000
#: The columns of `performance_profile`'s table.
PROFILE_COLUMNS = ("method", "threshold", "fraction", "low", "high")


def score_matrix(scores: ArrayLike, name: str = "scores") -> np.ndarray:
    """Return ``scores`` as a float matrix of shape ``(runs, tasks)``, checked.

    A 1-D sequence is one task. Raises `InvalidParameterError` for an empty, ragged, more
    than 2-D or non-finite input, naming ``name``.

    Examples
    --------
    >>> score_matrix([1, 2, 3]).shape
    (3, 1)
    """
    try:
        matrix = np.asarray(scores, dtype=np.float64)
    except (TypeError, ValueError):
        raise InvalidParameterError(
            f"`{name}` must be numbers, one per run (or a runs x tasks matrix); got {scores!r}."
        ) from None
    if matrix.ndim == 1:
        matrix = matrix.reshape(-1, 1)
    if matrix.ndim != 2 or matrix.size == 0:
        raise InvalidParameterError(
            f"`{name}` must be a non-empty sequence of scores, one per run, or a runs x tasks "
            f"matrix; got shape {np.shape(scores)}."
        )
    bad = ~np.isfinite(matrix)
    if bad.any():
        run, task = np.argwhere(bad)[0]
        raise InvalidParameterError(
            f"`{name}` must be finite; run {run} of task {task} is {matrix[run, task]}."
        )
    return matrix


def _check_interval_options(reps: int, level: float) -> None:
    if isinstance(reps, bool) or not isinstance(reps, (int, np.integer)) or reps < 1:
        raise InvalidParameterError(f"`reps` must be a positive int; got {reps!r}.")
    number = isinstance(level, (int, float, np.number)) and not isinstance(level, bool)
    if not number or not 0 < level < 1:
        raise InvalidParameterError(f"`level` must be within (0, 1); got {level!r}.")


@contextlib.contextmanager
def _global_numpy_seed(seed: Seed) -> Iterator[None]:
    """Seed numpy's global ``RandomState`` (which rliable draws from), then restore it."""
    value = seed_to_int(as_seed_sequence(seed))
    # The legacy global state on purpose: it is what rliable's bootstraps draw from.
    saved = np.random.get_state()  # noqa: NPY002
    np.random.seed(value)  # noqa: NPY002
    try:
        yield
    finally:
        np.random.set_state(saved)  # noqa: NPY002


def _estimate(
    scores: np.ndarray | list[np.ndarray],
    statistic: Callable[..., float],
    reps: int,
    level: float,
    seed: Seed,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Point estimate and interval ends of ``statistic`` by `rliable.library`."""
    _check_interval_options(reps, level)
    arrays = scores if isinstance(scores, list) else [scores]
    with _global_numpy_seed(seed):
        points, intervals = library.get_interval_estimates(
            {"scores": scores},
            func=lambda *s: np.atleast_1d(statistic(*s)),
            reps=int(reps),
            confidence_interval_size=level,
        )
    point, (low, high) = points["scores"], intervals["scores"]
    if min(a.shape[0] for a in arrays) < 2:
        low, high = np.full_like(point, math.nan), np.full_like(point, math.nan)
    return point, low, high


def iqm(scores: ArrayLike) -> float:
    """The interquartile mean: the mean of the middle 50% of all runs' scores.

    `rliable.metrics.aggregate_iqm` (a 25% trimmed mean over every run of every task).

    Examples
    --------
    >>> iqm([0.0, 1.0, 2.0, 3.0, 100.0, 4.0, 5.0, 6.0])
    3.5
    """
    return float(metrics.aggregate_iqm(score_matrix(scores)))


def iqm_interval(
    scores: ArrayLike, *, reps: int = DEFAULT_REPS, level: float = 0.95, seed: Seed = 0
) -> tuple[float, float, float]:
    """The IQM and its stratified-bootstrap percentile interval, ``(iqm, low, high)``.

    Parameters
    ----------
    scores : array-like
        One score per run, or a ``(runs, tasks)`` matrix.
    reps : int, default `DEFAULT_REPS`
        Bootstrap resamples.
    level : float, default 0.95
        The interval's coverage.
    seed : int or numpy.random.SeedSequence, default 0
        Of the resampling; the same seed gives the same interval.

    Examples
    --------
    >>> point, low, high = iqm_interval([1.0, 2.0, 3.0, 4.0], reps=200)
    >>> point, low <= point <= high
    (2.5, True)
    """
    point, low, high = _estimate(score_matrix(scores), metrics.aggregate_iqm, reps, level, seed)
    return float(point[0]), float(low[0]), float(high[0])


def probability_of_improvement(
    scores_x: ArrayLike,
    scores_y: ArrayLike,
    *,
    reps: int = DEFAULT_REPS,
    level: float = 0.95,
    seed: Seed = 0,
) -> tuple[float, float, float]:
    """P(X > Y): how likely a run of method X scores above a run of Y, with its interval.

    `rliable.metrics.probability_of_improvement`: per task, the Mann-Whitney U statistic of
    X over Y divided by the number of pairs (a tie counts one half), averaged over tasks.
    X and Y may have different numbers of runs but must have the same tasks; the interval
    resamples the runs of X and of Y independently within each task.

    Examples
    --------
    >>> probability_of_improvement([3.0, 4.0], [1.0, 2.0], reps=100)
    (1.0, 1.0, 1.0)
    """
    x, y = score_matrix(scores_x, "scores_x"), score_matrix(scores_y, "scores_y")
    if x.shape[1] != y.shape[1]:
        raise InvalidParameterError(
            f"`scores_x` and `scores_y` must have the same tasks (columns); got {x.shape[1]} "
            f"and {y.shape[1]}."
        )
    point, low, high = _estimate([x, y], metrics.probability_of_improvement, reps, level, seed)
    return float(point[0]), float(low[0]), float(high[0])


def performance_profile(
    scores: Mapping[str, ArrayLike],
    thresholds: Sequence[float] | np.ndarray,
    *,
    reps: int = DEFAULT_REPS,
    level: float = 0.95,
    seed: Seed = 0,
) -> pd.DataFrame:
    """Each method's performance profile: the fraction of runs scoring above each threshold.

    `rliable.library.create_performance_profile` (score distributions, over every run of
    every task), with its stratified-bootstrap interval.

    Parameters
    ----------
    scores : mapping of str to array-like
        Per method, one score per run or a ``(runs, tasks)`` matrix.
    thresholds : sequence of float
        The τ at which each profile is evaluated (finite).
    reps, level, seed
        As `iqm_interval`.

    Returns
    -------
    pandas.DataFrame
        Columns ``method``, ``threshold``, ``fraction``, ``low``, ``high`` (`PROFILE_COLUMNS`),
        one row per method and threshold, methods in the order given.

    Examples
    --------
    >>> table = performance_profile({"a": [1.0, 2.0, 3.0, 4.0]}, [0.0, 2.5], reps=100)
    >>> table["fraction"].tolist()
    [1.0, 0.5]
    """
    if not scores:
        raise InvalidParameterError("`scores` must map at least one method to its scores.")
    matrices = {str(m): score_matrix(s, f"scores[{m!r}]") for m, s in scores.items()}
    taus = score_matrix(thresholds, "thresholds")
    if taus.shape[1] != 1:
        raise InvalidParameterError(f"`thresholds` must be 1-D; got shape {np.shape(thresholds)}.")
    taus = taus[:, 0]
    _check_interval_options(reps, level)
    with _global_numpy_seed(seed):
        profiles, intervals = library.create_performance_profile(
            matrices, taus, reps=int(reps), confidence_interval_size=level
        )
    frames = []
    for method, matrix in matrices.items():
        low, high = intervals[method]
        if matrix.shape[0] < 2:
            low, high = np.full(taus.size, math.nan), np.full(taus.size, math.nan)
        frames.append(
            pd.DataFrame(
                {
                    "method": method,
                    "threshold": taus,
                    "fraction": profiles[method],
                    "low": low,
                    "high": high,
                }
            )
        )
    return pd.concat(frames, ignore_index=True)[list(PROFILE_COLUMNS)]
