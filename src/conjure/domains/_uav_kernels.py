"""Numba kernels of the UAV domains: Persistent Surveillance and Rescue Mission (Section 4.1.4).

Only integer bookkeeping lives here. The domains validate parameters and actions at their
boundary (STYLE section 7) and pass in the uniform draws they took from ``np_random``, so every
random number still comes from the domain's generator.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

from conjure.domains._mission_kernels import state_from_observation

__all__ = [
    "PSTConstants",
    "actions_of_mask",
    "pst_fill_legal_mask",
    "pst_legal_actions",
    "pst_num_crashed",
    "pst_start",
    "pst_step",
    "rescue_fill_legal_mask",
    "rescue_is_failed",
    "rescue_legal_actions",
    "rescue_step",
]

# ----------------------------------------------------------------------- Persistent Surveillance
# Locations on a line (RLPy's PST): BASE (maintenance) 0, REFUEL 1, COMMS 2, SURVEIL 3.
BASE, REFUEL, COMMS, SURVEIL = 0, 1, 2, 3
NUM_LOCATIONS = 4
# Per-UAV actions: RETREAT 0 (−1), LOITER 1 (stay), ADVANCE 2 (+1).
RETREAT, LOITER, ADVANCE = 0, 1, 2
# Per-UAV state offsets in the 4·n state vector: fuel, location, actuator, sensor.
FUEL, LOCATION, ACTUATOR, SENSOR = 0, 1, 2, 3


@njit(cache=True)
def pst_uav_legal_bits(fuel: int, location: int, actuator: int) -> int:
    """Return the legal actions of one UAV as bits (1 RETREAT, 2 LOITER, 4 ADVANCE)."""
    bits = 0
    if actuator == 1 or location == REFUEL or location == BASE:
        bits |= 1 << LOITER
    if fuel > 0:
        if location != SURVEIL and actuator == 1:
            bits |= 1 << ADVANCE
        if location != BASE:
            bits |= 1 << RETREAT
    if bits == 0:  # a crashed UAV gets a dummy LOITER (RLPy)
        bits = 1 << LOITER
    return bits


@njit(cache=True)
def _pst_fill_mask_from(fuels, locations, actuators, num_uavs, mask):
    bits = np.empty(num_uavs, dtype=np.int64)
    for i in range(num_uavs):
        bits[i] = pst_uav_legal_bits(fuels[i], locations[i], actuators[i])
    count = 0
    for a in range(mask.shape[0]):
        rest = a
        ok = 1
        for i in range(num_uavs):  # UAV i is digit i (least significant first, as RLPy)
            if not (bits[i] >> (rest % 3)) & 1:
                ok = 0
                break
            rest //= 3
        mask[a] = ok
        count += ok
    return count


@njit(cache=True)
def pst_fill_legal_mask(state: np.ndarray, num_uavs: int, mask: np.ndarray) -> int:
    """Write the joint legal-action mask of the int state into ``mask``; return the count."""
    fuels = np.empty(num_uavs, dtype=np.int64)
    locations = np.empty(num_uavs, dtype=np.int64)
    actuators = np.empty(num_uavs, dtype=np.int64)
    for i in range(num_uavs):
        fuels[i] = state[4 * i + FUEL]
        locations[i] = state[4 * i + LOCATION]
        actuators[i] = state[4 * i + ACTUATOR]
    return _pst_fill_mask_from(fuels, locations, actuators, num_uavs, mask)


@njit(cache=True)
def actions_of_mask(mask: np.ndarray) -> np.ndarray:
    """Return the sorted actions where ``mask`` is nonzero (int64)."""
    count = 0
    for a in range(mask.shape[0]):
        if mask[a]:
            count += 1
    out = np.empty(count, dtype=np.int64)
    j = 0
    for a in range(mask.shape[0]):
        if mask[a]:
            out[j] = a
            j += 1
    return out


@njit(cache=True)
def pst_legal_actions(state: np.ndarray, num_uavs: int, max_fuel: int) -> tuple[np.ndarray, int]:
    """Return (sorted legal joint actions, -1) of a float state, or (empty, bad dimension)."""
    highs = np.empty(state.shape[0], dtype=np.float64)
    for k in range(state.shape[0]):
        highs[k] = (max_fuel, NUM_LOCATIONS - 1, 1, 1)[k % 4]
    ints, bad = state_from_observation(state, highs)
    if bad >= 0:
        return np.empty(0, dtype=np.int64), bad
    mask = np.empty(3**num_uavs, dtype=np.int8)
    pst_fill_legal_mask(ints, num_uavs, mask)
    return actions_of_mask(mask), -1


@njit(cache=True)
def pst_num_crashed(state: np.ndarray, num_uavs: int) -> int:
    """Number of UAVs out of fuel outside REFUEL (the failure that ends the episode)."""
    num_crashed = 0
    for i in range(num_uavs):
        if state[4 * i + FUEL] <= 0 and state[4 * i + LOCATION] != REFUEL:
            num_crashed += 1
    return num_crashed


class PSTConstants(NamedTuple):
    """Persistent Surveillance's constants as `pst_step` and `pst_start` read them by name.

    Built once by the domain (`PersistentSurveillance`), passed by its ``step`` and by the
    compiled loop (`conjure.domains.compiled_domain.DomainKernel.pst`).
    """

    num_uavs: int
    num_targets: int
    max_fuel: int
    failure_probability: float
    surveillance_reward: float
    fuel_penalty: float
    crash_penalty: float
    crash_penalty_per_uav: bool
    is_relay_actuator_checked: bool


#: The `PSTConstants` of a compiled form that is not Persistent Surveillance's.
NO_PST = PSTConstants(
    num_uavs=0,
    num_targets=0,
    max_fuel=0,
    failure_probability=0.0,
    surveillance_reward=0.0,
    fuel_penalty=0.0,
    crash_penalty=0.0,
    crash_penalty_per_uav=False,
    is_relay_actuator_checked=False,
)


@njit(cache=True)
def pst_start(constants: PSTConstants, state: np.ndarray) -> None:
    """s₀ into ``state``: every UAV at BASE with full fuel and working parts (RLPy's PST)."""
    for i in range(constants.num_uavs):
        state[4 * i + FUEL] = constants.max_fuel
        state[4 * i + LOCATION] = BASE
        state[4 * i + ACTUATOR] = 1
        state[4 * i + SENSOR] = 1


@njit(cache=True)
def pst_step(
    state: np.ndarray, action: int, uniforms: np.ndarray, constants: PSTConstants, mask: np.ndarray
) -> tuple[np.ndarray, float, bool]:
    """Advance the int state in place; return (float observation, reward, terminated).

    ``uniforms`` holds 2n draws: actuator failures for UAVs 0..n−1, then sensor failures.
    The legal mask of the new state is written into ``mask``.
    """
    n = constants.num_uavs
    num_targets, max_fuel = constants.num_targets, constants.max_fuel
    failure_probability = constants.failure_probability
    surveillance_reward, fuel_penalty = constants.surveillance_reward, constants.fuel_penalty
    crash_penalty, crash_penalty_per_uav = constants.crash_penalty, constants.crash_penalty_per_uav
    is_relay_actuator_checked = constants.is_relay_actuator_checked
    # Reward from the pre-step state: a relay at COMMS and healthy sensors at SURVEIL.
    has_relay = False
    num_seeing = 0
    for i in range(n):
        location = state[4 * i + LOCATION]
        if location == COMMS and (not is_relay_actuator_checked or state[4 * i + ACTUATOR] == 1):
            has_relay = True
        if location == SURVEIL and state[4 * i + SENSOR] == 1:
            num_seeing += 1
    reward = 0.0
    if has_relay:
        reward += surveillance_reward * min(num_targets, num_seeing)
    num_burnt = 0
    rest = action
    for i in range(n):
        uav_action = rest % 3
        rest //= 3
        old = state[4 * i + LOCATION]
        new = old + uav_action - 1  # 1. move
        state[4 * i + LOCATION] = new
        if not (uav_action == LOITER and (new == REFUEL or new == BASE)):  # 2. burn
            num_burnt += 1
            if state[4 * i + FUEL] > 0:
                state[4 * i + FUEL] -= 1
        if uniforms[i] < failure_probability:  # 3. failures
            state[4 * i + ACTUATOR] = 0
        if uniforms[n + i] < failure_probability:
            state[4 * i + SENSOR] = 0
        if old == REFUEL and new == REFUEL:  # 4. refuel
            state[4 * i + FUEL] = max_fuel
        if old == BASE and new == BASE:  # 5. repair
            state[4 * i + ACTUATOR] = 1
            state[4 * i + SENSOR] = 1
    reward -= fuel_penalty * num_burnt
    num_crashed = pst_num_crashed(state, n)
    terminated = num_crashed > 0
    if terminated:
        reward -= crash_penalty * (num_crashed if crash_penalty_per_uav else 1)
    pst_fill_legal_mask(state, n, mask)
    obs = np.empty(state.shape[0], dtype=np.float64)
    for k in range(state.shape[0]):
        obs[k] = state[k]
    return obs, reward, terminated


# ----------------------------------------------------------------------------- Rescue Mission
# Internal state: medic location, medic fuel, comm location, comm fuel, comm mode,
# rescued bits of nodes 1..N−1, time step.
MEDIC_LOC, MEDIC_FUEL, COMM_LOC, COMM_FUEL, COMM_MODE, FIRST_BIT = 0, 1, 2, 3, 4, 5
FLYING, PERCHED = 0, 1
MEDIC_SLOTS, COMM_SLOTS = 4, 5  # medic: hover + 3 neighbours; comm: hover, perch + 3
HOVER, PERCH = 0, 1


@njit(cache=True)
def rescue_fill_legal_mask(
    state: np.ndarray, neighbours: np.ndarray, degrees: np.ndarray, mask: np.ndarray
) -> int:
    """Write the joint legal-action mask (medic slot × 5 + comm slot) into ``mask``."""
    medic_loc, comm_loc = state[MEDIC_LOC], state[COMM_LOC]
    count = 0
    for m in range(MEDIC_SLOTS):
        medic_ok = m == HOVER or (m - 1 < degrees[medic_loc] and state[MEDIC_FUEL] >= 1)
        for c in range(COMM_SLOTS):
            comm_ok = c == HOVER or c == PERCH
            if c >= 2:
                comm_ok = (
                    state[COMM_MODE] == FLYING
                    and c - 2 < degrees[comm_loc]
                    and state[COMM_FUEL] >= 1
                )
            ok = 1 if (medic_ok and comm_ok) else 0
            mask[m * COMM_SLOTS + c] = ok
            count += ok
    return count


@njit(cache=True)
def rescue_legal_actions(
    state: np.ndarray,
    highs: np.ndarray,
    neighbours: np.ndarray,
    degrees: np.ndarray,
) -> tuple[np.ndarray, int]:
    """Return (sorted legal joint actions, -1) of a float state, or (empty, bad dimension)."""
    ints, bad = state_from_observation(state, highs)
    if bad >= 0:
        return np.empty(0, dtype=np.int64), bad
    mask = np.empty(MEDIC_SLOTS * COMM_SLOTS, dtype=np.int8)
    rescue_fill_legal_mask(ints, neighbours, degrees, mask)
    return actions_of_mask(mask), -1


@njit(cache=True)
def rescue_is_failed(state: np.ndarray, horizon: int) -> bool:
    """A UAV out of fuel away from the base, or away from the base when t reaches H."""
    crashed = (state[MEDIC_FUEL] <= 0 and state[MEDIC_LOC] != 0) or (
        state[COMM_FUEL] <= 0 and state[COMM_LOC] != 0
    )
    away = state[MEDIC_LOC] != 0 or state[COMM_LOC] != 0
    return crashed or (state[state.shape[0] - 1] >= horizon and away)


@njit(cache=True)
def rescue_step(
    state: np.ndarray,
    action: int,
    uniform: float,
    neighbours: np.ndarray,
    degrees: np.ndarray,
    is_near: np.ndarray,
    people: np.ndarray,
    success: np.ndarray,
    horizon: int,
    fuel_penalty: float,
    failure_penalty: float,
    mask: np.ndarray,
) -> tuple[np.ndarray, float, bool, bool]:
    """Advance the int state in place; return (float observation, reward, terminated, failed)."""
    medic_slot = action // COMM_SLOTS
    comm_slot = action % COMM_SLOTS
    num_burnt = 0
    # Medic: hover (free while at the base) or move along an edge.
    if medic_slot == HOVER:
        if state[MEDIC_LOC] != 0:
            num_burnt += 1
            state[MEDIC_FUEL] -= 1
    else:
        state[MEDIC_LOC] = neighbours[state[MEDIC_LOC], medic_slot - 1]
        num_burnt += 1
        state[MEDIC_FUEL] -= 1
    # Communication UAV: perch (free), hover (free at the base) or move (flying only).
    if comm_slot == PERCH:
        state[COMM_MODE] = PERCHED
    elif comm_slot == HOVER:
        state[COMM_MODE] = FLYING
        if state[COMM_LOC] != 0:
            num_burnt += 1
            state[COMM_FUEL] -= 1
    else:
        state[COMM_LOC] = neighbours[state[COMM_LOC], comm_slot - 2]
        state[COMM_MODE] = FLYING
        num_burnt += 1
        state[COMM_FUEL] -= 1
    if state[MEDIC_FUEL] < 0:
        state[MEDIC_FUEL] = 0
    if state[COMM_FUEL] < 0:
        state[COMM_FUEL] = 0
    state[state.shape[0] - 1] += 1  # t
    reward = 0.0
    if num_burnt > 0:
        reward -= fuel_penalty * num_burnt
    # Rescue: medic at an unrescued node, comm UAV at most one edge away, success p_j.
    node = state[MEDIC_LOC]
    if node != 0 and state[FIRST_BIT + node - 1] == 0 and is_near[state[COMM_LOC], node]:
        if uniform < success[node]:
            state[FIRST_BIT + node - 1] = 1
            reward += people[node]
    failed = rescue_is_failed(state, horizon)
    if failed:
        reward -= failure_penalty
    rescue_fill_legal_mask(state, neighbours, degrees, mask)
    obs = np.empty(state.shape[0], dtype=np.float64)
    for k in range(state.shape[0]):
        obs[k] = state[k]
    return obs, reward, failed or state[state.shape[0] - 1] >= horizon, failed
