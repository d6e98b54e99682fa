"""A linear TD learner's compiled form, its state (`conjure.core.compiled_form`).

`AgentKernel` holds a learner's kind, traces, γ, step-size schedules, behaviour policy and
cost constraint (`ConstraintKernel`, `conjure.agents.constraints`); `LearnerArrays` its θ, ω,
sparse traces, cost critic θ_C and multiplier λ; `RowTracePair` Actor-Critic's traces;
`LearnerState` the three as one value. The learners build them in ``setup`` and keep them as
their state (`conjure.agents.linear_td`). The kernels here are the learners' update, written
once: `learn_step` (Q⁺(s, a), α_t and `td_update`: δ and the updates of Algorithms 10-12
through `td_step`, `td_step_traces` or the row traces' kernels, then the actor's), run by
the compiled loop's learn slot and by the Python ``learn``'s `learn_transition`; the targets
`bootstrap` and `cost_bootstrap`; ``begin_episode``'s trace clearing and multiplier update
(`clear_learner_traces`, `update_multiplier`); the rows of new features (`grow_learner_rows`,
Section 4.1.1, on both paths); `q_values_into` is Q(s, ·) = θᵀφ(s) and `acting_values` the
values a constrained learner acts on; Sauté's budget (`budget_bin`, `budget_rows`,
`budget_arrays`: the block of θ and ω for the episode's cost so far; `saute_reward`).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit, typeof
from numba.core import types
from numba.experimental import structref

from conjure.agents._kernels import (
    _value,
    add,
    add_log_policy_gradient,
    apply_row_traces,
    clear_row_traces,
    clear_traces,
    l1_norm,
    q_values_into,
    squared_norm,
    step_row_traces,
    td_step,
    td_step_traces,
)
from conjure.agents.row_traces import NO_ROW_TRACES, RowTraceArrays
from conjure.core.schedules import (
    EPISODIC,
    FEATURE_NORMALIZED,
    ScheduleKernel,
    episodic_rate,
    feature_normalized_rate,
)
from conjure.policies.compiled_policy import PolicyKernel
from conjure.representations.weights import parent_sum_row

__all__ = [
    "ACCUMULATING",
    "ACTOR_CRITIC",
    "LAGRANGIAN",
    "NO_CONSTRAINT",
    "NO_CONSTRAINT_KERNEL",
    "NO_ROW_TRACE_PAIR",
    "NO_TRACES",
    "PID_LAGRANGIAN",
    "PYTHON_PART",
    "Q_LEARNING",
    "REPLACING",
    "ROW_TRACES",
    "SARSA",
    "SAUTE",
    "AgentKernel",
    "ConstraintKernel",
    "LearnerArrays",
    "LearnerState",
    "RowTracePair",
    "acting_values",
    "begin_learner_episode",
    "bootstrap",
    "budget_arrays",
    "budget_bin",
    "budget_rows",
    "clear_learner_traces",
    "cost_bootstrap",
    "end_of_episode_traces",
    "grow_learner_rows",
    "has_cost_critic",
    "imagined_learn",
    "learn_step",
    "learn_transition",
    "learn_transition_with_actor_features",
    "learner_state",
    "multiplier",
    "penalized_values",
    "q_values_into",
    "row_trace_pair",
    "saute_reward",
    "shift_preference_into",
    "step_size",
    "td_update",
    "traces_fit",
    "update_multiplier",
    "weight_block",
]


#: Learner kinds of `AgentKernel`: Algorithms 11, 10 and 12.
SARSA, Q_LEARNING, ACTOR_CRITIC = 0, 1, 2
#: Eligibility traces of `AgentKernel`: none, SARSA(λ)'s sparse (feature, action) traces,
#: replacing or accumulating, and Actor-Critic's traces of θ and ω by feature row (`RowTraces`).
NO_TRACES, REPLACING, ACCUMULATING, ROW_TRACES = 0, 1, 2, 3
#: Cost constraints of `ConstraintKernel` (`conjure.agents.constraints`).
NO_CONSTRAINT, LAGRANGIAN, PID_LAGRANGIAN, SAUTE = 0, 1, 2, 3
#: The slots of `LearnerArrays.constraint_state`: λ, the PID integral I, the previous
#: episode's cost J_prev and the cost of the episode in progress; with `SAUTE` three more,
#: the episode's cost spent before the state of the last learning ``act``, before the one
#: of the learning ``act`` before it, and before the state of the last greedy ``act``
#: (``observe_episode_cost``).
MULTIPLIER, INTEGRAL, PREVIOUS_COST, EPISODE_COST = 0, 1, 2, 3
ACTED_SPENT, PREVIOUS_SPENT, GREEDY_SPENT = 4, 5, 6


class ConstraintKernel(NamedTuple):
    """A cost constraint of Algorithms 10-12 as the kernels read it (`conjure.agents.constraints`).

    Parameters
    ----------
    kind : int
        `NO_CONSTRAINT`, `LAGRANGIAN`, `PID_LAGRANGIAN` or `SAUTE`.
    cost_limit : float
        d, the cost allowed per episode.
    step_size : float, default 0.0
        The Lagrangian's multiplier step size η.
    kp, ki, kd : float, default 0.0
        The PID-Lagrangian's gains.
    unsafe_reward : float, default 0.0
        Sauté's reward of a step after which the budget is spent.
    num_budget_bins : int, default 0
        Sauté's B, the bins of the remaining budget in (0, 1].
    """

    kind: int
    cost_limit: float
    step_size: float = 0.0
    kp: float = 0.0
    ki: float = 0.0
    kd: float = 0.0
    unsafe_reward: float = 0.0
    num_budget_bins: int = 0


#: The `ConstraintKernel` of an unconstrained learner.
NO_CONSTRAINT_KERNEL = ConstraintKernel(
    kind=NO_CONSTRAINT, cost_limit=0.0, step_size=0.0, kp=0.0, ki=0.0, kd=0.0
)


class AgentKernel(NamedTuple):
    """A linear TD learner as the compiled loop reads it (Algorithms 10-12).

    Parameters
    ----------
    kind : int
        `SARSA`, `Q_LEARNING` or `ACTOR_CRITIC` (the actor sharing the critic's features).
    traces : int
        `NO_TRACES`, `REPLACING` or `ACCUMULATING` (SARSA), `ROW_TRACES` (Actor-Critic).
    trace_decay, min_trace : float
        γλ and the smallest trace kept.
    discount : float
        γ.
    schedule, actor_schedule : ScheduleKernel
        The critic's α_t and the actor's (the critic's again for the other learners).
    policy : PolicyKernel
        The behaviour policy.
    is_state_value : bool
        Actor-Critic's critic is V(s) (θ has one column), not Q(s, a).
    is_log_policy : bool
        Actor-Critic's actor steps along ∇_ω log π(s, a) (a Gibbs policy), not ψ(s, a).
    constraint : ConstraintKernel
        The cost constraint (`NO_CONSTRAINT_KERNEL`: none).
    """

    kind: int
    traces: int
    trace_decay: float
    min_trace: float
    discount: float
    schedule: ScheduleKernel
    actor_schedule: ScheduleKernel
    policy: PolicyKernel
    is_state_value: bool = False
    is_log_policy: bool = False
    constraint: ConstraintKernel = NO_CONSTRAINT_KERNEL


class LearnerArrays(NamedTuple):
    """θ, the actor's ω and their traces (Algorithms 11-12), updated in place.

    Parameters
    ----------
    weights : ndarray of shape (n, |A|)
        θ.
    actor_weights : ndarray of shape (n, |A|)
        Actor-Critic's ω; θ itself for the other learners.
    trace_slots, trace_features, trace_actions, trace_values, trace_count : ndarray
        SARSA(λ)'s sparse traces of `td_step_traces` (empty stand-ins without them).
    cost_weights : ndarray of shape (n, θ's columns)
        θ_C, the cost critic of a `LAGRANGIAN` or `PID_LAGRANGIAN` learner (else no rows).
    constraint_state : ndarray of shape (4,), or (7,) with `SAUTE`
        λ, I, J_prev and the episode's cost so far (slots `MULTIPLIER` ... `EPISODE_COST`);
        Sauté's costs spent (`ACTED_SPENT`, `PREVIOUS_SPENT`, `GREEDY_SPENT`).

    With `SAUTE`, θ and ω hold one block of rows per budget bin (`budget_rows`).

    Actor-Critic's traces are a separate `RowTracePair`: numba counts a reference per array
    wherever a tuple of ten or more arrays is passed, which slowed every learner's step.
    """

    weights: np.ndarray
    actor_weights: np.ndarray
    trace_slots: np.ndarray
    trace_features: np.ndarray
    trace_actions: np.ndarray
    trace_values: np.ndarray
    trace_count: np.ndarray
    cost_weights: np.ndarray
    constraint_state: np.ndarray


@structref.register
class _RowTracePairType(types.StructRef):
    """The numba type of `RowTracePair`."""

    def preprocess_fields(self, fields):
        return tuple((name, types.unliteral(kind)) for name, kind in fields)


class RowTracePair(structref.StructRefProxy):
    """Actor-Critic's eligibility traces z^θ and z^ω (Algorithm 12 with λ > 0), in place.

    One reference (a numba structref): a call that passed their eight arrays in a tuple made
    numba count references in every learner's step. Made by `row_trace_pair`.

    Parameters
    ----------
    critic, actor : RowTraceArrays
        z^θ and z^ω: the traces' own arrays (`RowTraces.compiled_form`).
    """


structref.define_boxing(_RowTracePairType, RowTracePair)
_ROW_TRACE_PAIR_TYPE = _RowTracePairType(
    [("critic", typeof(NO_ROW_TRACES)), ("actor", typeof(NO_ROW_TRACES))]
)


@njit(cache=True)
def _pack_row_traces(critic: RowTraceArrays, actor: RowTraceArrays) -> RowTracePair:
    pair = structref.new(_ROW_TRACE_PAIR_TYPE)
    pair.critic = critic
    pair.actor = actor
    return pair


def row_trace_pair(critic: RowTraceArrays, actor: RowTraceArrays) -> RowTracePair:
    """z^θ and z^ω as the loop's `RowTracePair` (the same arrays)."""
    return _pack_row_traces(critic, actor)


#: The `RowTracePair` of a learner without row traces.
NO_ROW_TRACE_PAIR = row_trace_pair(NO_ROW_TRACES, NO_ROW_TRACES)


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
    cost_q: np.ndarray,
    lagrange: float,
) -> float:
    """Q⁺(s, a) of Algorithms 10-12, line 5, for a non-terminal s'.

    ``q``: the chooser's values at s' (θ's, or the actor's for Actor-Critic); ``critic_q``:
    θ's values at s' (read only by Actor-Critic, which the caller has filled); ``cost_q``:
    θ_C's values at s' (read only by a constrained Q-Learning, with λ = ``lagrange``).
    SARSA: r + γ Q(s', a'); Q-Learning: r + γ max over the legal a' of Q(s', a'), or with a
    cost constraint r + γ Q(s', a*) for the legal a* maximising Q − λQ_C (`_best_action`);
    Actor-Critic: r + γ Q_θ(s', a'), or r + γ V_θ(s') with the state-value critic.
    """
    if agent.kind == SARSA:
        return reward + agent.discount * q[next_action]
    if agent.kind == ACTOR_CRITIC:
        return reward + agent.discount * critic_q[0 if agent.is_state_value else next_action]
    if has_cost_critic(agent.constraint):
        return reward + agent.discount * q[_best_action(q, cost_q, lagrange, next_legal)]
    best = q[next_legal[0]]
    for i in range(1, next_legal.shape[0]):
        best = max(best, q[next_legal[i]])
    return reward + agent.discount * best


@njit(cache=True, inline="always")
def _best_action(q: np.ndarray, cost_q: np.ndarray, lagrange: float, legal: np.ndarray) -> int:
    """The first legal a maximising Q(s, a) − λ Q_C(s, a)."""
    best, best_value = legal[0], q[legal[0]] - lagrange * cost_q[legal[0]]
    for i in range(1, legal.shape[0]):
        value = q[legal[i]] - lagrange * cost_q[legal[i]]
        if value > best_value:
            best, best_value = legal[i], value
    return best


@njit(cache=True, inline="always")
def cost_bootstrap(
    agent: AgentKernel,
    cost: float,
    q: np.ndarray,
    next_action: int,
    next_legal: np.ndarray,
    cost_q: np.ndarray,
    lagrange: float,
) -> float:
    """The cost critic's target c + γ Q_C(s', ·) for a non-terminal s', by `bootstrap`'s rule.

    SARSA and Actor-Critic: Q_C(s', a') (V_C(s') with the state-value critic); Q-Learning:
    Q_C(s', a*) at `bootstrap`'s a*.
    """
    if agent.kind == Q_LEARNING:
        next_action = _best_action(q, cost_q, lagrange, next_legal)
    elif agent.is_state_value:
        next_action = 0
    return cost + agent.discount * cost_q[next_action]


@njit(cache=True, inline="always")
def multiplier(agent: AgentKernel, arrays: LearnerArrays) -> float:
    """λ, the Lagrange multiplier (0 without a cost critic)."""
    if not has_cost_critic(agent.constraint):
        return 0.0
    return arrays.constraint_state[MULTIPLIER]


@njit(cache=True, inline="always")
def has_cost_critic(constraint: ConstraintKernel) -> bool:
    """Whether the constraint learns a cost critic θ_C and λ (`LAGRANGIAN`, `PID_LAGRANGIAN`)."""
    return constraint.kind == LAGRANGIAN or constraint.kind == PID_LAGRANGIAN


def budget_bin(spent: float, cost_limit: float, num_bins: int) -> int:
    """Sauté's budget bin b(z) of the remaining budget z = 1 − ``spent``/d.

    0 when z ≤ 0 (the budget is spent), else ⌈z·B⌉ clipped to [1, B] for B = ``num_bins``:
    bin b > 0 holds z in ((b − 1)/B, b/B], so z = 1 (nothing spent) is bin B.

    Examples
    --------
    >>> [budget_bin(spent, 2.0, 4) for spent in (0.0, 0.5, 1.0, 1.9, 2.0, 3.0)]
    [4, 3, 2, 1, 0, 0]
    """
    remaining = 1.0 - spent / cost_limit
    if remaining <= 0.0:
        return 0
    return min(max(math.ceil(remaining * num_bins), 1), num_bins)


def weight_block(weights: np.ndarray, block: int, num_blocks: int) -> np.ndarray:
    """Block ``block`` of ``weights`` cut in ``num_blocks``: rows [b·n, (b + 1)·n), a view."""
    num_rows = weights.shape[0] // num_blocks
    return weights[block * num_rows : (block + 1) * num_rows]


_budget_bin = njit(cache=True, inline="always")(budget_bin)
_weight_block = njit(cache=True, inline="always")(weight_block)


@njit(cache=True, inline="always")
def budget_rows(constraint: ConstraintKernel, weights: np.ndarray, spent: float) -> np.ndarray:
    """The rows of ``weights`` a learner reads after spending ``spent`` in the episode.

    ``weights`` itself, or with `SAUTE` the block θ_b of the bin b = `budget_bin`
    (`weight_block`: ``weights`` holds B + 1 blocks).
    """
    if constraint.kind != SAUTE:
        return weights
    bins = constraint.num_budget_bins
    block = _budget_bin(spent, constraint.cost_limit, bins)
    return _weight_block(weights, block, bins + 1)


@njit(cache=True, inline="always")
def budget_arrays(agent: AgentKernel, arrays: LearnerArrays, spent: float) -> LearnerArrays:
    """``arrays`` with θ and ω as `budget_rows` (``arrays`` itself without `SAUTE`)."""
    if agent.constraint.kind != SAUTE:
        return arrays
    weights = budget_rows(agent.constraint, arrays.weights, spent)
    actor = weights
    if agent.kind == ACTOR_CRITIC:
        actor = budget_rows(agent.constraint, arrays.actor_weights, spent)
    return LearnerArrays(
        weights=weights,
        actor_weights=actor,
        trace_slots=arrays.trace_slots,
        trace_features=arrays.trace_features,
        trace_actions=arrays.trace_actions,
        trace_values=arrays.trace_values,
        trace_count=arrays.trace_count,
        cost_weights=arrays.cost_weights,
        constraint_state=arrays.constraint_state,
    )


@njit(cache=True, inline="always")
def saute_reward(constraint: ConstraintKernel, reward: float, next_spent: float) -> float:
    """Sauté's r̃: ``reward`` while z' = 1 − ``next_spent``/d > 0, else the unsafe reward.

    ``reward`` itself without `SAUTE`.
    """
    if constraint.kind != SAUTE or 1.0 - next_spent / constraint.cost_limit > 0.0:
        return reward
    return constraint.unsafe_reward


@njit(cache=True, inline="always")
def acting_values(
    agent: AgentKernel,
    arrays: LearnerArrays,
    phi: np.ndarray,
    values: np.ndarray | None,
    q: np.ndarray,
    choice: np.ndarray,
) -> np.ndarray:
    """The values the learner acts on at s, ``q`` holding the chooser's values there.

    ``q`` itself, or for SARSA and Q-Learning with a cost critic Q − λQ_C written into
    ``choice`` (`penalized_values`; ``q`` is kept for the target).
    """
    if not has_cost_critic(agent.constraint) or agent.kind == ACTOR_CRITIC:
        return q
    for a in range(q.shape[0]):
        choice[a] = q[a]
    penalized_values(arrays, phi, values, choice, arrays.constraint_state[MULTIPLIER])
    return choice


@njit(cache=True)
def penalized_values(
    arrays: LearnerArrays,
    phi: np.ndarray,
    values: np.ndarray | None,
    q: np.ndarray,
    lagrange: float,
) -> None:
    """Q ← q − λ θ_Cᵀφ(s): the values a constrained SARSA or Q-Learning acts on, in place."""
    weights = arrays.cost_weights
    for i in range(phi.shape[0]):
        row = weights[phi[i]]
        amount = lagrange * _value(values, i)
        for a in range(q.shape[0]):
            q[a] -= amount * row[a]


@njit(cache=True)
def update_multiplier(constraint: ConstraintKernel, state: np.ndarray) -> None:
    """λ after an episode of cost J_C = Σ_t c_t (``state[EPISODE_COST]``, then zeroed).

    Lagrangian (dual ascent): λ ← max(0, λ + η (J_C − d)). PID-Lagrangian (Stooke, Achiam and
    Abbeel 2020, Algorithm 2): Δ = J_C − d; I ← max(0, I + Δ); ∂ = max(0, J_C − J_prev);
    λ = max(0, K_p Δ + K_i I + K_d ∂).
    """
    cost = state[EPISODE_COST]
    excess = cost - constraint.cost_limit
    if constraint.kind == LAGRANGIAN:
        state[MULTIPLIER] = max(0.0, state[MULTIPLIER] + constraint.step_size * excess)
    elif constraint.kind == PID_LAGRANGIAN:
        state[INTEGRAL] = max(0.0, state[INTEGRAL] + excess)
        rise = max(0.0, cost - state[PREVIOUS_COST])
        state[MULTIPLIER] = max(
            0.0, constraint.kp * excess + constraint.ki * state[INTEGRAL] + constraint.kd * rise
        )
    state[PREVIOUS_COST] = cost
    state[EPISODE_COST] = 0.0


@njit(cache=True)
def _num_active(indices: np.ndarray, values: np.ndarray | None) -> float:
    """k_t = |φ(s)|₁, the learners' `_step_size` (the number of features for binary φ)."""
    if values is None:
        return float(indices.shape[0])
    return l1_norm(values)


@njit(cache=True, inline="always")
def learn_step(
    agent: AgentKernel,
    arrays: LearnerArrays,
    row_traces: RowTracePair,
    phi: np.ndarray,
    values: np.ndarray | None,
    psi: np.ndarray,
    psi_values: np.ndarray | None,
    action: int,
    reward: float,
    is_terminal: bool,
    q_next: np.ndarray,
    critic_next: np.ndarray,
    cost_next: np.ndarray,
    next_action: int,
    next_legal: np.ndarray,
    episode: int,
    alphas: np.ndarray,
    drawn: np.ndarray,
    is_tracing: bool,
    cost: float,
    spent: float,
    next_spent: float,
) -> float:
    """The learners' learn, one kernel for both paths: Algorithms 10-12, lines 4-9.

    Q⁺(s, a) by `bootstrap` at a non-terminal s' from ``q_next`` (the chooser's values
    there), ``critic_next`` (θ's, read by Actor-Critic) and ``cost_next`` (θ_C's, and the
    cost critic's target by `cost_bootstrap`); α_t (and Actor-Critic's α'_t) from the
    schedules at episode max(episode, 1) with k_t = |φ(s)|₁ (k'_t = |ψ(s)|₁), or from
    ``alphas`` for a schedule of kind `PYTHON_PART` (the Python learner writes them); then
    `td_update`, and after a terminal step SARSA(λ) clears its traces
    (`end_of_episode_traces`) when ``is_tracing`` (False: an imagined transition). With
    `Saute` the reward is r̃ for the cost ``next_spent`` up to s' (`saute_reward`) and the
    update reads the blocks of θ and ω for the cost ``spent`` up to s (`budget_arrays`).
    Returns δ.
    """
    target, cost_target = saute_reward(agent.constraint, reward, next_spent), cost
    if not is_terminal:
        lagrange = multiplier(agent, arrays)
        if has_cost_critic(agent.constraint):
            cost_target = cost_bootstrap(
                agent, cost, q_next, next_action, next_legal, cost_next, lagrange
            )
        target = bootstrap(
            agent, target, q_next, next_action, next_legal, critic_next, cost_next, lagrange
        )
    counted = max(episode, 1)
    alpha, actor_alpha = alphas[0], alphas[1]
    if agent.schedule.kind != PYTHON_PART:
        alpha = step_size(agent.schedule, counted, _num_active(phi, values))
    if agent.kind == ACTOR_CRITIC and agent.actor_schedule.kind != PYTHON_PART:  # ω's α'_t
        actor_alpha = step_size(agent.actor_schedule, counted, _num_active(psi, psi_values))
    arrays = budget_arrays(agent, arrays, spent)
    delta = td_update(
        agent, arrays, row_traces, phi, values, psi, psi_values, action, target, alpha,
        actor_alpha, drawn, is_tracing, cost, cost_target,
    )  # fmt: skip
    if is_terminal and is_tracing:
        end_of_episode_traces(agent, arrays)
    return delta


@njit(cache=True, inline="always")
def td_update(
    agent: AgentKernel,
    arrays: LearnerArrays,
    row_traces: RowTracePair,
    phi: np.ndarray,
    values: np.ndarray | None,
    psi: np.ndarray,
    psi_values: np.ndarray | None,
    action: int,
    target: float,
    alpha: float,
    actor_alpha: float,
    drawn: np.ndarray,
    is_tracing: bool,
    cost: float,
    cost_target: float,
) -> float:
    """δ and θ's update (Algorithms 10-12, lines 6-7), then ω's on ψ(s) (Algorithm 12, line 9).

    The learners' one update rule, on both paths: δ and θ's update by `td_step` (on V's one
    column for the state-value critic) or, with traces and ``is_tracing``, `td_step_traces`
    (SARSA(λ)) or `_learn_with_row_traces` (Actor-Critic); without row traces Actor-Critic
    then adds α' δ ψ(s) to ω's row of ``action``, or with the log-policy actor
    α' δ ∇_ω log π(s, a) / τ from ``drawn``, π(s, ·) as it was when a was chosen
    (`add_log_policy_gradient`). ``is_tracing`` False (an imagined transition) updates without
    the traces. With a cost constraint the cost critic θ_C first steps toward ``cost_target``
    by `td_step` at the same α_t (δ_C; choice: without traces), the step's ``cost`` joins the
    episode's, and the actor steps on δ − λδ_C (the Lagrangian's advantage). Returns δ; ω is
    left alone when δ is not finite.
    """
    actor_offset = 0.0
    if has_cost_critic(agent.constraint):
        column = 0 if agent.is_state_value else action
        cost_delta = td_step(arrays.cost_weights, phi, values, column, cost_target, alpha)
        arrays.constraint_state[EPISODE_COST] += cost
        actor_offset = -arrays.constraint_state[MULTIPLIER] * cost_delta
    if is_tracing and agent.traces == ROW_TRACES:
        return _learn_with_row_traces(
            agent, arrays.weights, arrays.actor_weights, row_traces, phi, values, psi,
            psi_values, action, target, alpha, actor_alpha, drawn, actor_offset,
        )  # fmt: skip
    if not is_tracing or agent.traces == NO_TRACES or agent.traces == ROW_TRACES:
        column = 0 if agent.is_state_value else action
        delta = td_step(arrays.weights, phi, values, column, target, alpha)
    else:
        delta = td_step_traces(
            arrays.weights, phi, values, action, target, alpha, agent.trace_decay,
            agent.traces == REPLACING, agent.min_trace, arrays.trace_slots,
            arrays.trace_features, arrays.trace_actions, arrays.trace_values, arrays.trace_count,
        )  # fmt: skip
    if agent.kind == ACTOR_CRITIC and math.isfinite(delta):
        actor_delta = delta + actor_offset
        if agent.is_log_policy:
            amount = actor_alpha * actor_delta / agent.policy.parameter
            add_log_policy_gradient(arrays.actor_weights, psi, psi_values, action, drawn, amount)
        else:
            add(arrays.actor_weights, psi, psi_values, action, actor_alpha * actor_delta)
    return delta


@njit(cache=True)
def _learn_with_row_traces(
    agent: AgentKernel,
    weights: np.ndarray,
    actor_weights: np.ndarray,
    row_traces: RowTracePair,
    phi: np.ndarray,
    values: np.ndarray | None,
    psi: np.ndarray,
    psi_values: np.ndarray | None,
    action: int,
    target: float,
    alpha: float,
    actor_alpha: float,
    drawn: np.ndarray,
    actor_offset: float,
) -> float:
    """Actor-Critic's update with λ > 0 (Sutton & Barto 2018, §13.5; Algorithm 12's lines 6-9).

    δ = target − θ(s)[column]; z^θ ← γλz^θ + φ(s) ⊗ e_column; z^ω ← γλz^ω + ψ(s) ⊗ e_a, or
    ⊗ (e_a − π(s, ·))/τ for the log-policy actor (π(s, ·) as drawn); θ += αδz^θ and
    ω += α'(δ + ``actor_offset``)z^ω (the offset −λδ_C of a cost constraint), whatever δ (the
    caller stops on a non-finite one). The rows fit (`traces_fit`
    before the step, the same rule as `step_row_traces`).
    """
    critic, actor = row_traces.critic, row_traces.actor
    column = 0 if agent.is_state_value else action
    critic_values = np.empty(weights.shape[1])
    q_values_into(weights, phi, values, critic_values)
    delta = target - critic_values[column]
    unit = np.zeros(weights.shape[1])
    unit[column] = 1.0
    step_row_traces(critic.slot_of, critic.rows, critic.values, critic.count, agent.trace_decay,
                    agent.min_trace, phi, values, unit)  # fmt: skip
    direction = np.zeros(actor_weights.shape[1])
    direction[action] = 1.0
    if agent.is_log_policy:
        for b in range(direction.shape[0]):
            direction[b] = (direction[b] - drawn[b]) / agent.policy.parameter
    step_row_traces(actor.slot_of, actor.rows, actor.values, actor.count, agent.trace_decay,
                    agent.min_trace, psi, psi_values, direction)  # fmt: skip
    apply_row_traces(weights, critic.rows, critic.values, critic.count, alpha * delta)
    apply_row_traces(actor_weights, actor.rows, actor.values, actor.count,
                     actor_alpha * (delta + actor_offset))  # fmt: skip
    return delta


@njit(cache=True, inline="always")
def traces_fit(
    agent: AgentKernel, arrays: LearnerArrays, row_traces: RowTracePair, num_active: int
) -> bool:
    """Whether the traces have room for ``num_active`` more features (else the loop grows them)."""
    if agent.traces == NO_TRACES:
        return True
    if agent.traces == ROW_TRACES:
        critic, actor = row_traces.critic, row_traces.actor
        return (
            critic.count[0] + num_active <= critic.rows.shape[0]
            and actor.count[0] + num_active <= actor.rows.shape[0]
        )
    return arrays.trace_count[0] + num_active <= arrays.trace_values.shape[0]


@njit(cache=True)
def grow_learner_rows(
    arrays: LearnerArrays,
    first: int,
    parents: np.ndarray,
    is_actor_growing: bool,
    has_trace_slots: bool,
) -> None:
    """Rows ``first + i`` for the features an adaptive representation added (Section 4.1.1).

    The learners' one growth rule, called by their Python ``_grow`` and by the compiled loop
    after a discovery: θ_f = θ_g + θ_h for the i-th new feature f with parents
    ``parents[i]`` (`parent_sum_row`, −1 adding nothing); the actor's ω_f likewise when
    it shares the critic's features (``is_actor_growing``); a cost critic's θ_C likewise (when
    it has rows); SARSA(λ)'s trace slots of f empty (``has_trace_slots``: a new feature has
    no trace yet). The arrays must already have the rows
    (`conjure.representations.weights.with_room`).
    """
    has_cost_critic = arrays.cost_weights.shape[0] > 0
    for i in range(parents.shape[0]):
        f, g, h = first + i, parents[i, 0], parents[i, 1]
        parent_sum_row(arrays.weights, g, h, f)
        if has_cost_critic:
            parent_sum_row(arrays.cost_weights, g, h, f)
        if is_actor_growing:
            parent_sum_row(arrays.actor_weights, g, h, f)
        if has_trace_slots:
            for a in range(arrays.trace_slots.shape[1]):
                arrays.trace_slots[f, a] = 0


@njit(cache=True, inline="always")
def end_of_episode_traces(agent: AgentKernel, arrays: LearnerArrays) -> None:
    """After a terminal step: SARSA(λ) clears its traces (its ``_after_update``).

    Actor-Critic's row traces wait for the next ``begin_episode``, as in Python.
    """
    if agent.traces == REPLACING or agent.traces == ACCUMULATING:
        clear_traces(arrays.trace_slots, arrays.trace_features, arrays.trace_actions,
                     arrays.trace_count)  # fmt: skip


@njit(cache=True, inline="always")
def clear_learner_traces(
    agent: AgentKernel, arrays: LearnerArrays, row_traces: RowTracePair, episode: int
) -> None:
    """``begin_episode`` of a learner that has begun ``episode`` episodes before this one.

    A cost critic's constraint updates λ from the episode that ended (`update_multiplier`;
    none before the first); the traces, if any, are forgotten.
    """
    if has_cost_critic(agent.constraint) and episode > 0:
        update_multiplier(agent.constraint, arrays.constraint_state)
    if agent.traces == ROW_TRACES:
        critic, actor = row_traces.critic, row_traces.actor
        clear_row_traces(critic.slot_of, critic.rows, critic.count)
        clear_row_traces(actor.slot_of, actor.rows, actor.count)
    elif agent.traces != NO_TRACES:
        clear_traces(arrays.trace_slots, arrays.trace_features, arrays.trace_actions,
                     arrays.trace_count)  # fmt: skip


@njit(cache=True)
def shift_preference_into(
    actor_weights: np.ndarray,
    phi: np.ndarray,
    values: np.ndarray | None,
    action: int,
    amount: float,
) -> None:
    """ρ(s, a) += ``amount`` by ω_a += amount · ψ(s) / ‖ψ(s)‖² (`ActorCritic.shift_preference`).

    ``values`` None: binary ψ, ‖ψ(s)‖² the number of active features.
    """
    norm = float(phi.shape[0]) if values is None else squared_norm(values)
    if norm > 0.0:
        add(actor_weights, phi, values, action, amount / norm)


@njit(cache=True, inline="always")
def imagined_learn(
    agent: AgentKernel,
    arrays: LearnerArrays,
    phi: np.ndarray,
    values: np.ndarray | None,
    action: int,
    target: float,
    episode: int,
) -> float:
    """An imagined terminal step's update (`Transition.is_imagined`): δ and θ, no traces.

    The Python learners' ``learn`` of a vetoed proposal (`conjure.safety.CooperativeLearner`)
    for SARSA and Q-Learning: α_t from the schedule, `td_step` toward ``target``. Returns δ.
    """
    alpha = step_size(agent.schedule, max(episode, 1), _num_active(phi, values))
    return td_step(arrays.weights, phi, values, action, target, alpha)


# ---------------------------------------------------------------------------------------------
# The learner's compiled form as its state, and the Python path's calls into the same kernels


@structref.register
class _LearnerStateType(types.StructRef):
    """The numba type of `LearnerState`."""

    def preprocess_fields(self, fields):
        return tuple((name, types.unliteral(kind)) for name, kind in fields)


class LearnerState(structref.StructRefProxy):
    """A learner's compiled form (Algorithms 10-12): kernel, arrays, traces and two buffers.

    The learner builds it in ``setup`` and keeps it as its state (the same arrays as its
    ``arrays_`` and traces; a new one replaces it when they are reallocated). One reference
    (a numba structref), so the Python path's `learn_transition` call types and unboxes one
    value, not the ten-odd arrays the named tuples hold. Made by `learner_state`.

    Parameters
    ----------
    agent : AgentKernel
        The learner's kind, traces, γ, schedules and policy.
    arrays : LearnerArrays
        θ, ω and SARSA(λ)'s traces.
    row_traces : RowTracePair
        Actor-Critic's traces (`NO_ROW_TRACE_PAIR` for the others).
    alphas : ndarray of shape (2,)
        α_t and α'_t of schedules of kind `PYTHON_PART`, filled by the Python ``learn``.
    drawn : ndarray of shape (|A|,)
        π(s, ·) as ``act`` drew a, filled for the log-policy actor (a buffer, so no call
        passes it).
    """


structref.define_boxing(_LearnerStateType, LearnerState)


#: A part with no compiled form (a user's Python schedule or policy), as `ScheduleKernel.kind`
#: or `PolicyKernel.kind` in a learner's `AgentKernel`: the Python path computes α_t (and
#: chooses actions) in Python, and the learner has no compiled form for the loop.
PYTHON_PART = -1
_SAMPLE_KERNEL = AgentKernel(
    kind=SARSA,
    traces=NO_TRACES,
    trace_decay=0.0,
    min_trace=0.0,
    discount=1.0,
    schedule=ScheduleKernel(kind=PYTHON_PART, alpha_0=0.0, n_0=0.0),
    actor_schedule=ScheduleKernel(kind=PYTHON_PART, alpha_0=0.0, n_0=0.0),
    policy=PolicyKernel(kind=PYTHON_PART, parameter=0.0),
)
_SAMPLE_ARRAYS = LearnerArrays(
    weights=np.zeros((0, 0)),
    actor_weights=np.zeros((0, 0)),
    trace_slots=np.zeros((0, 0), dtype=np.int64),
    trace_features=np.zeros(0, dtype=np.int64),
    trace_actions=np.zeros(0, dtype=np.int64),
    trace_values=np.zeros(0),
    trace_count=np.zeros(1, dtype=np.int64),
    cost_weights=np.zeros((0, 0)),
    constraint_state=np.zeros(4),
)
_LEARNER_STATE_TYPE = _LearnerStateType(
    [("agent", typeof(_SAMPLE_KERNEL)), ("arrays", typeof(_SAMPLE_ARRAYS)),
     ("row_traces", _ROW_TRACE_PAIR_TYPE), ("alphas", typeof(np.zeros(2))),
     ("drawn", typeof(np.zeros(2)))]
)  # fmt: skip


@njit(cache=True)
def _pack_learner_state(
    kernel: AgentKernel,
    arrays: LearnerArrays,
    row_traces: RowTracePair,
    alphas: np.ndarray,
    drawn: np.ndarray,
) -> LearnerState:
    state = structref.new(_LEARNER_STATE_TYPE)
    state.agent = kernel
    state.arrays = arrays
    state.row_traces = row_traces
    state.alphas = alphas
    state.drawn = drawn
    return state


def learner_state(
    kernel: AgentKernel,
    arrays: LearnerArrays,
    row_traces: RowTracePair,
    alphas: np.ndarray,
    drawn: np.ndarray,
) -> LearnerState:
    """The learner's `LearnerState` over these values (the same arrays, nothing copied)."""
    return _pack_learner_state(kernel, arrays, row_traces, alphas, drawn)


@njit(cache=True)
def learn_transition(
    state: LearnerState,
    phi: np.ndarray,
    values: np.ndarray | None,
    action: int,
    reward: float,
    is_terminal: int,
    q_next: np.ndarray,
    next_action: int,
    next_legal: np.ndarray,
    episode: int,
    is_tracing: int,
    cost: float,
    cost_next: np.ndarray,
) -> tuple[bool, float]:
    """The Python learners' ``learn``: `learn_step`, the compiled loop's learn, the actor on φ.

    Algorithms 10-12, lines 4-9. ``q_next``: the chooser's values at a non-terminal s' (θ's;
    the critic's θᵀφ(s') for Actor-Critic), passed as both of `learn_step`'s values at s';
    α_t from the state's ``alphas`` for a schedule of kind `PYTHON_PART`; the log-policy
    actor reads π(s, ·) from its ``drawn``. With a cost constraint, ``cost`` is c_t and
    ``cost_next`` θ_C's values at s'; with `Saute` the costs up to s and s' are the ones the
    learner was told (`observe_episode_cost`). ``is_terminal`` and ``is_tracing`` are 0 or 1
    (an int costs the call less than a bool); ``is_tracing`` 0 is an imagined transition.
    Returns (False, nan) before touching anything when the traces might not fit
    (`traces_fit`: the caller grows them and calls again), else (True, δ).
    """
    return _learn_transition(
        state, phi, values, phi, values, action, reward, is_terminal, q_next, next_action,
        next_legal, episode, is_tracing, cost, cost_next,
    )  # fmt: skip


@njit(cache=True)
def learn_transition_with_actor_features(
    state: LearnerState,
    phi: np.ndarray,
    values: np.ndarray | None,
    psi: np.ndarray,
    psi_values: np.ndarray | None,
    action: int,
    reward: float,
    is_terminal: int,
    q_next: np.ndarray,
    next_action: int,
    next_legal: np.ndarray,
    episode: int,
    is_tracing: int,
    cost: float,
    cost_next: np.ndarray,
) -> tuple[bool, float]:
    """`learn_transition` for an actor on its own features ψ(s) (k'_t = |ψ(s)|₁ for α'_t)."""
    return _learn_transition(
        state, phi, values, psi, psi_values, action, reward, is_terminal, q_next, next_action,
        next_legal, episode, is_tracing, cost, cost_next,
    )  # fmt: skip


@njit(cache=True, inline="always")
def _learn_transition(
    state: LearnerState,
    phi: np.ndarray,
    values: np.ndarray | None,
    psi: np.ndarray,
    psi_values: np.ndarray | None,
    action: int,
    reward: float,
    is_terminal: int,
    q_next: np.ndarray,
    next_action: int,
    next_legal: np.ndarray,
    episode: int,
    is_tracing: int,
    cost: float,
    cost_next: np.ndarray,
) -> tuple[bool, float]:
    agent, arrays, row_traces = state.agent, state.arrays, state.row_traces
    if is_tracing != 0 and not traces_fit(
        agent, arrays, row_traces, max(phi.shape[0], psi.shape[0])
    ):
        return False, np.nan
    spent = next_spent = 0.0
    if agent.constraint.kind == SAUTE:  # the budget bins of s and s' (`observe_episode_cost`)
        spent = arrays.constraint_state[ACTED_SPENT if is_terminal != 0 else PREVIOUS_SPENT]
        next_spent = arrays.constraint_state[ACTED_SPENT]
        if is_terminal != 0 and cost > 0.0:  # no act at a terminal s': the step's cost added
            next_spent = spent + cost
    delta = learn_step(
        agent, arrays, row_traces, phi, values, psi, psi_values, action, reward,
        is_terminal != 0, q_next, q_next, cost_next, next_action, next_legal, episode,
        state.alphas, state.drawn, is_tracing != 0, cost, spent, next_spent,
    )  # fmt: skip
    return True, delta


@njit(cache=True)
def begin_learner_episode(state: LearnerState, episode: int) -> None:
    """The Python learners' ``begin_episode``: `clear_learner_traces`, as the loop does."""
    clear_learner_traces(state.agent, state.arrays, state.row_traces, episode)
