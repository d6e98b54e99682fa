"""The domains as the compiled learning loop reads them (`conjure.core.compiled_form`).

A domain's ``compiled_form()`` returns a `DomainKernel`: its kind, its constants and a copy of
its internal state; ``load_compiled_form`` writes the state back after the loop ran. The three
kernels here, `reset_into`, `step_into` and `legal_into`, choose the domain's own kernel by
kind: the shared-source transitions of `conjure.domains._kernels` (chain, grid world,
pendulum) and the mission kernels (`blocks_step`, `pst_step`, `rescue_step`, `mission_step`)
that the Python ``step`` methods call too, with the same draws in the same order. A domain
with no kernel of its own (`conjure.domains.gymnasium_adapter.GymnasiumDomain`: the user's
environment) can still run in the loop as a `CALLBACK` domain: the loop calls its own Python
``reset`` and ``step`` back (numba's object mode) and keeps everything else compiled.

Choice: one named tuple type serves every domain (unused fields are empty arrays), so the loop
compiles once for all of them; the per-domain layout of ``params``, ``table`` and ``cells`` is
written beside each domain's ``compiled_form``.
"""

from __future__ import annotations

import itertools
import math
import weakref
from typing import Any, NamedTuple

import numpy as np
from numba import njit, objmode

from conjure.domains._blocks_kernels import blocks_reset, blocks_step, legal_moves_into
from conjure.domains._kernels import chain_move, gridworld_move, pendulum_start, pendulum_transition
from conjure.domains._mission_kernels import legal_actions, mission_step
from conjure.domains._uav_kernels import (
    BASE,
    pst_fill_legal_mask,
    pst_step,
    rescue_fill_legal_mask,
    rescue_step,
)

__all__ = [
    "DomainKernel",
    "callback_domain",
    "callback_error",
    "callback_kernel",
    "domain_kernel",
    "legal_into",
    "reset_into",
    "step_into",
]

#: Domain kinds of `DomainKernel`.
PENDULUM, GRIDWORLD, CHAIN, BLOCKS, PERSISTENT_SURVEILLANCE, RESCUE, UAV_MISSION = range(7)
#: A domain whose own Python ``reset`` and ``step`` the loop calls back (`callback_kernel`).
CALLBACK = 7
#: Grid world: ``cells`` columns; ``table`` is `gridworld_move`'s.
C_REWARD, C_TERMINAL, C_PIT, C_NOISY, C_ROW, C_COL = range(6)
#: Rescue Mission: where s₀ starts in ``params`` (after horizon, fuel and failure penalties);
#: ``cells[:, :n]`` the one-edge-away table, then the people and success probability per node.
RESCUE_START, RESCUE_PEOPLE, RESCUE_SUCCESS = 3, 8, 9
#: UAV mission: s₀ starts in ``params`` after the traverse failure probability.
UAV_START = 1
#: Persistent Surveillance's start state of one UAV: full fuel (from ``params``), BASE, healthy.
_PST_START = (0, BASE, 1, 1)

_chain_move = njit(cache=True, inline="always")(chain_move)
_gridworld_move = njit(cache=True, inline="always")(gridworld_move)
_pendulum_start = njit(cache=True, inline="always")(pendulum_start)
_pendulum_transition = njit(cache=True, inline="always")(pendulum_transition)


class DomainKernel(NamedTuple):
    """A domain as the compiled loop reads it; fields a domain does not use are empty.

    The domains of Sections 3.3.1 (pendulum), 4.1.4 (BlocksWorld, Persistent Surveillance,
    Rescue Mission), 5.1 (grid worlds) and 5.3.5 (UAV missions), and the test chain.

    Parameters
    ----------
    kind : int
        Which domain (`PENDULUM` ... `UAV_MISSION`).
    params, table, cells : ndarray
        The domain's constants (float64 1-D, int64 2-D, float64 2-D; layouts beside each
        domain's ``compiled_form``).
    state, fstate : ndarray
        A copy of the domain's internal state, int64 or float64, updated in place.
    mask : ndarray of int8
        The legal-action mask of the domains whose step writes one.
    uniforms : ndarray
        Room for a step's draws.
    num_units : int
        The blocks or UAVs.
    has_action_constraints : bool
        Whether some actions are illegal somewhere (`legal_into`).
    """

    kind: int
    params: np.ndarray
    table: np.ndarray
    cells: np.ndarray
    state: np.ndarray
    fstate: np.ndarray
    mask: np.ndarray
    uniforms: np.ndarray
    num_units: int
    has_action_constraints: bool


