"""ε-greedy action selection, Geramifard (2012), Eq. 2.27."""

from __future__ import annotations

import numpy as np

from conjure.core.interfaces import Policy
from conjure.core.params import Interval
from conjure.policies._kernels import epsilon_greedy_action
from conjure.policies.compiled_policy import EPSILON_GREEDY, PolicyKernel

__all__ = ["EpsilonGreedy"]


class EpsilonGreedy(Policy):
    """π^ε(s): the greedy action with probability 1 − ε, a uniform action otherwise (Eq. 2.27).

    Parameters
    ----------
    epsilon : float, default 0.1
        Exploration rate ε in [0, 1]; the thesis used 0.1 (Section 4.1.4).

    Notes
    -----
    - Choice: ties between greedy actions are broken uniformly at random (an all-zero initial
      Q would otherwise always pick action 0). The exploratory draw may pick the greedy action.
    - One uniform number is drawn per call, so runs stay reproducible for a seed.

    Examples
    --------
    >>> import numpy as np
    >>> policy = EpsilonGreedy(epsilon=0.0)
    >>> policy.select(np.array([0.0, 2.0, 1.0]), np.random.default_rng(0), np.arange(3))
    1
    >>> policy.probabilities(np.array([0.0, 2.0, 1.0]), np.arange(3)).tolist()
    [0.0, 1.0, 0.0]
    """

    parameter_constraints = {"epsilon": Interval(float, 0, 1)}

    def __init__(self, *, epsilon: float = 0.1):
        self.epsilon = epsilon

    def select(
        self, values: np.ndarray, rng: np.random.Generator, legal_actions: np.ndarray
    ) -> int:
        """One uniform draw; the kernel `select_action` of the compiled loop draws the same."""
        return epsilon_greedy_action(values, legal_actions, self.epsilon, rng.random())

    compiled_methods = ("select",)

    def compiled_form(self) -> PolicyKernel:
        """ε for the compiled loop (`conjure.policies.compiled_policy.select_action`)."""
        return PolicyKernel(kind=EPSILON_GREEDY, parameter=float(self.epsilon))

    def probabilities(self, values: np.ndarray, legal_actions: np.ndarray) -> np.ndarray:
        probs = np.zeros(values.shape[0])
        legal_values = values[legal_actions]
        best = legal_actions[legal_values == legal_values.max()]
        probs[legal_actions] = self.epsilon / legal_actions.shape[0]
        probs[best] += (1.0 - self.epsilon) / best.shape[0]
        return probs
