"""Policies: action selection from Q-values or preferences alone (Eqs. 2.27 and 2.32)."""

from conjure.policies._kernels import greedy_action
from conjure.policies.epsilon_greedy import EpsilonGreedy
from conjure.policies.gibbs import Gibbs

__all__ = ["EpsilonGreedy", "Gibbs", "greedy_action"]
