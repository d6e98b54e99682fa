"""Numba kernels of the action-selection rules (Eqs. 2.27 and 2.32); one uniform draw each."""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def greedy_action(values: np.ndarray, legal: np.ndarray) -> int:
    """Return the first legal action of highest value (deterministic tie-breaking)."""
    best = legal[0]
    for i in range(1, legal.shape[0]):
        if values[legal[i]] > values[best]:
            best = legal[i]
    return best


@njit(cache=True)
def epsilon_greedy_action(values: np.ndarray, legal: np.ndarray, epsilon: float, u: float) -> int:
    """ε-greedy from one uniform u: explore if u < ε, else greedy with uniform tie-breaking."""
    n = legal.shape[0]
    if u < epsilon:
        return legal[min(int(u / epsilon * n), n - 1)]
    pick = (u - epsilon) / (1.0 - epsilon)
    best = -np.inf
    ties = 0
    for i in range(n):
        v = values[legal[i]]
        if v > best:
            best = v
            ties = 1
        elif v == best:
            ties += 1
    k = min(int(pick * ties), ties - 1)
    for i in range(n):
        if values[legal[i]] == best:
            if k == 0:
                return legal[i]
            k -= 1
    return legal[n - 1]


@njit(cache=True)
def gibbs_probabilities(values: np.ndarray, legal: np.ndarray, temperature: float) -> np.ndarray:
    """Softmax of values / τ over the legal actions (Eq. 2.32), shifted by the max for stability."""
    probs = np.empty(values.shape[0])
    gibbs_probabilities_into(values, legal, temperature, probs)
    return probs


@njit(cache=True)
def gibbs_probabilities_into(
    values: np.ndarray, legal: np.ndarray, temperature: float, probs: np.ndarray
) -> None:
    """`gibbs_probabilities` written into ``probs`` (0 for the illegal actions)."""
    for i in range(probs.shape[0]):
        probs[i] = 0.0
    top = values[legal[0]]
    for i in range(1, legal.shape[0]):
        top = max(top, values[legal[i]])
    total = 0.0
    for i in range(legal.shape[0]):
        p = np.exp((values[legal[i]] - top) / temperature)
        probs[legal[i]] = p
        total += p
    for i in range(legal.shape[0]):
        probs[legal[i]] /= total


@njit(cache=True)
def gibbs_action(values: np.ndarray, legal: np.ndarray, temperature: float, u: float) -> int:
    """Draw from the Gibbs softmax distribution by inverting its CDF at u."""
    probs = gibbs_probabilities(values, legal, temperature)
    cumulative = 0.0
    for i in range(legal.shape[0]):
        cumulative += probs[legal[i]]
        if u < cumulative:
            return legal[i]
    return legal[legal.shape[0] - 1]
