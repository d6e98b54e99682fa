"""Exact backward induction for UAV missions (Geramifard 2012, Section 5.3.5, Figure 5-6b).

t is part of the state and grows by one every step, so the states reachable from s₀ fall
into time layers 0 .. H−1 and one backward pass over the layers solves the finite-horizon
MDP exactly (γ = 1): V_H = 0 and V_t(s) = max_a Σ_{s'} P^a_{ss'} (R + V_{t+1}(s')). The same
pass with min gives the worst policy. States get an integer key within their layer:

    key = ((visited target bits) · Π_i (F_i + 1) + fuel digits) · N^n + location digits

where only nodes with a positive reward have a bit (the others never turn on). Each layer is
held as a dense array over all keys, so a layer costs Θ(2^m Π(F_i + 1) N^n) memory.

A fixed deterministic policy is evaluated exactly by the forward pass alone
(`evaluate_policy`): the probability of reaching each state under it, layer by layer, gives
V^π(s₀) = Σ_t Σ_s Pr(s_t = s) E[r | s, π(s)] and the probability of a crash.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numba import njit

from conjure.domains._mission_kernels import (
    HORIZON,
    NUM_NODES,
    NUM_UAVS,
    advance,
    collect_targets,
    crash_penalty,
    is_crashed,
    is_legal,
    legal_actions,
    target_chances,
    traversals,
)

__all__ = ["action_values", "evaluate_policy", "layer_size", "solve_mission", "state_key"]

ENDED, CRASHED = -1, -2  # the key `_outcomes` gives a terminal outcome: t = H, or a crash


def layer_size(num_nodes: int, fuel: tuple[int, ...], num_targets: int) -> int:
    """Number of keys of one time layer: 2^m · Π_i (F_i + 1) · N^n (Python ints, no overflow)."""
    size = 2**num_targets * num_nodes ** len(fuel)
    for f in fuel:
        size *= f + 1
    return size


@njit(cache=True)
def state_key(
    state: np.ndarray, layout: np.ndarray, fuel_caps: np.ndarray, target_bit: np.ndarray
) -> int:
    """The key of ``state`` within its time layer (see the module notes)."""
    n, num_nodes = layout[NUM_UAVS], layout[NUM_NODES]
    key = 0
    for j in range(num_nodes):
        if target_bit[j] >= 0 and state[2 * n + j] != 0:
            key |= 1 << target_bit[j]
    for i in range(n):
        key = key * (fuel_caps[i] + 1) + state[2 * i + 1]
    for i in range(n):
        key = key * num_nodes + state[2 * i]
    return key


@njit(cache=True)
def _decode(
    key: int,
    t: int,
    layout: np.ndarray,
    fuel_caps: np.ndarray,
    target_nodes: np.ndarray,
) -> np.ndarray:
    n, num_nodes = layout[NUM_UAVS], layout[NUM_NODES]
    state = np.zeros(2 * n + num_nodes + 1, dtype=np.int64)
    rest = key
    for i in range(n - 1, -1, -1):
        state[2 * i] = rest % num_nodes
        rest //= num_nodes
    for i in range(n - 1, -1, -1):
        state[2 * i + 1] = rest % (fuel_caps[i] + 1)
        rest //= fuel_caps[i] + 1
    for b in range(target_nodes.shape[0]):
        if (rest >> b) & 1:
            state[2 * n + target_nodes[b]] = 1
    state[state.shape[0] - 1] = t
    return state


@njit(cache=True)
def _outcome_buffers(layout: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Room for the (probability, reward, key) of every outcome `_outcomes` may write (4^n)."""
    max_outcomes = 1 << (2 * layout[NUM_UAVS])
    return (
        np.empty(max_outcomes, dtype=np.float64),
        np.empty(max_outcomes, dtype=np.float64),
        np.empty(max_outcomes, dtype=np.int64),
    )


