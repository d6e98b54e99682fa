"""Numba kernels of the domains layer (compiled once, cached on disk).

Only scalar arithmetic lives here; parameters are validated at the domain boundary, never in a
kernel (STYLE section 7).

The transitions of the chain, the grid world and the pendulum are plain functions of numbers,
indexable tables and a generator (`chain_move`, `gridworld_move`, `pendulum_transition`,
`pendulum_start`): the domains' Python ``step``/``reset`` run them as they are, and the compiled
loop runs the same source compiled by numba (`conjure.domains.compiled_domain`), so both paths
draw and round alike.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numba import njit

__all__ = [
    "chain_move",
    "gridworld_move",
    "pendulum_start",
    "pendulum_step",
    "pendulum_transition",
]

# Inverted pendulum constants, Geramifard (2012) Section 3.3.1 after Lagoudakis and Parr (2003).
GRAVITY = 9.8  # g, m/s^2
PENDULUM_MASS = 2.0  # m, kg
CART_MASS = 8.0  # M, kg
HALF_LENGTH = 0.5  # l, m (half of the 1 m pole)
ALPHA = 1.0 / (PENDULUM_MASS + CART_MASS)  # α = 1 / (m + M)
TIME_STEP = 0.1  # dt, s
MAX_ANGULAR_RATE = 2.0  # |θ̇| is clipped to 2 rad/s
HALF_PI = math.pi / 2.0  # the pendulum falls at |θ| = π/2


@njit(cache=True)
def pendulum_acceleration(theta: float, theta_dot: float, force: float) -> float:
    """Return θ̈ = (g sinθ − α m l θ̇² sin(2θ)/2 − α cosθ u) / (4l/3 − α m l cos²θ)."""
    cos_theta = math.cos(theta)
    numerator = (
        GRAVITY * math.sin(theta)
        - ALPHA * PENDULUM_MASS * HALF_LENGTH * theta_dot * theta_dot * math.sin(2.0 * theta) / 2.0
        - ALPHA * cos_theta * force
    )
    denominator = 4.0 * HALF_LENGTH / 3.0 - ALPHA * PENDULUM_MASS * HALF_LENGTH * cos_theta**2
    return numerator / denominator


@njit(cache=True)
def pendulum_rk4(theta: float, theta_dot: float, force: float, dt: float) -> tuple[float, float]:
    """Integrate (θ, θ̇) over ``dt`` with one classical Runge-Kutta-4 step, force held constant."""
    k1_theta = theta_dot
    k1_rate = pendulum_acceleration(theta, theta_dot, force)
    k2_theta = theta_dot + 0.5 * dt * k1_rate
    k2_rate = pendulum_acceleration(theta + 0.5 * dt * k1_theta, k2_theta, force)
    k3_theta = theta_dot + 0.5 * dt * k2_rate
    k3_rate = pendulum_acceleration(theta + 0.5 * dt * k2_theta, k3_theta, force)
    k4_theta = theta_dot + dt * k3_rate
    k4_rate = pendulum_acceleration(theta + dt * k3_theta, k4_theta, force)
    new_theta = theta + dt / 6.0 * (k1_theta + 2.0 * k2_theta + 2.0 * k3_theta + k4_theta)
    new_rate = theta_dot + dt / 6.0 * (k1_rate + 2.0 * k2_rate + 2.0 * k3_rate + k4_rate)
    return new_theta, new_rate


@njit(cache=True)
def pendulum_step(theta: float, theta_dot: float, force: float) -> tuple[float, float]:
    """One domain step: RK4 over ``TIME_STEP``, then clip θ̇ to [−2, 2]."""
    new_theta, new_rate = pendulum_rk4(theta, theta_dot, force, TIME_STEP)
    if new_rate > MAX_ANGULAR_RATE:
        new_rate = MAX_ANGULAR_RATE
    elif new_rate < -MAX_ANGULAR_RATE:
        new_rate = -MAX_ANGULAR_RATE
    return new_theta, new_rate


def pendulum_start(start_noise: float, rng: np.random.Generator) -> tuple[float, float]:
    """(θ, θ̇) at an episode's start: (0, 0), or uniform in [−x, x]² (two draws) for x > 0.

    Each draw is −x + 2x·u, numpy's ``uniform(-x, x)``.
    """
    if start_noise <= 0.0:
        return 0.0, 0.0
    span = start_noise - -start_noise
    theta = -start_noise + span * rng.random()
    return theta, -start_noise + span * rng.random()


def pendulum_transition(
    theta: float, theta_dot: float, action: int, force_noise: float, rng: np.random.Generator
) -> tuple[float, float, float, float, bool]:
    """One pendulum step from action 0/1/2 (−50, 0, +50 N) plus one uniform of force noise.

    Returns (θ', θ̇', the observed θ' clipped to ±π/2, reward, terminated): −1 and terminated
    once |θ'| >= π/2.
    """
    force = 50.0 * (action - 1)
    if force_noise > 0.0:
        force += force_noise * (2.0 * rng.random() - 1.0)
    theta, theta_dot = pendulum_step(theta, theta_dot, force)
    if -HALF_PI < theta < HALF_PI:
        return theta, theta_dot, theta, 0.0, False
    return theta, theta_dot, (HALF_PI if theta > 0.0 else -HALF_PI), -1.0, True


#: Columns of a grid world's move table row (`gridworld_move`): the 4 moves' target cells,
#: the number of feasible moves, those moves (4 columns), then 1 if the wind blows there.
GW_COUNT, GW_MOVES, GW_NOISY = 4, 5, 9


def gridworld_move(
    table: Any, noise: float, cell: int, action: int, rng: np.random.Generator
) -> int:
    """The grid world's next cell: with probability η (in a noisy cell) a random feasible move.

    ``table[c]`` is cell c's move table row (`GW_COUNT`, `GW_MOVES`, `GW_NOISY`): a list of
    lists in Python, an int64 array in the compiled loop. Two draws when the wind blows.
    """
    row = table[cell]
    if noise > 0.0 and row[GW_NOISY] and rng.random() < noise:
        count = row[GW_COUNT]
        if count > 0:
            action = row[GW_MOVES + int(rng.random() * count)]
    return row[action]


def chain_move(
    last: int, step_reward: float, slip: float, state: int, action: int, rng: np.random.Generator
) -> tuple[int, float]:
    """The chain's (next state, reward): action 0 moves right unless it slips (one draw)."""
    if state < last and action == 0:
        if slip == 0.0 or rng.random() >= slip:
            return state + 1, step_reward
    return state, 0.0
