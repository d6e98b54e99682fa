"""The compiled learning loop: n steps of domain, features, action choice and TD update.

One numba function, `advance_kernel`, runs the same step order as
`conjure.experiments.loop.LearningLoop` (Algorithms 10-12 as an interaction loop) for every
supported combination; integer codes in ``ints`` choose the domain, representation, agent,
policy and schedules, and the branches cost nothing next to the arithmetic. Compiled once
(``cache=True``), so a second process loads it from disk.

The kernel calls the library's own kernels (`pendulum_step`, `tile_features`,
`q_values_into`, `epsilon_greedy_action`, `td_step`, ...) so that both paths do the
same floating-point operations in the same order, and draws its random numbers from the same
`numpy.random.Generator` objects in the same order (numba shares the generator's state).

Packed arguments (see `conjure.compiled.stepper` for how they are built):

- ``ints`` int64: the codes and sizes named by the ``I_*`` constants.
- ``floats`` float64: the parameters named by the ``F_*`` constants.
- ``dparams`` (float64 1-D), ``dtable`` (int64 2-D), ``dcells`` (float64 2-D): the domain's
  constants; ``dstate`` (float64 1-D) its internal state, updated in place.
- ``rep``: the representation's tables (`conjure.representations._kernels`), the tuple
  (``rdims``, ``rlayout``, ``rgroups``, ``rvec``, ``htable``, ``hcounts``, ``rbf``); ``rbf`` is
  None for binary φ (every value 1, never read) or RBF's (affine, scaled centers), whose φ(s)
  lists every feature (``rvec`` = 0 .. n − 1) with its Gaussian value. The two cases are two
  compilations of the kernel, so the binary ones never carry a values array.
- ``loop`` int64 and ``loop_f`` float64: the resumable loop state (``L_*`` constants),
  ``obs`` the current state s.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from conjure.agents._kernels import (
    add,
    clear_traces,
    l1_norm,
    q_values_into,
    td_step,
    td_step_traces,
)
from conjure.domains._kernels import pendulum_step
from conjure.policies._kernels import epsilon_greedy_action, gibbs_action, greedy_action
from conjure.representations._kernels import (
    hashed_tile_features,
    independent_features,
    rbf_values,
    tabular_feature,
    tile_indices_into,
)

# Domain codes.
PENDULUM, GRIDWORLD, CHAIN = 0, 1, 2
# Representation codes.
TILES, HASHED_TILES, TABULAR, INDEPENDENT = 0, 1, 2, 3
RBF = 5  # (4 is the adaptive kernel's `INDICATORS`)
# Agent codes.
SARSA, Q_LEARNING, ACTOR_CRITIC = 0, 1, 2
# Policy codes.
EPSILON_GREEDY, GIBBS = 0, 1
# Step-size schedule codes (`conjure.core.schedules`).
CONSTANT, FEATURE_NORMALIZED, EPISODIC = 0, 1, 2
# Trace codes.
NO_TRACES, REPLACING, ACCUMULATING = 0, 1, 2
# Status codes returned by `advance_kernel`.
DONE, GROW_TRACES, DIVERGED = 0, 1, 2
# Loop phases.
NEEDS_RESET, NEEDS_BEGIN, IN_EPISODE = 0, 1, 2

# ints
I_DOMAIN, I_REP, I_AGENT, I_POLICY, I_SCHEDULE, I_ACTOR_SCHEDULE = 0, 1, 2, 3, 4, 5
I_CAP, I_TRACES, I_NUM_TILINGS, I_MAX_ACTIVE, I_NUM_ACTIONS = 6, 7, 8, 9, 10
I_IFDD = 11  # 1 when online iFDD sits on the representation (`_adaptive_kernel` only)
NUM_INTS = 12
# floats
F_DISCOUNT, F_POLICY, F_ALPHA, F_N0, F_ACTOR_ALPHA, F_ACTOR_N0 = 0, 1, 2, 3, 4, 5
F_TRACE_FACTOR, F_MIN_TRACE = 6, 7
NUM_FLOATS = 8
# loop (int64)
L_PHASE, L_ACTION, L_EPISODE_STEPS, L_EPISODE, L_LEARNING_STEPS, L_EPISODE_FAILURES = range(6)
# loop_f (float64)
LF_RETURN, LF_DISCOUNTED, LF_WEIGHT = 0, 1, 2

_HALF_PI = math.pi / 2.0
# GridWorld cell table columns (dcells) and move table layout (dtable: 4 targets, count, 4 moves).
C_REWARD, C_TERMINAL, C_PIT, C_NOISY, C_ROW, C_COL = range(6)


# ---------------------------------------------------------------------------------------------
# Domains: reset and step write the observation into ``obs``.


@njit(cache=True)
def domain_reset(
    kind: int,
    dparams: np.ndarray,
    dstate: np.ndarray,
    dcells: np.ndarray,
    obs: np.ndarray,
    rng: np.random.Generator,
) -> None:
    """Start an episode as the domain's ``reset(seed=None)`` does, with the same draws."""
    if kind == PENDULUM:
        x = dparams[1]
        if x > 0.0:
            span = x - -x  # numpy's uniform(low, high): low + (high - low) * u
            dstate[0] = -x + span * rng.random()
            dstate[1] = -x + span * rng.random()
        else:
            dstate[0] = 0.0
            dstate[1] = 0.0
        obs[0] = dstate[0]
        obs[1] = dstate[1]
    elif kind == GRIDWORLD:
        cell = int(dparams[1])
        dstate[0] = cell
        obs[0] = dcells[cell, C_ROW]
        obs[1] = dcells[cell, C_COL]
    else:
        dstate[0] = 0.0
        obs[0] = 0.0


