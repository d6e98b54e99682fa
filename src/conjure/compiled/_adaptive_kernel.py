"""The compiled learning loop of domains with legal actions and growing representations.

`adaptive_kernel` runs the step order of `conjure.experiments.loop.LearningLoop` for the
constrained domains of Geramifard (2012), Sections 4.1.4 and 5.3.5, BlocksWorld, Persistent
Surveillance, Rescue Mission and the UAV missions, with their initial features
(`BinaryIndicators` or `IndependentDiscretization`) alone or with online iFDD on top
(Algorithm 19 for φ̇, Algorithm 20/21 or the fixed rate of Eq. 4.6 for discovery), and for
the unconstrained domains of `conjure.compiled._kernels` (every action legal) with online iFDD
over tile coding, a table or independent discretization (Section 4.1.4's pendulum); learners
SARSA (Algorithm 11, with or without sparse eligibility traces), Q-Learning (Algorithm 10) or
Actor-Critic with the actor sharing the critic's features (Algorithm 12). It is a separate
kernel from `conjure.compiled._kernels.advance_kernel`, so that kernel's compile time does
not grow; it calls that module's `domain_reset`, `domain_step`, `encode`, `select_action`
and the per-step pieces both kernels share (`load_loop`, `learn`, `tally`, `store_loop`)
and `record_episode`.

The kernel calls the library's own kernels (`blocks_step`, `pst_step`, `independent_features`,
`activate`, `discover`, `td_step`, ...) and draws from the same generators in the same
order as the Python path: per step the domain's draws (BlocksWorld's and Rescue Mission's one
uniform, Persistent Surveillance's and a UAV mission's 2n, those of `domain_step`) and the
agent's one uniform per choice among the legal actions.

Arguments besides those of ``advance_kernel`` (``ints``, ``floats``, ``dparams``, ``dtable``,
``dcells``, ``loop``, ``loop_f``, ``obs``, the generators, the representation's six tables):

- ``dstate`` int64: the constrained domain's internal state (see
  `conjure.compiled.combination`), and ``fstate`` float64 the unconstrained one's (each empty
  for the other kind).
- ``ifdd``: `OnlineIFDD.kernel_tables` (its tables, updated in place), or the stand-in
  `empty_tables` without iFDD (``ints[I_IFDD] == 0``).
- ``weights``: θ with at least as many rows as the representation can hold features
  (``feat_start``'s length), so a discovery never outgrows it; rows past n_t are scratch.
  ``actor_weights``: Actor-Critic's ω, likewise (θ itself for the other learners).
- ``trace_slots`` (as many rows as ``weights``), ``trace_features``, ``trace_actions``,
  ``trace_values``, ``trace_count``: SARSA's sparse traces (`td_step_traces`), or
  empty stand-ins without traces. A discovered feature's trace row starts empty (-1), as
  SARSA's ``_grow`` appends it; `GROW_TRACES` stops before a step whose traces might not
  fit (the caller grows them with the agent's own method).

`GROW_REPRESENTATION` stops before a step whose `discover` would not fit in the iFDD arrays;
the caller grows them with the representation's own method and calls again.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from conjure.agents._kernels import clear_traces, q_values_into
from conjure.compiled._kernels import (
    ACTOR_CRITIC,
    DIVERGED,
    DONE,
    F_DISCOUNT,
    F_POLICY,
    GROW_TRACES,
    I_AGENT,
    I_CAP,
    I_DOMAIN,
    I_IFDD,
    I_MAX_ACTIVE,
    I_NUM_ACTIONS,
    I_NUM_TILINGS,
    I_POLICY,
    I_REP,
    I_TRACES,
    IN_EPISODE,
    NEEDS_BEGIN,
    NEEDS_RESET,
    NO_TRACES,
    SARSA,
    copy_into,
    domain_reset,
    domain_step,
    encode,
    learn,
    learner_arguments,
    load_loop,
    num_active,
    record_episode,
    select_action,
    store_loop,
    tally,
)
from conjure.domains._blocks_kernels import blocks_reset, blocks_step, legal_moves_into
from conjure.domains._mission_kernels import legal_actions, mission_step
from conjure.domains._uav_kernels import (
    BASE,
    pst_fill_legal_mask,
    pst_step,
    rescue_fill_legal_mask,
    rescue_step,
)
from conjure.representations._ifdd_kernels import (
    IFDDTables,
    activate,
    discover_fitting,
    discover_room,
)

# Domain codes (after those of `conjure.compiled._kernels`).
BLOCKS, PERSISTENT_SURVEILLANCE, RESCUE, UAV_MISSION = 3, 4, 5, 6
#: Where the start state s₀ begins in ``dparams`` of `RESCUE` and `UAV_MISSION` (after their
#: scalars: horizon, fuel penalty, failure penalty; the traverse failure probability).
RESCUE_START, UAV_START = 3, 1
#: Rescue Mission's graph: neighbours in ``dtable[:, :3]``, degree in ``dtable[:, 3]``;
#: ``dcells[:, :8]`` the one-edge-away table, then the people and success probability per node.
RESCUE_PEOPLE, RESCUE_SUCCESS = 8, 9
# Representation code (after those of `conjure.compiled._kernels`, whose codes it shares).
INDICATORS = 4
# Status code (after those of `conjure.compiled._kernels`).
GROW_REPRESENTATION = 3
#: Persistent Surveillance's start state of one UAV: full fuel (set from dparams), BASE, healthy.
_PST_START = (0, BASE, 1, 1)


@njit(cache=True, inline="always")
def _encode(
    kind: int,
    is_ifdd: bool,
    obs: np.ndarray,
    rep: tuple,
    num_tilings: int,
    scratch: tuple,
    ifdd: IFDDTables,
) -> np.ndarray:
    """φ⁰(s) of the base representation, or φ̇(s) from it (`OnlineIFDD.active_features`).

    ``rep`` is the base's tables as `conjure.compiled._kernels.encode` takes them (binary:
    its last entry is None) and ``scratch`` the (quanta, tiles) buffers of unhashed tile
    coding, which ``activate`` copies.
    """
    if kind == INDICATORS:
        initial = np.flatnonzero(obs)
    else:
        quanta, tiles = scratch
        initial = encode(kind, obs, rep, num_tilings, quanta, tiles)
    if is_ifdd:
        return activate(initial, ifdd)
    return initial


@njit(cache=True)
def _reset(
    kind: int,
    dparams: np.ndarray,
    dcells: np.ndarray,
    dstate: np.ndarray,
    fstate: np.ndarray,
    obs: np.ndarray,
    rng: np.random.Generator,
) -> None:
    """The domain's ``reset(seed=None)`` with its draws; writes s into ``obs``."""
    if kind < BLOCKS:
        domain_reset(kind, dparams, fstate, dcells, obs, rng)
        return
    if kind == BLOCKS:
        blocks_reset(int(dparams[0]), dstate, obs)
        return
    if kind == PERSISTENT_SURVEILLANCE:
        for i in range(int(dparams[0])):
            for j in range(4):
                dstate[4 * i + j] = _PST_START[j]
            dstate[4 * i] = int(dparams[2])
    else:  # the missions: s₀ is packed after their scalars
        start = RESCUE_START if kind == RESCUE else UAV_START
        for i in range(dstate.shape[0]):
            dstate[i] = int(dparams[start + i])
    for i in range(dstate.shape[0]):
        obs[i] = dstate[i]


