"""The compiled learning loop: n steps of domain, features, action choice and TD update.

`learning_loop` is `conjure.experiments.loop.Stepper`'s step order (Algorithms 10-12 as an
interaction loop) in one numba function. It owns no dynamics, features, schedule or update
arithmetic: every step calls the components' own kernels through their compiled forms
(`conjure.core.compiled_form`):

- the domain (`conjure.domains.compiled_domain`): `reset_into`, `step_into`, `legal_into`;
- the representation (`conjure.representations.compiled_representation`): `encode_into`
  and `values_of` for φ(s), and with online iFDD (`conjure.representations.compiled_ifdd`)
  `sparsify` (Algorithm 19), `room_for` and `discover_from`;
- the learner (`conjure.agents.compiled_agent`): `q_values_into`, `bootstrap`, `td_learn`,
  `clear_learner_traces`, `grow_learner_rows` for new features' rows (Section 4.1.1), and
  the policy's `select_action` (and `gibbs_policy` for the log-policy actor).

Per step: a = π(s) was chosen; s', r = step(a); unless terminal, φ(s') and a' = π(s') over the
legal actions of s'; Q⁺(s, a); δ and the updates (with a `Saute` constraint, acting at s' and
Q⁺ read the blocks of θ and ω for the episode's cost up to s', the update those up to s, and
r is Sauté's r̃: `budget_rows`, `budget_arrays`, `saute_reward`, from the loop's own
``episode_cost``, learning and greedy steps alike); with iFDD, discovery on φ(s) with δ and the
new features' rows; then s ← s', a ← a' (φ(s) recomputed after a discovery, as the Python
learner re-encodes). Inside an iCCA box (`conjure.safety.compiled_cooperative`) the box
chooses a and a'; a vetoed proposal it learns (Algorithm 24's veto rule) is followed by its
own discovery on that state's φ, before the step's update, as in the Python learner's
``learn``. Choice: the tables are then grown before a step unless two discoveries from any
sparsified φ fit (`has_room_for`), since the box cannot pause once the domain has stepped.
Random numbers come from the same `numpy.random.Generator` objects in the same order as the
Python path (numba shares their state): the domain's draws per step and one uniform per action
choice.

The loop's own state (phase, action, counters, return so far) is `LoopState`, resumable
between calls; an episode may span calls.

Choice: the loop reads its arguments and its scratch arrays through borrowed views
(`conjure.core.compiled_form.borrowed`, `release`): numba counts a reference to every array of
a form each time a kernel binds it, with an atomic add, and prunes few of those counts in a
function this large.

Compilation: one function serves every combination (the compiled forms have fixed field
types), with a second compilation for real-valued φ (`RBF`), so binary φ never reads a value.
It is cached on disk (``cache=True``). Choice: the kernels the loop calls at several places
that are not on the plain learner's step or whose own work outweighs a call (the box's
`box_action` and `greedy_box_action`, the policy checks' `peek_into`, iFDD's `sparsify` and
`_discover`, the action masks' `legal_into`) are compiled once and called, not inlined by numba
at each call site (``inline="always"`` types and lowers a body again per site, which made most
of the cold compile); `encode_into`, `step_into`, the policy's and the learner's kernels stay
inlined.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from conjure.agents.compiled_agent import (
    ACCUMULATING,
    ACTOR_CRITIC,
    NO_TRACES,
    REPLACING,
    AgentKernel,
    LearnerArrays,
    RowTracePair,
    acting_values,
    bootstrap,
    budget_arrays,
    budget_rows,
    clear_learner_traces,
    cost_bootstrap,
    end_of_episode_traces,
    grow_learner_rows,
    has_cost_critic,
    multiplier,
    q_values_into,
    saute_reward,
    td_learn,
    traces_fit,
)
from conjure.core.compiled_form import borrowed, release
from conjure.domains.compiled_domain import DomainKernel, legal_into, reset_into, step_into
from conjure.policies import greedy_action
from conjure.policies.compiled_policy import gibbs_policy, select_action
from conjure.representations.compiled_ifdd import (
    IFDDKernel,
    discover_from,
    has_room_for,
    room_for,
    sparsify,
)
from conjure.representations.compiled_representation import (
    HASHED_TABULAR,
    TILES,
    encode_into,
    peek_into,
    values_of,
)
from conjure.safety.compiled_cooperative import (
    NO_BOX,
    BoxKernel,
    BoxParts,
    box_action,
    box_learn,
    greedy_box_action,
)

__all__ = ["LoopState", "learning_loop"]

#: Status codes of `learning_loop`.
DONE, GROW_TRACES, DIVERGED, GROW_REPRESENTATION, DOMAIN_RAISED, FULL_INDEX = range(6)
#: Phases of `LoopState`.
NEEDS_RESET, NEEDS_BEGIN, IN_EPISODE = 0, 1, 2


class LoopState(NamedTuple):
    """The loop's resumable state: one-element arrays, updated in place by `learning_loop`.

    ``phase`` (`NEEDS_RESET`, `NEEDS_BEGIN`, `IN_EPISODE`), the chosen ``action``, the
    episode's ``episode_steps``, ``episode_failures``, return ``total``, ``discounted`` return,
    γ^t ``weight`` and cost Σ c_t ``episode_cost``; the learner's ``episode`` count and
    ``learning_steps``; ``drawn``, π(s, ·) when the action was chosen (read by the log-policy
    actor only).
    """

    phase: np.ndarray
    action: np.ndarray
    episode_steps: np.ndarray
    episode: np.ndarray
    learning_steps: np.ndarray
    episode_failures: np.ndarray
    total: np.ndarray
    discounted: np.ndarray
    weight: np.ndarray
    episode_cost: np.ndarray
    drawn: np.ndarray


def new_loop_state(num_actions: int) -> LoopState:
    """A `LoopState` before the first reset."""
    ints = ("phase", "action", "episode_steps", "episode", "learning_steps", "episode_failures")
    return LoopState(
        **{name: np.zeros(1, dtype=np.int64) for name in ints},
        total=np.zeros(1),
        discounted=np.zeros(1),
        weight=np.ones(1),
        episode_cost=np.zeros(1),
        drawn=np.zeros(num_actions),
    )


@njit(cache=True, inline="always")
def _record_episode(
    ep_float: np.ndarray,
    ep_int: np.ndarray,
    index: int,
    total: float,
    discounted: float,
    cost: float,
    length: int,
    failures: int,
) -> tuple[np.ndarray, np.ndarray]:
    """Write an ended episode's statistics at row ``index`` (doubling the arrays when full)."""
    if index == ep_float.shape[0]:
        grown_float = np.empty((2 * index, 3))
        grown_int = np.empty((2 * index, 2), dtype=np.int64)
        for i in range(index):
            for j in range(3):
                grown_float[i, j] = ep_float[i, j]
            for j in range(2):
                grown_int[i, j] = ep_int[i, j]
        ep_float, ep_int = grown_float, grown_int
    ep_float[index, 0] = total
    ep_float[index, 1] = discounted
    ep_float[index, 2] = cost
    ep_int[index, 0] = length
    ep_int[index, 1] = failures
    return ep_float, ep_int


