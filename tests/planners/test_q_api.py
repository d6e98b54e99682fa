import numpy as np
import pytest

from conjure.domains import GridWorld
from conjure.planners import QAPI, ValueIteration
from conjure.representations import IndependentDiscretization
from conjure.testing.planner_checks import chain_walk_model, check_planner


@pytest.mark.parametrize("evaluation", ["lstd", "brm"])
def test_planner_checks(evaluation):
    check_planner(QAPI(evaluation=evaluation))


@pytest.mark.parametrize("model", [chain_walk_model(20), GridWorld().model()])
def test_tabular_qapi_reaches_the_optimal_values(model):
    plan = QAPI().plan(model)
    assert np.allclose(
        plan.state_values(), ValueIteration(tolerance=1e-10).plan(model).values, atol=1e-5
    )


def test_linear_features_still_give_a_sensible_policy():
    model = GridWorld().model()
    plan = QAPI(representation=IndependentDiscretization()).plan(model)
    assert plan.weights.shape == (17, 4) and plan.iterations >= 1
