import numpy as np
import pytest

from conjure.core.errors import IncompatibleComponentsError, InvalidParameterError
from conjure.domains import GridWorld, InvertedPendulum
from conjure.planners import SampledQAPI1, SampledQAPI2, ValueIteration
from conjure.testing.planner_checks import chain_walk_model, check_planner, three_state_model


@pytest.mark.parametrize("cls", [SampledQAPI1, SampledQAPI2])
@pytest.mark.parametrize("evaluation", ["lstd", "brm"])
def test_planner_checks(cls, evaluation):
    check_planner(cls(evaluation=evaluation))


def test_api1_with_exact_expectations_is_exact_once_every_pair_is_visited():
    # Eq. 2.21 uses P itself: with Φ = I every visited row of Ã θ̄ = b̃ is an exact Bellman
    # equation, so the answer is policy iteration's as soon as the samples cover the chain.
    model = chain_walk_model(4)
    exact = ValueIteration(tolerance=1e-12).plan(model)
    plan = SampledQAPI1(num_samples=1000).plan(model)
    assert np.allclose(plan.state_values(), exact.values, atol=1e-6)
    assert np.array_equal(plan.policy, exact.policy)


@pytest.mark.parametrize("cls", [SampledQAPI1, SampledQAPI2])
def test_more_samples_approach_value_iteration(cls):
    model = chain_walk_model(4)
    exact = ValueIteration(tolerance=1e-12).plan(model)

    def mean_error(num_samples):
        extra = {} if cls is SampledQAPI1 else {"num_next_samples": num_samples // 50 + 1}
        plans = [cls(num_samples=num_samples, seed=s, **extra).plan(model) for s in range(3)]
        return np.mean([np.abs(p.state_values() - exact.values).max() for p in plans])

    few, many = mean_error(10), mean_error(1000)
    assert many < 0.1 * few and many < 0.05


def test_api2_needs_only_a_generative_model():
    plan = SampledQAPI2(num_samples=200, max_iterations=2).plan(GridWorld())  # set_state
    assert plan.model is None and plan.iterations <= 2
    assert plan.action(np.array([0.0, 0.0])) in range(4)


def test_api1_needs_an_exact_model():
    with pytest.raises(IncompatibleComponentsError, match="tabular model"):
        SampledQAPI1().plan(InvertedPendulum())


def test_bad_evaluation():
    with pytest.raises(InvalidParameterError, match="evaluation"):
        SampledQAPI2(evaluation="td").plan(three_state_model())