def domain_kernel(
    kind: int,
    num_actions: int,
    *,
    params: np.ndarray | None = None,
    table: np.ndarray | None = None,
    cells: np.ndarray | None = None,
    state: np.ndarray | None = None,
    fstate: np.ndarray | None = None,
    num_units: int = 0,
    num_uniforms: int = 0,
) -> DomainKernel:
    """A `DomainKernel` of the given arrays, empty ones for the rest.

    The state is copied (the loop updates the copy, `load_compiled_form` takes it back); a
    constant table is used as it is when it already has the loop's type (C-contiguous,
    writeable, of its dtype), so that a domain that keeps its tables that way pays nothing per
    call, and copied otherwise.
    """

    def constant(value: np.ndarray | None, dtype: type, ndim: int) -> np.ndarray:
        if value is None:
            return np.zeros((0,) * ndim, dtype=dtype)
        is_ready = (
            isinstance(value, np.ndarray)
            and value.dtype == dtype
            and value.ndim == ndim
            and value.flags.c_contiguous
            and value.flags.writeable
        )
        return value if is_ready else np.array(value, dtype=dtype, order="C", ndmin=ndim)

    def copy(value: np.ndarray | None, dtype: type) -> np.ndarray:
        return np.zeros(0, dtype=dtype) if value is None else np.array(value, dtype=dtype)

    return DomainKernel(
        kind,
        constant(params, np.float64, 1),
        constant(table, np.int64, 2),
        constant(cells, np.float64, 2),
        copy(state, np.int64),
        copy(fstate, np.float64),
        np.zeros(num_actions, dtype=np.int8),
        np.zeros(num_uniforms),  # scratch: each step overwrites what it draws
        num_units,
        BLOCKS <= kind <= UAV_MISSION,
    )


# ---------------------------------------------------------------------- callback domains
#: The live callback domains by key (a key is what the loop holds: numba takes no objects).
_CALLBACK_DOMAINS: weakref.WeakValueDictionary[int, Any] = weakref.WeakValueDictionary()
_CALLBACK_KEYS: weakref.WeakKeyDictionary[Any, int] = weakref.WeakKeyDictionary()
#: What a callback domain's ``reset`` or ``step`` raised, by key, until `callback_error`.
_CALLBACK_ERRORS: dict[int, BaseException] = {}
_NEXT_KEY = itertools.count()


def callback_kernel(domain: Any) -> DomainKernel:
    """The `CALLBACK` form of ``domain``: the loop calls its Python ``reset`` and ``step``.

    For a domain without action constraints whose ``step`` never truncates (the loop ends
    episodes at ``domain_spec.max_episode_steps``). Its failures are ``info["cost"] > 0``, as
    in the Python loop. Costs one object-mode call per step (about a microsecond) on top of
    the domain's own ``step``.
    """
    key = _CALLBACK_KEYS.get(domain)
    if key is None:
        key = next(_NEXT_KEY)
        _CALLBACK_KEYS[domain] = key
        _CALLBACK_DOMAINS[key] = domain
    return domain_kernel(CALLBACK, domain.domain_spec.num_actions, state=np.array([key]))


def callback_domain(form: DomainKernel) -> Any:
    """The domain a `CALLBACK` form calls back."""
    return _CALLBACK_DOMAINS[int(form.state[0])]


def callback_error(form: DomainKernel) -> BaseException | None:
    """What the callback domain of ``form`` raised in the loop, if anything (cleared)."""
    return _CALLBACK_ERRORS.pop(int(form.state[0]), None) if form.kind == CALLBACK else None


def _python_reset(key: int, obs: np.ndarray) -> bool:
    """``domain.reset()`` into ``obs``; False (the exception kept) if it raised."""
    try:
        obs[:] = _CALLBACK_DOMAINS[key].reset()[0]
    except BaseException as error:  # re-raised by the stepper
        _CALLBACK_ERRORS[key] = error
        return False
    return True


def _python_step(key: int, action: int, obs: np.ndarray) -> tuple[float, bool, float]:
    """``domain.step(action)`` into ``obs``: (r, terminated, cost); r = NaN if it raised."""
    try:
        domain = _CALLBACK_DOMAINS[key]
        next_obs, reward, terminated, _, info = domain.step(action)
        if math.isnan(reward):
            raise ValueError(f"{type(domain).__name__}.step returned a NaN reward.")
        obs[:] = next_obs
        return float(reward), bool(terminated), float(info.get("cost", 0.0))
    except BaseException as error:  # re-raised by the stepper
        _CALLBACK_ERRORS[key] = error
        return math.nan, True, 0.0


