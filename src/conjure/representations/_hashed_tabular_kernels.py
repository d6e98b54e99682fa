"""Numba kernels of `HashedTabular`: an open-addressing index of grid cells in first-seen order.

A state's key is its cell, the vector of its buckets per dimension (``_kernels.dimension_table``:
a discrete dimension's bucket is ``value − low``). Arrays, built by ``HashedTabular.setup``:

- ``slots (2^m,)`` int64: −1 for an empty slot, else the index of the cell stored there;
  ``2^m >= 2 · capacity``, so the load factor stays at or below 1/2;
- ``cells (capacity, d)`` int64: row i is the cell of index i (indices in first-seen order);
- ``counts (1,)`` int64: the number of cells stored.

A probe compares the whole stored cell with the query, so two cells whose hashes collide get
two indices: keys are never merged. Inputs are trusted (validated in ``setup``/``check_state``).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from conjure.representations._kernels import _bucket, _mix

__all__ = ["cell_hash", "find_cell", "lookup_cell", "peek_cell", "rebuild_slots", "state_cell"]

EMPTY = -1
#: `find_cell`'s answer when the cell is new and the table holds ``capacity`` cells already.
FULL = -2


@njit(cache=True)
def state_cell(state: np.ndarray, dims: np.ndarray) -> np.ndarray:
    """Return the cell of ``state``: its bucket in every dimension."""
    d = state.shape[0]
    cell = np.empty(d, dtype=np.int64)
    for i in range(d):
        cell[i] = _bucket(state[i], dims[i, 0], dims[i, 1], dims[i, 2], dims[i, 3])
    return cell


@njit(cache=True)
def cell_hash(cell: np.ndarray) -> np.uint64:
    """A 64-bit hash of a cell: splitmix64 folded over its entries (order-sensitive)."""
    h = np.uint64(0x9E3779B97F4A7C15)
    for i in range(cell.shape[0]):
        h = _mix(h ^ np.uint64(cell[i] + 1))
    return h


@njit(cache=True, inline="always")
def _is_stored_at(cell: np.ndarray, cells: np.ndarray, index: int) -> bool:
    for i in range(cell.shape[0]):
        if cells[index, i] != cell[i]:
            return False
    return True


@njit(cache=True)
def _probe(cell: np.ndarray, slots: np.ndarray, cells: np.ndarray) -> int:
    """Return the slot holding ``cell``, or the empty slot where it would go."""
    mask = slots.shape[0] - 1
    slot = np.int64(cell_hash(cell) & np.uint64(mask))
    while True:
        index = slots[slot]
        if index == EMPTY or _is_stored_at(cell, cells, index):
            return slot
        slot = (slot + 1) & mask  # linear probing


@njit(cache=True)
def find_cell(
    state: np.ndarray, dims: np.ndarray, slots: np.ndarray, cells: np.ndarray, counts: np.ndarray
) -> np.ndarray:
    """φ(s) as a one-element array: the index of s's cell, stored first if it is new.

    Returns ``[FULL]`` (and stores nothing) when the cell is new and the table is full.
    """
    cell = state_cell(state, dims)
    slot = _probe(cell, slots, cells)
    out = np.empty(1, dtype=np.int64)
    index = slots[slot]
    if index == EMPTY:
        index = counts[0]
        if index == cells.shape[0]:
            out[0] = FULL
            return out
        cells[index] = cell
        slots[slot] = index
        counts[0] = index + 1
    out[0] = index
    return out


@njit(cache=True)
def peek_cell(
    state: np.ndarray, dims: np.ndarray, slots: np.ndarray, cells: np.ndarray, counts: np.ndarray
) -> np.ndarray:
    """`find_cell` storing nothing: the index of s's cell, or the one it would get if new.

    A new cell's index, ``counts[0]``, is a row no update has touched, so φ(s) gives the same
    values as after storing it; a new cell of a full table gets no feature (an empty array).
    """
    index = lookup_cell(state, dims, slots, cells)
    if index == EMPTY:
        index = counts[0]
    num_active = 0 if index == cells.shape[0] else 1
    out = np.empty(num_active, dtype=np.int64)
    if num_active:
        out[0] = index
    return out


@njit(cache=True)
def lookup_cell(state: np.ndarray, dims: np.ndarray, slots: np.ndarray, cells: np.ndarray) -> int:
    """Return the index of s's cell, or −1 if it has not been stored (stores nothing)."""
    return slots[_probe(state_cell(state, dims), slots, cells)]


@njit(cache=True)
def rebuild_slots(slots: np.ndarray, cells: np.ndarray, num_stored: int) -> None:
    """Refill an all-empty ``slots`` from the first ``num_stored`` cells (after a restore)."""
    for index in range(num_stored):
        slots[_probe(cells[index], slots, cells)] = index
