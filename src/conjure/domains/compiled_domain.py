"""The domains as the compiled learning loop reads them (`conjure.core.compiled_form`).

A domain's ``compiled_form()`` returns a `DomainKernel`: its kind, its constants and its
internal state, the domain's own arrays (`KeptCompiledForm`): the loop's steps and the Python
``step`` update the same arrays, so nothing is copied back after the loop ran. The three
kernels here, `reset_into`, `step_into` and `legal_into`, choose the domain's own kernel by
kind: the shared-source transitions of `conjure.domains._kernels` (chain, grid world,
pendulum) and the mission kernels (`blocks_masked_transition`, `pst_step`, `rescue_step`,
`mission_step`)
that the Python ``step`` methods call too, with the same draws in the same order. A domain
with no kernel of its own (`conjure.domains.gymnasium_adapter.GymnasiumDomain`: the user's
environment) can still run in the loop as a `CALLBACK` domain: the loop calls its own Python
``reset`` and ``step`` back (numba's object mode) and keeps everything else compiled.

Choice: one named tuple type serves every domain (unused fields are empty arrays and the
stand-in constants of the other domains), so the loop compiles once for all of them. Each
domain's constants are its own named tuple (`PendulumConstants` ... `PSTConstants`), read by
name; the layout of ``table`` and ``cells`` is written beside each domain's ``compiled_form``.
"""

from __future__ import annotations

import itertools
import math
import weakref
from collections.abc import Callable
from typing import Any, NamedTuple

import numpy as np
from numba import njit, objmode

from conjure.domains._blocks_kernels import (
    NO_BLOCKS,
    BlocksConstants,
    blocks_fill_legal_mask,
    blocks_masked_transition,
    blocks_reset,
)
from conjure.domains._kernels import chain_move, gridworld_move, pendulum_start, pendulum_transition
from conjure.domains._mission_kernels import legal_actions, mission_step
from conjure.domains._uav_kernels import (
    NO_PST,
    PSTConstants,
    pst_fill_legal_mask,
    pst_start,
    pst_step,
    rescue_fill_legal_mask,
    rescue_step,
)

