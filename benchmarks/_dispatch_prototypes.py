"""Prototypes of three ways the compiled loop could reach its components' kernels.

Read by ``benchmarks/dispatch_cost.py``: one small learning loop (pendulum, Section 3.3.1;
unhashed tile coding; SARSA without traces, Algorithm 11; ε-greedy), restricted to what that
measurement needs, whose domain and representation are reached through `reset_into`,
`step_into` and `encode_into`. What those resolve to depends on the types the loop is called
with, so the same source is compiled three ways:

- ``specialised``: the forms are named tuples (`PendulumForm`, `TilesForm`) and the three
  calls resolve at compile time to the pendulum's and the tiles' kernels (`numba.extending.
  overload` on the form's type): one compilation per combination of form types, with the
  kernels inlined by LLVM;
- ``structref``: the same forms as numba structrefs (`as_structrefs`): the same resolution
  per structref type (what `overload_method` methods compile to), the fields read through
  one reference;
- ``first-class``: the loop gets the three kernels as first-class functions
  (`FUNCTIONS`, a tuple of `numba.types.FunctionType` of fixed signatures) and calls them
  through their addresses: one compilation for every kernel of those signatures.

The kernels are the library's own (`pendulum_start`, `pendulum_transition`,
`tile_indices_into`, `q_values_into`, `epsilon_greedy_action`, `td_step`) in
`conjure.compiled.learning_loop`'s order with the same draws, so θ after the same steps equals
`learning_loop`'s bit for bit. The episode statistics and status codes of the real loop are
left out: they are the same in every option.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit, typeof, types
from numba.experimental import structref
from numba.extending import overload

from conjure.agents._kernels import q_values_into, td_step
from conjure.agents.compiled_agent import step_size
from conjure.domains._kernels import pendulum_start, pendulum_transition
from conjure.policies._kernels import epsilon_greedy_action
from conjure.representations._kernels import tile_indices_into

_F1, _I1 = types.float64[::1], types.int64[::1]
_RNG = typeof(np.random.default_rng(0))
#: The first-class functions' signatures: reset(fstate, params, obs, rng),
#: step(fstate, params, action, obs, rng) -> (r, terminated, cost), encode(form arrays, s, φ).
RESET_SIGNATURE = types.void(_F1, _F1, _F1, _RNG)
STEP_SIGNATURE = types.Tuple((types.float64, types.boolean, types.float64))(
    _F1, _F1, types.int64, _F1, _RNG
)
ENCODE_SIGNATURE = types.void(
    types.float64[:, ::1], types.int64[:, ::1], types.int64[:, ::1], types.int64, _I1, _F1, _I1
)
FUNCTIONS = types.Tuple(
    tuple(types.FunctionType(s) for s in (RESET_SIGNATURE, STEP_SIGNATURE, ENCODE_SIGNATURE))
)


_pendulum_start = njit(cache=True, inline="always")(pendulum_start)
_pendulum_transition = njit(cache=True, inline="always")(pendulum_transition)


class PendulumForm(NamedTuple):
    """The pendulum's state (θ, θ̇) and parameters (force noise, start noise)."""

    fstate: np.ndarray
    params: np.ndarray


class TilesForm(NamedTuple):
    """Unhashed tile coding's tables (`conjure.representations.compiled_representation`)."""

    dims: np.ndarray
    layout: np.ndarray
    groups: np.ndarray
    num_tilings: int
    quanta: np.ndarray


@njit(RESET_SIGNATURE, cache=True)
def pendulum_reset(fstate, params, obs, rng):
    """The pendulum's reset into ``obs`` (its start draws)."""
    fstate[0], fstate[1] = _pendulum_start(params[1], rng)
    obs[0], obs[1] = fstate[0], fstate[1]


@njit(STEP_SIGNATURE, cache=True)
def pendulum_step(fstate, params, action, obs, rng):
    """One pendulum step into ``obs``: (r, terminated, cost)."""
    theta, theta_dot, shown, reward, terminated = _pendulum_transition(
        fstate[0], fstate[1], action, params[0], rng
    )
    fstate[0], fstate[1] = theta, theta_dot
    obs[0], obs[1] = shown, theta_dot
    return reward, terminated, 1.0 if terminated else 0.0


@njit(ENCODE_SIGNATURE, cache=True)
def tiles_encode(dims, layout, groups, num_tilings, quanta, state, out):
    """φ(s) of unhashed tiles into ``out``."""
    tile_indices_into(state, dims, layout, groups, num_tilings, quanta, out)


