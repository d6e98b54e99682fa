"""Numba kernels of ARiFDD's basic tiles (Geramifard 2012, Algorithm 22, Section 4.2).

The basic tiles of dimension i partition its extent ``[edges[i, 0], edges[i, m_i])`` into
``m_i = num_tiles[i]`` intervals ``[edges[i, j], edges[i, j + 1])``, held in flat arrays:

- ``edges (d, capacity + 1)`` float64: the sorted boundaries (unused slots are +inf);
- ``tile_feature (d, capacity)`` int64: the feature id of the j-th tile of dimension i;
- ``stats (d, capacity, 3)`` float64: Ξ (the sum of |δ|), μ and σ² (the |δ|-weighted mean and
  variance of the states seen in the tile, Alg 22 lines 4-8).

Inputs are trusted: `ARiFDD` validates at ``setup`` and in ``check_state``.
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["basic_features", "record_errors"]


@njit(cache=True, inline="always")
def _slot(x: float, edges_row: np.ndarray, m: int) -> int:
    """The tile j of ``x``: the number of interior boundaries ``edges[1 .. m-1]`` <= x.

    Values below the extent (and NaN, which compares False) go to tile 0, above it to m - 1.
    """
    a, b = 1, m
    while a < b:
        mid = (a + b) >> 1
        if edges_row[mid] <= x:
            a = mid + 1
        else:
            b = mid
    return a - 1


@njit(cache=True)
def basic_features(
    state: np.ndarray, edges: np.ndarray, num_tiles: np.ndarray, tile_feature: np.ndarray
) -> np.ndarray:
    """φ⁰(s): the sorted feature ids of the d basic tiles holding ``state``, one per dimension."""
    d = state.shape[0]
    out = np.empty(d, dtype=np.int64)
    for i in range(d):
        out[i] = tile_feature[i, _slot(state[i], edges[i], num_tiles[i])]
    for i in range(1, d):  # insertion sort: d is small
        v = out[i]
        j = i - 1
        while j >= 0 and out[j] > v:
            out[j + 1] = out[j]
            j -= 1
        out[j + 1] = v
    return out


@njit(cache=True, inline="always")
def _split_point(mu: float, is_discrete: bool) -> float:
    """Line 13: a continuous tile splits at μ, a discrete one between values, at ⌊μ⌋ + 1/2."""
    return np.floor(mu) + 0.5 if is_discrete else mu


@njit(cache=True)
def record_errors(
    state: np.ndarray,
    weight: float,
    edges: np.ndarray,
    num_tiles: np.ndarray,
    stats: np.ndarray,
    low: np.ndarray,
    high: np.ndarray,
    min_width: np.ndarray,
    is_discrete: np.ndarray,
    split_threshold: float,
    can_split: bool,
    counters: np.ndarray,
) -> tuple[int, int, float]:
    """Algorithm 22, lines 2-13: update Ξ, μ, σ² of s's basic tiles, pick the tile to split.

    ``weight`` is |δ|. Among the tiles whose Ξ exceeds ς and whose split at μ leaves both
    halves at least ``min_width`` wide, returns (dimension, tile slot, split point) of the one
    with the least σ² (line 12 as printed). Returns
    (-1, -1, 0) when no tile passes ς, when every one that does is blocked by the floor
    (counted in ``counters[1]``), or when ``can_split`` is False. ``counters[0]`` counts the
    steps with a tile past ς.
    """
    d = state.shape[0]
    best_dim, best_slot, best_score = -1, -1, 0.0
    num_candidates = 0
    for i in range(d):  # line 3: each basic feature f of φ⁰(s)
        x = state[i]
        if not x >= low[i]:  # below the range and NaN
            x = low[i]
        elif x > high[i]:
            x = high[i]
        m = num_tiles[i]
        j = _slot(x, edges[i], m)
        xi = stats[i, j, 0]
        xi_new = xi + weight  # line 4: Ξ⁺ = Ξ + |δ|
        if xi_new > 0.0:
            mu = stats[i, j, 1]
            mu_new = mu + (weight / xi_new) * (x - mu)  # line 5
            var = (stats[i, j, 2] * xi + weight * (x - mu) * (x - mu_new)) / xi_new  # line 6
            stats[i, j, 0] = xi_new  # line 7
            stats[i, j, 1] = mu_new  # line 8
            stats[i, j, 2] = var if var > 0.0 else 0.0
        if not (stats[i, j, 0] > split_threshold and edges[i, m] > edges[i, 0]):  # lines 9-10
            continue
        num_candidates += 1
        lo, hi = edges[i, j], edges[i, j + 1]
        point = _split_point(stats[i, j, 1], is_discrete[i])
        tolerance = min_width[i] * (1.0 - 1e-9)
        if not (point - lo >= tolerance and hi - point >= tolerance and lo < point < hi):
            continue  # Section 4.2.1: a half would cover less than the floor
        score = stats[i, j, 2]
        if best_dim < 0 or score < best_score:  # line 12: argmin σ² (first on ties)
            best_dim, best_slot, best_score = i, j, score
    if num_candidates == 0 or not can_split:
        return -1, -1, 0.0
    counters[0] += 1
    if best_dim < 0:
        counters[1] += 1  # every candidate was blocked by the floor
        return -1, -1, 0.0
    return best_dim, best_slot, _split_point(stats[best_dim, best_slot, 1], is_discrete[best_dim])