__all__ = [
    "ChainConstants",
    "DomainKernel",
    "GridConstants",
    "KeptCompiledForm",
    "MissionConstants",
    "PendulumConstants",
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
#: Rescue Mission: ``cells[:, :n]`` the one-edge-away table, then the people and success
#: probability per node.
RESCUE_PEOPLE, RESCUE_SUCCESS = 8, 9


class PendulumConstants(NamedTuple):
    """The pendulum's constants (Section 3.3.1), read by name by the loop's kernels.

    Parameters
    ----------
    force_noise : float
        Half-width of the uniform noise added to the force, in N.
    start_noise : float
        Half-width x of the uniform start distribution of θ and θ̇.
    """

    force_noise: float
    start_noise: float


class GridConstants(NamedTuple):
    """A grid world's constants (Section 5.1), read by name by the loop's kernels.

    Parameters
    ----------
    noise : float
        η, the probability that the action is replaced by a random feasible move.
    start_cell : int
        The start cell's row in ``table`` and ``cells``.
    """

    noise: float
    start_cell: int


class ChainConstants(NamedTuple):
    """The test chain's constants (Section 2.1, Equation 2.5), read by name by the loop.

    Parameters
    ----------
    num_states : int
        n; state n − 1 is terminal.
    step_reward : float
        The reward of a move right.
    slip : float
        The probability that a move fails.
    """

    num_states: int
    step_reward: float
    slip: float


class MissionConstants(NamedTuple):
    """Rescue Mission's or a UAV mission's constants (Sections 4.1.4, 5.3.5), by name.

    Parameters
    ----------
    start : ndarray of int64
        s₀.
    horizon : int
        Rescue: the episode's last step.
    fuel_penalty, failure_penalty : float
        Rescue: the penalties of a step's fuel and of a failure.
    traverse_failure : float
        A UAV mission: the probability that a UAV trying to traverse an edge stays put.
    """

    start: np.ndarray
    horizon: int
    fuel_penalty: float
    failure_penalty: float
    traverse_failure: float


_NO_PENDULUM = PendulumConstants(force_noise=0.0, start_noise=0.0)
_NO_GRID = GridConstants(noise=0.0, start_cell=0)
_NO_CHAIN = ChainConstants(num_states=0, step_reward=0.0, slip=0.0)
_NO_MISSION = MissionConstants(
    start=np.zeros(0, dtype=np.int64),
    horizon=0,
    fuel_penalty=0.0,
    failure_penalty=0.0,
    traverse_failure=0.0,
)
#: Where `domain_kernel` puts each kind of constants.
_CONSTANT_FIELDS = {
    PendulumConstants: "pendulum",
    GridConstants: "grid",
    ChainConstants: "chain",
    BlocksConstants: "blocks",
    PSTConstants: "pst",
    MissionConstants: "mission",
}

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
    pendulum, grid, chain, blocks, pst, mission : named tuples
        The constants of the domain of ``kind`` by name (`PendulumConstants`,
        `GridConstants`, `ChainConstants`, `BlocksConstants`, `PSTConstants`,
        `MissionConstants`); stand-ins for the other domains.
    table, cells : ndarray
        The domain's tables (int64 2-D, float64 2-D; layouts beside each domain's
        ``compiled_form``).
    state, fstate : ndarray
        The domain's internal state, int64 or float64: its own arrays, updated in place.
    mask : ndarray of int8
        The legal-action mask of the domains whose reset and step write one (BlocksWorld,
        Persistent Surveillance, Rescue: the domain's own); unused otherwise.
    uniforms : ndarray
        Room for a step's draws.
    num_units : int
        The blocks or UAVs.
    has_action_constraints : bool
        Whether some actions are illegal somewhere (`legal_into`).
    """

    kind: int
    pendulum: PendulumConstants
    grid: GridConstants
    chain: ChainConstants
    blocks: BlocksConstants
    pst: PSTConstants
    mission: MissionConstants
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
    constants: Any = None,
    table: np.ndarray | None = None,
    cells: np.ndarray | None = None,
    state: np.ndarray | None = None,
    fstate: np.ndarray | None = None,
    mask: np.ndarray | None = None,
    num_units: int = 0,
    num_uniforms: int = 0,
) -> DomainKernel:
    """A `DomainKernel` of the given constants and arrays, stand-ins and empty ones for the rest.

    ``state``, ``fstate`` and ``mask`` are the domain's own arrays (int64, float64 and int8,
    C-contiguous), shared, not copied: the loop updates the domain's state in place. A
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

    def own(value: np.ndarray | None, dtype: type, size: int = 0) -> np.ndarray:
        if value is None:
            return np.zeros(size, dtype=dtype)
        if value.dtype != dtype or not value.flags.c_contiguous or not value.flags.writeable:
            raise TypeError(
                f"domain_kernel shares a domain's state arrays: expected a writeable "
                f"C-contiguous {np.dtype(dtype).name} array, got {value.dtype} with flags "
                f"{value.flags}."
            )
        return value

    fields = {
        "pendulum": _NO_PENDULUM, "grid": _NO_GRID, "chain": _NO_CHAIN, "blocks": NO_BLOCKS,
        "pst": NO_PST, "mission": _NO_MISSION,
    }  # fmt: skip
    if constants is not None:
        fields[_CONSTANT_FIELDS[type(constants)]] = constants
    return DomainKernel(
        kind,
        **fields,
        table=constant(table, np.int64, 2),
        cells=constant(cells, np.float64, 2),
        state=own(state, np.int64),
        fstate=own(fstate, np.float64),
        mask=own(mask, np.int8, num_actions),
        uniforms=np.zeros(num_uniforms),  # scratch: each step overwrites what it draws
        num_units=num_units,
        has_action_constraints=BLOCKS <= kind <= UAV_MISSION,
    )