def reset_into(dom, functions, obs, rng):
    """The domain's reset (resolved by type, see the module docstring)."""


def step_into(dom, functions, action, obs, rng):
    """The domain's step (resolved by type)."""


def encode_into(rep, functions, state, out):
    """The representation's φ(s) (resolved by type)."""


def _is_first_class(functions) -> bool:
    return isinstance(functions, types.BaseTuple)


@overload(reset_into)
def _reset_into(dom, functions, obs, rng):
    if _is_first_class(functions):
        return lambda dom, functions, obs, rng: functions[0](dom.fstate, dom.params, obs, rng)
    return lambda dom, functions, obs, rng: pendulum_reset(dom.fstate, dom.params, obs, rng)


@overload(step_into)
def _step_into(dom, functions, action, obs, rng):
    if _is_first_class(functions):

        def first_class(dom, functions, action, obs, rng):
            return functions[1](dom.fstate, dom.params, action, obs, rng)

        return first_class

    def specialised(dom, functions, action, obs, rng):
        return pendulum_step(dom.fstate, dom.params, action, obs, rng)

    return specialised


@overload(encode_into)
def _encode_into(rep, functions, state, out):
    if _is_first_class(functions):

        def first_class(rep, functions, state, out):
            functions[2](rep.dims, rep.layout, rep.groups, rep.num_tilings, rep.quanta, state, out)

        return first_class

    def specialised(rep, functions, state, out):
        tiles_encode(rep.dims, rep.layout, rep.groups, rep.num_tilings, rep.quanta, state, out)

    return specialised


@njit(cache=True)
def prototype_loop(dom, rep, functions, num_steps, domain_rng, agent, weights, agent_rng, cap):
    """``num_steps`` SARSA steps from a reset (Algorithm 11 with ε-greedy, no traces).

    ``functions``: `FUNCTIONS` for the first-class option, None otherwise.
    """
    num_actions = weights.shape[1]
    max_active = rep.num_tilings
    obs, next_obs = np.empty(2), np.empty(2)
    phi = np.empty(max_active, dtype=np.int64)
    next_phi = np.empty(max_active, dtype=np.int64)
    all_actions = np.arange(num_actions)
    q = np.empty(num_actions)
    epsilon = agent.policy.parameter
    episode, episode_steps, action = 0, 0, 0
    is_new_episode = True
    for _ in range(num_steps):
        if is_new_episode:
            reset_into(dom, functions, obs, domain_rng)
            episode += 1
            episode_steps = 0
            encode_into(rep, functions, obs, phi)
            q_values_into(weights, phi, None, q)
            action = epsilon_greedy_action(q, all_actions, epsilon, agent_rng.random())
        reward, terminated, _ = step_into(dom, functions, action, next_obs, domain_rng)
        episode_steps += 1
        target = reward
        next_action = 0
        if not terminated:
            encode_into(rep, functions, next_obs, next_phi)
            q_values_into(weights, next_phi, None, q)
            next_action = epsilon_greedy_action(q, all_actions, epsilon, agent_rng.random())
            target = reward + agent.discount * q[next_action]
        alpha = step_size(agent.schedule, episode, float(phi.shape[0]))
        if not math.isfinite(td_step(weights, phi, None, action, target, alpha)):
            break
        is_new_episode = terminated or episode_steps >= cap
        for i in range(phi.shape[0]):
            phi[i] = next_phi[i]
        obs[0], obs[1] = next_obs[0], next_obs[1]
        action = next_action


class _FormStructType(types.StructRef):
    """A form as a numba structref (the ``structref`` option)."""

    def preprocess_fields(self, fields):
        return tuple((name, types.unliteral(kind)) for name, kind in fields)


@structref.register
class _PendulumStructType(_FormStructType):
    """The numba type of `_PendulumStruct`."""


@structref.register
class _TilesStructType(_FormStructType):
    """The numba type of `_TilesStruct`."""


class _PendulumStruct(structref.StructRefProxy):
    """A `PendulumForm` as one reference."""


class _TilesStruct(structref.StructRefProxy):
    """A `TilesForm` as one reference."""


structref.define_proxy(_PendulumStruct, _PendulumStructType, list(PendulumForm._fields))
structref.define_proxy(_TilesStruct, _TilesStructType, list(TilesForm._fields))


def as_structrefs(dom: PendulumForm, rep: TilesForm) -> tuple[_PendulumStruct, _TilesStruct]:
    """The two forms as structrefs sharing their arrays."""
    return _PendulumStruct(*dom), _TilesStruct(*rep)
