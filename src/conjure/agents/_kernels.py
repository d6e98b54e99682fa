"""Numba kernels of the linear TD learners: Q(s, ·) = θᵀφ(s) and the updates of Algs 10-12.

θ has shape (n_features, |A|): row f holds feature f's weight for every action, which is the
per-action copy of φ(s) in Eq. 2.11 without building φ(s, a). φ(s) is sparse
(`conjure.core.SparseFeatures`): sorted ``indices`` with their ``values``. ``values`` may be
``None`` for binary φ (every value 1; numba compiles that case without reading a value): the
compiled loops (`conjure.compiled`) pass binary φ that way. Multiplying by a value of 1.0 is
exact, so binary φ gives bit-identical results either way.
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True, inline="always")
def _value(values: np.ndarray | None, i: int) -> float:
    """φ's i-th listed value (1 when ``values`` is None)."""
    if values is None:
        return 1.0
    return values[i]


@njit(cache=True)
def q_values(weights: np.ndarray, indices: np.ndarray, values: np.ndarray | None) -> np.ndarray:
    """Q(s, ·) = Σ_i φ_i(s) θ_i over the listed features."""
    q = np.empty(weights.shape[1])
    q_values_into(weights, indices, values, q)
    return q


@njit(cache=True)
def q_values_into(
    weights: np.ndarray, indices: np.ndarray, values: np.ndarray | None, q: np.ndarray
) -> None:
    """Write Q(s, ·) = Σ_i φ_i(s) θ_i into ``q`` (no allocation, for compiled loops)."""
    q[:] = 0.0
    for i in range(indices.shape[0]):
        row = weights[indices[i]]
        value = _value(values, i)
        for a in range(q.shape[0]):
            q[a] += row[a] * value


@njit(cache=True)
def td_step(
    weights: np.ndarray,
    indices: np.ndarray,
    values: np.ndarray | None,
    action: int,
    target: float,
    step_size: float,
) -> float:
    """δ = target − Q(s, a); θ ← θ + α δ φ(s, a) (Algorithm 11, lines 6-7). Returns δ."""
    q = 0.0
    for i in range(indices.shape[0]):
        q += weights[indices[i], action] * _value(values, i)
    delta = target - q
    add(weights, indices, values, action, step_size * delta)
    return delta


@njit(cache=True)
def add(
    weights: np.ndarray,
    indices: np.ndarray,
    values: np.ndarray | None,
    action: int,
    amount: float,
) -> None:
    """θ ← θ + amount · φ(s, a) (the TD and actor updates of Algorithms 11-12)."""
    for i in range(indices.shape[0]):
        weights[indices[i], action] += amount * _value(values, i)


@njit(cache=True)
def add_log_policy_gradient(
    weights: np.ndarray,
    indices: np.ndarray,
    values: np.ndarray | None,
    action: int,
    probabilities: np.ndarray,
    amount: float,
) -> None:
    """ω_b ← ω_b + amount · φ(s) (𝟙[b = a] − π(s, b)) for every action b: ∇_ω log π(s, a).

    The gradient of a Gibbs policy over ρ(s, ·) = ωᵀψ(s, ·) at τ = 1 (Bhatnagar et al. 2009's
    compatible features, ψ(s, a) − Σ_b π(s, b) ψ(s, b)).
    """
    for i in range(indices.shape[0]):
        row = weights[indices[i]]
        value = amount * _value(values, i)
        for b in range(row.shape[0]):
            row[b] -= value * probabilities[b]
        row[action] += value


@njit(cache=True)
def decay_row_traces(
    slot_of: np.ndarray,
    rows: np.ndarray,
    traces: np.ndarray,
    count: np.ndarray,
    factor: float,
    min_trace: float,
) -> None:
    """Decay: z ← factor·z over the live rows; rows whose entries all fell below the minimum go.

    The live traces are rows ``traces[:count[0]]`` of features ``rows[:count[0]]``;
    ``slot_of[f]`` is feature f's row or −1.
    """
    kept = 0
    for k in range(count[0]):
        largest = 0.0
        for b in range(traces.shape[1]):
            traces[k, b] *= factor
            largest = max(largest, abs(traces[k, b]))
        feature = rows[k]
        if largest < min_trace:
            slot_of[feature] = -1
            continue
        if kept != k:
            rows[kept] = feature
            for b in range(traces.shape[1]):
                traces[kept, b] = traces[k, b]
        slot_of[feature] = kept
        kept += 1
    count[0] = kept


