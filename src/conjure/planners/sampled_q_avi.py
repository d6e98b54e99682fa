"""Sampled Q-based Approximate Value Iteration (Geramifard 2012, Algorithm 8; Wu and Givan 2007)."""

from __future__ import annotations

from typing import Any

import numpy as np

from conjure.core.interfaces import Representation
from conjure.core.params import NEXT_SAMPLES, SAMPLES, InstanceOf, Interval
from conjure.planners import _kernels
from conjure.planners._sampling import Sampling
from conjure.planners.base import Plan, Planner

__all__ = ["SampledQAVI"]


class SampledQAVI(Planner):
    """Q-AVI on samples: L₁ pairs ⟨s_i, a_i⟩ from π^ε, Q⁺ from L₂ draws s' ~ P(s_i, a_i).

    Geramifard (2012), Algorithm 8 (Wu and Givan 2007): each iteration follows π^ε (greedy in
    the current Q, Eq. 2.27) for L₁ steps (line 3); for each sample in order it draws L₂
    successors (line 5), forms Q⁺(s_i, a_i) = (1/L₂) Σ [r + γ max_a' Q(s', a')] (line 6), and
    takes the gradient step θ̄ ← θ̄ + αδφ(s_i, a_i) of Eq. 2.30 (lines 7-8). Needs only a
    generative model (Eq. 2.28): a `TabularModel`, a domain with ``set_state`` or ``model()``.

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
    step_size : float, default 0.5
        α in (0, 1].
    tolerance : float, default 1e-6
        Stop when an iteration's max |δ| < tolerance; in (0, inf).
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
    ε       epsilon           exploration of π^ε (line 3)
    α       step_size         gradient step (line 8)
    ======  ================  ====================================

    - Choice: the L₁ samples form one trajectory of π^ε from the start distribution, continuing
      from the first of the L₂ draws and restarting at termination or after the episode cap;
      π^ε is fixed during the sampling and θ̄ changes sample by sample during the updates, as
      the algorithm is written.
    - Choice: θ₀ ~ U(−10⁻⁶, 10⁻⁶) ("Random()"); "while time left" is a max-|δ| checkpoint
      plus an iteration cap (with stochastic successors δ never vanishes: the cap rules).
    - Choice: with a `TabularModel` the reward of a draw is R(s, a), the expected reward.
    - Choice: a terminal successor contributes max_a' Q = 0.

    Complexity
    ----------
    Θ(k L₁ L₂ |A|) per iteration for k active features (Θ(n L₁ L₂ |A|), Table 2.2).

    Examples
    --------
    >>> from conjure.testing.planner_checks import three_state_model
    >>> plan = SampledQAVI().plan(three_state_model())
    >>> plan.state_values().round(3).tolist(), plan.policy.tolist()
    ([2.989, 3.321, 3.69], [0, 0, 0])
    """

    is_sampled = True
    parameter_constraints = {
        "representation": InstanceOf((Representation, type(None)), "a Representation or None"),
        "num_samples": SAMPLES,
        "num_next_samples": NEXT_SAMPLES,
        "epsilon": Interval(float, 0.0, 1.0),
        "step_size": Interval(float, 0.0, 1.0, closed="right"),
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
        step_size: float = 0.5,
        tolerance: float = 1e-6,
        max_iterations: int = 200,
        seed: int = 0,
    ):
        self.representation = representation
        self.num_samples = num_samples
        self.num_next_samples = num_next_samples
        self.epsilon = epsilon
        self.step_size = step_size
        self.tolerance = tolerance
        self.max_iterations = max_iterations
        self.seed = seed

    def _plan(self, source: Any) -> Plan:
        sampling = Sampling(*self._generative(source), self.representation, self.seed)

        def descend(data: dict[str, Any], weights: np.ndarray) -> tuple[np.ndarray, float]:
            change = _kernels.q_avi_pass(  # lines 4-8, θ̄ updated in place
                weights,
                _kernels.sparse_rows(data["phi"]),
                _kernels.drawn_backups(data),
                sampling.spec.discount,
                float(self.step_size),
            )
            return weights, change

        return sampling.iterate(  # lines 1-3
            descend,
            epsilon=self.epsilon,
            num_samples=self.num_samples,
            num_next=self.num_next_samples,
            tolerance=self.tolerance,
            max_iterations=self.max_iterations,
        )
