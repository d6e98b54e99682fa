import numpy as np
import pytest
import scipy.sparse as sp

from conjure.core.errors import IncompatibleComponentsError, InvalidParameterError
from conjure.domains import GridWorld, InvertedPendulum
from conjure.models import TabularModel
from conjure.planners import PolicyIteration, ValueIteration
from conjure.testing.planner_checks import check_planner


def random_model(num_states=30, num_actions=3, discount=0.9, seed=0, terminal=True):
    rng = np.random.default_rng(seed)
    matrices = []
    is_terminal = np.zeros(num_states, bool)
    if terminal:
        is_terminal[-1] = True
    for _ in range(num_actions):
        p = rng.random((num_states, num_states)) * (rng.random((num_states, num_states)) < 0.2)
        p[np.arange(num_states), rng.integers(num_states, size=num_states)] += 0.1
        p /= p.sum(axis=1, keepdims=True)
        p[is_terminal] = 0.0
        p[is_terminal, is_terminal] = 1.0
        matrices.append(sp.csr_matrix(p))
    rewards = rng.normal(size=(num_states, num_actions))
    rewards[is_terminal] = 0.0
    start = np.zeros(num_states)
    start[0] = 1.0
    return TabularModel(
        transitions=matrices,
        rewards=rewards,
        is_terminal=is_terminal,
        discount=discount,
        states=np.arange(float(num_states)).reshape(-1, 1),
        start_distribution=start,
    )


def test_planner_checks():
    check_planner(ValueIteration(tolerance=1e-9))


@pytest.mark.parametrize("seed", range(4))
def test_agrees_with_policy_iteration_on_random_mdps(seed):
    model = random_model(seed=seed, discount=0.95)
    vi = ValueIteration(tolerance=1e-10).plan(model)
    pi = PolicyIteration(seed=seed).plan(model)
    assert np.allclose(vi.values, pi.values, atol=1e-7)
    assert np.array_equal(vi.policy[~model.is_terminal], pi.policy[~model.is_terminal])


@pytest.mark.parametrize("make", [GridWorld.gridworld_1, GridWorld.gridworld_2])
def test_agrees_with_policy_iteration_on_gridworld_maps(make):
    model = make().model()
    vi = ValueIteration(tolerance=1e-12).plan(model)
    pi = PolicyIteration().plan(model)
    assert np.allclose(vi.values, pi.values, atol=1e-8)
    q = model.q_values(pi.values)
    live = ~model.is_terminal
    assert np.allclose(q[live, vi.policy[live]], q[live].max(axis=1))


def test_stops_on_max_change_and_records_iterations():
    plan = ValueIteration(tolerance=1e-3).plan(GridWorld().model())
    assert plan.history[-1] < 1e-3 <= plan.history[-2]
    assert plan.iterations == len(plan.history) and plan.wall_time_s > 0


def test_domain_without_model_gets_the_house_message():
    with pytest.raises(IncompatibleComponentsError, match=r"needs `domain.model\(\)`"):
        ValueIteration().plan(InvertedPendulum())


def test_bad_parameters():
    with pytest.raises(InvalidParameterError, match=r"ValueIteration\.tolerance"):
        ValueIteration(tolerance=0.0).plan(GridWorld().model())