@njit(cache=True)
def _outcomes(
    state: np.ndarray,
    action: int,
    layout: np.ndarray,
    node_table: np.ndarray,
    traverse_failure: float,
    fuel_caps: np.ndarray,
    target_bit: np.ndarray,
    probabilities: np.ndarray,
    rewards: np.ndarray,
    keys: np.ndarray,
) -> int:
    """Write every outcome of (s, a) as (probability, reward, key, `ENDED` or `CRASHED`).

    The outcomes are those of `mission_step`: each traversal fails with probability η, then
    (without a crash) each qualifying target is obtained with its chance.
    """
    n = layout[NUM_UAVS]
    tried = traversals(state, action, layout)
    movers = np.empty(n, dtype=np.int64)
    num_movers = 0
    if traverse_failure > 0.0:
        for i in range(n):
            if (tried >> i) & 1:
                movers[num_movers] = i
                num_movers += 1
    count = 0
    for pattern in range(1 << num_movers):
        p_move, failed = 1.0, 0
        for b in range(num_movers):
            if (pattern >> b) & 1:
                p_move *= traverse_failure
                failed |= 1 << movers[b]
            else:
                p_move *= 1.0 - traverse_failure
        if p_move == 0.0:
            continue
        moved, burnt = advance(state, action, layout, failed)
        if is_crashed(moved, layout):
            probabilities[count], rewards[count] = p_move, crash_penalty(node_table)
            keys[count] = CRASHED
            count += 1
            continue
        nodes, chances = target_chances(moved, layout, node_table)
        is_last = moved[moved.shape[0] - 1] >= layout[HORIZON]
        for obtained in range(1 << nodes.shape[0]):
            p = p_move
            for c in range(nodes.shape[0]):
                p *= chances[c] if (obtained >> c) & 1 else 1.0 - chances[c]
            if p == 0.0:
                continue
            after = moved.copy()
            gain = collect_targets(after, nodes, obtained, layout, node_table)
            probabilities[count], rewards[count] = p, gain - burnt
            keys[count] = ENDED if is_last else state_key(after, layout, fuel_caps, target_bit)
            count += 1
    return count


