"""What the sampled planners share (Algorithms 5, 6, 8, 9, 13): π^ε batches, θ̄ solves, plans.

`Sampling` is the generative side of Algorithms 5, 6, 8, 9 and 13 (Eq. 2.28): the sampler,
the set-up φ and the one RNG all sampling draws from, with θ₀ of line 1, the L₁ samples of
π^ε per iteration and the final `Plan`; `Sampling.iterate` is the "while time left" loop of
Algorithms 6, 8, 9 and 13, each of which supplies only its update of θ̄. The planner hands
`Sampling` its generative model explicitly. `solve_q_weights` is the regularised Ãθ̄ = b̃ of
Eqs. 2.23-2.26 (and 2.35-2.36) that Algorithms 5, 6 and 13 share.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
import scipy.sparse as sp

from conjure.core.interfaces import Representation
from conjure.core.linalg import brm_system, lstd_system, solve_regularized
from conjure.core.seeding import make_rng
from conjure.models.generative import GenerativeModel
from conjure.models.tabular_model import TabularModel
from conjure.planners import _kernels
from conjure.planners.base import Iterations, Plan

#: update(data, θ̄_k) -> (θ̄_{k+1}, change): one iteration's fit of θ̄ to an `encode_samples` batch.
Update = Callable[[dict[str, Any], np.ndarray], tuple[np.ndarray, float]]


class Sampling:
    """The generative model, φ and RNG of one sampled planning run (Eq. 2.28).

    Parameters
    ----------
    sampler : GenerativeModel
        Draws s₀ and s' ~ P(s, a) (Eq. 2.28).
    model : TabularModel or None
        The exact model behind ``sampler`` when there is one: the returned `Plan` then holds π
        and Q over its states.
    representation : Representation or None
        φ(s), cloned and set up here; ``None`` means `Tabular`.
    seed : int
        Seed of the one RNG all sampling draws from (θ₀ first) and of the representation.
    """

    def __init__(
        self,
        sampler: GenerativeModel,
        model: TabularModel | None,
        representation: Representation | None,
        seed: int,
    ):
        self.sampler, self.model = sampler, model
        self.spec = sampler.spec
        self.rng = make_rng(seed)
        self.representation = _kernels.setup_representation(representation, self.spec, seed)

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

    def iterate(
        self,
        update: Update,
        *,
        epsilon: float,
        num_samples: int,
        num_next: int = 1,
        tolerance: float,
        max_iterations: int,
    ) -> Plan:
        """Run the loop Algorithms 6, 8, 9 and 13 share and return the `Plan` of the last θ̄.

        Line 1: θ̄ ← Random(); while time left (line 2): create L₁ samples following π^ε,
        greedy in the current θ̄, each with L₂ draws s' ~ P(s_i, a_i) (line 3 of Algorithms 8,
        9 and 13; lines 4-5 of Algorithm 6); ``update`` turns them into the next θ̄ and a
        change; the loop stops once the change is below ``tolerance`` or after
        ``max_iterations`` iterations (the "while time left" checkpoint).
        """
        weights = self.initial_weights()  # line 1
        loop = Iterations(max_iterations)
        for _ in loop:  # line 2: while time left
            data = self.follow(weights, epsilon, num_samples, num_next)
            weights, change = update(data, weights)
            if loop.record(change) < tolerance:
                break
        return self.plan(weights, loop)

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