@njit(cache=True)
def domain_step(
    kind: int,
    dparams: np.ndarray,
    dtable: np.ndarray,
    dcells: np.ndarray,
    dstate: np.ndarray,
    action: int,
    obs: np.ndarray,
    rng: np.random.Generator,
) -> tuple[float, bool, float]:
    """One domain step with the Python domain's draws; returns (reward, terminated, cost)."""
    if kind == PENDULUM:
        force = 50.0 * (action - 1)  # (-50, 0, +50) N
        if dparams[0] > 0.0:
            force += dparams[0] * (2.0 * rng.random() - 1.0)
        theta, theta_dot = pendulum_step(dstate[0], dstate[1], force)
        dstate[0] = theta
        dstate[1] = theta_dot
        obs[1] = theta_dot
        if -_HALF_PI < theta < _HALF_PI:
            obs[0] = theta
            return 0.0, False, 0.0
        obs[0] = _HALF_PI if theta > 0.0 else -_HALF_PI
        return -1.0, True, 1.0
    if kind == GRIDWORLD:
        cell = int(dstate[0])
        noise = dparams[0]
        if noise > 0.0 and dcells[cell, C_NOISY] > 0.0 and rng.random() < noise:
            num_moves = dtable[cell, 4]
            if num_moves > 0:
                action = dtable[cell, 5 + int(rng.random() * num_moves)]
        cell = dtable[cell, action]
        dstate[0] = cell
        obs[0] = dcells[cell, C_ROW]
        obs[1] = dcells[cell, C_COL]
        return dcells[cell, C_REWARD], dcells[cell, C_TERMINAL] > 0.0, dcells[cell, C_PIT]
    # CHAIN: dparams = [num_states, step_reward, slip]
    state = int(dstate[0])
    last = int(dparams[0]) - 1
    reward = 0.0
    if state < last and action == 0:
        slip = dparams[2]
        if slip == 0.0 or rng.random() >= slip:
            state += 1
            reward = dparams[1]
    dstate[0] = state
    obs[0] = state
    return reward, state == last, 0.0


# ---------------------------------------------------------------------------------------------
# Features, step sizes and action choice


@njit(cache=True, inline="always")
def encode(
    kind: int,
    state: np.ndarray,
    rep: tuple,
    num_tilings: int,
    quanta: np.ndarray,
    out: np.ndarray,
) -> np.ndarray:
    """φ(s)'s indices by the representation's own kernel.

    Unhashed tiles are written into ``out``; RBF lists every feature (``rvec``).
    """
    rdims, rlayout, rgroups, rvec, htable, hcounts, _ = rep
    if kind == TILES:
        tile_indices_into(state, rdims, rlayout, rgroups, num_tilings, quanta, out)
        return out
    if kind == HASHED_TILES:
        return hashed_tile_features(state, rdims, rlayout, rgroups, num_tilings, htable, hcounts)
    if kind == TABULAR:
        return tabular_feature(state, rdims, rvec)
    if kind == RBF:
        return rvec
    return independent_features(state, rdims, rvec)


@njit(cache=True)
def feature_values(rbf: tuple | None, num_features: int, state: np.ndarray) -> np.ndarray | None:
    """φ(s)'s values: None for binary φ (``rbf`` None), else `RBF.encode`'s Gaussians.

    ``rbf`` = (affine, scaled centers) of `conjure.representations.RBF`. numba compiles the
    two cases apart, so binary φ never reads a value.
    """
    if rbf is None:
        return None
    affine, centers = rbf
    return rbf_values(state, affine, centers, num_features)


