"""Numba kernels of BlocksWorld: the moves and legal moves of On(·,·) states (thesis §4.1.4).

Legal-action computation dominated RLPy's BlocksWorld (set differences per step); here it is
one O(n²) pass over the 36-entry On vector, compiled. The move itself (`blocks_transition`) is
the one implementation of the dynamics: `BlocksWorld.step` calls it through
`blocks_masked_transition`, and so does the compiled loop. Parameters are
validated by the domain.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

__all__ = [
    "NO_BLOCKS",
    "BlocksConstants",
    "blocks_fill_legal_mask",
    "blocks_legal_actions",
    "blocks_masked_transition",
    "blocks_reset",
    "blocks_transition",
    "legal_moves_into",
]


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
    count = legal_moves_into(on, above, n, out)
    return out[:count].copy(), 0


@njit(cache=True, inline="always")
def _is_legal_move(on: np.ndarray, above: np.ndarray, b: int, d: int) -> bool:
    """move(b, d): b is clear, and d is a clear other block or, for d = b, the table under b."""
    if above[b] >= 0:
        return False
    return on[b] != b if d == b else above[d] < 0


@njit(cache=True)
def legal_moves_into(on: np.ndarray, above: np.ndarray, num_blocks: int, out: np.ndarray) -> int:
    """Write the sorted legal moves of a well-formed state into ``out``; return their number.

    ``on[i]`` is block i's support (i itself: the table) and ``above[i]`` the block on i or
    -1 (int or float arrays).
    """
    n = num_blocks
    count = 0
    for b in range(n):
        for d in range(n):
            if _is_legal_move(on, above, b, d):
                out[count] = b * n + d
                count += 1
    return count


# The domain's state, shared by `BlocksWorld` and the compiled loop: ``dstate`` (int64) =
# [On vector (n²), on (n), above (n)]; its constants are a `BlocksConstants`.


class BlocksConstants(NamedTuple):
    """BlocksWorld's constants as its kernels read them by name (`BlocksWorld` and the loop)."""

    num_blocks: int
    drop: float
    step_reward: float
    goal_reward: float


#: The `BlocksConstants` of a compiled form that is not BlocksWorld's.
NO_BLOCKS = BlocksConstants(num_blocks=0, drop=0.0, step_reward=0.0, goal_reward=0.0)


@njit(cache=True)
def blocks_reset(num_blocks: int, dstate: np.ndarray, obs: np.ndarray) -> None:
    """Put every block on the table (`BlocksWorld.reset`; no random draw)."""
    n = num_blocks
    nn = n * n
    dstate[:nn] = 0
    for b in range(n):
        dstate[b * n + b] = 1
        dstate[nn + b] = b
        dstate[nn + n + b] = -1
    for i in range(nn):
        obs[i] = dstate[i]


@njit(cache=True)
def blocks_transition(
    constants: BlocksConstants, dstate: np.ndarray, action: int, obs: np.ndarray, uniform: float
) -> tuple[float, bool]:
    """Apply the legal move ``action`` given its one uniform draw; (reward, terminated).

    The block drops onto the table when ``uniform`` < the drop probability. ``dstate`` and
    ``obs`` are updated in place.
    """
    n = constants.num_blocks
    nn = n * n
    block = action // n
    target = action % n
    source = dstate[nn + block]
    if uniform < constants.drop:
        target = block  # dropped: lands on the table
    if source != block:
        dstate[nn + n + source] = -1
    if target != block:
        dstate[nn + n + target] = block
    dstate[nn + block] = target
    dstate[block * n + source] = 0
    dstate[block * n + target] = 1
    for i in range(nn):
        obs[i] = dstate[i]
    terminated = block == n - 1 and target == n - 2 and dstate[nn] == 0
    for i in range(1, n):
        if not terminated:
            break
        terminated = dstate[nn + i] == i - 1
    return (constants.goal_reward if terminated else constants.step_reward), terminated


@njit(cache=True)
def blocks_fill_legal_mask(dstate: np.ndarray, num_blocks: int, mask: np.ndarray) -> int:
    """Write the legal-move mask of ``dstate`` into ``mask`` (1 legal, 0 not); return the count.

    Allocates nothing: the compiled loop's step calls it every step.
    """
    n = num_blocks
    nn = n * n
    on, above = dstate[nn : nn + n], dstate[nn + n :]
    count = 0
    for b in range(n):
        for d in range(n):
            is_legal = _is_legal_move(on, above, b, d)
            mask[b * n + d] = is_legal
            count += is_legal
    return count


@njit(cache=True)
def blocks_masked_transition(
    constants: BlocksConstants,
    dstate: np.ndarray,
    action: int,
    obs: np.ndarray,
    uniform: float,
    mask: np.ndarray,
) -> tuple[float, bool]:
    """`blocks_transition`, then the new state's legal mask into ``mask`` (`BlocksWorld.step`)."""
    reward, terminated = blocks_transition(constants, dstate, action, obs, uniform)
    blocks_fill_legal_mask(dstate, constants.num_blocks, mask)
    return reward, terminated
