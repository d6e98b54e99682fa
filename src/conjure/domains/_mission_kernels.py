"""Numba kernels of the UAV mission MDP (Geramifard 2012, Section 5.3.5).

Every kernel is a pure function of packed arrays (and, for the random step, a
``numpy.random.Generator``), so a compiled learning loop can call them directly:

- ``state``: int64 ``[l_1, f_1, ..., l_n, f_n, v_0, ..., v_{N-1}, t]``, the layout of
  `conjure.domains.mission_graph`;
- ``layout``: int64 ``[n, N, base, H]``;
- ``adjacency``: uint8 (N, N), 1 where an edge joins two nodes and on the diagonal (staying);
- ``node_table``: float64 (N, 4), per node: reward, probability, window start, window end.

Every step consumes exactly 2n uniforms (`mission_transition`), whether or not they decide
anything, so the random stream does not depend on the path taken.

A joint action is a = Σ_i l_i⁺ N^i (UAV 0 is the least significant digit). Parameters and
actions are validated at the domain boundary (STYLE section 7); kernels assume legal input.
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = [
    "advance",
    "checked_legal_actions",
    "checked_transition",
    "collect_targets",
    "count_unintended",
    "crash_penalty",
    "is_crashed",
    "is_legal",
    "is_terminal",
    "legal_actions",
    "mission_step",
    "mission_transition",
    "nominal_next_state",
    "state_from_observation",
    "target_chances",
    "traversals",
]

NUM_UAVS, NUM_NODES, BASE, HORIZON = 0, 1, 2, 3  # layout entries
REWARD, PROBABILITY, WINDOW_START, WINDOW_END = 0, 1, 2, 3  # node_table columns
ILLEGAL = -2  # status of checked_transition for an illegal action


@njit(cache=True)
def is_crashed(state: np.ndarray, layout: np.ndarray) -> bool:
    """A UAV is away from the base with no fuel left, or when the horizon is reached."""
    base, horizon = layout[BASE], layout[HORIZON]
    t = state[state.shape[0] - 1]
    for i in range(layout[NUM_UAVS]):
        if state[2 * i] != base and (state[2 * i + 1] <= 0 or t >= horizon):
            return True
    return False


@njit(cache=True)
def is_terminal(state: np.ndarray, layout: np.ndarray) -> bool:
    """The mission is over: t = H (home or not) or a crash."""
    return state[state.shape[0] - 1] >= layout[HORIZON] or is_crashed(state, layout)


@njit(cache=True)
def is_legal(state: np.ndarray, action: int, layout: np.ndarray, adjacency: np.ndarray) -> bool:
    """Each UAV stays, or moves along an edge with at least one fuel unit left."""
    num_nodes = layout[NUM_NODES]
    if action < 0:
        return False
    rest = action
    for i in range(layout[NUM_UAVS]):
        destination = rest % num_nodes
        rest //= num_nodes
        location = state[2 * i]
        if destination != location and (
            adjacency[location, destination] == 0 or state[2 * i + 1] < 1
        ):
            return False
    return rest == 0


@njit(cache=True)
def legal_actions(state: np.ndarray, layout: np.ndarray, adjacency: np.ndarray) -> np.ndarray:
    """The sorted legal joint actions: the product of each UAV's stay-or-move options."""
    n, num_nodes = layout[NUM_UAVS], layout[NUM_NODES]
    options = np.empty((n, num_nodes), dtype=np.int64)
    counts = np.zeros(n, dtype=np.int64)
    total = 1
    for i in range(n):
        location, fuel = state[2 * i], state[2 * i + 1]
        for node in range(num_nodes):  # increasing node order keeps the output sorted
            if node == location or (adjacency[location, node] != 0 and fuel >= 1):
                options[i, counts[i]] = node
                counts[i] += 1
        total *= counts[i]
    out = np.empty(total, dtype=np.int64)
    digits = np.zeros(n, dtype=np.int64)
    for k in range(total):  # UAV 0 varies fastest: ascending joint actions
        action, power = 0, 1
        for i in range(n):
            action += options[i, digits[i]] * power
            power *= num_nodes
        out[k] = action
        for i in range(n):
            digits[i] += 1
            if digits[i] < counts[i]:
                break
            digits[i] = 0
    return out


@njit(cache=True)
def traversals(state: np.ndarray, action: int, layout: np.ndarray) -> int:
    """Bit i set when UAV i tries to traverse an edge (its destination is another node)."""
    num_nodes = layout[NUM_NODES]
    bits, rest = 0, action
    for i in range(layout[NUM_UAVS]):
        if rest % num_nodes != state[2 * i]:
            bits |= 1 << i
        rest //= num_nodes
    return bits


