import numpy as np
import pytest

from conjure.core.errors import InvalidParameterError
from conjure.planners import TrajectoryQAPI
from conjure.testing.planner_checks import chain_walk_model, check_planner, three_state_model


def epsilon_greedy_q(model, policy, epsilon):
    """Exact Q^{π^ε}: Q = R̄ + γ P̄_ε Q with P̄_ε((s, a), (s', a')) = P^a_{ss'} π^ε(a'|s')."""
    num_states, num_actions = model.num_states, model.num_actions
    probs = np.full((num_states, num_actions), epsilon / num_actions)
    probs[np.arange(num_states), policy] += 1.0 - epsilon
    chain = np.zeros((num_states * num_actions, num_states * num_actions))
    for a in range(num_actions):
        p = model.transitions[a].toarray()
        for s in range(num_states):
            chain[s * num_actions + a] = (p[s][:, None] * probs).reshape(-1)
    rewards = model.rewards.reshape(-1)
    eye = np.eye(num_states * num_actions)
    return np.linalg.solve(eye - model.discount * chain, rewards).reshape(num_states, -1)


def test_planner_checks():
    check_planner(TrajectoryQAPI())  # the closed-form check is a declared exception


@pytest.mark.parametrize(
    "model", [three_state_model(), chain_walk_model(4)], ids=["three_state", "chain_walk"]
)
def test_approaches_the_epsilon_greedy_q_as_samples_grow(model):
    errors = []
    for num_samples in (100, 5000):
        plan = TrajectoryQAPI(num_samples=num_samples, max_iterations=5).plan(model)
        exact = epsilon_greedy_q(model, plan.policy, 0.1)
        errors.append(np.abs(plan.q_values - exact).max())
    assert errors[1] < 0.15 and errors[1] < 0.5 * errors[0]


def test_finds_the_optimal_policy():
    model = chain_walk_model(4)
    plan = TrajectoryQAPI(num_samples=2000, max_iterations=5).plan(model)
    assert plan.policy.tolist() == [1, 1, 0, 0] and plan.iterations == len(plan.history)


def test_bad_tolerance():
    with pytest.raises(InvalidParameterError, match="tolerance"):
        TrajectoryQAPI(tolerance=0.0).plan(three_state_model())
