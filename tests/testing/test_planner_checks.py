import numpy as np
import pytest

from conjure.planners import ValueIteration
from conjure.planners.base import Plan, Planner
from conjure.testing.planner_checks import (
    chain_walk_model,
    chain_walk_optimal_policy,
    check_planner,
    three_state_model,
    three_state_optimal_values,
)


class _Wrong(Planner):
    """A planner returning wrong values (Algorithm 2 with one sweep), to see the checks fail."""

    def __init__(self, *, policy_offset: int = 0):
        self.policy_offset = policy_offset

    def _plan(self, model):
        plan = ValueIteration(max_iterations=1).plan(model)
        if self.policy_offset:
            plan.values = three_state_optimal_values()
            plan.policy = (plan.policy + self.policy_offset) % 2
        return plan


def test_checks_pass_on_value_iteration():
    check_planner(ValueIteration(tolerance=1e-9))


def test_checks_fail_on_wrong_values_and_non_greedy_policies():
    with pytest.raises(AssertionError, match="expected"):
        check_planner(_Wrong())
    with pytest.raises(AssertionError, match="not greedy"):
        check_planner(_Wrong(policy_offset=1))


def test_chain_walk_optimal_policy_is_optimal():
    for n in (4, 20):
        plan = ValueIteration(tolerance=1e-10).plan(chain_walk_model(n))
        assert plan.policy.tolist() == chain_walk_optimal_policy(n).tolist()


def test_three_state_closed_form_is_the_fixed_point():
    model = three_state_model()
    v = three_state_optimal_values()
    assert np.allclose(model.q_values(v).max(axis=1), v)
    assert isinstance(ValueIteration().plan(model), Plan)
