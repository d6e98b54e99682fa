"""Gibbs softmax action selection with a temperature, Geramifard (2012), Eq. 2.32."""

from __future__ import annotations

import numpy as np

from conjure.core.interfaces import Policy
from conjure.core.params import Interval
from conjure.policies._kernels import gibbs_action, gibbs_probabilities, greedy_action
from conjure.policies.compiled_policy import GIBBS, PolicyKernel

__all__ = ["Gibbs"]


class Gibbs(Policy):
    """π(s, a) = exp(ρ(s, a)/τ) / Σ_b exp(ρ(s, b)/τ), Eq. 2.32 (the actor of Algorithm 12).

    Parameters
    ----------
    temperature : float, default 1.0
        τ in [0, inf); τ → ∞ is uniform, τ = 0 is greedy. The thesis used τ = 1 (Section 5.3.5).

    Notes
    -----
    - Choice: τ = 0 selects the first highest-valued action (the limit of Eq. 2.32 up to ties).
    - The values are shifted by their maximum before exponentiating, which leaves Eq. 2.32
      unchanged and avoids overflow.

    Examples
    --------
    >>> import numpy as np
    >>> Gibbs(temperature=1.0).probabilities(np.array([0.0, np.log(3.0)]), np.arange(2)).round(3)
    array([0.25, 0.75])
    """

    parameter_constraints = {"temperature": Interval(float, 0, None)}

    def __init__(self, *, temperature: float = 1.0):
        self.temperature = temperature

    def select(
        self, values: np.ndarray, rng: np.random.Generator, legal_actions: np.ndarray
    ) -> int:
        u = rng.random()
        if self.temperature == 0:
            return greedy_action(values, legal_actions)
        return gibbs_action(values, legal_actions, self.temperature, u)

    compiled_methods = ("select",)

    def compiled_form(self) -> PolicyKernel:
        """τ for the compiled loop (`conjure.policies.compiled_policy.select_action`)."""
        return PolicyKernel(kind=GIBBS, parameter=float(self.temperature))

    def probabilities(self, values: np.ndarray, legal_actions: np.ndarray) -> np.ndarray:
        if self.temperature == 0:
            probs = np.zeros(values.shape[0])
            probs[greedy_action(values, legal_actions)] = 1.0
            return probs
        return gibbs_probabilities(values.astype(np.float64), legal_actions, self.temperature)