class KeptCompiledForm:
    """A domain mixin: the compiled form built once per ``_build``, over the domain's own state.

    The form is what the compiled loop of Algorithms 10-12 steps (`step_into`).

    The constants and tables (`domain_kernel`) are built at the first ``compiled_form`` after
    ``_build`` (the parameters' last change: every ``_build`` makes a new ``domain_spec``,
    the key) and kept by the domain. Its ``state``, ``fstate`` and ``mask`` are the arrays the
    domain's Python methods read and write in place, so the loop and ``step`` share one state
    and nothing is copied in or back per call.
    """

    domain_spec: Any

    def _kept_form(self, build: Callable[[], DomainKernel]) -> DomainKernel:
        """``build()``'s form, kept since this ``_build``."""
        kept = getattr(self, "_compiled_form_kept", None)
        if kept is None or kept[0] is not self.domain_spec:
            kept = self._compiled_form_kept = (self.domain_spec, build())
        return kept[1]


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

    A domain with a legal-action mask gets the start state's (the mask is always its state's).

    False only when a `CALLBACK` domain's ``reset`` raised (`callback_error` has it).
    """
    kind, state, fstate = domain.kind, domain.state, domain.fstate
    if kind == CALLBACK:
        return _callback_reset(state[0], obs)
    if kind == PENDULUM:
        fstate[0], fstate[1] = _pendulum_start(domain.pendulum.start_noise, rng)
        obs[0], obs[1] = fstate[0], fstate[1]
    elif kind == GRIDWORLD:
        cell = domain.grid.start_cell
        state[0] = cell
        obs[0], obs[1] = domain.cells[cell, C_ROW], domain.cells[cell, C_COL]
    elif kind == CHAIN:
        state[0] = 0
        obs[0] = 0.0
    elif kind == BLOCKS:
        blocks_reset(domain.num_units, state, obs)
        blocks_fill_legal_mask(state, domain.num_units, domain.mask)
    else:
        if kind == PERSISTENT_SURVEILLANCE:
            pst_start(domain.pst, state)  # `PersistentSurveillance.reset`'s own kernel
            pst_fill_legal_mask(state, domain.num_units, domain.mask)
        else:
            _copy(state, domain.mission.start)
        if kind == RESCUE:
            rescue_fill_legal_mask(state, domain.table[:, :3], domain.table[:, 3], domain.mask)
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
        return _pendulum(domain.pendulum, domain.fstate, action, obs, rng)
    if kind == GRIDWORLD:
        return _gridworld(domain.grid, domain.table, domain.cells, domain.state, action, obs, rng)
    if kind == CHAIN:
        return _chain(domain.chain, domain.state, action, obs, rng)
    if kind == BLOCKS:
        reward, terminated = blocks_masked_transition(
            domain.blocks, domain.state, action, obs, rng.random(), domain.mask
        )
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
    constants: PendulumConstants,
    fstate: np.ndarray,
    action: int,
    obs: np.ndarray,
    rng: np.random.Generator,
) -> tuple[float, bool, float]:
    theta, theta_dot, shown, reward, terminated = _pendulum_transition(
        fstate[0], fstate[1], action, constants.force_noise, rng
    )
    fstate[0], fstate[1] = theta, theta_dot
    obs[0], obs[1] = shown, theta_dot
    return reward, terminated, 1.0 if terminated else 0.0


@njit(cache=True, inline="always")
def _gridworld(
    constants: GridConstants,
    table: np.ndarray,
    cells: np.ndarray,
    state: np.ndarray,
    action: int,
    obs: np.ndarray,
    rng: np.random.Generator,
) -> tuple[float, bool, float]:
    cell = _gridworld_move(table, constants.noise, state[0], action, rng)
    state[0] = cell
    obs[0], obs[1] = cells[cell, C_ROW], cells[cell, C_COL]
    return cells[cell, C_REWARD], cells[cell, C_TERMINAL] > 0.0, cells[cell, C_PIT]


@njit(cache=True, inline="always")
def _chain(
    constants: ChainConstants,
    state: np.ndarray,
    action: int,
    obs: np.ndarray,
    rng: np.random.Generator,
) -> tuple[float, bool, float]:
    last = constants.num_states - 1
    next_state, reward = _chain_move(
        last, constants.step_reward, constants.slip, state[0], action, rng
    )
    state[0] = next_state
    obs[0] = next_state
    return reward, next_state == last, 0.0


@njit(cache=True)
def _rescue(
    domain: DomainKernel, action: int, obs: np.ndarray, rng: np.random.Generator
) -> tuple[float, bool, float]:
    """One uniform per step, as `RescueMission.step`."""
    constants, table, cells = domain.mission, domain.table, domain.cells
    u = rng.random()
    nodes = cells.shape[0]
    next_obs, reward, terminated, failed = rescue_step(
        domain.state, action, u, table[:, :3], table[:, 3], cells[:, :nodes],
        cells[:, RESCUE_PEOPLE], cells[:, RESCUE_SUCCESS], constants.horizon,
        constants.fuel_penalty, constants.failure_penalty, domain.mask,
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
        state, action, domain.table[0], domain.cells, domain.mission.traverse_failure, rng
    )
    _copy(state, next_state)
    _copy(obs, next_state)
    return reward, terminated, cost


@njit(cache=True)
def _persistent_surveillance(
    domain: DomainKernel, action: int, obs: np.ndarray, rng: np.random.Generator
) -> tuple[float, bool, float]:
    """2n uniforms per step (``np_random.random(2n)``), as `PersistentSurveillance.step`."""
    uniforms = domain.uniforms
    for i in range(uniforms.shape[0]):
        uniforms[i] = rng.random()
    next_obs, reward, terminated = pst_step(domain.state, action, uniforms, domain.pst, domain.mask)
    _copy(obs, next_obs)
    return reward, terminated, 1.0 if terminated else 0.0


@njit(cache=True)
def legal_into(domain: DomainKernel, out: np.ndarray) -> np.ndarray:
    """The sorted legal actions of the current state (a view of ``out``).

    Every action is legal in the pendulum, the grid world and the chain: ``out`` then already
    lists them all. BlocksWorld's, Rescue's and Persistent Surveillance's are read from
    ``domain.mask``, the domain's own mask, which their reset and step kernels keep as the
    current state's (so the domain's Python methods read it too).
    """
    kind, table, state, mask = domain.kind, domain.table, domain.state, domain.mask
    if not domain.has_action_constraints:
        return out
    if kind == UAV_MISSION:
        nodes = table.shape[0] - 1
        legal = legal_actions(state, table[0], table[1:, :nodes])
        _copy(out, legal)
        return out[: legal.shape[0]]
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