@njit(cache=True)
def advance(
    state: np.ndarray, action: int, layout: np.ndarray, failed: int
) -> tuple[np.ndarray, int]:
    """Move, burn fuel and tick the clock; UAVs whose bit is set in ``failed`` stay put.

    Returns the next state (visited bits unchanged) and the fuel burnt: one unit per UAV that
    traversed (or tried to) and per UAV loitering away from the base.
    """
    num_nodes, base = layout[NUM_NODES], layout[BASE]
    next_state = state.copy()
    burnt, rest = 0, action
    for i in range(layout[NUM_UAVS]):
        destination = rest % num_nodes
        rest //= num_nodes
        location = state[2 * i]
        if destination != location or location != base:
            burnt += 1
            next_state[2 * i + 1] -= 1
        if destination != location and not (failed >> i) & 1:
            next_state[2 * i] = destination
    next_state[next_state.shape[0] - 1] += 1
    return next_state, burnt


@njit(cache=True)
def target_chances(
    state: np.ndarray, layout: np.ndarray, node_table: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """The nodes where a reward may be obtained now, and the chance 1 − (1 − p_j)^k of each.

    A node qualifies when it has a positive reward, is not yet visited, t lies in its window
    and k >= 1 UAVs are there; nodes are listed in the order of the first UAV at each.
    """
    n = layout[NUM_UAVS]
    t = state[state.shape[0] - 1]
    nodes = np.empty(n, dtype=np.int64)
    chances = np.empty(n, dtype=np.float64)
    count = 0
    for i in range(n):
        node = state[2 * i]
        is_first = True
        for earlier in range(i):
            if state[2 * earlier] == node:
                is_first = False
                break
        if (
            not is_first
            or state[2 * n + node] != 0
            or node_table[node, REWARD] <= 0.0
            or t < node_table[node, WINDOW_START]
            or t > node_table[node, WINDOW_END]
        ):
            continue
        num_there = 0
        for j in range(i, n):
            if state[2 * j] == node:
                num_there += 1
        nodes[count] = node
        chances[count] = 1.0 - (1.0 - node_table[node, PROBABILITY]) ** num_there
        count += 1
    return nodes[:count], chances[:count]


@njit(cache=True)
def collect_targets(
    state: np.ndarray, nodes: np.ndarray, obtained: int, layout: np.ndarray, node_table: np.ndarray
) -> float:
    """Turn on v_j for the ``nodes`` whose bit is set in ``obtained``; return their rewards."""
    first_bit = 2 * layout[NUM_UAVS]
    gain = 0.0
    for c in range(nodes.shape[0]):
        if (obtained >> c) & 1:
            state[first_bit + nodes[c]] = 1
            gain += node_table[nodes[c], REWARD]
    return gain


@njit(cache=True)
def crash_penalty(node_table: np.ndarray) -> float:
    """The failure reward −Σ_j r_j (Section 5.3.5)."""
    return -node_table[:, REWARD].sum()


@njit(cache=True)
def mission_transition(
    state: np.ndarray,
    action: int,
    layout: np.ndarray,
    node_table: np.ndarray,
    traverse_failure: float,
    uniforms: np.ndarray,
) -> tuple[np.ndarray, float, bool, float]:
    """One step from a legal action, given 2n uniforms: (next state, reward, terminated, cost).

    UAV i trying to traverse an edge stays put (burning its fuel) when ``uniforms[i]`` <
    ``traverse_failure``; then, unless the team crashed, the c-th node listed by
    `target_chances` is obtained when ``uniforms[n + c]`` < its chance. A terminal ``state``
    absorbs: it is returned unchanged with reward 0.
    """
    if is_terminal(state, layout):
        return state.copy(), 0.0, True, 0.0
    n = layout[NUM_UAVS]
    tried = traversals(state, action, layout)
    failed = 0
    for i in range(n):
        if (tried >> i) & 1 and uniforms[i] < traverse_failure:
            failed |= 1 << i
    next_state, burnt = advance(state, action, layout, failed)
    if is_crashed(next_state, layout):
        return next_state, crash_penalty(node_table), True, 1.0
    nodes, chances = target_chances(next_state, layout, node_table)
    obtained = 0
    for c in range(nodes.shape[0]):
        if uniforms[n + c] < chances[c]:
            obtained |= 1 << c
    gain = collect_targets(next_state, nodes, obtained, layout, node_table)
    terminated = next_state[next_state.shape[0] - 1] >= layout[HORIZON]
    return next_state, gain - burnt, terminated, 0.0


@njit(cache=True)
def mission_step(
    state: np.ndarray,
    action: int,
    layout: np.ndarray,
    node_table: np.ndarray,
    traverse_failure: float,
    rng: np.random.Generator,
) -> tuple[np.ndarray, float, bool, float]:
    """`mission_transition` with exactly 2n uniforms drawn from ``rng`` (for compiled loops).

    The draws equal ``rng.random(2 * n)``, so `UAVMission.step`, which draws them in Python
    and calls `mission_transition` (a Generator crossing into numba is costly per call),
    follows the same trajectory for the same generator state.
    """
    uniforms = np.empty(2 * layout[NUM_UAVS], dtype=np.float64)
    for k in range(uniforms.shape[0]):
        uniforms[k] = rng.random()
    return mission_transition(state, action, layout, node_table, traverse_failure, uniforms)


@njit(cache=True)
def nominal_next_state(state: np.ndarray, action: int, layout: np.ndarray) -> np.ndarray:
    """Return s' with every traversal succeeding and every target draw failing.

    A terminal ``state`` absorbs.
    """
    if is_terminal(state, layout):
        return state.copy()
    return advance(state, action, layout, 0)[0]


@njit(cache=True)
def count_unintended(
    state: np.ndarray, action: int, next_state: np.ndarray, layout: np.ndarray
) -> tuple[int, int]:
    """(#UAVs that tried to traverse an edge but stayed, #UAVs that tried); (0, 0) if s ended."""
    if is_terminal(state, layout):
        return 0, 0
    tried = traversals(state, action, layout)
    num_failed, num_tried = 0, 0
    for i in range(layout[NUM_UAVS]):
        if (tried >> i) & 1:
            num_tried += 1
            if next_state[2 * i] == state[2 * i]:
                num_failed += 1
    return num_failed, num_tried


@njit(cache=True)
def state_from_observation(observation: np.ndarray, highs: np.ndarray) -> tuple[np.ndarray, int]:
    """(int64 state, -1), or (anything, k) when dimension k is not an integer in [0, highs[k]]."""
    state = np.empty(observation.shape[0], dtype=np.int64)
    for k in range(observation.shape[0]):
        value = observation[k]
        if not (value >= 0.0 and value <= highs[k] and value == np.floor(value)):
            return state, k
        state[k] = np.int64(value)
    return state, -1


@njit(cache=True)
def checked_transition(
    observation: np.ndarray,
    action: int,
    highs: np.ndarray,
    layout: np.ndarray,
    adjacency: np.ndarray,
    node_table: np.ndarray,
    traverse_failure: float,
    uniforms: np.ndarray,
) -> tuple[np.ndarray, float, bool, float, int]:
    """`mission_transition` from a float observation: (s', r, terminated, cost, status).

    One call checks the state and the action and steps (the domain's `step` and `simulate`).
    ``status`` is -1 on success, the index of a bad dimension, or ``ILLEGAL``; on failure the
    other outputs are meaningless.
    """
    state, bad = state_from_observation(observation, highs)
    if bad >= 0:
        return observation, 0.0, False, 0.0, bad
    if not is_legal(state, action, layout, adjacency):
        return observation, 0.0, False, 0.0, ILLEGAL
    next_state, reward, terminated, cost = mission_transition(
        state, action, layout, node_table, traverse_failure, uniforms
    )
    return next_state.astype(np.float64), reward, terminated, cost, -1


@njit(cache=True)
def checked_legal_actions(
    observation: np.ndarray, highs: np.ndarray, layout: np.ndarray, adjacency: np.ndarray
) -> tuple[np.ndarray, int]:
    """(sorted legal joint actions, -1) of a float observation, or (empty, bad dimension)."""
    state, bad = state_from_observation(observation, highs)
    if bad >= 0:
        return np.empty(0, dtype=np.int64), bad
    return legal_actions(state, layout, adjacency), -1


@njit(cache=True)
def checked_legal_mask(
    observation: np.ndarray,
    highs: np.ndarray,
    layout: np.ndarray,
    adjacency: np.ndarray,
    num_actions: int,
) -> np.ndarray:
    """The legal joint actions of a float observation as a bool mask (all False if invalid)."""
    mask = np.zeros(num_actions, dtype=np.bool_)
    for action in checked_legal_actions(observation, highs, layout, adjacency)[0]:
        mask[action] = True
    return mask
