"""A policy as the compiled learning loop reads it (`conjure.core.compiled_form`).

`PolicyKernel` is a policy's kind and parameter; `select_action` draws one uniform and calls
the policy's own kernel (`epsilon_greedy_action`, `gibbs_action`, `greedy_action`), as
`EpsilonGreedy.select` and `Gibbs.select` do; `gibbs_policy` is `Gibbs.probabilities`.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

from conjure.policies._kernels import (
    epsilon_greedy_action,
    gibbs_action,
    gibbs_probabilities_into,
    greedy_action,
)

__all__ = ["EPSILON_GREEDY", "GIBBS", "PolicyKernel", "gibbs_policy", "select_action"]


#: Policy kinds of `PolicyKernel`.
EPSILON_GREEDY, GIBBS = 0, 1


class PolicyKernel(NamedTuple):
    """A policy as the compiled loop reads it: its kind and its one parameter (ε or τ)."""

    kind: int
    parameter: float


@njit(cache=True, inline="always")
def select_action(
    policy: PolicyKernel, values: np.ndarray, legal: np.ndarray, rng: np.random.Generator
) -> int:
    """π(s) from one uniform draw, as `EpsilonGreedy.select` / `Gibbs.select`."""
    u = rng.random()
    if policy.kind == EPSILON_GREEDY:
        return epsilon_greedy_action(values, legal, policy.parameter, u)
    if policy.parameter == 0.0:
        return greedy_action(values, legal)
    return gibbs_action(values, legal, policy.parameter, u)


@njit(cache=True, inline="always")
def gibbs_policy(
    policy: PolicyKernel, values: np.ndarray, legal: np.ndarray, out: np.ndarray
) -> None:
    """π(s, ·) of a `GIBBS` policy with τ > 0 over the legal actions into ``out``.

    `Gibbs.probabilities`' kernel, writing into the loop's buffer.
    """
    gibbs_probabilities_into(values, legal, policy.parameter, out)
