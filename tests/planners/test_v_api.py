import numpy as np
import pytest

from conjure.domains import GridWorld
from conjure.planners import VAPI, ValueIteration
from conjure.testing.planner_checks import chain_walk_model, check_planner, three_state_model


@pytest.mark.parametrize("evaluation", ["lstd", "brm"])
def test_planner_checks(evaluation):
    check_planner(VAPI(evaluation=evaluation))


@pytest.mark.parametrize("evaluation", ["lstd", "brm"])
@pytest.mark.parametrize("weighting", ["uniform", "steady_state"])
def test_identity_features_give_exact_policy_values(evaluation, weighting):
    # Section 2.5: with Φ = I both BRM and LSTD return (I − γP)⁻¹R.
    model = three_state_model()
    plan = VAPI(evaluation=evaluation, weighting=weighting, max_iterations=1, seed=5).plan(model)
    policy = np.random.default_rng(5).integers(2, size=3)
    p = model.policy_matrix(policy).toarray()
    exact = np.linalg.solve(np.eye(3) - 0.9 * p, model.policy_rewards(policy))
    assert np.allclose(plan.values, exact, atol=1e-6)


@pytest.mark.parametrize("model", [chain_walk_model(20), GridWorld().model()])
def test_tabular_vapi_reaches_the_optimal_values(model):
    plan = VAPI().plan(model)
    assert np.allclose(plan.values, ValueIteration(tolerance=1e-10).plan(model).values, atol=1e-5)
