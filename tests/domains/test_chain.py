import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import conjure.domains  # noqa: F401  (registers the Gymnasium ids)
from conjure.core.errors import InvalidParameterError
from conjure.domains import ChainMDP


def value_iteration(domain, sweeps=2000):
    transitions, rewards = domain.tabular_model()
    gamma = domain.discount
    values = np.zeros(domain.num_states)
    for _ in range(sweeps):
        q = rewards + gamma * transitions @ values  # (A, S)
        q[:, -1] = 0.0
        values = q.max(axis=0)
    return values, q.T


@pytest.mark.parametrize(
    "make", [ChainMDP, lambda: ChainMDP(num_actions=2, slip=0.3, num_states=6)]
)
def test_check_env_passes_with_warnings_as_errors(make):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(make(), skip_render_check=True)


def test_gymnasium_make():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        env = gym.make("conjure/ChainMDP-v0")
        obs, _ = env.reset(seed=0)
        assert obs.tolist() == [0.0]
        assert env.step(0)[:3] == (pytest.approx([1.0]), 1.0, False)


def test_exact_values_for_four_states():
    domain = ChainMDP(num_actions=2)
    np.testing.assert_allclose(domain.optimal_values(), [2.71, 1.9, 1.0, 0.0])
    q = domain.optimal_q_values()
    np.testing.assert_allclose(q[:, 0], [2.71, 1.9, 1.0, 0.0])
    np.testing.assert_allclose(q[:, 1], 0.9 * np.array([2.71, 1.9, 1.0, 0.0]))
    np.testing.assert_allclose(ChainMDP().optimal_q_values(), [[2.71], [1.9], [1.0], [0.0]])


@pytest.mark.parametrize(
    "params",
    [
        {},
        {"num_actions": 2, "slip": 0.25},
        {"num_states": 7, "discount": 0.5, "step_reward": 2.0, "slip": 0.6},
        {"num_actions": 2, "step_reward": -1.0},  # staying forever (value 0) is optimal
        {"num_actions": 2, "step_reward": -1.0, "slip": 0.2, "discount": 0.95},
        {"discount": 1.0, "slip": 0.1, "num_states": 5},
    ],
)
def test_closed_form_matches_value_iteration(params):
    domain = ChainMDP(**params)
    values, q = value_iteration(domain)
    np.testing.assert_allclose(domain.optimal_values(), values, atol=1e-9)
    np.testing.assert_allclose(domain.optimal_q_values(), q, atol=1e-9)


def test_model_rows_sum_to_one_and_terminal_absorbs():
    transitions, rewards = ChainMDP(num_actions=2, slip=0.2).tabular_model()
    np.testing.assert_allclose(transitions.sum(axis=2), 1.0)
    assert np.all(transitions[:, -1, -1] == 1.0) and np.all(rewards[:, -1] == 0.0)


def test_dynamics_without_slip():
    domain = ChainMDP(num_actions=2)
    obs, _ = domain.reset(seed=0)
    assert domain.step(1)[:3] == (pytest.approx([0.0]), 0.0, False)
    rewards = []
    for _ in range(3):
        obs, reward, terminated, truncated, _ = domain.step(0)
        rewards.append(reward)
        assert not truncated
    assert obs.tolist() == [3.0] and terminated and rewards == [1.0, 1.0, 1.0]


def test_slip_rate_and_seeding():
    domain = ChainMDP(num_states=1000, slip=0.3, max_episode_steps=10_000)

    def run(seed):
        domain.reset(seed=seed)
        return [domain.step(0)[1] for _ in range(900)]

    first = run(4)
    assert first == run(4)
    assert first != run(5)
    assert 1 - np.mean(first) == pytest.approx(0.3, abs=0.05)


@pytest.mark.parametrize(
    "params",
    [
        {"num_states": 1},
        {"num_actions": 3},
        {"num_actions": 2.0},
        {"slip": 1.0},
        {"discount": -0.1},
        {"max_episode_steps": 0},
    ],
)
def test_bad_parameters(params):
    with pytest.raises(InvalidParameterError):
        ChainMDP(**params)


def test_bad_action():
    domain = ChainMDP()
    domain.reset(seed=0)
    with pytest.raises(InvalidParameterError, match="got 1"):
        domain.step(1)