@njit(cache=True)
def solve_mission(
    start: np.ndarray,
    layout: np.ndarray,
    adjacency: np.ndarray,
    node_table: np.ndarray,
    traverse_failure: float,
    fuel_caps: np.ndarray,
    target_bit: np.ndarray,
    target_nodes: np.ndarray,
    num_keys: int,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Backward induction over the states reachable from ``start`` (a non-terminal t = 0 state).

    Returns (layer_sizes, local keys, V*, V_worst, optimal action, worst action) of every
    reachable non-terminal state, layer by layer (t = 0 .. H−1) and by key within a layer.
    Ties go to the lowest action index.
    """
    horizon = layout[HORIZON]
    probabilities, rewards, keys = _outcome_buffers(layout)

    # Forward: the reachable keys of every layer.
    layers = [np.array([state_key(start, layout, fuel_caps, target_bit)], dtype=np.int64)]
    for t in range(horizon - 1):
        is_reached = np.zeros(num_keys, dtype=np.uint8)
        for key in layers[t]:
            state = _decode(key, t, layout, fuel_caps, target_nodes)
            for action in legal_actions(state, layout, adjacency):
                count = _outcomes(
                    state, action, layout, node_table, traverse_failure, fuel_caps,
                    target_bit, probabilities, rewards, keys,
                )  # fmt: skip
                for o in range(count):
                    if keys[o] >= 0:
                        is_reached[keys[o]] = 1
        layers.append(np.flatnonzero(is_reached).astype(np.int64))

    sizes = np.empty(horizon, dtype=np.int64)
    for t in range(horizon):
        sizes[t] = layers[t].shape[0]
    offsets = np.zeros(horizon + 1, dtype=np.int64)
    offsets[1:] = np.cumsum(sizes)
    all_keys = np.empty(offsets[horizon], dtype=np.int64)
    best = np.empty(offsets[horizon], dtype=np.float64)
    worst = np.empty(offsets[horizon], dtype=np.float64)
    best_actions = np.empty(offsets[horizon], dtype=np.int64)
    worst_actions = np.empty(offsets[horizon], dtype=np.int64)

    # Backward: V_t from V_{t+1} (dense over the layer's keys; V_H = 0).
    best_next = np.zeros(num_keys, dtype=np.float64)
    worst_next = np.zeros(num_keys, dtype=np.float64)
    for t in range(horizon - 1, -1, -1):
        best_here = np.zeros(num_keys, dtype=np.float64)
        worst_here = np.zeros(num_keys, dtype=np.float64)
        for index in range(sizes[t]):
            key = layers[t][index]
            state = _decode(key, t, layout, fuel_caps, target_nodes)
            high, low = -np.inf, np.inf
            high_action, low_action = -1, -1
            for action in legal_actions(state, layout, adjacency):
                count = _outcomes(
                    state, action, layout, node_table, traverse_failure, fuel_caps,
                    target_bit, probabilities, rewards, keys,
                )  # fmt: skip
                q_high, q_low = 0.0, 0.0
                for o in range(count):
                    q_high += probabilities[o] * rewards[o]
                    q_low += probabilities[o] * rewards[o]
                    if keys[o] >= 0:
                        q_high += probabilities[o] * best_next[keys[o]]
                        q_low += probabilities[o] * worst_next[keys[o]]
                if q_high > high:
                    high, high_action = q_high, action
                if q_low < low:
                    low, low_action = q_low, action
            best_here[key], worst_here[key] = high, low
            row = offsets[t] + index
            all_keys[row], best[row], worst[row] = key, high, low
            best_actions[row], worst_actions[row] = high_action, low_action
        best_next, worst_next = best_here, worst_here
    return sizes, all_keys, best, worst, best_actions, worst_actions


@njit(cache=True)
def action_values(
    state: np.ndarray,
    layout: np.ndarray,
    adjacency: np.ndarray,
    node_table: np.ndarray,
    traverse_failure: float,
    fuel_caps: np.ndarray,
    target_bit: np.ndarray,
    solution_keys: np.ndarray,
    values: np.ndarray,
    num_keys: int,
) -> tuple[np.ndarray, np.ndarray]:
    """(legal actions, Q(s, a) = Σ_{s'} P^a_{ss'} (R + V(s'))) of a non-terminal ``state``.

    ``solution_keys`` (t · num_keys + key, ascending) and ``values`` are the rows of
    `solve_mission`; every non-terminal outcome of a legal action is among them.
    """
    probabilities, rewards, keys = _outcome_buffers(layout)
    offset = (state[state.shape[0] - 1] + 1) * num_keys  # the next layer's keys
    actions = legal_actions(state, layout, adjacency)
    q = np.zeros(actions.shape[0], dtype=np.float64)
    for k in range(actions.shape[0]):
        count = _outcomes(
            state, actions[k], layout, node_table, traverse_failure, fuel_caps, target_bit,
            probabilities, rewards, keys,
        )  # fmt: skip
        for o in range(count):
            q[k] += probabilities[o] * rewards[o]
            if keys[o] >= 0:
                row = np.searchsorted(solution_keys, offset + keys[o])
                q[k] += probabilities[o] * values[row]
    return actions, q


def evaluate_policy(
    start: np.ndarray,
    policy: Callable[[np.ndarray], int],
    layout: np.ndarray,
    adjacency: np.ndarray,
    node_table: np.ndarray,
    traverse_failure: float,
    fuel_caps: np.ndarray,
    target_bit: np.ndarray,
    target_nodes: np.ndarray,
) -> tuple[float, float, np.ndarray, np.ndarray, np.ndarray]:
    """Exact forward evaluation of a deterministic policy from ``start`` (t = 0, non-terminal).

    ``policy`` maps an int64 state to a joint action; it is asked once per reached state.
    Return (V^π(s₀), crash probability, reached non-terminal states (k, 2n + N + 1) int64 by
    time and key, their probability of being reached, the policy's action in each). Raise
    ValueError naming the state when the policy picks an illegal action.
    """
    probabilities, rewards, keys = _outcome_buffers(layout)
    layer = {int(state_key(start, layout, fuel_caps, target_bit)): 1.0}
    value, crash = 0.0, 0.0
    states, reach, actions = [], [], []
    for t in range(int(layout[HORIZON])):
        next_layer: dict[int, float] = {}
        for key in sorted(layer):
            mass = layer[key]
            state = _decode(key, t, layout, fuel_caps, target_nodes)
            action = int(policy(state))
            if not is_legal(state, action, layout, adjacency):
                raise ValueError(f"action {action} is illegal in state {state.tolist()}")
            count = _outcomes(
                state, action, layout, node_table, traverse_failure, fuel_caps, target_bit,
                probabilities, rewards, keys,
            )  # fmt: skip
            for o in range(count):
                p = mass * probabilities[o]
                value += p * rewards[o]
                if keys[o] == CRASHED:
                    crash += p
                elif keys[o] >= 0:
                    next_layer[int(keys[o])] = next_layer.get(int(keys[o]), 0.0) + p
            states.append(state)
            reach.append(mass)
            actions.append(action)
        layer = next_layer
    return (
        value,
        crash,
        np.array(states, dtype=np.int64),
        np.array(reach, dtype=np.float64),
        np.array(actions, dtype=np.int64),
    )