@njit(cache=True)
def add_row_traces(
    slot_of: np.ndarray,
    rows: np.ndarray,
    traces: np.ndarray,
    count: np.ndarray,
    indices: np.ndarray,
    values: np.ndarray | None,
    vector: np.ndarray,
) -> bool:
    """z_f ← z_f + φ_f(s)·``vector`` for the listed features f (a new row starts at 0).

    Returns False, changing nothing, when the rows could overflow (the caller grows them).
    """
    if count[0] + indices.shape[0] > rows.shape[0]:
        return False
    for i in range(indices.shape[0]):
        feature = indices[i]
        slot = slot_of[feature]
        if slot < 0:
            slot = count[0]
            count[0] += 1
            slot_of[feature] = slot
            rows[slot] = feature
            for b in range(traces.shape[1]):
                traces[slot, b] = 0.0
        value = _value(values, i)
        for b in range(traces.shape[1]):
            traces[slot, b] += value * vector[b]
    return True


@njit(cache=True)
def apply_row_traces(
    weights: np.ndarray, rows: np.ndarray, traces: np.ndarray, count: np.ndarray, amount: float
) -> None:
    """θ ← θ + amount·z over the live rows."""
    for k in range(count[0]):
        row = weights[rows[k]]
        for b in range(traces.shape[1]):
            row[b] += amount * traces[k, b]


@njit(cache=True)
def step_row_traces(
    slot_of: np.ndarray,
    rows: np.ndarray,
    traces: np.ndarray,
    count: np.ndarray,
    factor: float,
    min_trace: float,
    indices: np.ndarray,
    values: np.ndarray | None,
    vector: np.ndarray,
) -> bool:
    """One step of a row trace: z ← factor·z (`decay_row_traces`) + φ(s) ⊗ ``vector``.

    Returns False, changing nothing, when the live rows might overflow (count + |φ(s)| rows
    before the decay; the caller grows them and calls again).
    """
    if count[0] + indices.shape[0] > rows.shape[0]:
        return False
    decay_row_traces(slot_of, rows, traces, count, factor, min_trace)
    return add_row_traces(slot_of, rows, traces, count, indices, values, vector)


@njit(cache=True)
def clear_row_traces(slot_of: np.ndarray, rows: np.ndarray, count: np.ndarray) -> None:
    """Forget every live row (a new episode): ``slot_of`` of each live feature back to −1."""
    for k in range(count[0]):
        slot_of[rows[k]] = -1
    count[0] = 0


@njit(cache=True)
def l1_norm(values: np.ndarray) -> float:
    """|φ(s)|₁ = Σ_i |φ_i(s)|: k_t, the number of active features, for binary φ."""
    total = 0.0
    for i in range(values.shape[0]):
        total += abs(values[i])
    return total


@njit(cache=True)
def squared_norm(values: np.ndarray) -> float:
    """φ(s)ᵀφ(s) = Σ_i φ_i(s)²: k_t for binary φ."""
    total = 0.0
    for i in range(values.shape[0]):
        total += values[i] * values[i]
    return total


@njit(cache=True)
def td_step_traces(
    weights: np.ndarray,
    indices: np.ndarray,
    values: np.ndarray | None,
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

    e ← γλ e (dropping traces below ``min_trace``); e(i, a) ← φ_i(s) (replacing) or
    e(i, a) + φ_i(s) (accumulating) for the listed features i; θ ← θ + α δ e. Replacing
    traces apply only when every listed value is 1 (binary φ); a φ(s) with other values
    accumulates. The live traces are kept in three parallel arrays of length ``count[0]``;
    ``slot_of[f, a]`` is 1 + the slot of trace (f, a), or 0 for none (so a table of zeros,
    whose pages are mapped only when written, starts empty). Returns δ, or nan before
    touching anything if the trace arrays could overflow (the caller grows them and calls
    again).
    """
    if count[0] + indices.shape[0] > trace_value.shape[0]:
        return np.nan
    q = 0.0
    replace = is_replacing
    for i in range(indices.shape[0]):
        value = _value(values, i)
        q += weights[indices[i], action] * value
        if value != 1.0:
            replace = False
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
            kept += 1
            slot_of[f, a] = kept
        else:
            slot_of[f, a] = 0
    for i in range(indices.shape[0]):
        f = indices[i]
        value = _value(values, i)
        slot = slot_of[f, action] - 1
        if slot < 0:
            slot = kept
            kept += 1
            slot_of[f, action] = kept
            trace_feature[slot] = f
            trace_action[slot] = action
            trace_value[slot] = value
        elif replace:
            trace_value[slot] = value
        else:
            trace_value[slot] += value
    count[0] = kept
    change = step_size * delta
    for i in range(kept):
        weights[trace_feature[i], trace_action[i]] += change * trace_value[i]
    return delta


@njit(cache=True)
def clear_traces(
    slot_of: np.ndarray, trace_feature: np.ndarray, trace_action: np.ndarray, count: np.ndarray
) -> None:
    """Forget every live sparse trace (at the start of an episode; see `td_step_traces`)."""
    for i in range(count[0]):
        slot_of[trace_feature[i], trace_action[i]] = 0
    count[0] = 0
