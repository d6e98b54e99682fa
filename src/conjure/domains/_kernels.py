"""Numba kernels of the domains layer (compiled once, cached on disk).

Only scalar arithmetic lives here; parameters are validated at the domain boundary, never in a
kernel (STYLE section 7).
"""

from __future__ import annotations

import math

from numba import njit

__all__ = ["pendulum_step"]

# Inverted pendulum constants, Geramifard (2012) Section 3.3.1 after Lagoudakis and Parr (2003).
GRAVITY = 9.8  # g, m/s^2
PENDULUM_MASS = 2.0  # m, kg
CART_MASS = 8.0  # M, kg
HALF_LENGTH = 0.5  # l, m (half of the 1 m pole)
ALPHA = 1.0 / (PENDULUM_MASS + CART_MASS)  # α = 1 / (m + M)
TIME_STEP = 0.1  # dt, s
MAX_ANGULAR_RATE = 2.0  # |θ̇| is clipped to 2 rad/s


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
