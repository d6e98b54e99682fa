"""Numba kernels of the linear TD learners: Q(s, ·) = θᵀφ(s) and the updates of Algs 10-12.

θ has shape (n_features, |A|): row f holds feature f's weight for every action, which is the
per-action copy of φ(s) in Eq. 2.11 without building φ(s, a). φ(s) is sparse
(`conjure.core.SparseFeatures`): sorted ``indices`` with their ``values``. ``values`` may be
``None`` for binary φ (every value 1; numba compiles that case without reading a value): the
compiled loops (`conjure.compiled`) pass binary φ that way. Multiplying by a value of 1.0 is
exact, so binary φ gives bit-identical results either way.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from conjure.core.schedules import (
    EPISODIC,
    FEATURE_NORMALIZED,
    ScheduleKernel,
    episodic_rate,
    feature_normalized_rate,
)
from conjure.policies._kernels import PolicyKernel


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
    ``slot_of[f, a]`` is the slot of trace (f, a) or −1. Returns δ, or nan before touching
    anything if the trace arrays could overflow (the caller grows them and calls again).
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
            slot_of[f, a] = kept
            kept += 1
        else:
            slot_of[f, a] = -1
    for i in range(indices.shape[0]):
        f = indices[i]
        value = _value(values, i)
        slot = slot_of[f, action]
        if slot < 0:
            slot = kept
            kept += 1
            slot_of[f, action] = slot
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
    """Forget every live sparse trace (at the start of an episode)."""
    for i in range(count[0]):
        slot_of[trace_feature[i], trace_action[i]] = -1
    count[0] = 0


# ---------------------------------------------------------------------------------------------
# The compiled form of a linear TD learner (`conjure.core.compiled_form`)

#: Learner kinds of `AgentKernel`: Algorithms 11, 10 and 12.
SARSA, Q_LEARNING, ACTOR_CRITIC = 0, 1, 2
#: Eligibility traces of `AgentKernel`.
NO_TRACES, REPLACING, ACCUMULATING = 0, 1, 2


class AgentKernel(NamedTuple):
    """A linear TD learner as the compiled loop reads it (`conjure.compiled`).

    ``kind``: `SARSA`, `Q_LEARNING` or `ACTOR_CRITIC` (the actor sharing the critic's
    features); ``traces``: `NO_TRACES`, `REPLACING` or `ACCUMULATING`, with γλ
    (``trace_decay``) and the smallest trace kept; ``schedule`` the critic's α_t and
    ``actor_schedule`` the actor's (the critic's again for the other learners); γ and the
    behaviour policy.
    """

    kind: int
    traces: int
    trace_decay: float
    min_trace: float
    discount: float
    schedule: ScheduleKernel
    actor_schedule: ScheduleKernel
    policy: PolicyKernel


class LearnerArrays(NamedTuple):
    """θ, the actor's ω (θ itself but for Actor-Critic) and SARSA(λ)'s sparse traces.

    The traces are those of `td_step_traces` (empty stand-ins without traces); all are
    updated in place.
    """

    weights: np.ndarray
    actor_weights: np.ndarray
    trace_slots: np.ndarray
    trace_features: np.ndarray
    trace_actions: np.ndarray
    trace_values: np.ndarray
    trace_count: np.ndarray


_feature_normalized_rate = njit(cache=True, inline="always")(feature_normalized_rate)
_episodic_rate = njit(cache=True, inline="always")(episodic_rate)


@njit(cache=True, inline="always")
def step_size(schedule: ScheduleKernel, episode: int, num_active: float) -> float:
    """α_t of the schedule's ``value`` (`conjure.core.schedules`: the same source, compiled)."""
    if schedule.kind == FEATURE_NORMALIZED:
        return _feature_normalized_rate(schedule.alpha_0, schedule.n_0, episode, num_active)
    if schedule.kind == EPISODIC:
        return _episodic_rate(schedule.alpha_0, schedule.n_0, episode)
    return schedule.alpha_0


@njit(cache=True, inline="always")
def bootstrap(
    agent: AgentKernel,
    reward: float,
    q: np.ndarray,
    next_action: int,
    next_legal: np.ndarray,
    critic_q: np.ndarray,
) -> float:
    """Q⁺(s, a) of Algorithms 10-12, line 5, for a non-terminal s'.

    ``q``: the chooser's values at s' (θ's, or the actor's for Actor-Critic); ``critic_q``:
    θ's values at s' (read only by Actor-Critic, which the caller has filled).
    SARSA: r + γ Q(s', a'); Q-Learning: r + γ max over the legal a' of Q(s', a');
    Actor-Critic: r + γ Q_θ(s', a').
    """
    if agent.kind == SARSA:
        return reward + agent.discount * q[next_action]
    if agent.kind == ACTOR_CRITIC:
        return reward + agent.discount * critic_q[next_action]
    best = q[next_legal[0]]
    for i in range(1, next_legal.shape[0]):
        best = max(best, q[next_legal[i]])
    return reward + agent.discount * best


@njit(cache=True)
def _num_active(indices: np.ndarray, values: np.ndarray | None) -> float:
    """k_t = |φ(s)|₁, the learners' `_step_size` (the number of features for binary φ)."""
    if values is None:
        return float(indices.shape[0])
    return l1_norm(values)


@njit(cache=True, inline="always")
def td_learn(
    agent: AgentKernel,
    arrays: LearnerArrays,
    phi: np.ndarray,
    values: np.ndarray | None,
    action: int,
    target: float,
    episode: int,
) -> float:
    """α_t, δ and θ's update (Algorithms 10-12, lines 6-7), then ω's (Algorithm 12, line 9).

    The learners' ``learn`` in one kernel: k_t = |φ(s)|₁ (the number of features for binary
    φ), α_t from the schedule at episode max(episode, 1), δ and θ's update by `td_step` or,
    with traces, `td_step_traces`; Actor-Critic then adds α^actor_t δ φ(s) to ω's row of
    ``action``. Returns δ; ω is left alone when δ is not finite.
    """
    k_t = _num_active(phi, values)
    counted = max(episode, 1)
    alpha = step_size(agent.schedule, counted, k_t)
    if agent.traces == NO_TRACES:
        delta = td_step(arrays.weights, phi, values, action, target, alpha)
    else:
        delta = td_step_traces(
            arrays.weights, phi, values, action, target, alpha, agent.trace_decay,
            agent.traces == REPLACING, agent.min_trace, arrays.trace_slots,
            arrays.trace_features, arrays.trace_actions, arrays.trace_values, arrays.trace_count,
        )  # fmt: skip
    if agent.kind == ACTOR_CRITIC and math.isfinite(delta):
        actor_alpha = step_size(agent.actor_schedule, counted, k_t)
        add(arrays.actor_weights, phi, values, action, actor_alpha * delta)
    return delta


@njit(cache=True, inline="always")
def clear_learner_traces(agent: AgentKernel, arrays: LearnerArrays) -> None:
    """`clear_traces` of the learner's sparse traces, if it has any."""
    if agent.traces != NO_TRACES:
        clear_traces(arrays.trace_slots, arrays.trace_features, arrays.trace_actions,
                     arrays.trace_count)  # fmt: skip
