"""The compiled learning loop of domains with legal actions and growing representations.

`adaptive_kernel` runs the step order of `conjure.experiments.loop.LearningLoop` for the
constrained domains of Geramifard (2012), Section 4.1.4, BlocksWorld and Persistent
Surveillance, with their initial features (`BinaryIndicators` or
`IndependentDiscretization`) alone or with online iFDD on top (Algorithm 19 for φ̇, Algorithm
20/21 or the fixed rate of Eq. 4.6 for discovery), and SARSA (Algorithm 11, with or without
sparse eligibility traces) or Q-Learning (Algorithm 10). It is a separate kernel from
`conjure.compiled._kernels.advance_kernel`, so that kernel's compile time does not grow; it
shares that module's constants, `step_size`, `select_action` and `record_episode`.

The kernel calls the library's own kernels (`blocks_step`, `pst_step`, `independent_features`,
`activate`, `discover`, `td_step`, ...) and draws from the same generators in the same
order as the Python path: per step the domain's draws (BlocksWorld's one uniform, Persistent
Surveillance's 2n) and the agent's one uniform per choice among the legal actions.

Arguments besides those of ``advance_kernel`` (``ints``, ``floats``, ``dparams``, ``loop``,
``loop_f``, ``obs``, the generators):

- ``dstate`` int64: the domain's internal state (see `conjure.compiled.combination`).
- ``rdims``, ``rvec``: `IndependentDiscretization`'s bucket table and offsets (empty for the
  indicators).
- ``activate_args`` and ``discover_args``: `OnlineIFDD`'s own argument tuples of `activate`
  and `discover` (its tables, updated in place), or empty stand-ins of the same types without
  iFDD (``ints[I_IFDD] == 0``).
- ``weights``: θ with at least as many rows as the representation can hold features
  (``feat_start``'s length), so a discovery never outgrows it; rows past n_t are scratch.
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
    DIVERGED,
    DONE,
    F_ALPHA,
    F_DISCOUNT,
    F_MIN_TRACE,
    F_N0,
    F_POLICY,
    F_TRACE_FACTOR,
    GROW_TRACES,
    I_AGENT,
    I_CAP,
    I_DOMAIN,
    I_IFDD,
    I_NUM_ACTIONS,
    I_POLICY,
    I_REP,
    I_SCHEDULE,
    I_TRACES,
    IN_EPISODE,
    INDEPENDENT,
    L_ACTION,
    L_EPISODE,
    L_EPISODE_FAILURES,
    L_EPISODE_STEPS,
    L_LEARNING_STEPS,
    L_PHASE,
    LF_DISCOUNTED,
    LF_RETURN,
    LF_WEIGHT,
    NEEDS_BEGIN,
    NEEDS_RESET,
    NO_TRACES,
    SARSA,
    record_episode,
    select_action,
    step_size,
    td_update,
)
from conjure.domains._blocks_kernels import blocks_reset, blocks_step, legal_moves_into
from conjure.domains._uav_kernels import BASE, pst_fill_legal_mask, pst_step
from conjure.representations._ifdd_kernels import I_NUM_FEATURES, activate, discover, discover_room
from conjure.representations._kernels import independent_features

# Domain codes (after those of `conjure.compiled._kernels`).
BLOCKS, PERSISTENT_SURVEILLANCE = 3, 4
# Representation code (after those of `conjure.compiled._kernels`; `INDEPENDENT` is shared).
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
    rdims: np.ndarray,
    rvec: np.ndarray,
    activate_args: tuple,
) -> np.ndarray:
    """φ⁰(s) of the base representation, or φ̇(s) from it (`OnlineIFDD.active_features`)."""
    if kind == INDEPENDENT:
        initial = independent_features(obs, rdims, rvec)
    else:
        initial = np.flatnonzero(obs)
    if is_ifdd:
        return activate(initial, *activate_args)
    return initial


@njit(cache=True)
def _reset(kind: int, dparams: np.ndarray, dstate: np.ndarray, obs: np.ndarray) -> None:
    """The domain's ``reset(seed=None)`` (neither draws); writes s into ``obs``."""
    if kind == BLOCKS:
        blocks_reset(int(dparams[0]), dstate, obs)
        return
    num_uavs = int(dparams[0])
    for i in range(num_uavs):
        for j in range(4):
            dstate[4 * i + j] = _PST_START[j]
        dstate[4 * i] = int(dparams[2])
    for i in range(dstate.shape[0]):
        obs[i] = dstate[i]


