"""Fitted Value Iteration (Boyan 1995; Geramifard 2012, Algorithm 9 with Eq. 2.31)."""

from __future__ import annotations

from typing import Any

import numpy as np
import scipy.sparse as sp

from conjure.core.interfaces import Representation
from conjure.core.linalg import solve_regularized
from conjure.core.params import NEXT_SAMPLES, SAMPLES, InstanceOf, Interval
from conjure.planners import _kernels
from conjure.planners._sampling import Sampling, weight_change
from conjure.planners.base import Plan, Planner

__all__ = ["FittedValueIteration"]


class FittedValueIteration(Planner):
    """Sampled Bellman targets Q⁺ projected on span(Φ̄) by least squares, θ̄ = (Φ̃ᵀΦ̃)⁻¹Φ̃ᵀQ⁺.

    Geramifard (2012), Algorithm 9: each iteration follows π^ε for L₁ steps (line 3), forms
    Q⁺(s_i, a_i) = (1/L₂) Σ [r + γ max_a' Q(s', a')] from L₂ draws s' ~ P(s_i, a_i) (lines
    4-6), then solves the regression of Eq. 2.31 (line 7). Needs only a generative model.

    Parameters
    ----------
    representation : Representation or None, default None
        φ(s), copied per action (Eq. 2.11); ``None`` means `Tabular`.
    num_samples : int, default 300
        L₁, samples per iteration, in [1, 10^7].
    num_next_samples : int, default 1
        L₂, successor draws per sample, in [1, 10^4].
    epsilon : float, default 0.1
        ε of the sampling policy π^ε, in [0, 1].
    regularization : float, default 1e-8
        λ ≥ 0 added to the diagonal of Φ̃ᵀΦ̃/L₁ (the inverse does not exist while some
        feature is inactive on every sample).
    tolerance : float, default 1e-6
        Stop when max |θ̄_{k+1} − θ̄_k| < tolerance; in (0, inf).
    max_iterations : int, default 200
        Cap on iterations ("while time left"), in [1, inf).
    seed : int, default 0
        Seed of θ₀ and of all sampling, in [0, inf).

    Notes
    -----
    ======  ================  ====================================
    Symbol  Name              Meaning
    ======  ================  ====================================
    L₁      num_samples       pairs ⟨s_i, a_i⟩ per iteration
    L₂      num_next_samples  draws s' ~ P(s_i, a_i) per pair
    Q⁺      (targets)         sampled Bellman backups, line 6
    λ       regularization    ridge term of the regression
    ======  ================  ====================================

    - Choice: the regression is solved as (Φ̃ᵀΦ̃/L₁ + λI)θ̄ = Φ̃ᵀQ⁺/L₁; a feature no sample
      activates gets θ = 0. With Φ = I, θ(s, a) is the mean of the targets of (s, a): sampled
      value iteration (exact value iteration on a deterministic model).
    - Choice: samples form one trajectory of π^ε (greedy in the current Q) from the start
      distribution, continuing from the first draw and restarting at termination or after
      ``spec.max_episode_steps`` steps.
    - Choice: θ₀ ~ U(−10⁻⁶, 10⁻⁶) ("Random()"); a terminal successor has max_a' Q = 0.

    Complexity
    ----------
    Θ(k L₁ L₂ |A| + k² L₁ + n³|A|³) per iteration (Θ(n L₁ L₂ |A| + n³|A|³), Table 2.2).

    Examples
    --------
    >>> from conjure.testing.planner_checks import three_state_model
    >>> plan = FittedValueIteration().plan(three_state_model())
    >>> plan.state_values().round(3).tolist(), plan.policy.tolist()
    ([2.989, 3.321, 3.69], [0, 0, 0])
    """

    is_sampled = True
    parameter_constraints = {
        "representation": InstanceOf((Representation, type(None)), "a Representation or None"),
        "num_samples": SAMPLES,
        "num_next_samples": NEXT_SAMPLES,
        "epsilon": Interval(float, 0.0, 1.0),
        "regularization": Interval(float, 0.0, None),
        "tolerance": Interval(float, 0.0, None, closed="neither"),
        "max_iterations": Interval(int, 1, None),
        "seed": Interval(int, 0, None),
    }

    def __init__(
        self,
        *,
        representation: Representation | None = None,
        num_samples: int = 300,
        num_next_samples: int = 1,
        epsilon: float = 0.1,
        regularization: float = 1e-8,
        tolerance: float = 1e-6,
        max_iterations: int = 200,
        seed: int = 0,
    ):
        self.representation = representation
        self.num_samples = num_samples
        self.num_next_samples = num_next_samples
        self.epsilon = epsilon
        self.regularization = regularization
        self.tolerance = tolerance
        self.max_iterations = max_iterations
        self.seed = seed

    def _plan(self, source: Any) -> Plan:
        sampling = Sampling(*self._generative(source), self.representation, self.seed)
        num_actions = sampling.num_actions

        def fit(data: dict[str, Any], weights: np.ndarray) -> tuple[np.ndarray, float]:
            targets = _kernels.sampled_backups(data, weights, sampling.spec.discount)  # line 6: Q⁺
            phi_bar = _kernels.action_features(data["phi"], data["actions"], num_actions)
            phi_t = sp.csr_matrix(phi_bar.T)
            gram = (phi_t @ phi_bar) / self.num_samples
            rhs = (phi_t @ targets) / self.num_samples
            theta = solve_regularized(gram, rhs, float(self.regularization))  # line 7, Eq. 2.31
            fitted = _kernels.weights_by_action(theta, num_actions)
            return fitted, weight_change(fitted, weights)

        return sampling.iterate(  # lines 1-5
            fit,
            epsilon=self.epsilon,
            num_samples=self.num_samples,
            num_next=self.num_next_samples,
            tolerance=self.tolerance,
            max_iterations=self.max_iterations,
        )
