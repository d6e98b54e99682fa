import numpy as np
import pytest

from conjure.core.errors import InvalidParameterError
from conjure.domains import GridWorld
from conjure.planners import SampledQAVI, ValueIteration
from conjure.testing.planner_checks import chain_walk_model, check_planner, three_state_model


def test_planner_checks():
    check_planner(SampledQAVI())


def test_deterministic_model_gives_value_iteration():
    model = three_state_model()
    plan = SampledQAVI(step_size=1.0).plan(model)
    assert np.allclose(
        plan.state_values(), ValueIteration(tolerance=1e-12).plan(model).values, atol=1e-5
    )


def test_more_successor_draws_approach_value_iteration():
    # Q⁺ averages L₂ draws s' ~ P (line 6): its noise, and the error, shrink as L₂ grows.
    model = chain_walk_model(4)
    exact = ValueIteration(tolerance=1e-12).plan(model)
    errors = []
    for num_next in (1, 10):
        per_seed = []
        for seed in range(2):
            plan = SampledQAVI(
                num_next_samples=num_next,
                num_samples=300,
                step_size=0.1,
                max_iterations=25,
                seed=seed,
            ).plan(model)
            assert np.array_equal(plan.policy, exact.policy)
            per_seed.append(np.abs(plan.state_values() - exact.values).max())
        errors.append(np.mean(per_seed))
    assert errors[1] < 0.5 * errors[0] and errors[1] < 0.1


def test_same_seed_same_plan_and_domain_source():
    model = GridWorld(noise=0.0).model()
    one = SampledQAVI(num_samples=200, max_iterations=20, step_size=1.0).plan(model)
    two = SampledQAVI(num_samples=200, max_iterations=20, step_size=1.0).plan(model)
    assert np.array_equal(one.weights, two.weights)
    from_domain = SampledQAVI(num_samples=200, max_iterations=20, step_size=1.0).plan(
        GridWorld(noise=0.0)
    )
    assert from_domain.model is None and from_domain.weights.shape == one.weights.shape
    assert from_domain.action(np.array([0.0, 0.0])) in range(4)


def test_bad_parameters():
    with pytest.raises(InvalidParameterError, match="num_next_samples"):
        SampledQAVI(num_next_samples=0).plan(three_state_model())
