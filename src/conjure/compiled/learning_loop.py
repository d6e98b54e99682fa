"""The compiled learning loop: n steps of domain, features, action choice and TD update.

`learning_loop` is `conjure.experiments.loop.Stepper`'s step order (Algorithms 10-12 as an
interaction loop) in one numba function. It owns no dynamics, features, schedule or update
arithmetic: every step calls the components' own kernels through their compiled forms
(`conjure.core.compiled_form`):

- the domain (`conjure.domains.compiled_domain`): `reset_into`, `step_into`, `legal_into`;
- the representation (`conjure.representations.compiled_representation`): `encode_into`
  and `values_of` for φ(s), and with online iFDD or ARiFDD
  (`conjure.representations.compiled_ifdd`) `sparsify` (Algorithm 19), `room_for` and
  `discover_from` (Algorithms 20-22: the loop never asks which);
- the learner (`conjure.agents.compiled_agent`): `q_values_into`, `learn_step` (the Python
  learner's learn too), `clear_learner_traces`, `grow_learner_rows` for new features' rows
  (Section 4.1.1), and the policy's `select_action` (and `gibbs_policy` for the log-policy
  actor).

Per step: a = π(s) was chosen; s', r = step(a); unless terminal, φ(s') and a' = π(s') over
the legal actions of s'; Q⁺(s, a); δ and the updates (with a `Saute` constraint, acting at
s' and Q⁺ read the blocks of θ and ω for the episode's cost up to s', the update those up to
s, and r is Sauté's r̃: `budget_rows`, `budget_arrays`, `saute_reward`, from the loop's own
``episode_cost``, learning and greedy steps alike); with iFDD or ARiFDD, discovery on φ(s)
with δ and the new features' rows; then s ← s', a ← a' (φ(s) recomputed after a discovery,
as the Python learner re-encodes). Inside an iCCA box
(`conjure.safety.compiled_cooperative`) the box chooses a and a'; a vetoed proposal it
learns (Algorithm 24's veto rule) is followed by its own discovery on that state's φ, before
the step's update, as in the Python learner's ``learn``. Choice: the tables are then grown
before a step unless two discoveries from any sparsified φ fit (`has_room_for`), since the
box cannot pause once the domain has stepped.
Random numbers come from the same `numpy.random.Generator` objects in the same order as the
Python path (numba shares their state): the domain's draws per step and one uniform per action
choice. "iFDD" below is any representation with online iFDD's tables (`IFDDKernel.is_ifdd`:
`OnlineIFDD`, `RandomExpansion`, and `ARiFDD`, whose φ⁰ also splits).

The loop reads like `Stepper._steps`; its slots are small kernels, inlined
(``inline="always"``) so the step's compiled code is that of one function, except `_begin` (the
learner's begin_episode and a = π(s), once per episode, called): `_room` (before a learning
step that discovers: whether discoveries fit), `_choose_alone` (φ(s), the legal actions and a = π(s)
of the learner alone) or `_choose` (the same inside a box, whose `_act` chooses; discovery
after a learned veto), `_learn` (Q⁺(s, a) and the update), then the grow slot `_discover` and
Algorithm 26's `box_learn`. Each mode lives in the slot it changes (a policy check acts
greedily in `_act` and never reaches `_learn`). The loop's own state (phase, action, counters,
return so far) is `LoopState`, resumable between calls; an episode may span calls.

Choice: the loop reads its arguments and its scratch arrays through borrowed views
(`conjure.core.compiled_form.borrowed`, `release`): numba counts a reference to every array of
a form each time a kernel binds it, with an atomic add, and prunes few of those counts in a
function this large. A structref cannot be borrowed (its pointer is its data), so every
inlined slot that binds a form holding one (iFDD's tables in `IFDDKernel`, `RowTracePair`,
`BoxParts`) pays two atomic counts per binding, and a slot nested in another pays them again.
Choice: the slots take the forms they read, each as its own argument (no bundle of all forms),
and the loop calls a slot that binds a structref only where it applies, by flags set once per
call: `_room` with iFDD, `traces_fit` with traces, `_choose` only inside a box, `_discover`
with iFDD and `box_learn` with an adaptive model. `_begin`, which binds every form, runs once
per episode and is called, not inlined. `benchmarks/loop_refcounts.py` counts what is left.

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
    budget_rows,
    clear_learner_traces,
    grow_learner_rows,
    has_cost_critic,
    learn_step,
    q_values_into,
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
    RepresentationKernel,
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


@njit(cache=True, inline="always")
def _resume(state: LoopState) -> tuple[int, int, int, int, int, int, float, float, float, float]:
    """`LoopState`'s values, in its field order (``drawn`` aside)."""
    return (state.phase[0], state.action[0], state.episode_steps[0], state.episode[0],
            state.learning_steps[0], state.episode_failures[0], state.total[0],
            state.discounted[0], state.weight[0], state.episode_cost[0])  # fmt: skip