@njit(cache=True)
def _step(
    kind: int,
    domain: tuple,
    action: int,
    obs: np.ndarray,
    mask: np.ndarray,
    uniforms: np.ndarray,
    rng: np.random.Generator,
) -> tuple[float, bool, float]:
    """One domain step with the Python domain's draws; returns (reward, terminated, cost).

    ``domain`` is (dparams, dtable, dcells, dstate, fstate).
    """
    dparams, dtable, dcells, dstate, fstate = domain
    if kind < BLOCKS:
        return domain_step(kind, dparams, dtable, dcells, fstate, action, obs, rng)
    if kind == BLOCKS:
        reward, terminated = blocks_step(dparams, dstate, action, obs, rng)
        return reward, terminated, 0.0
    if kind == RESCUE:  # one uniform per step, as `RescueMission.step`
        u = rng.random()
        nodes = dcells.shape[0]
        next_obs, reward, terminated, failed = rescue_step(
            dstate, action, u, dtable[:, :3], dtable[:, 3], dcells[:, :nodes],
            dcells[:, RESCUE_PEOPLE], dcells[:, RESCUE_SUCCESS], int(dparams[0]), dparams[1],
            dparams[2], mask,
        )  # fmt: skip
        copy_into(obs, next_obs)
        return reward, terminated, 1.0 if failed else 0.0
    if kind == UAV_MISSION:  # 2n uniforms per step, as `UAVMission.step`
        next_state, reward, terminated, cost = mission_step(
            dstate, action, dtable[0], dcells, dparams[0], rng
        )
        copy_into(dstate, next_state)
        copy_into(obs, next_state)
        return reward, terminated, cost
    for i in range(uniforms.shape[0]):  # as np_random.random(2n)
        uniforms[i] = rng.random()
    next_obs, reward, terminated = pst_step(
        dstate,
        action,
        uniforms,
        int(dparams[0]),
        int(dparams[1]),
        int(dparams[2]),
        dparams[3],
        dparams[4],
        dparams[5],
        dparams[6],
        dparams[7] != 0.0,
        dparams[8] != 0.0,
        mask,
    )
    copy_into(obs, next_obs)
    return reward, terminated, 1.0 if terminated else 0.0


