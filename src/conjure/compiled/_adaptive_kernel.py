"""The compiled learning loop of domains with legal actions and growing representations.

`adaptive_kernel` runs the step order of `conjure.experiments.loop.LearningLoop` for
BlocksWorld (Geramifard 2012, Section 4.1.4) with its On(·,·) indicators alone or with online
iFDD on top (Algorithm 19 for φ̇, Algorithm 20/21 or the fixed rate of Eq. 4.6 for discovery),
SARSA (Algorithm 11) or Q-Learning (Algorithm 10). It is a separate kernel from
`conjure.compiled._kernels.advance_kernel`, so that kernel's compile time does not grow; it
shares that module's constants, `step_size` and `select_action`.

The kernel calls the library's own kernels (`blocks_step`, `activate`, `discover`,
`td_step_binary`, ...) and draws from the same generators in the same order as the Python
path: per step the domain's one uniform (the drop) and the agent's one uniform per choice
among the legal moves of the state.

Arguments besides those of ``advance_kernel`` (``ints``, ``floats``, ``dparams``, ``dstate``,
``loop``, ``loop_f``, ``obs``, the generators):

- ``activate_args`` and ``discover_args``: `OnlineIFDD`'s own argument tuples of `activate`
  and `discover` (its tables, updated in place), or empty stand-ins of the same types for
  the indicators alone.
- ``weights``: θ with at least as many rows as the representation can hold features
  (``feat_start``'s length), so a discovery never outgrows it; rows past n_t are scratch.

`GROW_REPRESENTATION` stops before a step whose `discover` would not fit in the iFDD arrays;
the caller grows them with the representation's own method and calls again.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from conjure.agents._kernels import q_values_binary_into, td_step_binary
from conjure.compiled._kernels import (
    DIVERGED,
    DONE,
    F_ALPHA,
    F_DISCOUNT,
    F_N0,
    F_POLICY,
    I_AGENT,
    I_CAP,
    I_NUM_ACTIONS,
    I_POLICY,
    I_REP,
    I_SCHEDULE,
    IN_EPISODE,
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
    SARSA,
    record_episode,
    select_action,
    step_size,
)
from conjure.domains._blocks_kernels import blocks_reset, blocks_step, legal_moves_into
from conjure.representations._ifdd_kernels import I_NUM_FEATURES, activate, discover, discover_room

# Domain code (after those of `conjure.compiled._kernels`).
BLOCKS = 3
# Representation codes.
INDICATORS, IFDD = 4, 5
# Status code (after those of `conjure.compiled._kernels`).
GROW_REPRESENTATION = 3


@njit(cache=True, inline="always")
def _encode(kind: int, obs: np.ndarray, activate_args: tuple) -> np.ndarray:
    """φ⁰(s) (`BinaryIndicators`), or φ̇(s) from it (`OnlineIFDD.active_features`)."""
    initial = np.flatnonzero(obs)
    if kind == IFDD:
        return activate(initial, *activate_args)
    return initial


@njit(cache=True, inline="always")
def _legal(dstate: np.ndarray, num_blocks: int, out: np.ndarray) -> np.ndarray:
    nn = num_blocks * num_blocks
    count = legal_moves_into(
        dstate[nn : nn + num_blocks], dstate[nn + num_blocks :], num_blocks, out
    )
    return out[:count]


@njit(cache=True)
def adaptive_kernel(
    num_steps: int,
    ints: np.ndarray,
    floats: np.ndarray,
    dparams: np.ndarray,
    dstate: np.ndarray,
    domain_rng: np.random.Generator,
    activate_args: tuple,
    discover_args: tuple,
    weights: np.ndarray,
    agent_rng: np.random.Generator,
    obs: np.ndarray,
    loop: np.ndarray,
    loop_f: np.ndarray,
) -> tuple[int, int, int, float, np.ndarray, np.ndarray]:
    """Take up to ``num_steps`` steps; return as ``advance_kernel`` (failures are always 0).

    BlocksWorld has no failure states. Stops early with `GROW_REPRESENTATION` or `DIVERGED`.
    """
    r_kind, agent, policy = ints[I_REP], ints[I_AGENT], ints[I_POLICY]
    cap, schedule = ints[I_CAP], ints[I_SCHEDULE]
    discount, parameter = floats[F_DISCOUNT], floats[F_POLICY]
    alpha_0, n_0 = floats[F_ALPHA], floats[F_N0]
    num_blocks = int(dparams[0])
    is_ifdd = r_kind == IFDD
    feat_len, feat_parents = discover_args[3], discover_args[4]
    pool, node_key, table = discover_args[1], discover_args[5], discover_args[12]
    r_ints = discover_args[14]
    legal_buffer = np.empty(ints[I_NUM_ACTIONS], dtype=np.int64)
    next_buffer = np.empty(ints[I_NUM_ACTIONS], dtype=np.int64)
    next_obs = np.empty_like(obs)
    q = np.empty(weights.shape[1])
    ep_float = np.empty((16, 2))
    ep_int = np.empty((16, 2), dtype=np.int64)
    num_ended = done = 0
    delta = 0.0
    status = DONE
    phase, action, episode_steps = loop[L_PHASE], loop[L_ACTION], loop[L_EPISODE_STEPS]
    episode, learning_steps = loop[L_EPISODE], loop[L_LEARNING_STEPS]
    total, discounted, weight = loop_f[LF_RETURN], loop_f[LF_DISCOUNTED], loop_f[LF_WEIGHT]
    phi = np.empty(0, dtype=np.int64)
    if phase == IN_EPISODE:
        phi = _encode(r_kind, obs, activate_args)
    while done < num_steps:
        if phase == NEEDS_RESET:
            blocks_reset(num_blocks, dstate, obs)
            phase = NEEDS_BEGIN
        if phase == NEEDS_BEGIN:
            episode += 1
            phi = _encode(r_kind, obs, activate_args)
            q_values_binary_into(weights, phi, q)
            legal = _legal(dstate, num_blocks, legal_buffer)
            action = select_action(policy, q, legal, parameter, agent_rng)
            episode_steps = 0
            total, discounted, weight = 0.0, 0.0, 1.0
            phase = IN_EPISODE
        if is_ifdd and discover_room(phi, feat_len, pool, node_key, table, r_ints) < 0:
            status = GROW_REPRESENTATION
            break
        reward, terminated = blocks_step(dparams, dstate, action, next_obs, domain_rng)
        episode_steps += 1
        next_phi = phi
        next_action = 0
        target = reward
        if not terminated:
            next_phi = _encode(r_kind, next_obs, activate_args)
            q_values_binary_into(weights, next_phi, q)
            next_legal = _legal(dstate, num_blocks, next_buffer)
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
        delta = td_step_binary(weights, phi, action, target, alpha)  # lines 6-7
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
            grew = added > 0
        done += 1
        total += reward
        discounted += weight * reward
        weight *= discount
        if terminated or episode_steps >= cap:
            ep_float, ep_int = record_episode(
                ep_float, ep_int, num_ended, total, discounted, episode_steps, 0
            )
            num_ended += 1
            phase = NEEDS_RESET
        else:
            obs[:] = next_obs
            phi = _encode(r_kind, obs, activate_args) if grew else next_phi
            action = next_action
    loop[L_PHASE], loop[L_ACTION], loop[L_EPISODE_STEPS] = phase, action, episode_steps
    loop[L_EPISODE], loop[L_LEARNING_STEPS], loop[L_EPISODE_FAILURES] = episode, learning_steps, 0
    loop_f[LF_RETURN], loop_f[LF_DISCOUNTED], loop_f[LF_WEIGHT] = total, discounted, weight
    return status, done, 0, delta, ep_float[:num_ended], ep_int[:num_ended]