@njit(cache=True, inline="always")
def _pause(
    state: LoopState, phase: int, action: int, episode_steps: int, episode: int,
    learning_steps: int, episode_failures: int, total: float, discounted: float, weight: float,
    episode_cost: float,
) -> None:  # fmt: skip
    """Write the loop's values back into ``state`` (`_resume`'s inverse)."""
    state.phase[0], state.action[0], state.episode_steps[0] = phase, action, episode_steps
    state.episode[0], state.learning_steps[0] = episode, learning_steps
    state.episode_failures[0], state.total[0] = episode_failures, total
    state.discounted[0], state.weight[0], state.episode_cost[0] = discounted, weight, episode_cost


class Scratch(NamedTuple):
    """A call's buffers: φ(s) and φ(s') of tile coding, legal actions at s and s', s', Q(s', ·).

    ``quanta`` and ``row_buffer`` for encoding, ``all_actions`` for an unmasked domain, the
    critic's and the cost critic's values at s' and the acting values ``choice``; ``next_drawn``
    is π(s', ·) for the log-policy actor; ``alphas`` is `learn_step`'s (never read here).
    """

    quanta: np.ndarray
    row_buffer: np.ndarray
    phi_buffer: np.ndarray
    next_buffer: np.ndarray
    all_actions: np.ndarray
    legal_buffer: np.ndarray
    next_legal_buffer: np.ndarray
    next_obs: np.ndarray
    q: np.ndarray
    critic_q: np.ndarray
    cost_q: np.ndarray
    choice: np.ndarray
    next_drawn: np.ndarray
    alphas: np.ndarray


@njit(cache=True, inline="always")
def _new_scratch(obs: np.ndarray, rep: IFDDKernel, arrays: LearnerArrays) -> Scratch:
    max_active = max(rep.base.max_active, 1)
    num_actions = arrays.actor_weights.shape[1]  # θ has one column for a V critic
    return Scratch(
        quanta=np.empty(obs.shape[0], dtype=np.int64),
        row_buffer=np.empty(1, dtype=np.int64),
        phi_buffer=np.empty(max_active, dtype=np.int64),
        next_buffer=np.empty(max_active, dtype=np.int64),
        all_actions=np.arange(num_actions),
        legal_buffer=np.arange(num_actions),
        next_legal_buffer=np.arange(num_actions),
        next_obs=np.empty_like(obs),
        q=np.empty(num_actions),
        critic_q=np.empty(arrays.weights.shape[1]),
        cost_q=np.zeros(arrays.weights.shape[1]),
        choice=np.empty(num_actions),
        next_drawn=np.empty(num_actions),
        alphas=np.zeros(2),  # α_t of a Python schedule (never here: no compiled form)
    )


@njit(cache=True, inline="always")
def _encode(
    base: RepresentationKernel, learn: bool, obs: np.ndarray, buffer: np.ndarray, scratch: Scratch
) -> np.ndarray:
    """φ(s) of the fixed features, stored by a learning step (`encode_into`), not by a check.

    A policy check reads without storing a new cell (`peek_into`).
    """
    if learn:
        return encode_into(base, obs, scratch.quanta, buffer)
    return peek_into(base, obs, scratch.quanta, buffer)


@njit(cache=True, inline="always")
def _observe(
    domain: DomainKernel,
    base: RepresentationKernel,
    learn: bool,
    obs: np.ndarray,
    buffer: np.ndarray,
    legal_buffer: np.ndarray,
    scratch: Scratch,
) -> tuple[np.ndarray, np.ndarray | None, np.ndarray, bool]:
    """φ(s) of the fixed features, its values, the legal actions, and whether an index was full.

    A full `HashedTabular` refuses a new cell (φ[0] < 0).
    """
    phi = _encode(base, learn, obs, buffer, scratch)
    is_full = learn and base.kind == HASHED_TABULAR and phi[0] < 0
    if domain.has_action_constraints:
        return phi, values_of(base, obs), legal_into(domain, legal_buffer), is_full
    return phi, values_of(base, obs), scratch.all_actions, is_full


