"""What the sampled planners share (Algorithms 5, 6, 8, 9, 13): π^ε batches, θ̄ solves, plans.

`Sampling` is the generative side of Algorithms 6, 8, 9 and 13 (Eq. 2.28): the sampler, the
set-up φ and the one RNG all sampling draws from, with θ₀ of line 1, the L₁ samples of π^ε
per iteration and the final `Plan`. `solve_q_weights` is the regularised Ãθ̄ = b̃ of Eqs.
2.23-2.26 (and 2.35-2.36) that Algorithms 5, 6 and 13 share.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
import scipy.sparse as sp

from conjure.core.linalg import brm_system, lstd_system, solve_regularized
from conjure.core.seeding import make_rng
from conjure.planners import _kernels
from conjure.planners.base import Iterations, Plan, Planner


class Sampling:
    """The generative model, φ and RNG of one sampled planning run (Eq. 2.28).

    Parameters
    ----------
    planner : Planner
        A sampled planner with ``representation`` and ``seed`` parameters.
    source : TabularModel or Domain
        What to plan on: a model, or a domain with ``set_state`` or ``model()``.
    """

    def __init__(self, planner: Planner, source: Any):
        self.sampler, self.model = planner._generative(source)
        self.spec = self.sampler.spec
        self.rng = make_rng(planner.seed)
        self.representation = _kernels.setup_representation(
            planner.representation, self.spec, planner.seed
        )

    @property
    def num_actions(self) -> int:
        """|A|."""
        return self.spec.num_actions

    def initial_weights(self) -> np.ndarray:
        """θ₀ ~ U(−10⁻⁶, 10⁻⁶), shape (n, |A|) (line 1, "Random()")."""
        return _kernels.initial_weights(
            self.rng, self.representation.num_features_, self.num_actions
        )

    def policy(
        self, weights: np.ndarray, epsilon: float
    ) -> Callable[[np.ndarray, np.random.Generator], int]:
        """π^ε, ε-greedy in Q = θ̄ᵀφ(s, a) (Eq. 2.27)."""
        return _kernels.epsilon_greedy_chooser(
            self.representation, weights, float(epsilon), self.num_actions
        )

    def follow(
        self, weights: np.ndarray, epsilon: float, num_samples: int, num_next: int = 1
    ) -> dict[str, Any]:
        """L₁ steps of π^ε with L₂ draws s' ~ P(s_i, a_i) each, encoded (`encode_samples`)."""
        batch = _kernels.sample_trajectory(
            self.sampler, self.policy(weights, epsilon), num_samples, self.rng, num_next=num_next
        )
        return _kernels.encode_samples(self.representation, batch)

    def plan(self, weights: np.ndarray, loop: Iterations) -> Plan:
        """The `Plan` of θ̄ (with the greedy π and Q over the model's states when there is one)."""
        return _kernels.linear_plan(self.spec, self.model, self.representation, weights, loop)


def solve_q_weights(
    evaluation: str,
    phi_bar: sp.csr_matrix,
    p_phi: sp.csr_matrix,
    rewards: np.ndarray,
    discount: float,
    regularization: float,
    num_actions: int,
) -> np.ndarray:
    """θ̄ = Ã⁻¹b̃ of Eqs. 2.23-2.24 (LSTD) or 2.25-2.26 (BRM), regularised, as (n, |A|)."""
    system = lstd_system if evaluation == "lstd" else brm_system
    a, b = system(phi_bar, p_phi, rewards, discount)
    theta = solve_regularized(a, b, float(regularization))
    return _kernels.weights_by_action(theta, num_actions)


def weight_change(new: np.ndarray, old: np.ndarray) -> float:
    """Return max |θ̄_{k+1} − θ̄_k|, the "while time left" checkpoint of Algorithms 9 and 13."""
    return float(np.abs(new - old).max(initial=0.0))
