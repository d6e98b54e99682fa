"""Numba kernel of BlocksWorld: the legal moves of an On(·,·) state (thesis Section 4.1.4).

Legal-action computation dominated RLPy's BlocksWorld (set differences per step); here it is
one O(n²) pass over the 36-entry On vector, compiled. Parameters are validated by the domain.
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["blocks_legal_actions"]


@njit(cache=True)
def blocks_legal_actions(state: np.ndarray, num_blocks: int) -> tuple[np.ndarray, int]:
    """Return (sorted legal actions, 0) for an On vector, or (empty, code) if it is malformed.

    ``state[i * n + j] != 0`` means block i sits on block j, and ``j == i`` means on the table.
    Action ``b * n + d`` moves block b onto d (``d == b``: onto the table); it is legal when b is
    clear and either d is a clear block other than b, or d == b and b is not on the table.
    Codes: 1 a block without exactly one support, 2 two blocks on one block, 3 a cycle.
    """
    n = num_blocks
    on = np.empty(n, dtype=np.int64)
    above = np.full(n, -1, dtype=np.int64)
    empty = np.empty(0, dtype=np.int64)
    for i in range(n):
        support = -1
        count = 0
        for j in range(n):
            if state[i * n + j] != 0.0:
                support = j
                count += 1
        if count != 1:
            return empty, 1
        on[i] = support
    for i in range(n):
        if on[i] != i:
            if above[on[i]] >= 0:
                return empty, 2
            above[on[i]] = i
    for i in range(n):  # every chain must reach the table within n steps
        block = i
        steps = 0
        while on[block] != block:
            block = on[block]
            steps += 1
            if steps > n:
                return empty, 3
    out = np.empty(n * n, dtype=np.int64)
    count = 0
    for b in range(n):
        if above[b] >= 0:
            continue
        for d in range(n):
            if d == b:
                if on[b] != b:
                    out[count] = b * n + d
                    count += 1
            elif above[d] < 0:
                out[count] = b * n + d
                count += 1
    return out[:count].copy(), 0


@njit(cache=True)
def blocks_legal_mask(state: np.ndarray, num_blocks: int) -> np.ndarray:
    """Return the legal moves of a well-formed On vector as a bool mask of length n²."""
    mask = np.zeros(num_blocks * num_blocks, dtype=np.bool_)
    for action in blocks_legal_actions(state, num_blocks)[0]:
        mask[action] = True
    return mask