@njit(cache=True, inline="always")
def _act_alone(
    agent: AgentKernel,
    arrays: LearnerArrays,
    agent_rng: np.random.Generator,
    learn: bool,
    phi: np.ndarray,
    values: np.ndarray | None,
    legal: np.ndarray,
    spent: float,
    scratch: Scratch,
) -> int:
    """The action π(s) of the learner alone; Q(s, ·) of the rows for the cost ``spent`` in q.

    Its policy's action when learning, else the greedy one; a constrained SARSA or Q-Learning
    acts on Q − λQ_C (`acting_values`).
    """
    chooser = budget_rows(agent.constraint, arrays.actor_weights, spent)
    q_values_into(chooser, phi, values, scratch.q)
    acting = acting_values(agent, arrays, phi, values, scratch.q, scratch.choice)
    if learn:
        return select_action(agent.policy, acting, legal, agent_rng)
    return greedy_action(acting, legal)


@njit(cache=True, inline="always")
def _act(
    agent: AgentKernel,
    arrays: LearnerArrays,
    agent_rng: np.random.Generator,
    box: BoxKernel,
    box_parts: BoxParts,
    learn: bool,
    phi: np.ndarray,
    values: np.ndarray | None,
    legal: np.ndarray,
    spent: float,
    obs: np.ndarray,
    scratch: Scratch,
    episode: int,
) -> tuple[int, float, bool]:
    """The act slot inside a box: a = π(s) by the box (Q(s, ·) in ``scratch.q``).

    Returns (a, a vetoed proposal's δ, whether the box learned one). A policy check acts
    through the box (`greedy_box_action`); a constrained learner's check acts greedily on its
    own (`_act_alone`).
    """
    is_penalized = has_cost_critic(agent.constraint) and agent.kind != ACTOR_CRITIC
    if not learn and is_penalized:
        return _act_alone(agent, arrays, agent_rng, learn, phi, values, legal, spent,
                          scratch), 0.0, False  # fmt: skip
    if not learn:
        chooser = budget_rows(agent.constraint, arrays.actor_weights, spent)
        return greedy_box_action(box, box_parts, chooser, phi, values, scratch.q, legal,
                                 obs), 0.0, False  # fmt: skip
    return box_action(  # it fills Q(s, ·) after moving ρ, for Algorithm 23
        box, box_parts, agent, arrays, phi, values, scratch.q, legal, agent_rng, obs,
        scratch.quanta, scratch.row_buffer, episode,
    )  # fmt: skip


@njit(cache=True)
def _discover(
    rep: IFDDKernel, arrays: LearnerArrays, phi: np.ndarray, delta: float, room: int,
    agent: AgentKernel, state: np.ndarray,
) -> bool:  # fmt: skip
    """The grow slot: discovery on φ(s) at s with δ, then the learner's rows for new features.

    The representation's own `discover_from` runs (Algorithm 20/21, or ARiFDD's 22). The rows
    come from the learners' own growth kernel (`grow_learner_rows`: θ_f = θ_g + θ_h, Section
    4.1.1; a split tile's halves copy θ_t). Returns whether features were added (φ of every
    state must then be encoded again).
    """
    first, added, parents = discover_from(rep, phi, delta, room, state)
    has_trace_slots = agent.traces == REPLACING or agent.traces == ACCUMULATING  # SARSA(λ)'s
    grow_learner_rows(arrays, first, parents[first : first + added],
                      agent.kind == ACTOR_CRITIC, has_trace_slots)  # fmt: skip
    return added > 0


@njit(cache=True, inline="always")
def _features(rep: IFDDKernel, learn: bool, obs: np.ndarray, buffer: np.ndarray,
              scratch: Scratch) -> np.ndarray:  # fmt: skip
    """φ(s) encoded again (sparsified by iFDD, Algorithm 19, with the features it holds now)."""
    phi = _encode(rep.base, learn, obs, buffer, scratch)
    return sparsify(rep, phi) if rep.is_ifdd else phi


@njit(cache=True, inline="always")
def _shift(phi_buffer: np.ndarray, next_phi: np.ndarray, is_buffered: bool) -> np.ndarray:
    """φ(s) ← φ(s'): tile coding's φ(s) stays in its buffer (a copy), others are rebound."""
    if is_buffered:
        _copy(phi_buffer, next_phi)
        return phi_buffer
    return next_phi


