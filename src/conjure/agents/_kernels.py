"""Numba kernels of the linear TD learners: Q(s, ·) = θᵀφ(s) and the updates of Algs 10-12.

θ has shape (n_features, |A|): row f holds feature f's weight for every action, which is the
per-action copy of φ(s) in Eq. 2.11 without building φ(s, a). Binary φ is an int array of
active indices; dense φ is a float array of all feature values.
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def q_values_binary(weights: np.ndarray, active: np.ndarray) -> np.ndarray:
    """Q(s, ·) = Σ_{f ∈ φ(s)} θ_f."""
    q = np.empty(weights.shape[1])
    q_values_binary_into(weights, active, q)
    return q


@njit(cache=True)
def q_values_binary_into(weights: np.ndarray, active: np.ndarray, q: np.ndarray) -> None:
    """Write Q(s, ·) = Σ_{f ∈ φ(s)} θ_f into ``q`` (no allocation, for compiled loops)."""
    q[:] = 0.0
    for i in range(active.shape[0]):
        row = weights[active[i]]
        for a in range(q.shape[0]):
            q[a] += row[a]


@njit(cache=True)
def q_values_dense(weights: np.ndarray, phi: np.ndarray) -> np.ndarray:
    """Q(s, ·) = Σ_f φ_f(s) θ_f."""
    q = np.zeros(weights.shape[1])
    for f in range(phi.shape[0]):
        value = phi[f]
        if value != 0.0:
            for a in range(q.shape[0]):
                q[a] += value * weights[f, a]
    return q


@njit(cache=True)
def td_step_binary(
    weights: np.ndarray, active: np.ndarray, action: int, target: float, step_size: float
) -> float:
    """δ = target − Q(s, a); θ ← θ + α δ φ(s, a) (Algorithm 11, lines 6-7). Returns δ."""
    q = 0.0
    for i in range(active.shape[0]):
        q += weights[active[i], action]
    delta = target - q
    change = step_size * delta
    for i in range(active.shape[0]):
        weights[active[i], action] += change
    return delta


@njit(cache=True)
def td_step_dense(
    weights: np.ndarray, phi: np.ndarray, action: int, target: float, step_size: float
) -> float:
    """The dense form of `td_step_binary`."""
    q = 0.0
    for f in range(phi.shape[0]):
        q += phi[f] * weights[f, action]
    delta = target - q
    change = step_size * delta
    for f in range(phi.shape[0]):
        weights[f, action] += change * phi[f]
    return delta


@njit(cache=True)
def add_binary(weights: np.ndarray, active: np.ndarray, action: int, amount: float) -> None:
    """θ ← θ + amount · φ(s, a) for binary φ (the actor update of Algorithm 12)."""
    for i in range(active.shape[0]):
        weights[active[i], action] += amount


@njit(cache=True)
def add_dense(weights: np.ndarray, phi: np.ndarray, action: int, amount: float) -> None:
    """θ ← θ + amount · φ(s, a) for dense φ."""
    for f in range(phi.shape[0]):
        weights[f, action] += amount * phi[f]


@njit(cache=True)
def td_step_traces_binary(
    weights: np.ndarray,
    active: np.ndarray,
    action: int,
    target: float,
    step_size: float,
    decay: float,
    is_replacing: bool,
    min_trace: float,
    slot_of: np.ndarray,
    trace_feature: np.ndarray,
    trace_action: np.ndarray,
    trace_value: np.ndarray,
    count: np.ndarray,
) -> float:
    """SARSA(λ) step with sparse eligibility traces e (Sutton and Barto 1998, Fig. 8.8).

    e ← γλ e (dropping traces below ``min_trace``); e(f, a) ← 1 (replacing) or e(f, a) + 1
    (accumulating) for f ∈ φ(s); θ ← θ + α δ e. The live traces are kept in three parallel
    arrays of length ``count[0]``; ``slot_of[f, a]`` is the slot of trace (f, a) or −1.
    Returns δ, or nan before touching anything if the trace arrays could overflow (the caller
    grows them and calls again).
    """
    if count[0] + active.shape[0] > trace_value.shape[0]:
        return np.nan
    q = 0.0
    for i in range(active.shape[0]):
        q += weights[active[i], action]
    delta = target - q
    # Decay and compact the live traces.
    kept = 0
    for i in range(count[0]):
        value = trace_value[i] * decay
        f = trace_feature[i]
        a = trace_action[i]
        if value >= min_trace:
            trace_feature[kept] = f
            trace_action[kept] = a
            trace_value[kept] = value
            slot_of[f, a] = kept
            kept += 1
        else:
            slot_of[f, a] = -1
    for i in range(active.shape[0]):
        f = active[i]
        slot = slot_of[f, action]
        if slot < 0:
            slot = kept
            kept += 1
            slot_of[f, action] = slot
            trace_feature[slot] = f
            trace_action[slot] = action
            trace_value[slot] = 1.0
        elif is_replacing:
            trace_value[slot] = 1.0
        else:
            trace_value[slot] += 1.0
    count[0] = kept
    change = step_size * delta
    for i in range(kept):
        weights[trace_feature[i], trace_action[i]] += change * trace_value[i]
    return delta


@njit(cache=True)
def td_step_traces_dense(
    weights: np.ndarray,
    phi: np.ndarray,
    action: int,
    target: float,
    step_size: float,
    decay: float,
    traces: np.ndarray,
) -> float:
    """SARSA(λ) step with dense accumulating traces: e ← γλ e + φ(s, a); θ ← θ + α δ e."""
    q = 0.0
    for f in range(phi.shape[0]):
        q += phi[f] * weights[f, action]
    delta = target - q
    change = step_size * delta
    for f in range(traces.shape[0]):
        for a in range(traces.shape[1]):
            value = traces[f, a] * decay
            if a == action:
                value += phi[f]
            traces[f, a] = value
            weights[f, a] += change * value
    return delta


@njit(cache=True)
def clear_traces(
    slot_of: np.ndarray, trace_feature: np.ndarray, trace_action: np.ndarray, count: np.ndarray
) -> None:
    """Forget every live sparse trace (at the start of an episode)."""
    for i in range(count[0]):
        slot_of[trace_feature[i], trace_action[i]] = -1
    count[0] = 0