@njit(cache=True, inline="always")
def _legal(
    kind: int, domain: tuple, num_units: int, mask: np.ndarray, is_filled: bool, out: np.ndarray
):
    """The sorted legal actions of the domain's current state (a view of ``out``).

    ``domain`` is (dparams, dtable, dcells, dstate, fstate), ``num_units`` the number of blocks
    or UAVs of BlocksWorld and Persistent Surveillance. ``mask`` holds the state's legal mask
    of Rescue and Persistent Surveillance when ``is_filled`` (their step writes it), else it is
    filled here. Every action is legal in the domains of ``advance_kernel``: ``out`` then
    already lists them all (the kernel fills it once).
    """
    dtable, dstate = domain[1], domain[3]
    if kind < BLOCKS:
        return out
    if kind == BLOCKS:
        nn = num_units * num_units
        count = legal_moves_into(
            dstate[nn : nn + num_units], dstate[nn + num_units :], num_units, out
        )
        return out[:count]
    if kind == UAV_MISSION:
        nodes = dtable.shape[0] - 1
        legal = legal_actions(dstate, dtable[0], dtable[1:, :nodes])
        copy_into(out, legal)
        return out[: legal.shape[0]]
    if not is_filled and kind == RESCUE:
        rescue_fill_legal_mask(dstate, dtable[:, :3], dtable[:, 3], mask)
    elif not is_filled:
        pst_fill_legal_mask(dstate, num_units, mask)
    count = 0
    for a in range(mask.shape[0]):
        if mask[a]:
            out[count] = a
            count += 1
    return out[:count]


@njit(cache=True, inline="always")
def _grow_row(weights: np.ndarray, parents: np.ndarray, f: int) -> None:
    """Row f = θ_g + θ_h as `grow_weights` computes it, (0 + θ_g) + θ_h."""
    g, h = parents[f, 0], parents[f, 1]
    for a in range(weights.shape[1]):
        weights[f, a] = 0.0
        weights[f, a] += weights[g, a]
        weights[f, a] += weights[h, a]