@njit(cache=True)
def _step(
    kind: int,
    dparams: np.ndarray,
    dstate: np.ndarray,
    action: int,
    obs: np.ndarray,
    mask: np.ndarray,
    uniforms: np.ndarray,
    rng: np.random.Generator,
) -> tuple[float, bool, float]:
    """One domain step with the Python domain's draws; returns (reward, terminated, cost)."""
    if kind == BLOCKS:
        reward, terminated = blocks_step(dparams, dstate, action, obs, rng)
        return reward, terminated, 0.0
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
    obs[:] = next_obs
    return reward, terminated, 1.0 if terminated else 0.0


@njit(cache=True, inline="always")
def _legal(kind: int, dstate: np.ndarray, num_units: int, mask: np.ndarray, out: np.ndarray):
    """The sorted legal actions of the domain's current state (a view of ``out``).

    ``num_units`` is the number of blocks or UAVs; ``mask`` is scratch.
    """
    if kind == BLOCKS:
        nn = num_units * num_units
        count = legal_moves_into(
            dstate[nn : nn + num_units], dstate[nn + num_units :], num_units, out
        )
        return out[:count]
    pst_fill_legal_mask(dstate, num_units, mask)
    count = 0
    for a in range(mask.shape[0]):
        if mask[a]:
            out[count] = a
            count += 1
    return out[:count]