@njit(cache=True)
def _callback_reset(key: int, obs: np.ndarray) -> bool:
    with objmode(ok="boolean"):
        ok = _python_reset(key, obs)
    return ok


@njit(cache=True)
def _callback_step(key: int, action: int, obs: np.ndarray) -> tuple[float, bool, float]:
    with objmode(reward="float64", terminated="boolean", cost="float64"):
        reward, terminated, cost = _python_step(key, action, obs)
    return reward, terminated, cost


@njit(cache=True)
def reset_into(domain: DomainKernel, obs: np.ndarray, rng: np.random.Generator) -> bool:
    """The domain's ``reset(seed=None)`` with its draws; writes s into ``obs``.

    False only when a `CALLBACK` domain's ``reset`` raised (`callback_error` has it).
    """
    kind, params, state, fstate = domain.kind, domain.params, domain.state, domain.fstate
    if kind == CALLBACK:
        return _callback_reset(state[0], obs)
    if kind == PENDULUM:
        fstate[0], fstate[1] = _pendulum_start(params[1], rng)
        obs[0], obs[1] = fstate[0], fstate[1]
    elif kind == GRIDWORLD:
        cell = int(params[1])
        state[0] = cell
        obs[0], obs[1] = domain.cells[cell, C_ROW], domain.cells[cell, C_COL]
    elif kind == CHAIN:
        state[0] = 0
        obs[0] = 0.0
    elif kind == BLOCKS:
        blocks_reset(domain.num_units, state, obs)
    else:
        if kind == PERSISTENT_SURVEILLANCE:
            for i in range(domain.num_units):
                for j in range(4):
                    state[4 * i + j] = _PST_START[j]
                state[4 * i] = int(params[2])
        else:  # the missions: s₀ is packed after their scalars
            start = RESCUE_START if kind == RESCUE else UAV_START
            for i in range(state.shape[0]):
                state[i] = int(params[start + i])
        for i in range(state.shape[0]):
            obs[i] = state[i]
    return True


@njit(cache=True, inline="always")
def step_into(
    domain: DomainKernel, action: int, obs: np.ndarray, rng: np.random.Generator
) -> tuple[float, bool, float]:
    """One domain step with the Python domain's draws; writes s' into ``obs``.

    Returns (reward, terminated, cost); the cost is the step's failure (``info["cost"]``).
    A `CALLBACK` domain whose ``step`` raised returns a NaN reward (`callback_error`). Each
    branch reads only its domain's fields (a field read outside the branch that uses it
    costs the loop a reference count per step).
    """
    kind = domain.kind
    if kind == PENDULUM:
        return _pendulum(domain.params, domain.fstate, action, obs, rng)
    if kind == GRIDWORLD:
        return _gridworld(domain.params, domain.table, domain.cells, domain.state, action, obs, rng)
    if kind == CHAIN:
        return _chain(domain.params, domain.state, action, obs, rng)
    if kind == BLOCKS:
        reward, terminated = blocks_step(domain.params, domain.state, action, obs, rng)
        return reward, terminated, 0.0
    if kind == RESCUE:
        return _rescue(domain, action, obs, rng)
    if kind == UAV_MISSION:
        return _uav_mission(domain, action, obs, rng)
    if kind == CALLBACK:
        return _callback_step(domain.state[0], action, obs)
    return _persistent_surveillance(domain, action, obs, rng)


@njit(cache=True, inline="always")
def _pendulum(
    params: np.ndarray, fstate: np.ndarray, action: int, obs: np.ndarray, rng: np.random.Generator
) -> tuple[float, bool, float]:
    theta, theta_dot, shown, reward, terminated = _pendulum_transition(
        fstate[0], fstate[1], action, params[0], rng
    )
    fstate[0], fstate[1] = theta, theta_dot
    obs[0], obs[1] = shown, theta_dot
    return reward, terminated, 1.0 if terminated else 0.0