@njit(cache=True)
def adaptive_kernel(
    num_steps: int,
    ints: np.ndarray,
    floats: np.ndarray,
    dparams: np.ndarray,
    dtable: np.ndarray,
    dcells: np.ndarray,
    dstate: np.ndarray,
    fstate: np.ndarray,
    domain_rng: np.random.Generator,
    rep: tuple,
    ifdd: IFDDTables,
    weights: np.ndarray,
    actor_weights: np.ndarray,
    trace_slots: np.ndarray,
    trace_features: np.ndarray,
    trace_actions: np.ndarray,
    trace_values: np.ndarray,
    trace_count: np.ndarray,
    agent_rng: np.random.Generator,
    obs: np.ndarray,
    loop: np.ndarray,
    loop_f: np.ndarray,
) -> tuple[int, int, int, float, np.ndarray, np.ndarray]:
    """Take up to ``num_steps`` steps; return as ``advance_kernel`` does.

    Stops early with `GROW_REPRESENTATION` or `GROW_TRACES` (before the step) or `DIVERGED`.
    """
    d_kind, r_kind, agent, policy = ints[I_DOMAIN], ints[I_REP], ints[I_AGENT], ints[I_POLICY]
    cap, is_ifdd, num_tilings = ints[I_CAP], ints[I_IFDD] != 0, ints[I_NUM_TILINGS]
    discount, parameter, traces = floats[F_DISCOUNT], floats[F_POLICY], ints[I_TRACES]
    rates, sparse = learner_arguments(
        ints, floats, trace_slots, trace_features, trace_actions, trace_values, trace_count
    )
    domain = (dparams, dtable, dcells, dstate, fstate)
    scratch = (np.empty(obs.shape[0], dtype=np.int64), np.empty(ints[I_MAX_ACTIVE], np.int64))
    is_units = d_kind == BLOCKS or d_kind == PERSISTENT_SURVEILLANCE
    num_units = int(dparams[0]) if is_units else 0  # blocks or UAVs
    feat_parents = ifdd.feat_parents
    num_actions = ints[I_NUM_ACTIONS]
    # The actor's preferences choose actions for Actor-Critic (shared features), θ otherwise.
    is_actor_critic = agent == ACTOR_CRITIC
    chooser = actor_weights if is_actor_critic else weights
    legal_buffer = np.arange(num_actions)  # every action, until a constrained domain writes
    next_buffer = np.arange(num_actions)
    mask = np.zeros(num_actions, dtype=np.int8)
    uniforms = np.empty(2 * num_units)
    next_obs = np.empty_like(obs)
    q = np.empty(weights.shape[1])
    critic_q = np.empty(weights.shape[1])
    ep_float = np.empty((16, 2))
    ep_int = np.empty((16, 2), dtype=np.int64)
    num_ended = done = failures = 0
    delta = 0.0
    status = DONE
    (phase, action, episode_steps, episode, learning_steps, episode_failures,
     total, discounted, weight) = load_loop(loop, loop_f)  # fmt: skip
    phi = np.empty(0, dtype=np.int64)
    if phase == IN_EPISODE:
        phi = _encode(r_kind, is_ifdd, obs, rep, num_tilings, scratch, ifdd)
    while done < num_steps:
        if phase == NEEDS_RESET:
            _reset(d_kind, dparams, dcells, dstate, fstate, obs, domain_rng)
            phase = NEEDS_BEGIN
        if phase == NEEDS_BEGIN:
            episode += 1
            if traces != NO_TRACES:
                clear_traces(trace_slots, trace_features, trace_actions, trace_count)
            phi = _encode(r_kind, is_ifdd, obs, rep, num_tilings, scratch, ifdd)
            q_values_into(chooser, phi, None, q)
            legal = _legal(d_kind, domain, num_units, mask, False, legal_buffer)
            action = select_action(policy, q, legal, parameter, agent_rng)
            episode_steps = episode_failures = 0
            total, discounted, weight = 0.0, 0.0, 1.0
            phase = IN_EPISODE
        room = discover_room(phi, ifdd) if is_ifdd else 0  # Σ|f| for discover_fitting
        if room < 0:
            status = GROW_REPRESENTATION
            break
        if traces != NO_TRACES and trace_count[0] + phi.shape[0] > trace_values.shape[0]:
            status = GROW_TRACES
            break
        reward, terminated, cost = _step(
            d_kind, domain, action, next_obs, mask, uniforms, domain_rng
        )
        episode_steps += 1
        next_phi = phi
        next_action = 0
        target = reward
        if not terminated:
            next_phi = _encode(r_kind, is_ifdd, next_obs, rep, num_tilings, scratch, ifdd)
            q_values_into(chooser, next_phi, None, q)
            next_legal = _legal(d_kind, domain, num_units, mask, True, next_buffer)
            next_action = select_action(policy, q, next_legal, parameter, agent_rng)
            # Algorithms 10-12, line 5: Q⁺(s, a) = r + γ Q(s', a') or r + γ max_a' Q(s', a')
            if agent == SARSA:
                target += discount * q[next_action]
            elif is_actor_critic:
                q_values_into(weights, next_phi, None, critic_q)
                target += discount * critic_q[next_action]
            else:
                best = q[next_legal[0]]
                for i in range(1, next_legal.shape[0]):
                    best = max(best, q[next_legal[i]])
                target += discount * best
        k_t = num_active(phi, None)
        delta = learn(weights, actor_weights, phi, None, action, target, episode, k_t,
                      is_actor_critic, traces, rates, sparse)  # fmt: skip
        learning_steps += 1
        if not math.isfinite(delta):
            status = DIVERGED
            phase = NEEDS_RESET
            break
        grew = False
        if is_ifdd:  # Algorithm 20/21; new features start at θ_g + θ_h (Section 4.1.1)
            before = ifdd.num_features[0]
            added = discover_fitting(phi, delta, room, ifdd)
            for f in range(before, before + added):
                _grow_row(weights, feat_parents, f)
                if is_actor_critic:
                    _grow_row(actor_weights, feat_parents, f)
                if traces != NO_TRACES:
                    trace_slots[f] = -1
            grew = added > 0
        if traces != NO_TRACES and terminated:
            clear_traces(trace_slots, trace_features, trace_actions, trace_count)
        done += 1
        failures, episode_failures, total, discounted, weight = tally(
            reward, cost, discount, failures, episode_failures, total, discounted, weight
        )
        if terminated or episode_steps >= cap:
            ep_float, ep_int = record_episode(
                ep_float, ep_int, num_ended, total, discounted, episode_steps, episode_failures
            )
            num_ended += 1
            phase = NEEDS_RESET
        else:
            copy_into(obs, next_obs)
            if grew:  # φ(s) with the new features, as the Python learner re-encodes
                next_phi = _encode(r_kind, is_ifdd, obs, rep, num_tilings, scratch, ifdd)
            phi = next_phi
            action = next_action
    store_loop(loop, loop_f, phase, action, episode_steps, episode, learning_steps,
               episode_failures, total, discounted, weight)  # fmt: skip
    return status, done, failures, delta, ep_float[:num_ended], ep_int[:num_ended]