@njit(cache=True, inline="always")
def _copy(target: np.ndarray, source: np.ndarray) -> None:
    """``target[:n] = source`` as a loop.

    A slice assignment would link numba's error formatting, whose code a cached kernel loads
    on every start (``benchmarks/startup.py``).
    """
    for i in range(source.shape[0]):
        target[i] = source[i]


@njit(cache=True)
def _discover(
    rep: IFDDKernel,
    arrays: LearnerArrays,
    phi: np.ndarray,
    delta: float,
    room: int,
    is_actor_critic: bool,
    has_trace_slots: bool,
) -> bool:
    """Algorithm 20/21 on φ(s) with δ, then the learner's rows for the new features.

    The rows come from the learners' own growth kernel (`grow_learner_rows`: θ_f = θ_g + θ_h,
    Section 4.1.1). Returns whether features were added (φ of every state must then be
    encoded again).
    """
    first, added, parents = discover_from(rep, phi, delta, room)
    grow_learner_rows(arrays, first, parents[first : first + added], is_actor_critic,
                      has_trace_slots)  # fmt: skip
    return added > 0


@njit(cache=True)
def learning_loop(
    num_steps: int,
    domain: DomainKernel,
    domain_rng: np.random.Generator,
    rep: IFDDKernel,
    agent: AgentKernel,
    arrays: LearnerArrays,
    row_traces: RowTracePair,
    agent_rng: np.random.Generator,
    cap: int,
    obs: np.ndarray,
    state: LoopState,
    box: BoxKernel,
    parts: BoxParts,
    learn: bool,
    max_episodes: int,
) -> tuple[int, int, int, float, float, np.ndarray, np.ndarray]:
    """Take up to ``num_steps`` steps; stop early on a status other than `DONE`.

    ``cap``: the episode cap; ``obs``: s, updated in place; ``box`` and ``parts``: iCCA's
    box around the learner and its parts called per state (`conjure.safety.compiled_cooperative`:
    its `box_action` chooses the actions, `box_learn` is Algorithm 26's model update), or
    `NO_BOX` and `NO_PARTS`. ``learn``: learning steps, or greedy ones (a policy check:
    `greedy_box_action`; no begin_episode, update, discovery or model update, as the Python
    `Stepper` with ``learn=False``); the call also stops when ``max_episodes`` episodes
    ended. Returns (status, steps taken, failures, Σ c_t over the steps, last δ, episodes
    (m, 3) float64 [return, discounted return, cost], episodes (m, 2) int64 [length,
    failures]) for the m episodes that ended during the call.

    `GROW_REPRESENTATION` and `GROW_TRACES` stop before a step whose discoveries or traces
    might not fit (the caller grows them with the component's own method and calls again);
    `DIVERGED` stops after an update whose δ is not finite (that step is not counted);
    `DOMAIN_RAISED` stops when a callback domain's ``reset`` or ``step`` raised (that step is
    not counted; the episode cannot be continued); `FULL_INDEX` when a state's new cell did
    not fit a full `HashedTabular` (the learner's or the box's index; ``obs`` is then that
    state, the step is not counted and the episode cannot be continued).
    θ (and ω, the trace slots) must have a row for every feature iFDD's tables can hold.
    """
    domain, domain_rng, agent_rng = borrowed(domain), borrowed(domain_rng), borrowed(agent_rng)
    rep, arrays, obs, box = borrowed(rep), borrowed(arrays), borrowed(obs), borrowed(box)
    state = borrowed(state)
    num_actions = arrays.actor_weights.shape[1]  # θ has one column for a V critic
    has_traces = agent.traces != NO_TRACES
    is_tracing = learn and has_traces
    has_trace_slots = agent.traces == REPLACING or agent.traces == ACCUMULATING  # SARSA(λ)'s
    is_actor_critic = agent.kind == ACTOR_CRITIC
    is_log_policy = learn and agent.is_log_policy  # keeps π(s, ·) as drawn (`drawn`)
    is_box = learn and box.kind != NO_BOX  # a learning box (greedy acting: `greedy_box_action`)
    is_adaptive_box = is_box and parts.is_adaptive
    is_constrained = has_cost_critic(agent.constraint)  # a cost critic and λ
    is_penalized = is_constrained and not is_actor_critic  # acting on Q − λQ_C
    constraint = agent.constraint  # Sauté: blocks of θ and ω by the budget spent
    row_buffer = np.empty(1, dtype=np.int64)
    # The actor's preferences choose actions for Actor-Critic (shared features), θ otherwise
    # (``chooser``: their rows for the episode's cost so far, `budget_rows`).
    full_chooser = chooser = arrays.actor_weights
    # Scratch: φ(s) and φ(s') buffers of tile coding, legal-action lists, Q(s', ·).
    base, is_ifdd = rep.base, rep.is_ifdd
    is_discovering = learn and is_ifdd
    is_growing_box = is_box and is_ifdd  # Algorithm 24's veto rule may discover features
    max_active = max(base.max_active, 1)
    quanta = np.empty(obs.shape[0], dtype=np.int64)
    phi_buffer = np.empty(max_active, dtype=np.int64)
    next_buffer = np.empty(max_active, dtype=np.int64)
    all_actions = np.arange(num_actions)
    legal_buffer = np.arange(num_actions)
    next_legal_buffer = np.arange(num_actions)
    is_masked = domain.has_action_constraints
    next_obs = np.empty_like(obs)
    q = np.empty(num_actions)
    critic_q = np.empty(arrays.weights.shape[1])
    cost_q, choice = np.zeros(arrays.weights.shape[1]), np.empty(num_actions)
    drawn, next_drawn = state.drawn, np.empty(num_actions)
    # The scratch as borrowed views too, its owners held until the call ends (`release`).
    owners = (row_buffer, quanta, phi_buffer, next_buffer, all_actions, legal_buffer,
              next_legal_buffer, next_obs, q, critic_q, next_drawn, cost_q, choice)  # fmt: skip
    (row_buffer, quanta, phi_buffer, next_buffer, all_actions, legal_buffer, next_legal_buffer,
     next_obs, q, critic_q, next_drawn, cost_q, choice) = borrowed(owners)  # fmt: skip
    ep_float = np.empty((16, 3))
    ep_int = np.empty((16, 2), dtype=np.int64)
    is_buffered = base.kind == TILES and not is_ifdd  # φ(s) lives in phi_buffer
    is_indexed = learn and base.kind == HASHED_TABULAR  # φ(s) may be [FULL] (not on peeking)
    num_ended = done = failures = 0
    delta = costs = 0.0
    status = DONE
    # The loop state, in locals while running (LLVM keeps them in registers).
    phase, action, episode_steps = state.phase[0], state.action[0], state.episode_steps[0]
    episode, learning_steps = state.episode[0], state.learning_steps[0]
    episode_failures, total = state.episode_failures[0], state.total[0]
    discounted, weight = state.discounted[0], state.weight[0]
    episode_cost = state.episode_cost[0]
    phi = phi_buffer
    values = values_of(base, obs)  # φ(s)'s values (None: binary φ)
    if phase == IN_EPISODE:
        phi = encode_into(base, obs, quanta, phi_buffer) if learn else peek_into(
            base, obs, quanta, phi_buffer
        )  # fmt: skip
        if is_ifdd:  # `rep` is read only with iFDD (see `sparsify`)
            phi = sparsify(rep, phi)
    while done < num_steps:
        if phase == NEEDS_RESET:
            if not reset_into(domain, obs, domain_rng):
                status = DOMAIN_RAISED
                break
            phase = NEEDS_BEGIN
        if phase == NEEDS_BEGIN:  # the learner's begin_episode, then a = π(s)
            if is_growing_box and not has_room_for(rep, 1):  # a vetoed proposal's discovery
                status = GROW_REPRESENTATION
                break
            if learn:
                episode += 1
                clear_learner_traces(agent, arrays, row_traces, episode - 1)
                phi = encode_into(base, obs, quanta, phi_buffer)
            else:  # a policy check stores nothing (`Representation.peek`)
                phi = peek_into(base, obs, quanta, phi_buffer)
            if is_indexed and phi[0] < 0:
                status, phase = FULL_INDEX, NEEDS_RESET
                break
            if is_ifdd:
                phi = sparsify(rep, phi)
            values = values_of(base, obs)
            legal = legal_into(domain, False, legal_buffer) if is_masked else all_actions
            chooser = budget_rows(constraint, full_chooser, 0.0)  # nothing spent yet
            if not learn and is_penalized:  # a constrained learner's greedy action (no box)
                q_values_into(chooser, phi, values, q)
                action = greedy_action(acting_values(agent, arrays, phi, values, q, choice), legal)
            elif not learn:
                action = greedy_box_action(box, parts, chooser, phi, values, q, legal, obs)
            elif is_box:  # the box fills q (after moving ρ, for Algorithm 23)
                action, vetoed, imagined = box_action(
                    box, parts, agent, arrays, phi, values, q, legal, agent_rng, obs, quanta,
                    row_buffer, episode,
                )  # fmt: skip
                if action < 0:  # the box's index is full
                    status, phase = FULL_INDEX, NEEDS_RESET
                    break
                if not math.isfinite(vetoed):  # a vetoed proposal's update diverged
                    status, delta, phase = DIVERGED, vetoed, NEEDS_RESET
                    break
                if is_growing_box and imagined:  # the vetoed update's discovery on φ(s)
                    room = room_for(rep, phi)
                    if _discover(rep, arrays, phi, vetoed, room, is_actor_critic, has_trace_slots):
                        phi = sparsify(rep, encode_into(base, obs, quanta, phi_buffer))
            else:
                q_values_into(chooser, phi, values, q)
                acting = acting_values(agent, arrays, phi, values, q, choice)
                action = select_action(agent.policy, acting, legal, agent_rng)
            if is_log_policy:
                gibbs_policy(agent.policy, q, legal, drawn)
            episode_steps = episode_failures = 0
            total, discounted, weight, episode_cost = 0.0, 0.0, 1.0, 0.0
            phase = IN_EPISODE
        room = room_for(rep, phi) if is_discovering else 0
        if room < 0 or (is_growing_box and not has_room_for(rep, 2)):  # discoveries at s', s
            status = GROW_REPRESENTATION
            break
        if is_tracing and not traces_fit(agent, arrays, row_traces, phi.shape[0]):
            status = GROW_TRACES
            break
        reward, terminated, cost = step_into(domain, action, next_obs, domain_rng)
        if math.isnan(reward):  # only a callback domain's step that raised
            status = DOMAIN_RAISED
            phase = NEEDS_RESET
            break
        episode_steps += 1
        next_phi, next_values = phi, values
        next_action = 0
        next_spent = episode_cost + cost if cost > 0.0 else episode_cost  # spent at s'
        target, cost_target = saute_reward(constraint, reward, next_spent), cost
        if not terminated:  # φ(s'), a' = π(s') and Q⁺(s, a) (Algorithms 10-12, lines 4-5)
            next_phi = encode_into(base, next_obs, quanta, next_buffer) if learn else peek_into(
                base, next_obs, quanta, next_buffer
            )  # fmt: skip
            if is_indexed and next_phi[0] < 0:
                _copy(obs, next_obs)
                status, phase = FULL_INDEX, NEEDS_RESET
                break
            if is_ifdd:
                next_phi = sparsify(rep, next_phi)
            next_values = values_of(base, next_obs)
            next_legal = legal_into(domain, True, next_legal_buffer) if is_masked else all_actions
            chooser = budget_rows(constraint, full_chooser, next_spent)
            if not learn and is_penalized:
                q_values_into(chooser, next_phi, next_values, q)
                acting = acting_values(agent, arrays, next_phi, next_values, q, choice)
                next_action = greedy_action(acting, next_legal)
            elif not learn:
                next_action = greedy_box_action(
                    box, parts, chooser, next_phi, next_values, q, next_legal, next_obs
                )
            elif is_box:
                next_action, vetoed, imagined = box_action(
                    box, parts, agent, arrays, next_phi, next_values, q, next_legal, agent_rng,
                    next_obs, quanta, row_buffer, episode,
                )  # fmt: skip
                if next_action < 0:  # the box's index is full
                    _copy(obs, next_obs)
                    status, phase = FULL_INDEX, NEEDS_RESET
                    break
                if not math.isfinite(vetoed):  # a vetoed proposal's update diverged
                    status, delta, phase = DIVERGED, vetoed, NEEDS_RESET
                    break
                if is_growing_box and imagined:  # the vetoed update's discovery on φ(s')
                    next_room = room_for(rep, next_phi)
                    if _discover(rep, arrays, next_phi, vetoed, next_room, is_actor_critic,
                                 has_trace_slots):  # fmt: skip
                        # φ(s'), Q(s', ·) and φ(s) with the new features (the Python learner
                        # encodes again after growing)
                        next_phi = sparsify(rep, encode_into(base, next_obs, quanta, next_buffer))
                        q_values_into(arrays.weights, next_phi, next_values, q)
                        phi = sparsify(rep, encode_into(base, obs, quanta, phi_buffer))
                        room = room_for(rep, phi)
            else:
                q_values_into(chooser, next_phi, next_values, q)
                acting = acting_values(agent, arrays, next_phi, next_values, q, choice)
                next_action = select_action(agent.policy, acting, next_legal, agent_rng)
            if is_log_policy:
                gibbs_policy(agent.policy, q, next_legal, next_drawn)
            if learn:
                if is_actor_critic:
                    critic = budget_rows(constraint, arrays.weights, next_spent)
                    q_values_into(critic, next_phi, next_values, critic_q)
                lagrange = multiplier(agent, arrays)
                if is_constrained:  # θ_Cᵀφ(s') and the cost critic's target
                    q_values_into(arrays.cost_weights, next_phi, next_values, cost_q)
                    cost_target = cost_bootstrap(
                        agent, cost, q, next_action, next_legal, cost_q, lagrange
                    )
                target = bootstrap(
                    agent, target, q, next_action, next_legal, critic_q, cost_q, lagrange
                )
        grew = False
        if learn:
            delta = td_learn(
                agent, budget_arrays(agent, arrays, episode_cost), row_traces, phi, values,
                action, target, episode, drawn, cost, cost_target,
            )  # fmt: skip
            learning_steps += 1
            if not math.isfinite(delta):
                status = DIVERGED
                phase = NEEDS_RESET
                break
            grew = is_ifdd and _discover(
                rep, arrays, phi, delta, room, is_actor_critic, has_trace_slots
            )
            if is_adaptive_box:  # Algorithm 26: T̂ learns from the move, π^p may switch
                box_learn(box, parts, obs, action, next_obs)
            if terminated:
                end_of_episode_traces(agent, arrays)
        done += 1
        if cost > 0.0:  # a failure step (`info["cost"] > 0`)
            failures += 1
            episode_failures += 1
            costs += cost
            episode_cost += cost
        total += reward
        discounted += weight * reward
        weight *= agent.discount
        if terminated or episode_steps >= cap:
            ep_float, ep_int = _record_episode(
                ep_float, ep_int, num_ended, total, discounted, episode_cost, episode_steps,
                episode_failures,
            )  # fmt: skip
            num_ended += 1
            phase = NEEDS_RESET
            if num_ended >= max_episodes:
                break
        else:
            _copy(obs, next_obs)
            if grew:  # φ(s) with the new features, as the Python learner re-encodes
                phi = sparsify(rep, encode_into(base, obs, quanta, phi_buffer))
            elif is_buffered:  # φ(s) ← φ(s'): copy; φ(s) stays in its buffer (phi is phi_buffer)
                _copy(phi_buffer, next_phi)
            else:
                phi = next_phi
            values = next_values
            action = next_action
            if is_log_policy:
                _copy(drawn, next_drawn)
    state.phase[0], state.action[0], state.episode_steps[0] = phase, action, episode_steps
    state.episode[0], state.learning_steps[0] = episode, learning_steps
    state.episode_failures[0], state.total[0] = episode_failures, total
    state.discounted[0], state.weight[0] = discounted, weight
    state.episode_cost[0] = episode_cost
    release(owners)
    return status, done, failures, costs, delta, ep_float[:num_ended], ep_int[:num_ended]