@njit(cache=True)
def adaptive_kernel(
    num_steps: int,
    ints: np.ndarray,
    floats: np.ndarray,
    dparams: np.ndarray,
    dstate: np.ndarray,
    domain_rng: np.random.Generator,
    rdims: np.ndarray,
    rvec: np.ndarray,
    activate_args: tuple,
    discover_args: tuple,
    weights: np.ndarray,
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
    cap, schedule, is_ifdd = ints[I_CAP], ints[I_SCHEDULE], ints[I_IFDD] != 0
    discount, parameter = floats[F_DISCOUNT], floats[F_POLICY]
    alpha_0, n_0 = floats[F_ALPHA], floats[F_N0]
    traces = ints[I_TRACES]
    trace_factor, min_trace = floats[F_TRACE_FACTOR], floats[F_MIN_TRACE]
    sparse = (trace_factor, min_trace, trace_slots, trace_features, trace_actions, trace_values,
              trace_count)  # fmt: skip
    num_units = int(dparams[0])  # blocks or UAVs
    feat_len, feat_parents = discover_args[3], discover_args[4]
    pool, node_key, table = discover_args[1], discover_args[5], discover_args[12]
    r_ints = discover_args[14]
    num_actions = ints[I_NUM_ACTIONS]
    legal_buffer = np.empty(num_actions, dtype=np.int64)
    next_buffer = np.empty(num_actions, dtype=np.int64)
    mask = np.zeros(num_actions, dtype=np.int8)
    uniforms = np.empty(2 * num_units)
    next_obs = np.empty_like(obs)
    q = np.empty(weights.shape[1])
    ep_float = np.empty((16, 2))
    ep_int = np.empty((16, 2), dtype=np.int64)
    num_ended = done = failures = 0
    delta = 0.0
    status = DONE
    phase, action, episode_steps = loop[L_PHASE], loop[L_ACTION], loop[L_EPISODE_STEPS]
    episode, learning_steps = loop[L_EPISODE], loop[L_LEARNING_STEPS]
    episode_failures = loop[L_EPISODE_FAILURES]
    total, discounted, weight = loop_f[LF_RETURN], loop_f[LF_DISCOUNTED], loop_f[LF_WEIGHT]
    phi = np.empty(0, dtype=np.int64)
    if phase == IN_EPISODE:
        phi = _encode(r_kind, is_ifdd, obs, rdims, rvec, activate_args)
    while done < num_steps:
        if phase == NEEDS_RESET:
            _reset(d_kind, dparams, dstate, obs)
            phase = NEEDS_BEGIN
        if phase == NEEDS_BEGIN:
            episode += 1
            if traces != NO_TRACES:
                clear_traces(trace_slots, trace_features, trace_actions, trace_count)
            phi = _encode(r_kind, is_ifdd, obs, rdims, rvec, activate_args)
            q_values_into(weights, phi, None, q)
            legal = _legal(d_kind, dstate, num_units, mask, legal_buffer)
            action = select_action(policy, q, legal, parameter, agent_rng)
            episode_steps = episode_failures = 0
            total, discounted, weight = 0.0, 0.0, 1.0
            phase = IN_EPISODE
        if is_ifdd and discover_room(phi, feat_len, pool, node_key, table, r_ints) < 0:
            status = GROW_REPRESENTATION
            break
        if traces != NO_TRACES and trace_count[0] + phi.shape[0] > trace_values.shape[0]:
            status = GROW_TRACES
            break
        reward, terminated, cost = _step(
            d_kind, dparams, dstate, action, next_obs, mask, uniforms, domain_rng
        )
        episode_steps += 1
        next_phi = phi
        next_action = 0
        target = reward
        if not terminated:
            next_phi = _encode(r_kind, is_ifdd, next_obs, rdims, rvec, activate_args)
            q_values_into(weights, next_phi, None, q)
            next_legal = _legal(d_kind, dstate, num_units, mask, next_buffer)
            next_action = select_action(policy, q, next_legal, parameter, agent_rng)
            # Algorithms 10-11, line 5: Q⁺(s, a) = r + γ Q(s', a') or r + γ max_a' Q(s', a')
            if agent == SARSA:
                target += discount * q[next_action]
            else:
                best = q[next_legal[0]]
                for i in range(1, next_legal.shape[0]):
                    best = max(best, q[next_legal[i]])
                target += discount * best
        alpha = step_size(schedule, alpha_0, n_0, max(episode, 1), float(phi.shape[0]))
        delta = td_update(weights, phi, None, action, target, alpha, traces, sparse)
        learning_steps += 1
        if not math.isfinite(delta):
            status = DIVERGED
            phase = NEEDS_RESET
            break
        grew = False
        if is_ifdd:  # Algorithm 20/21; new features start at θ_g + θ_h (Section 4.1.1)
            before = r_ints[I_NUM_FEATURES]
            added = discover(phi, delta, *discover_args)
            for f in range(before, before + added):
                g, h = feat_parents[f, 0], feat_parents[f, 1]
                for a in range(weights.shape[1]):  # as `grow_weights`: (0 + θ_g) + θ_h
                    weights[f, a] = 0.0
                    weights[f, a] += weights[g, a]
                    weights[f, a] += weights[h, a]
                if traces != NO_TRACES:
                    trace_slots[f] = -1
            grew = added > 0
        if traces != NO_TRACES and terminated:
            clear_traces(trace_slots, trace_features, trace_actions, trace_count)
        done += 1
        if cost > 0.0:
            failures += 1
            episode_failures += 1
        total += reward
        discounted += weight * reward
        weight *= discount
        if terminated or episode_steps >= cap:
            ep_float, ep_int = record_episode(
                ep_float, ep_int, num_ended, total, discounted, episode_steps, episode_failures
            )
            num_ended += 1
            phase = NEEDS_RESET
        else:
            obs[:] = next_obs
            if grew:  # φ(s) with the new features, as the Python learner re-encodes
                next_phi = _encode(r_kind, is_ifdd, obs, rdims, rvec, activate_args)
            phi = next_phi
            action = next_action
    loop[L_PHASE], loop[L_ACTION], loop[L_EPISODE_STEPS] = phase, action, episode_steps
    loop[L_EPISODE], loop[L_LEARNING_STEPS] = episode, learning_steps
    loop[L_EPISODE_FAILURES] = episode_failures
    loop_f[LF_RETURN], loop_f[LF_DISCOUNTED], loop_f[LF_WEIGHT] = total, discounted, weight
    return status, done, failures, delta, ep_float[:num_ended], ep_int[:num_ended]