@njit(cache=True)
def num_active(indices: np.ndarray, values: np.ndarray | None) -> float:
    """k_t = |φ(s)|₁, the learners' `_step_size` (the number of features for binary φ)."""
    if values is None:
        return float(indices.shape[0])
    return l1_norm(values)


@njit(cache=True)
def step_size(kind: int, alpha_0: float, n_0: float, episode: int, num_active: float) -> float:
    """α_t of `conjure.core.schedules` (same expression, same rounding)."""
    if kind == FEATURE_NORMALIZED:
        return alpha_0 / num_active * (n_0 + 1.0) / (n_0 + float(episode) ** 1.1)
    if kind == EPISODIC:
        return alpha_0 * (n_0 + 1.0) / (n_0 + episode)
    return alpha_0


@njit(cache=True, inline="always")
def select_action(
    kind: int, values: np.ndarray, legal: np.ndarray, parameter: float, rng: np.random.Generator
) -> int:
    """π(s) from one uniform draw, as `EpsilonGreedy.select` / `Gibbs.select`."""
    u = rng.random()
    if kind == EPSILON_GREEDY:
        return epsilon_greedy_action(values, legal, parameter, u)
    if parameter == 0.0:
        return greedy_action(values, legal)
    return gibbs_action(values, legal, parameter, u)


@njit(cache=True, inline="always")
def copy_into(target: np.ndarray, source: np.ndarray) -> None:
    """``target[:n] = source`` for a 1-D ``source`` of length n, as a loop.

    Choice: the kernels copy arrays with loops, never slice assignments or
    ``np.concatenate``: those link numba's shape-mismatch error path (string formatting,
    about 2,800 LLVM instructions), and a cached kernel's IR size is the memory its load
    costs (``benchmarks/startup.py``).
    """
    for i in range(source.shape[0]):
        target[i] = source[i]


@njit(cache=True, inline="always")
def record_episode(
    ep_float: np.ndarray,
    ep_int: np.ndarray,
    index: int,
    total: float,
    discounted: float,
    length: int,
    failures: int,
) -> tuple[np.ndarray, np.ndarray]:
    """Write an ended episode's statistics at row ``index`` (doubling the arrays when full)."""
    if index == ep_float.shape[0]:
        grown_float = np.empty((2 * index, 2))
        grown_int = np.empty((2 * index, 2), dtype=np.int64)
        for i in range(index):
            for j in range(2):
                grown_float[i, j] = ep_float[i, j]
                grown_int[i, j] = ep_int[i, j]
        ep_float, ep_int = grown_float, grown_int
    ep_float[index, 0] = total
    ep_float[index, 1] = discounted
    ep_int[index, 0] = length
    ep_int[index, 1] = failures
    return ep_float, ep_int


@njit(cache=True, inline="always")
def td_update(
    weights: np.ndarray,
    phi: np.ndarray,
    values: np.ndarray | None,
    action: int,
    target: float,
    alpha: float,
    traces: int,
    sparse: tuple,
) -> float:
    """δ and θ's update (Algorithms 10-12, lines 6-7), through SARSA(λ)'s traces if any.

    ``phi``, ``values``: φ(s) as `td_step` takes it (``values`` None for binary φ).

    ``sparse`` = (γλ, min trace, slots, features, actions, trace values, count) of
    `td_step_traces`; unused when ``traces`` is `NO_TRACES`.
    """
    if traces == NO_TRACES:
        return td_step(weights, phi, values, action, target, alpha)
    decay, min_trace, slots, features, actions, trace_values, count = sparse
    is_replacing = traces == REPLACING
    return td_step_traces(
        weights, phi, values, action, target, alpha, decay, is_replacing, min_trace, slots,
        features, actions, trace_values, count,
    )  # fmt: skip


@njit(cache=True, inline="always")
def learner_arguments(
    ints: np.ndarray,
    floats: np.ndarray,
    trace_slots: np.ndarray,
    trace_features: np.ndarray,
    trace_actions: np.ndarray,
    trace_values: np.ndarray,
    trace_count: np.ndarray,
) -> tuple[tuple, tuple]:
    """``rates`` of `learn` and ``sparse`` of `td_update`, read once from ``ints``/``floats``.

    ``rates`` = (schedule, α₀, N₀, actor schedule, actor α₀, actor N₀).
    """
    rates = (ints[I_SCHEDULE], floats[F_ALPHA], floats[F_N0],
             ints[I_ACTOR_SCHEDULE], floats[F_ACTOR_ALPHA], floats[F_ACTOR_N0])  # fmt: skip
    sparse = (floats[F_TRACE_FACTOR], floats[F_MIN_TRACE], trace_slots, trace_features,
              trace_actions, trace_values, trace_count)  # fmt: skip
    return rates, sparse