@njit(cache=True, inline="always")
def _gridworld(
    params: np.ndarray,
    table: np.ndarray,
    cells: np.ndarray,
    state: np.ndarray,
    action: int,
    obs: np.ndarray,
    rng: np.random.Generator,
) -> tuple[float, bool, float]:
    cell = _gridworld_move(table, params[0], state[0], action, rng)
    state[0] = cell
    obs[0], obs[1] = cells[cell, C_ROW], cells[cell, C_COL]
    return cells[cell, C_REWARD], cells[cell, C_TERMINAL] > 0.0, cells[cell, C_PIT]


@njit(cache=True, inline="always")
def _chain(
    params: np.ndarray, state: np.ndarray, action: int, obs: np.ndarray, rng: np.random.Generator
) -> tuple[float, bool, float]:
    last = int(params[0]) - 1
    next_state, reward = _chain_move(last, params[1], params[2], state[0], action, rng)
    state[0] = next_state
    obs[0] = next_state
    return reward, next_state == last, 0.0


@njit(cache=True)
def _rescue(
    domain: DomainKernel, action: int, obs: np.ndarray, rng: np.random.Generator
) -> tuple[float, bool, float]:
    """One uniform per step, as `RescueMission.step`."""
    params, table, cells = domain.params, domain.table, domain.cells
    u = rng.random()
    nodes = cells.shape[0]
    next_obs, reward, terminated, failed = rescue_step(
        domain.state, action, u, table[:, :3], table[:, 3], cells[:, :nodes],
        cells[:, RESCUE_PEOPLE], cells[:, RESCUE_SUCCESS], int(params[0]), params[1],
        params[2], domain.mask,
    )  # fmt: skip
    _copy(obs, next_obs)
    return reward, terminated, 1.0 if failed else 0.0


@njit(cache=True)
def _uav_mission(
    domain: DomainKernel, action: int, obs: np.ndarray, rng: np.random.Generator
) -> tuple[float, bool, float]:
    """2n uniforms per step, as `UAVMission.step`."""
    state = domain.state
    next_state, reward, terminated, cost = mission_step(
        state, action, domain.table[0], domain.cells, domain.params[0], rng
    )
    _copy(state, next_state)
    _copy(obs, next_state)
    return reward, terminated, cost


@njit(cache=True)
def _persistent_surveillance(
    domain: DomainKernel, action: int, obs: np.ndarray, rng: np.random.Generator
) -> tuple[float, bool, float]:
    """2n uniforms per step (``np_random.random(2n)``), as `PersistentSurveillance.step`."""
    params, uniforms = domain.params, domain.uniforms
    for i in range(uniforms.shape[0]):
        uniforms[i] = rng.random()
    next_obs, reward, terminated = pst_step(
        domain.state, action, uniforms, int(params[0]), int(params[1]), int(params[2]),
        params[3], params[4], params[5], params[6], params[7] != 0.0, params[8] != 0.0,
        domain.mask,
    )  # fmt: skip
    _copy(obs, next_obs)
    return reward, terminated, 1.0 if terminated else 0.0


@njit(cache=True, inline="always")
def legal_into(domain: DomainKernel, is_filled: bool, out: np.ndarray) -> np.ndarray:
    """The sorted legal actions of the current state (a view of ``out``).

    Every action is legal in the pendulum, the grid world and the chain: ``out`` then already
    lists them all. ``domain.mask`` holds Rescue's and Persistent Surveillance's mask when
    ``is_filled`` (their step writes it), else it is filled here.
    """
    kind, table, state, mask = domain.kind, domain.table, domain.state, domain.mask
    if not domain.has_action_constraints:
        return out
    if kind == BLOCKS:
        n = domain.num_units
        nn = n * n
        count = legal_moves_into(state[nn : nn + n], state[nn + n :], n, out)
        return out[:count]
    if kind == UAV_MISSION:
        nodes = table.shape[0] - 1
        legal = legal_actions(state, table[0], table[1:, :nodes])
        _copy(out, legal)
        return out[: legal.shape[0]]
    if not is_filled and kind == RESCUE:
        rescue_fill_legal_mask(state, table[:, :3], table[:, 3], mask)
    elif not is_filled:
        pst_fill_legal_mask(state, domain.num_units, mask)
    count = 0
    for a in range(mask.shape[0]):
        if mask[a]:
            out[count] = a
            count += 1
    return out[:count]


@njit(cache=True, inline="always")
def _copy(target: np.ndarray, source: np.ndarray) -> None:
    """``target[:n] = source`` as a loop (a slice assignment links numba's error formatting)."""
    for i in range(source.shape[0]):
        target[i] = source[i]