@njit(cache=True, inline="always")
def _choose_alone(
    domain: DomainKernel,
    rep: IFDDKernel,
    agent: AgentKernel,
    arrays: LearnerArrays,
    agent_rng: np.random.Generator,
    learn: bool,
    obs: np.ndarray,
    buffer: np.ndarray,
    legal_buffer: np.ndarray,
    drawn: np.ndarray,
    spent: float,
    scratch: Scratch,
) -> tuple[np.ndarray, np.ndarray | None, np.ndarray, int, int]:
    """φ(s), its values and legal actions, then a = π(s) of the learner alone, for s = ``obs``.

    With iFDD or ARiFDD φ(s) is sparsified (Algorithm 19). The
    log-policy actor's π(s, ·) goes to ``drawn``. Returns (φ(s), values, legal actions, a,
    status). It binds no box part: see `learning_loop`'s Choice.
    """
    phi, values, legal, is_full = _observe(domain, rep.base, learn, obs, buffer, legal_buffer,
                                           scratch)  # fmt: skip
    if is_full:
        return phi, values, legal, -1, FULL_INDEX
    if rep.is_ifdd:  # `rep` is read only with iFDD (see `sparsify`)
        phi = sparsify(rep, phi)
    action = _act_alone(agent, arrays, agent_rng, learn, phi, values, legal, spent, scratch)
    if learn and agent.is_log_policy:
        gibbs_policy(agent.policy, scratch.q, legal, drawn)
    return phi, values, legal, action, DONE


@njit(cache=True, inline="always")
def _choose(
    domain: DomainKernel,
    rep: IFDDKernel,
    agent: AgentKernel,
    arrays: LearnerArrays,
    agent_rng: np.random.Generator,
    box: BoxKernel,
    box_parts: BoxParts,
    learn: bool,
    at_next: bool,
    obs: np.ndarray,
    buffer: np.ndarray,
    legal_buffer: np.ndarray,
    drawn: np.ndarray,
    spent: float,
    scratch: Scratch,
    episode: int,
) -> tuple[np.ndarray, np.ndarray | None, np.ndarray, int, int, float, bool]:
    """`_choose_alone` inside a box: a = π(s) by the box (`_act`) for s = ``obs``.

    With iFDD, a vetoed proposal the box learned is followed by discovery on φ(s) (φ(s) is
    then encoded again; at s' Q(s', ·) too, the Python learner's order). Returns (φ(s),
    values, legal actions, a, status, the vetoed δ, whether features were added).
    """
    phi, values, legal, is_full = _observe(domain, rep.base, learn, obs, buffer, legal_buffer,
                                           scratch)  # fmt: skip
    if is_full:
        return phi, values, legal, -1, FULL_INDEX, 0.0, False
    if rep.is_ifdd:  # `rep` is read only with iFDD (see `sparsify`)
        phi = sparsify(rep, phi)
    action, vetoed, imagined = _act(agent, arrays, agent_rng, box, box_parts, learn, phi, values,
                                    legal, spent, obs, scratch, episode)  # fmt: skip
    status = FULL_INDEX if action < 0 else DIVERGED if not math.isfinite(vetoed) else DONE
    if status != DONE:
        return phi, values, legal, action, status, vetoed, False
    grew = imagined and rep.is_ifdd and _discover(rep, arrays, phi, vetoed, room_for(rep, phi),
                                                  agent, obs)  # fmt: skip
    if grew:
        phi = _features(rep, learn, obs, buffer, scratch)
        if at_next:
            q_values_into(arrays.weights, phi, values, scratch.q)
    if learn and agent.is_log_policy:
        gibbs_policy(agent.policy, scratch.q, legal, drawn)
    return phi, values, legal, action, status, vetoed, grew


@njit(cache=True, inline="always")
def _room(rep: IFDDKernel, box: BoxKernel, phi: np.ndarray) -> tuple[int, int]:
    """Before a learning step that discovers: (status, room for discoveries on φ(s)).

    `GROW_REPRESENTATION` asks to grow the tables. Choice: inside a box they must fit two
    discoveries from any sparsified φ (at s' after a vetoed proposal, and at s), since the box
    cannot pause once the domain stepped.
    """
    room = room_for(rep, phi)
    if room < 0 or (box.kind != NO_BOX and not has_room_for(rep, 2)):
        return GROW_REPRESENTATION, room
    return DONE, room


