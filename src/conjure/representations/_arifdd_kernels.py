"""Numba kernels of ARiFDD's basic tiles (Geramifard 2012, Algorithm 22, Section 4.2).

The basic tiles of dimension i partition its extent ``[edges[i, 0], edges[i, m_i])`` into
``m_i = num_tiles[i]`` intervals ``[edges[i, j], edges[i, j + 1])``, held in flat arrays:

- ``edges (d, capacity + 1)`` float64: the sorted boundaries (unused slots are +inf);
- ``tile_feature (d, capacity)`` int64: the feature id of the j-th tile of dimension i;
- ``stats (d, capacity, 3)`` float64: Ξ (the sum of |δ|), μ and σ² (the |δ|-weighted mean and
  variance of the states seen in the tile, Alg 22 lines 4-8).

`BasicTiles` holds them with Algorithm 22's settings: the state of `ARiFDD`'s basic tiles,
which its Python methods and the compiled learning loop pass to the same kernels. A split
(`split_at`, lines 2-18) writes the two new features into online iFDD's tables
(`conjure.representations._ifdd_kernels.IFDDTables`) as initial sets.

Inputs are trusted: `ARiFDD` validates at ``setup`` and in ``check_state``.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

from conjure.representations._ifdd_kernels import splitmix64

__all__ = ["BasicTiles", "basic_features", "fits_splits", "record_errors", "split_at", "tile_word"]

_GOLDEN = np.uint64(0x9E3779B97F4A7C15)


class BasicTiles(NamedTuple):
    """ARiFDD's basic tiles φ⁰ and Algorithm 22's settings (arrays updated in place).

    Parameters
    ----------
    edges, num_tiles, tile_feature, stats : ndarray
        The tiles (module docstring).
    low, high : ndarray of float64
        The state range the statistics clip s into.
    min_width : ndarray of float64
        The coverage floor per dimension (Section 4.2.1), in state units.
    is_discrete : ndarray of bool
        Which dimensions split between integer values.
    counters : ndarray of int64
        The steps with a tile past ς and those whose candidates the floor all blocked.
    split_threshold : float
        ς (Alg 22 line 9).
    """

    edges: np.ndarray
    num_tiles: np.ndarray
    tile_feature: np.ndarray
    stats: np.ndarray
    low: np.ndarray
    high: np.ndarray
    min_width: np.ndarray
    is_discrete: np.ndarray
    counters: np.ndarray
    split_threshold: float


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
    tiles: BasicTiles, state: np.ndarray, weight: float, can_split: bool
) -> tuple[int, int, float]:
    """Algorithm 22, lines 2-13: update Ξ, μ, σ² of s's basic tiles, pick the tile to split.

    ``weight`` is |δ|. Among the tiles whose Ξ exceeds ς and whose split at μ leaves both
    halves at least ``min_width`` wide, returns (dimension, tile slot, split point) of the one
    with the least σ² (line 12 as printed). Returns (-1, -1, 0) when no tile passes ς, when
    every one that does is blocked by the floor (counted in ``counters[1]``), or when
    ``can_split`` is False. ``counters[0]`` counts the steps with a tile past ς.
    """
    edges, num_tiles, stats, counters = tiles.edges, tiles.num_tiles, tiles.stats, tiles.counters
    low, high, min_width, is_discrete = tiles.low, tiles.high, tiles.min_width, tiles.is_discrete
    split_threshold = tiles.split_threshold
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


@njit(cache=True)
def tile_word(seed_word: int, feature: int) -> int:
    """A new tile's 64-bit hash word (as int64): splitmix64 of the seed word and its id."""
    return np.int64(splitmix64(np.uint64(seed_word) + np.uint64(feature) * _GOLDEN))


@njit(cache=True)
def fits_splits(tiles: BasicTiles, count: int, num_features: int, t) -> bool:
    """Whether ``count`` splits and ``num_features`` new features fit.

    A split needs a free tile slot in every dimension and two features; a discovery's
    conjunctions need features too (splits add features without iFDD's nodes, so the nodes'
    room does not bound them). ``t``: iFDD's tables.
    """
    for i in range(tiles.num_tiles.shape[0]):
        if tiles.num_tiles[i] + count > tiles.tile_feature.shape[1]:
            return False
    return (
        t.num_features[0] + num_features <= t.feat_start.shape[0]
        and t.pool_used[0] + 2 * count <= t.pool.shape[0]
    )


@njit(cache=True)
def split_at(tiles: BasicTiles, state: np.ndarray, td_error: float, t) -> int:
    """Algorithm 22, lines 2-18, at a state s whose φ̇(s) is one feature: 0 or 2 new features.

    Lines 2-13 by `record_errors` (with ``|δ|``; no split beyond iFDD's ``max_features``);
    a split tile's slot gets the two halves (ids n_t and n_t + 1, lower first), which join
    iFDD's tables ``t`` as initial sets {f₁}, {f₂} with parents (t, −1) (line 15). The tables
    and tiles must fit it (`fits_splits`).
    """
    t.num_calls[0] += 1
    first = t.num_features[0]
    dim, slot, point = record_errors(tiles, state, abs(td_error), first + 2 <= t.max_features[0])
    if dim < 0:
        return 0
    tile = _split_tile(tiles, dim, slot, point, first)
    for feature in range(first, first + 2):  # line 15: {f₁}, {f₂} join χ as initial sets
        used = t.pool_used[0]
        t.pool[used] = feature
        t.pool_used[0] = used + 1
        t.feat_start[feature] = used
        t.feat_len[feature] = 1
        t.feat_parents[feature, 0] = tile
        t.feat_parents[feature, 1] = -1
        t.words[feature] = tile_word(t.random_word[0], feature)
    t.num_features[0] = first + 2
    return 2  # lines 16-18: no conjunction on the retired tile is ever activated again


@njit(cache=True)
def _split_tile(tiles: BasicTiles, dim: int, slot: int, point: float, first: int) -> int:
    """Lines 13-14: tile ``slot`` of ``dim`` becomes ``first`` (below ``point``) and ``first + 1``.

    Returns the retired tile's id. The later tiles move up one slot; the halves' statistics
    start at zero.
    """
    edges, tile_feature, stats = tiles.edges[dim], tiles.tile_feature[dim], tiles.stats[dim]
    m = tiles.num_tiles[dim]
    tile = tile_feature[slot]
    for j in range(m, slot, -1):  # from the top: the slots overlap
        edges[j + 1] = edges[j]
        tile_feature[j] = tile_feature[j - 1]
        for k in range(3):
            stats[j, k] = stats[j - 1, k]
    edges[slot + 1] = point
    tile_feature[slot] = first
    tile_feature[slot + 1] = first + 1
    for k in range(3):
        stats[slot, k] = 0.0
        stats[slot + 1, k] = 0.0
    tiles.num_tiles[dim] = m + 1
    return tile
