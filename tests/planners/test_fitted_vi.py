import numpy as np
import pytest

from conjure.core.errors import InvalidParameterError
from conjure.planners import FittedValueIteration, ValueIteration
from conjure.representations import IndependentDiscretization
from conjure.testing.planner_checks import chain_walk_model, check_planner, three_state_model


def test_planner_checks():
    check_planner(FittedValueIteration())


def test_tabular_features_equal_value_iteration_on_a_deterministic_model():
    # Φ = I: θ(s, a) is the mean target of (s, a) — one exact Bellman backup per iteration.
    model = three_state_model()
    plan = FittedValueIteration(tolerance=1e-9).plan(model)
    exact = ValueIteration(tolerance=1e-12).plan(model)
    assert np.allclose(plan.state_values(), exact.values, atol=1e-6)
    assert np.array_equal(plan.policy, exact.policy)


def test_more_successor_draws_approach_value_iteration():
    model = chain_walk_model(4)
    exact = ValueIteration(tolerance=1e-12).plan(model)
    errors = []
    for num_next in (1, 10):
        plans = [
            FittedValueIteration(
                num_next_samples=num_next, num_samples=150, max_iterations=50, seed=s
            ).plan(model)
            for s in range(2)
        ]
        assert all(np.array_equal(p.policy, exact.policy) for p in plans)
        errors.append(np.mean([np.abs(p.state_values() - exact.values).max() for p in plans]))
    assert errors[1] < 0.5 * errors[0] and errors[1] < 0.15


def test_linear_features_and_history():
    model = chain_walk_model(20)
    spec_rep = IndependentDiscretization(num_buckets=4)
    plan = FittedValueIteration(representation=spec_rep, max_iterations=5).plan(model)
    assert plan.iterations == len(plan.history) == 5 and np.all(np.isfinite(plan.weights))


def test_bad_regularization():
    with pytest.raises(InvalidParameterError, match="regularization"):
        FittedValueIteration(regularization=-1.0).plan(three_state_model())