@njit(cache=True, inline="always")
def _learn(
    agent: AgentKernel,
    arrays: LearnerArrays,
    row_traces: RowTracePair,
    scratch: Scratch,
    phi: np.ndarray,
    values: np.ndarray | None,
    action: int,
    reward: float,
    cost: float,
    terminated: bool,
    next_phi: np.ndarray,
    next_values: np.ndarray | None,
    next_action: int,
    next_legal: np.ndarray,
    spent: float,
    next_spent: float,
    episode: int,
    drawn: np.ndarray,
) -> float:
    """The learn slot: the values at s' its target reads, then the learners' `learn_step`.

    Q(s', ·) is in ``scratch.q`` (`_act`); Actor-Critic's θᵀφ(s') and a cost critic's
    θ_Cᵀφ(s') are read here. ``spent`` and ``next_spent``: the episode's cost before s and
    before s' (Sauté's blocks). Returns δ.
    """
    if not terminated and agent.kind == ACTOR_CRITIC:
        critic = budget_rows(agent.constraint, arrays.weights, next_spent)
        q_values_into(critic, next_phi, next_values, scratch.critic_q)
    if not terminated and has_cost_critic(agent.constraint):
        q_values_into(arrays.cost_weights, next_phi, next_values, scratch.cost_q)
    return learn_step(
        agent, arrays, row_traces, phi, values, phi, values, action, reward, terminated,
        scratch.q, scratch.critic_q, scratch.cost_q, next_action, next_legal, episode,
        scratch.alphas, drawn, True, cost, spent, next_spent,
    )  # fmt: skip