@njit(cache=True, inline="always")
def learn(
    weights: np.ndarray,
    actor_weights: np.ndarray,
    phi: np.ndarray,
    values: np.ndarray | None,
    action: int,
    target: float,
    episode: int,
    k_t: float,
    is_actor_critic: bool,
    traces: int,
    rates: tuple,
    sparse: tuple,
) -> float:
    """α_t, δ and θ's update (Algorithms 10-12, lines 6-7), then ω's (Algorithm 12, line 9).

    ``k_t``: |φ(s)|₁ (`num_active`); ``rates``, ``sparse``: of `learner_arguments`. Returns δ;
    ω is left alone when δ is not finite.
    """
    schedule, alpha_0, n_0, actor_schedule, actor_alpha_0, actor_n_0 = rates
    counted = max(episode, 1)
    alpha = step_size(schedule, alpha_0, n_0, counted, k_t)
    delta = td_update(weights, phi, values, action, target, alpha, traces, sparse)
    if is_actor_critic and math.isfinite(delta):
        actor_alpha = step_size(actor_schedule, actor_alpha_0, actor_n_0, counted, k_t)
        add(actor_weights, phi, values, action, actor_alpha * delta)
    return delta


@njit(cache=True, inline="always")
def load_loop(loop: np.ndarray, loop_f: np.ndarray) -> tuple:
    """The loop state ``loop``, ``loop_f`` as locals.

    Returns (phase, action, episode steps, episode, learning steps, episode failures, return,
    discounted return, γ^t).
    """
    phase, action, episode_steps = loop[L_PHASE], loop[L_ACTION], loop[L_EPISODE_STEPS]
    episode, learning_steps = loop[L_EPISODE], loop[L_LEARNING_STEPS]
    episode_failures = loop[L_EPISODE_FAILURES]
    total, discounted, weight = loop_f[LF_RETURN], loop_f[LF_DISCOUNTED], loop_f[LF_WEIGHT]
    return (phase, action, episode_steps, episode, learning_steps, episode_failures,
            total, discounted, weight)  # fmt: skip


@njit(cache=True, inline="always")
def store_loop(
    loop: np.ndarray,
    loop_f: np.ndarray,
    phase: int,
    action: int,
    episode_steps: int,
    episode: int,
    learning_steps: int,
    episode_failures: int,
    total: float,
    discounted: float,
    weight: float,
) -> None:
    """Write the locals of `load_loop` back into ``loop`` and ``loop_f``."""
    loop[L_PHASE], loop[L_ACTION], loop[L_EPISODE_STEPS] = phase, action, episode_steps
    loop[L_EPISODE], loop[L_LEARNING_STEPS] = episode, learning_steps
    loop[L_EPISODE_FAILURES] = episode_failures
    loop_f[LF_RETURN], loop_f[LF_DISCOUNTED], loop_f[LF_WEIGHT] = total, discounted, weight


@njit(cache=True, inline="always")
def tally(
    reward: float,
    cost: float,
    discount: float,
    failures: int,
    episode_failures: int,
    total: float,
    discounted: float,
    weight: float,
) -> tuple[int, int, float, float, float]:
    """A counted step's statistics: failures (cost > 0), return and discounted return.

    Returns (failures, episode failures, return, discounted return, γ^(t+1)). An ended
    episode's `record_episode` stays in the kernels, so that the episode arrays are not
    passed through (and reference-counted) every step.
    """
    if cost > 0.0:
        failures += 1
        episode_failures += 1
    total += reward
    discounted += weight * reward
    weight *= discount
    return failures, episode_failures, total, discounted, weight


# ---------------------------------------------------------------------------------------------
# The loop


