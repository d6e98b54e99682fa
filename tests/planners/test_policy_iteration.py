import numpy as np
import pytest

from conjure.core.errors import InvalidParameterError
from conjure.domains import GridWorld
from conjure.planners import PolicyIteration
from conjure.testing.planner_checks import (
    chain_walk_model,
    chain_walk_optimal_policy,
    check_planner,
)


def test_planner_checks():
    check_planner(PolicyIteration())


@pytest.mark.parametrize("n", [4, 20])
def test_chain_walk_optimal_policy(n):
    assert PolicyIteration().plan(chain_walk_model(n)).policy.tolist() == (
        chain_walk_optimal_policy(n).tolist()
    )


def test_iterative_evaluation_matches_direct():
    model = GridWorld(discount=0.95).model()
    direct = PolicyIteration(evaluation="direct").plan(model)
    iterative = PolicyIteration(evaluation="iterative").plan(model)
    assert np.allclose(direct.values, iterative.values, atol=1e-6)


def test_improper_policy_under_gamma_one_is_handled():
    # noise 0 and gamma 1: a random initial policy can walk into a wall forever.
    plan = PolicyIteration(seed=3).plan(GridWorld(map_name="4x5", noise=0.0).model())
    assert np.all(np.isfinite(plan.values)) and plan.start_value() > 0.99


def test_bad_parameters():
    with pytest.raises(InvalidParameterError, match=r"PolicyIteration\.evaluation"):
        PolicyIteration(evaluation="lu").plan(chain_walk_model(4))
