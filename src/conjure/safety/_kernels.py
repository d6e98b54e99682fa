"""Numba kernel of Algorithm 25's rollouts in a tabular T̂ = (1 − η̂)·P_0 + η̂·P_1."""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def _sample(
    state: int,
    action: int,
    noise: float,
    num_states: int,
    num_actions: int,
    indptr: np.ndarray,
    indices: np.ndarray,
    probabilities: np.ndarray,
    rng: np.random.Generator,
) -> int:
    """S' ~ T̂(s, a): the noise acts with probability η̂ (row of P_1), else a row of P_0."""
    table = 1 if rng.random() < noise else 0
    row = (table * num_states + state) * num_actions + action
    u = rng.random()
    start, stop = indptr[row], indptr[row + 1]
    total = 0.0
    for j in range(start, stop):
        total += probabilities[j]
        if u < total:
            return indices[j]
    return indices[stop - 1]


@njit(cache=True)
def count_failures(
    state: int,
    action: int,
    noise: float,
    num_rollouts: int,
    horizon: int,
    num_actions: int,
    indptr: np.ndarray,
    indices: np.ndarray,
    probabilities: np.ndarray,
    policy: np.ndarray,
    is_constrained: np.ndarray,
    is_terminal: np.ndarray,
    rng: np.random.Generator,
) -> int:
    """How many of M rollouts (first ``action``, then π^p) end in a constrained state.

    The CSR arrays stack P_0 and P_1 state-major: row ((k·|S| + s)·|A| + a) is P_k^a(s, ·).
    Each rollout stops at a constrained or terminal state or after ``horizon`` transitions
    (Algorithm 25, lines 3-7).
    """
    num_states = policy.shape[0]
    failures = 0
    for _ in range(num_rollouts):
        s = _sample(
            state, action, noise, num_states, num_actions, indptr, indices, probabilities, rng
        )
        t = 1
        while not is_constrained[s] and not is_terminal[s] and t < horizon:
            s = _sample(
                s, policy[s], noise, num_states, num_actions, indptr, indices, probabilities, rng
            )
            t += 1
        if is_constrained[s]:
            failures += 1
    return failures