@njit(cache=True)
def advance_kernel(
    num_steps: int,
    ints: np.ndarray,
    floats: np.ndarray,
    dparams: np.ndarray,
    dtable: np.ndarray,
    dcells: np.ndarray,
    dstate: np.ndarray,
    domain_rng: np.random.Generator,
    rep: tuple,
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
    """Take up to ``num_steps`` learning steps; stop early on a status other than `DONE`.

    Returns (status, steps taken, failures, last δ, episodes (m, 2) float64 [return,
    discounted return], episodes (m, 2) int64 [length, failures]) for the m episodes that
    ended during the call. `GROW_TRACES` stops before a step whose traces might not fit;
    `DIVERGED` stops after an update whose δ is not finite (that step is not counted).
    """
    d_kind, r_kind, agent, policy = ints[I_DOMAIN], ints[I_REP], ints[I_AGENT], ints[I_POLICY]
    cap, traces, num_tilings = ints[I_CAP], ints[I_TRACES], ints[I_NUM_TILINGS]
    max_active, discount, parameter = ints[I_MAX_ACTIVE], floats[F_DISCOUNT], floats[F_POLICY]
    rates, sparse = learner_arguments(
        ints, floats, trace_slots, trace_features, trace_actions, trace_values, trace_count
    )
    legal = np.arange(ints[I_NUM_ACTIONS])
    # The actor's preferences choose actions for Actor-Critic (shared features), θ otherwise.
    chooser = actor_weights if agent == ACTOR_CRITIC else weights
    # Scratch: φ(s) and φ(s') buffers for tile coding (the other encoders allocate).
    next_obs = np.empty_like(obs)
    quanta = np.empty(obs.shape[0], dtype=np.int64)
    phi_buffer = np.empty(max_active, dtype=np.int64)
    next_buffer = np.empty(max_active, dtype=np.int64)
    q = np.empty(legal.shape[0])
    critic_q = np.empty(legal.shape[0])
    ep_float = np.empty((16, 2))
    ep_int = np.empty((16, 2), dtype=np.int64)
    num_ended = done = failures = 0
    delta = 0.0
    status = DONE
    # The loop state, in locals while running.
    (phase, action, episode_steps, episode, learning_steps, episode_failures,
     total, discounted, weight) = load_loop(loop, loop_f)  # fmt: skip
    rbf, num_features = rep[6], rep[3].shape[0]
    phi = phi_buffer
    values = feature_values(rbf, num_features, obs)  # φ(s)'s values (None: binary φ)
    if phase == IN_EPISODE:
        phi = encode(r_kind, obs, rep, num_tilings, quanta, phi)
    while done < num_steps:
        if phase == NEEDS_RESET:
            domain_reset(d_kind, dparams, dstate, dcells, obs, domain_rng)
            phase = NEEDS_BEGIN
        if phase == NEEDS_BEGIN:
            episode += 1
            if traces != NO_TRACES:
                clear_traces(trace_slots, trace_features, trace_actions, trace_count)
            phi = encode(r_kind, obs, rep, num_tilings, quanta, phi_buffer)
            values = feature_values(rbf, num_features, obs)
            q_values_into(chooser, phi, values, q)
            action = select_action(policy, q, legal, parameter, agent_rng)
            episode_steps = episode_failures = 0
            total, discounted, weight = 0.0, 0.0, 1.0
            phase = IN_EPISODE
        if traces != NO_TRACES and trace_count[0] + max_active > trace_values.shape[0]:
            status = GROW_TRACES
            break
        reward, terminated, cost = domain_step(
            d_kind, dparams, dtable, dcells, dstate, action, next_obs, domain_rng
        )
        episode_steps += 1
        next_phi, next_values = phi, values
        next_action = 0
        if not terminated:
            next_phi = encode(r_kind, next_obs, rep, num_tilings, quanta, next_buffer)
            next_values = feature_values(rbf, num_features, next_obs)
            q_values_into(chooser, next_phi, next_values, q)
            next_action = select_action(policy, q, legal, parameter, agent_rng)
        # Learning (Algorithms 10-12, lines 4-7).
        target = reward
        if not terminated:
            if agent == SARSA:
                target += discount * q[next_action]
            elif agent == Q_LEARNING:
                target += discount * q.max()
            else:
                q_values_into(weights, next_phi, next_values, critic_q)
                target += discount * critic_q[next_action]
        k_t = num_active(phi, values)
        delta = learn(weights, actor_weights, phi, values, action, target, episode, k_t,
                      agent == ACTOR_CRITIC, traces, rates, sparse)  # fmt: skip
        learning_steps += 1
        if not math.isfinite(delta):
            status = DIVERGED
            phase = NEEDS_RESET
            break
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
            if r_kind == TILES:  # φ(s) ← φ(s'): copy, so that φ(s) stays in its buffer
                for i in range(max_active):
                    phi_buffer[i] = next_buffer[i]
            else:
                phi = next_phi
            values = next_values
            action = next_action
    store_loop(loop, loop_f, phase, action, episode_steps, episode, learning_steps,
               episode_failures, total, discounted, weight)  # fmt: skip
    return status, done, failures, delta, ep_float[:num_ended], ep_int[:num_ended]