@njit(cache=True)
def _begin(
    domain: DomainKernel,
    rep: IFDDKernel,
    agent: AgentKernel,
    arrays: LearnerArrays,
    row_traces: RowTracePair,
    agent_rng: np.random.Generator,
    box: BoxKernel,
    box_parts: BoxParts,
    learn: bool,
    obs: np.ndarray,
    drawn: np.ndarray,
    scratch: Scratch,
    episode: int,
) -> tuple[int, np.ndarray, np.ndarray | None, int, float]:
    """The learner's begin_episode (traces cleared), then a = π(s) at the start s.

    Returns (status, φ(s), values, a, a vetoed proposal's δ). Inside a box the tables must
    first fit that proposal's discovery (`GROW_REPRESENTATION`). Called once per episode, not
    inlined: it binds every form.
    """
    if learn and rep.is_ifdd and box.kind != NO_BOX and not has_room_for(rep, 1):
        return GROW_REPRESENTATION, scratch.phi_buffer, values_of(rep.base, obs), 0, 0.0
    if learn:
        clear_learner_traces(agent, arrays, row_traces, episode - 1)
    buffer, legal_buffer = scratch.phi_buffer, scratch.legal_buffer
    if box.kind == NO_BOX:
        phi, values, _, action, status = _choose_alone(
            domain, rep, agent, arrays, agent_rng, learn, obs, buffer, legal_buffer, drawn, 0.0,
            scratch,
        )  # fmt: skip
        return status, phi, values, action, 0.0
    phi, values, _, action, status, vetoed, _ = _choose(
        domain, rep, agent, arrays, agent_rng, box, box_parts, learn, False, obs, buffer,
        legal_buffer, drawn, 0.0, scratch, episode,
    )  # fmt: skip
    return status, phi, values, action, vetoed


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
    domain, domain_rng, rep, agent, arrays, agent_rng, box = borrowed(
        (domain, domain_rng, rep, agent, arrays, agent_rng, box)
    )
    obs, state, owned = borrowed(obs), borrowed(state), _new_scratch(obs, rep, arrays)
    scratch = borrowed(owned)  # its owners held until the call ends (`release`)
    # Which slots bind a structref (see the Choice above): iFDD's, a box's, the traces'.
    is_discovering, has_traces = learn and rep.is_ifdd, learn and agent.traces != NO_TRACES
    is_adaptive = learn and box.kind != NO_BOX and parts.is_adaptive  # Algorithm 26's
    is_buffered = rep.base.kind == TILES and not rep.is_ifdd  # φ(s) lives in phi_buffer
    ep_float, ep_int = np.empty((16, 3)), np.empty((16, 2), dtype=np.int64)
    num_ended = done = failures = room = 0
    status, delta, costs = DONE, 0.0, 0.0
    # The loop state, in locals while running (LLVM keeps them in registers).
    (phase, action, episode_steps, episode, learning_steps, episode_failures, total, discounted,
     weight, spent) = _resume(state)  # fmt: skip
    drawn, next_obs, phi_buffer = state.drawn, scratch.next_obs, scratch.phi_buffer
    phi = _features(rep, learn, obs, phi_buffer, scratch) if phase == IN_EPISODE else phi_buffer
    values = values_of(rep.base, obs)
    while done < num_steps:
        if phase == NEEDS_RESET:
            if not reset_into(domain, obs, domain_rng):
                status = DOMAIN_RAISED
                break
            phase = NEEDS_BEGIN
        if phase == NEEDS_BEGIN:  # the learner's begin_episode, then a = π(s)
            episode += 1 if learn else 0
            status, phi, values, action, vetoed = _begin(
                domain, rep, agent, arrays, row_traces, agent_rng, box, parts, learn, obs, drawn,
                scratch, episode)  # fmt: skip
            if status != DONE:
                delta, phase = vetoed if status == DIVERGED else delta, NEEDS_RESET
                break
            episode_steps = episode_failures = 0
            phase, total, discounted, weight, spent = IN_EPISODE, 0.0, 0.0, 1.0, 0.0
        status, room = _room(rep, box, phi) if is_discovering else (DONE, 0)
        if has_traces and status == DONE and not traces_fit(agent, arrays, row_traces, len(phi)):
            status = GROW_TRACES
        if status != DONE:
            break
        reward, terminated, cost = step_into(domain, action, next_obs, domain_rng)
        if math.isnan(reward):  # only a callback domain's step that raised
            status, phase = DOMAIN_RAISED, NEEDS_RESET
            break
        episode_steps += 1
        next_spent = spent + cost if cost > 0.0 else spent
        next_phi, next_values, next_action, next_legal = phi, values, 0, scratch.all_actions
        if not terminated and box.kind == NO_BOX:  # φ(s'), a' = π(s') (Algorithms 10-12)
            next_phi, next_values, next_legal, next_action, status = _choose_alone(
                domain, rep, agent, arrays, agent_rng, learn, next_obs, scratch.next_buffer,
                scratch.next_legal_buffer, scratch.next_drawn, next_spent, scratch)  # fmt: skip
        elif not terminated:
            next_phi, next_values, next_legal, next_action, status, vetoed, grew = _choose(
                domain, rep, agent, arrays, agent_rng, box, parts, learn, True, next_obs,
                scratch.next_buffer, scratch.next_legal_buffer, scratch.next_drawn, next_spent,
                scratch, episode)  # fmt: skip
            phi = _features(rep, learn, obs, phi_buffer, scratch) if grew else phi  # new features
            room = room_for(rep, phi) if grew else room
            delta = vetoed if status == DIVERGED else delta
        if status != DONE:
            if status == FULL_INDEX:  # obs is the state that did not fit
                _copy(obs, next_obs)
            phase = NEEDS_RESET
            break
        grew = False
        if learn:
            delta = _learn(agent, arrays, row_traces, scratch, phi, values, action, reward, cost,
                           terminated, next_phi, next_values, next_action, next_legal, spent,
                           next_spent, episode, drawn)  # fmt: skip
            learning_steps += 1
            if not math.isfinite(delta):
                status, phase = DIVERGED, NEEDS_RESET
                break
            grew = is_discovering and _discover(rep, arrays, phi, delta, room, agent, obs)
            if is_adaptive:  # Algorithm 26: T̂ learns from the move, π^p may switch
                box_learn(box, parts, obs, action, next_obs)
        done += 1
        if cost > 0.0:  # a failure step (`info["cost"] > 0`)
            failures, episode_failures = failures + 1, episode_failures + 1
            costs, spent = costs + cost, spent + cost
        total, discounted = total + reward, discounted + weight * reward
        weight *= agent.discount
        if terminated or episode_steps >= cap:
            ep_float, ep_int = _record_episode(ep_float, ep_int, num_ended, total, discounted,
                                               spent, episode_steps, episode_failures)  # fmt: skip
            num_ended += 1
            phase = NEEDS_RESET
            if num_ended >= max_episodes:
                break
        else:
            _copy(obs, next_obs)  # after a discovery φ(s) is encoded again, as in Python
            phi = (_features(rep, learn, obs, phi_buffer, scratch) if grew
                   else _shift(phi_buffer, next_phi, is_buffered))  # fmt: skip
            values, action = next_values, next_action
            if learn and agent.is_log_policy:
                _copy(drawn, scratch.next_drawn)
    _pause(state, phase, action, episode_steps, episode, learning_steps, episode_failures, total,
           discounted, weight, spent)  # fmt: skip
    release(owned)
    return status, done, failures, costs, delta, ep_float[:num_ended], ep_int[:num_ended]
