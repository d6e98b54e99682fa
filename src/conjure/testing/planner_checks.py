"""Shipped checks for planners (STYLE §6) and the small MDPs they use.

``check_planner(planner)`` runs every planner check: on a 3-state MDP with a closed-form V*,
the plan's values match V* and its policy is greedy with respect to its own values (Eq. 2.9).
`chain_walk_model` builds Lagoudakis and Parr's (2003) chain walk, the LSPI test problem.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import scipy.sparse as sp

from conjure.core.interfaces import DomainSpec
from conjure.models.tabular_model import TabularModel

__all__ = [
    "PLANNER_CHECKS",
    "chain_walk_model",
    "chain_walk_optimal_policy",
    "check_planner",
    "check_planner_matches_closed_form",
    "check_planner_policy_is_greedy",
    "three_state_model",
    "three_state_optimal_values",
]


def three_state_model(discount: float = 0.9) -> TabularModel:
    """A 3-state, 2-action cycle with a closed-form V* (see `three_state_optimal_values`).

    Action 0 advances 0 → 1 → 2 → 0, earning 1 on leaving state 2 and 0 otherwise; action 1
    stays put and earns 0.1. Deterministic, no terminal state, start in state 0.

    Examples
    --------
    >>> three_state_model().num_states
    3
    """
    advance = sp.csr_matrix(np.array([[0.0, 1, 0], [0, 0, 1], [1, 0, 0]]))
    stay = sp.identity(3, format="csr")
    rewards = np.array([[0.0, 0.1], [0.0, 0.1], [1.0, 0.1]])
    return TabularModel(
        transitions=[advance, stay],
        rewards=rewards,
        is_terminal=np.zeros(3, dtype=bool),
        discount=discount,
        states=np.arange(3.0).reshape(-1, 1),
        start_distribution=np.array([1.0, 0.0, 0.0]),
        name="ThreeStateCycle",
    )


def three_state_optimal_values(discount: float = 0.9) -> np.ndarray:
    """V* of `three_state_model`: V(2) = 1/(1 − γ³), V(1) = γV(2), V(0) = γ²V(2).

    Staying forever earns 0.1/(1 − γ), less than cycling for γ = 0.9, so π* advances.

    Examples
    --------
    >>> three_state_optimal_values().round(3).tolist()
    [2.989, 3.321, 3.69]
    """
    v2 = 1.0 / (1.0 - discount**3)
    cycle = np.array([discount**2 * v2, discount * v2, v2])
    return np.maximum(cycle, 0.1 / (1.0 - discount))


def chain_walk_model(num_states: int = 4, discount: float = 0.9) -> TabularModel:
    """Lagoudakis and Parr's (2003) chain walk: left/right succeed with probability 0.9.

    Actions 0 (left) and 1 (right) move one state in their direction with probability 0.9 and
    in the opposite direction otherwise; the ends bounce back (stay). The reward is +1 in states
    2 and 3 of the 4-state chain and in states 1 and 20 of the 20-state chain (1-based, as in
    the paper), earned in the current state; no terminal state, uniform start.

    Examples
    --------
    >>> chain_walk_model(4).rewards[:, 0].tolist()
    [0.0, 1.0, 1.0, 0.0]
    """
    n = int(num_states)
    rewarded = {4: (1, 2), 20: (0, n - 1)}.get(n, (0, n - 1))
    state_reward = np.zeros(n)
    state_reward[list(rewarded)] = 1.0
    matrices = []
    for direction in (-1, 1):
        p = np.zeros((n, n))
        for s in range(n):
            p[s, min(max(s + direction, 0), n - 1)] += 0.9
            p[s, min(max(s - direction, 0), n - 1)] += 0.1
        matrices.append(sp.csr_matrix(p))
    spec = DomainSpec(
        name=f"ChainWalk{n}",
        low=[0.0],
        high=[n - 1.0],
        is_discrete=[True],
        num_actions=2,
        discount=discount,
        max_episode_steps=100,
    )
    return TabularModel(
        transitions=matrices,
        rewards=np.repeat(state_reward[:, None], 2, axis=1),
        is_terminal=np.zeros(n, dtype=bool),
        discount=discount,
        states=np.arange(float(n)).reshape(-1, 1),
        start_distribution=np.full(n, 1.0 / n),
        name=spec.name,
        spec=spec,
    )


def chain_walk_optimal_policy(num_states: int = 4) -> np.ndarray:
    """The optimal chain-walk policy (0 left, 1 right): RRLL for 4 states, L×10 R×10 for 20.

    Examples
    --------
    >>> chain_walk_optimal_policy(4).tolist()
    [1, 1, 0, 0]
    """
    if num_states == 4:
        return np.array([1, 1, 0, 0])
    half = num_states // 2
    return np.array([0] * half + [1] * (num_states - half))


def _plan(planner: Any) -> tuple[TabularModel, Any]:
    model = three_state_model()
    return model, planner.clone().plan(model)


def check_planner_matches_closed_form(planner: Any) -> None:
    """The plan's V(s) on the 3-state cycle matches the closed form within 1e-3 (STYLE §6)."""
    model, plan = _plan(planner)
    expected = three_state_optimal_values(model.discount)
    values = plan.state_values()
    assert np.allclose(values, expected, atol=1e-3), f"V = {values}, expected {expected}."
    assert plan.iterations >= 1 and plan.wall_time_s >= 0.0, "Iterations and time not recorded."


def check_planner_policy_is_greedy(planner: Any) -> None:
    """The returned policy is greedy with respect to the returned value function (Eq. 2.9)."""
    model, plan = _plan(planner)
    q = model.q_values(plan.state_values())
    chosen = q[np.arange(model.num_states), plan.policy]
    assert np.all(chosen >= q.max(axis=1) - 1e-6), (
        f"Policy {plan.policy.tolist()} is not greedy w.r.t. its values (Q = {q.tolist()})."
    )


PLANNER_CHECKS = (check_planner_matches_closed_form, check_planner_policy_is_greedy)


def check_planner(planner: Any) -> None:
    """Run every planner check, minus the planner's declared ``expected_check_failures``."""
    skipped = getattr(planner, "expected_check_failures", {})
    for check in PLANNER_CHECKS:
        if check.__name__ not in skipped:
            check(planner)
