"""The inverted pendulum of Lagoudakis and Parr (2003), as used in Geramifard (2012)."""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np
from gymnasium import spaces

from conjure.core.errors import InvalidParameterError
from conjure.core.interfaces import Domain, DomainSpec
from conjure.core.params import Constraint, Interval
from conjure.domains._kernels import HALF_PI, MAX_ANGULAR_RATE, pendulum_start, pendulum_transition
from conjure.domains.compiled_domain import (
    PENDULUM,
    DomainKernel,
    KeptCompiledForm,
    PendulumConstants,
    domain_kernel,
)

__all__ = ["InvertedPendulum"]

_NUM_ACTIONS = 3  # forces −50, 0, +50 N (`pendulum_transition`)


class InvertedPendulum(KeptCompiledForm, Domain):
    """Balance a pendulum on a cart by pushing the cart left, not at all, or right.

    Geramifard (2012), Section 3.3.1 and Section 4.1.4; Lagoudakis and Parr (2003). The state is
    (θ, θ̇) with θ = 0 upright; the three actions push the cart with u ∈ {−50, 0, +50} N plus a
    uniform force noise. The angular acceleration is

        θ̈ = (g sinθ − α m l θ̇² sin(2θ)/2 − α cosθ u) / (4l/3 − α m l cos²θ),

    with g = 9.8 m/s², m = 2 kg, M = 8 kg, α = 1/(m + M), l = 0.5 m. Every step earns 0 until
    |θ| ≥ π/2, which earns −1 and ends the episode; γ = 0.95 and episodes are capped at 3000
    steps. The fall is the domain's failure (`is_constrained`; ``info["cost"] = 1.0`` on the
    falling step, 0.0 otherwise).

    Parameters
    ----------
    force_noise : float, default=10.0
        Half-width of the uniform noise added to the force, in N; in [0, inf). The thesis
        uses 10 (noise in [−10, 10] N).
    start_noise : float, default=0.0
        Half-width x of the uniform start distribution: θ and θ̇ are each drawn from [−x, x];
        in [0, π/2). 0 starts upright at rest, as in 2012.

    Attributes
    ----------
    domain_spec : DomainSpec
        Bounds [−π/2, π/2] × [−2, 2] (both continuous), 3 actions, γ = 0.95, cap 3000.

    Notes
    -----
    ========  ==========  ========================================
    Symbol    Name        Meaning
    ========  ==========  ========================================
    θ, θ̇      obs[0:2]    pole angle (rad) and angular rate (rad/s)
    u         action      force index: 0 → −50 N, 1 → 0 N, 2 → +50 N
    γ         discount    0.95
    ========  ==========  ========================================

    - Choice: one classical RK4 step over dt = 0.1 s with the force held constant, as RLPy's
      ``InfCartPoleBalance``; Lagoudakis and Parr integrated with RK45-Fehlberg.
    - Choice: θ̇ is clipped to [−2, 2] after every step (thesis footnote 6), giving the domain
      [−π/2, π/2] × [−2, 2].
    - Choice: on the terminal step the observed θ is clipped to ±π/2 so that observations stay
      inside ``observation_space``; the internal state keeps the true angle.
    - Choice: the start state is (0, 0) (the 2012 version); RLPy today draws it uniformly from
      [−0.2, 0.2]², which ``start_noise=0.2`` reproduces.
    - Choice: the force noise is one uniform draw per step from ``np_random``, added to the
      nominal force (as RLPy).
    - Choice: the domain never truncates; the run loop (and Gymnasium's ``TimeLimit``) cut
      episodes at ``domain_spec.max_episode_steps``.

    Complexity: Θ(1) per step (one compiled RK4 step).

    Examples
    --------
    >>> domain = InvertedPendulum()
    >>> obs, info = domain.reset(seed=0)
    >>> obs
    array([0., 0.])
    >>> next_obs, reward, terminated, truncated, info = domain.step(1)
    >>> reward, terminated, truncated
    (0.0, False, False)
    """

    parameter_constraints: ClassVar[dict[str, Constraint]] = {
        "force_noise": Interval(float, 0.0, None),
        "start_noise": Interval(float, 0.0, HALF_PI, closed="left"),
    }

    def __init__(self, *, force_noise: float = 10.0, start_noise: float = 0.0) -> None:
        self.force_noise = force_noise
        self.start_noise = start_noise
        self._build()

    def _build(self) -> None:
        """Validate the parameters and build the spaces and the spec."""
        self.validate_params()
        low = np.array([-HALF_PI, -MAX_ANGULAR_RATE], dtype=np.float64)
        high = np.array([HALF_PI, MAX_ANGULAR_RATE], dtype=np.float64)
        self.observation_space = spaces.Box(low=low, high=high, dtype=np.float64)
        self.action_space = spaces.Discrete(_NUM_ACTIONS)
        self.domain_spec = DomainSpec(
            name="InvertedPendulum",
            low=low,
            high=high,
            is_discrete=[False, False],
            num_actions=_NUM_ACTIONS,
            discount=0.95,
            max_episode_steps=3000,
        )
        self._force_noise = float(self.force_noise)
        self._fstate = np.zeros(2)  # (θ, θ̇), shared with the compiled form

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """Start an episode at (0, 0), or uniformly in [−x, x]² with ``start_noise = x``."""
        super().reset(seed=seed)
        fstate = self._fstate
        fstate[0], fstate[1] = pendulum_start(float(self.start_noise), self.np_random)
        return fstate.copy(), {}

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        """Apply force ``action`` (0: −50 N, 1: 0 N, 2: +50 N) plus noise for 0.1 s."""
        fstate = self._fstate
        theta, theta_dot, shown, reward, terminated = pendulum_transition(
            fstate[0], fstate[1], self.check_action(action), self._force_noise, self.np_random
        )
        fstate[0], fstate[1] = theta, theta_dot
        info = {"cost": 1.0 if terminated else 0.0}
        return np.array((shown, theta_dot)), reward, terminated, False, info

    compiled_methods = ("step", "reset")

    def compiled_form(self) -> DomainKernel:
        """The pendulum for the compiled loop: `PendulumConstants`, (θ, θ̇) (`KeptCompiledForm`)."""
        return self._kept_form(
            lambda: domain_kernel(
                PENDULUM,
                3,
                constants=PendulumConstants(
                    force_noise=self._force_noise, start_noise=float(self.start_noise)
                ),
                fstate=self._fstate,
            )
        )

    def is_constrained(self, state: np.ndarray) -> bool:
        """Whether the pendulum has fallen, |θ| >= π/2 (the failure that ends the episode)."""
        array = np.asarray(state, dtype=np.float64)
        if array.shape != (2,):
            raise InvalidParameterError(
                f"InvertedPendulum.is_constrained expects a state (θ, θ̇) of shape (2,); got "
                f"shape {array.shape}."
            )
        return bool(abs(array[0]) >= HALF_PI)
