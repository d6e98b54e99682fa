"""Kernels of the representation-expanding baselines (Geramifard 2012, Section 4.1.4).

Adaptive tile coding (Whiteson et al., 2007) keeps its tiles as the leaves of a kd-tree in flat
arrays; sparse distributed memories (Ratitch & Precup, 2004) keep their prototypes in a
uniform grid of linked lists. Inputs are trusted: the representations validate at ``setup``.
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = [
    "atc_leaf",
    "atc_record",
    "sdm_active",
    "sdm_cell",
]


# ---------------------------------------------------------------------------------------------
# Adaptive tile coding
#
# node_dim (N,) int64: the split dimension of an inner node, -1 for a leaf (a tile).
# node_threshold (N,) float64: inner nodes send x[dim] >= threshold to the right child.
# node_left (N,) int64: the left child; the right child is node_left + 1.
# node_feature (N,) int64: the tile (feature) of a leaf.


@njit(cache=True)
def atc_leaf(
    state: np.ndarray,
    node_dim: np.ndarray,
    node_threshold: np.ndarray,
    node_left: np.ndarray,
    node_feature: np.ndarray,
) -> np.ndarray:
    """Return the one tile holding ``state``: descend the kd-tree from the root (node 0)."""
    node = 0
    while node_dim[node] >= 0:
        # NaN compares False and goes left, like values below the range
        node = node_left[node] + (1 if state[node_dim[node]] >= node_threshold[node] else 0)
    out = np.empty(1, dtype=np.int64)
    out[0] = node_feature[node]
    return out


@njit(cache=True, inline="always")
def _split_point(low: float, high: float, is_discrete: bool) -> float:
    """The midpoint of [low, high); a discrete tile [a - 1/2, b + 1/2) splits between values."""
    if is_discrete:
        return low + np.floor(np.round(high - low) / 2.0)
    return 0.5 * (low + high)


@njit(cache=True)
def atc_record(
    tile: int,
    state: np.ndarray,
    td_error: float,
    patience: int,
    can_split: bool,
    tile_low: np.ndarray,
    tile_high: np.ndarray,
    is_discrete: np.ndarray,
    min_half_width: np.ndarray,
    lowest_error: np.ndarray,
    num_since_lowest: np.ndarray,
    half_sums: np.ndarray,
    half_counts: np.ndarray,
) -> int:
    """Record one TD error δ of ``tile``; return the dimension to split it along, or -1.

    Whiteson et al. (2007): a tile whose lowest |δ| has not improved for ``patience`` updates
    has stopped learning. The value criterion splits it along the dimension whose two
    prospective halves disagree most: here the gap between the mean δ observed in each half.
    """
    error = abs(td_error)
    if error < lowest_error[tile]:
        lowest_error[tile] = error
        num_since_lowest[tile] = 0
    else:
        num_since_lowest[tile] += 1
    d = tile_low.shape[1]
    for i in range(d):
        mid = _split_point(tile_low[tile, i], tile_high[tile, i], is_discrete[i])
        half = 1 if state[i] >= mid else 0
        half_sums[tile, i, half] += td_error
        half_counts[tile, i, half] += 1
    if num_since_lowest[tile] < patience or not can_split:
        return -1
    num_since_lowest[tile] = 0  # whether or not a dimension qualifies, wait again
    best, best_gap = -1, -1.0
    for i in range(d):
        width = tile_high[tile, i] - tile_low[tile, i]
        if is_discrete[i]:
            if np.round(width) < 2.0:
                continue
        elif not (width > 0.0 and 0.5 * width >= min_half_width[i]):
            continue
        n0, n1 = half_counts[tile, i, 0], half_counts[tile, i, 1]
        if n0 == 0 or n1 == 0:
            continue
        gap = abs(half_sums[tile, i, 0] / n0 - half_sums[tile, i, 1] / n1)
        if gap > best_gap:
            best, best_gap = i, gap
    return best


# ---------------------------------------------------------------------------------------------
# Sparse distributed memories
#
# Coordinates are normalised, u = (s - low) / (high - low) clipped into [0, 1] (NaN -> 0).
# grid (G, 3) int64 rows [dim, cells, stride]: the cell of u along dim is
#   min(floor(u * cells), cells - 1); a cell's id is the sum of coordinate * stride.
# cell_head (C,) int64: first prototype of each cell, -1 if empty; next_in_cell (K,) links.


@njit(cache=True, inline="always")
def _normalise(state: np.ndarray, low: np.ndarray, inverse_range: np.ndarray) -> np.ndarray:
    d = state.shape[0]
    u = np.empty(d, dtype=np.float64)
    for i in range(d):
        v = (state[i] - low[i]) * inverse_range[i]
        if not v >= 0.0:  # below the range, -inf and NaN
            v = 0.0
        elif v > 1.0:
            v = 1.0
        u[i] = v
    return u


@njit(cache=True, inline="always")
def _cell_coordinate(v: float, cells: int) -> int:
    c = int(np.floor(v * cells))
    if c < 0:
        return 0
    if c >= cells:
        return cells - 1
    return c


@njit(cache=True)
def sdm_cell(u: np.ndarray, grid: np.ndarray) -> int:
    """Return the grid cell of the normalised point ``u``."""
    cell = 0
    for g in range(grid.shape[0]):
        cell += _cell_coordinate(u[grid[g, 0]], grid[g, 1]) * grid[g, 2]
    return cell


@njit(cache=True)
def sdm_active(
    state: np.ndarray,
    low: np.ndarray,
    inverse_range: np.ndarray,
    radius: np.ndarray,
    centers: np.ndarray,
    grid: np.ndarray,
    cell_head: np.ndarray,
    next_in_cell: np.ndarray,
) -> np.ndarray:
    """Return the sorted prototypes k with |u_i − c_ki| <= r_i in every dimension i.

    Only the grid cells that the box u ± r overlaps are visited (2 per grid dimension when
    cells are at least 2r wide), so the cost depends on the local density, not on K.
    """
    u = _normalise(state, low, inverse_range)
    d = u.shape[0]
    num_grid = grid.shape[0]
    first = np.empty(num_grid, dtype=np.int64)
    last = np.empty(num_grid, dtype=np.int64)
    coordinate = np.empty(num_grid, dtype=np.int64)
    for g in range(num_grid):
        i, cells = grid[g, 0], grid[g, 1]
        first[g] = _cell_coordinate(u[i] - radius[i], cells)
        last[g] = _cell_coordinate(u[i] + radius[i], cells)
        coordinate[g] = first[g]
    out = np.empty(16, dtype=np.int64)
    count = 0
    while True:
        cell = 0
        for g in range(num_grid):
            cell += coordinate[g] * grid[g, 2]
        k = cell_head[cell]
        while k >= 0:
            inside = True
            for i in range(d):
                if abs(u[i] - centers[k, i]) > radius[i]:
                    inside = False
                    break
            if inside:
                if count == out.shape[0]:
                    bigger = np.empty(2 * count, dtype=np.int64)
                    bigger[:count] = out
                    out = bigger
                out[count] = k
                count += 1
            k = next_in_cell[k]
        # odometer over the overlapped cells
        g = 0
        while g < num_grid:
            if coordinate[g] < last[g]:
                coordinate[g] += 1
                break
            coordinate[g] = first[g]
            g += 1
        if g == num_grid:
            break
    return np.sort(out[:count])
