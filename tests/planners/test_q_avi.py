import numpy as np
import pytest

from conjure.core.errors import InvalidParameterError
from conjure.domains import GridWorld
from conjure.planners import QAVI, ValueIteration, _kernels
from conjure.representations import IndependentDiscretization
from conjure.testing.planner_checks import chain_walk_model, check_planner, three_state_model


def test_planner_checks():
    check_planner(QAVI())


@pytest.mark.parametrize(
    "model", [three_state_model(), chain_walk_model(20), GridWorld().model()], ids=str
)
def test_identity_features_give_value_iteration(model):
    # Φ = I (Tabular) and α = 1: each update sets Q(s, a) = Q⁺(s, a), Gauss-Seidel VI.
    plan = QAVI().plan(model)
    exact = ValueIteration(tolerance=1e-12).plan(model)
    assert np.allclose(plan.state_values(), exact.values, atol=1e-6)
    assert np.array_equal(plan.policy, exact.policy)
    assert plan.iterations == len(plan.history) and plan.wall_time_s > 0


def test_smaller_steps_reach_the_same_fixed_point():
    model = three_state_model()
    plan = QAVI(step_size=0.3).plan(model)
    exact = ValueIteration(tolerance=1e-12).plan(model)
    assert np.allclose(plan.state_values(), exact.values, atol=1e-6)
    assert plan.iterations > QAVI().plan(model).iterations


def test_linear_features_run():
    model = GridWorld().model()
    plan = QAVI(representation=IndependentDiscretization(), step_size=0.1, max_iterations=50)
    plan = plan.plan(model)
    assert plan.weights.shape == (17, 4) and np.all(np.isfinite(plan.weights))


def test_one_pass_serves_algorithms_7_and_8():
    # Algorithm 8 is Algorithm 7 on sampled pairs with sampled successors (Section 2.5.3):
    # on a deterministic model, "samples" of every pair in sweep order give the same pass.
    model = GridWorld(noise=0.0).model()
    rep = _kernels.setup_representation(IndependentDiscretization(), model.domain_spec, 0)
    phi = _kernels.state_features(model, rep)
    exact = _kernels.model_backups(model, phi)
    successors = model.state_major_transitions[exact.states * model.num_actions + exact.actions]
    assert np.all(successors.getnnz(axis=1) == 1)  # deterministic
    drawn = {
        "phi": phi[exact.states],
        "phi_next": phi[successors.indices],
        "actions": exact.actions,
        "rewards": exact.rewards.reshape(-1, 1),
    }
    start = _kernels.initial_weights(np.random.default_rng(0), rep.num_features_, 4)
    swept, sampled = start.copy(), start.copy()
    for _ in range(3):
        one = _kernels.q_avi_pass(swept, _kernels.sparse_rows(phi), exact, 0.9, 0.1)
        two = _kernels.q_avi_pass(
            sampled, _kernels.sparse_rows(drawn["phi"]), _kernels.drawn_backups(drawn), 0.9, 0.1
        )
        assert one == two and np.array_equal(swept, sampled)
    assert not np.array_equal(swept, start)


def test_bad_step_size():
    with pytest.raises(InvalidParameterError, match="step_size"):
        QAVI(step_size=1.5).plan(three_state_model())
