import itertools
import math
import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env
from scipy.integrate import solve_ivp

import conjure.domains  # noqa: F401  (registers the Gymnasium ids)
from conjure.core.errors import InvalidParameterError
from conjure.domains import InvertedPendulum
from conjure.domains._kernels import pendulum_rk4, pendulum_step


def reference_acceleration(theta, theta_dot, force):
    """θ̈ of Geramifard (2012) / Lagoudakis and Parr (2003), written independently."""
    g, m, big_m, length = 9.8, 2.0, 8.0, 0.5
    alpha = 1.0 / (m + big_m)
    numerator = (
        g * np.sin(theta)
        - alpha * m * length * theta_dot**2 * np.sin(2 * theta) / 2
        - alpha * np.cos(theta) * force
    )
    return numerator / (4 * length / 3 - alpha * m * length * np.cos(theta) ** 2)


def rollout(domain, seed, actions):
    obs, _ = domain.reset(seed=seed)
    observations, rewards = [obs], []
    for action in actions:
        obs, reward, terminated, _, _ = domain.step(action)
        observations.append(obs)
        rewards.append(reward)
        if terminated:
            break
    return np.array(observations), np.array(rewards)


def test_check_env_passes_with_warnings_as_errors():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(InvertedPendulum(), skip_render_check=True)
        check_env(InvertedPendulum(start_noise=0.2), skip_render_check=True)


def test_gymnasium_make():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        env = gym.make("conjure/InvertedPendulum-v0")
        obs, _ = env.reset(seed=0)
        assert env.observation_space.contains(obs)
        assert len(env.step(0)) == 5
        assert env.spec.max_episode_steps == 3000
        assert env.unwrapped.force_noise == 10.0


def test_spec():
    spec = InvertedPendulum().domain_spec
    assert spec.max_episode_steps == 3000
    assert spec.discount == 0.95
    assert spec.num_actions == 3
    np.testing.assert_allclose(spec.low, [-math.pi / 2, -2.0])
    np.testing.assert_allclose(spec.high, [math.pi / 2, 2.0])
    assert not spec.is_discrete.any()


def test_starts_upright_at_rest_unless_start_noise():
    obs, info = InvertedPendulum().reset(seed=0)
    np.testing.assert_array_equal(obs, [0.0, 0.0])
    assert obs.dtype == np.float64 and info == {}
    domain = InvertedPendulum(start_noise=0.2)
    starts = np.array([domain.reset(seed=s)[0] for s in range(200)])
    assert np.all(np.abs(starts) <= 0.2)
    assert np.abs(starts).max() > 0.15  # actually spread over the interval


def test_same_seed_same_rollout_different_seed_differs():
    actions = [0, 1, 2, 2, 1, 0] * 20
    obs_a, rew_a = rollout(InvertedPendulum(), 7, actions)
    obs_b, rew_b = rollout(InvertedPendulum(), 7, actions)
    np.testing.assert_array_equal(obs_a, obs_b)
    np.testing.assert_array_equal(rew_a, rew_b)
    obs_c, _ = rollout(InvertedPendulum(), 8, actions)
    n = min(len(obs_a), len(obs_c))
    assert not np.array_equal(obs_a[:n], obs_c[:n])


def test_without_force_a_tilted_pendulum_falls_over():
    domain = InvertedPendulum(force_noise=0.0)
    for tilt in (0.05, -0.05):
        domain.reset(seed=3)
        domain._fstate[:] = (tilt, 0.0)  # slightly tilted, at rest
        angles = [abs(tilt)]
        for _ in range(100):
            obs, _, terminated, _, _ = domain.step(1)  # 0 N
            angles.append(abs(obs[0]))
            if terminated:
                break
        assert terminated
        assert all(b > a for a, b in itertools.pairwise(angles))
        assert np.sign(obs[0]) == np.sign(tilt)


def test_reward_and_termination_exactly_at_half_pi():
    domain = InvertedPendulum(force_noise=0.0)
    for push in (0, 2):
        domain.reset(seed=0)
        for _ in range(3000):
            obs, reward, terminated, truncated, _ = domain.step(push)
            assert not truncated
            assert domain.observation_space.contains(obs)
            true_theta = domain._fstate[0]
            if abs(true_theta) >= math.pi / 2:
                assert terminated and reward == -1.0
                assert abs(obs[0]) == pytest.approx(math.pi / 2)
                break
            assert not terminated and reward == 0.0
        else:
            pytest.fail("pushing one way for 3000 steps never dropped the pendulum")


def test_angular_rate_stays_clipped():
    domain = InvertedPendulum()
    domain.reset(seed=1)
    rates = []
    for t in range(2000):
        obs, _, terminated, _, _ = domain.step(2 if t % 10 < 5 else 0)
        rates.append(obs[1])
        if terminated:
            domain.reset()
    rates = np.array(rates)
    assert np.all(np.abs(rates) <= 2.0)
    assert np.abs(rates).max() == 2.0  # the clip is actually reached


def test_fresh_observation_arrays():
    domain = InvertedPendulum()
    first, _ = domain.reset(seed=0)
    second = domain.step(1)[0]
    third = domain.step(1)[0]
    assert first is not second and second is not third
    assert not np.shares_memory(second, third)


@pytest.mark.parametrize(
    "state, force",
    [((0.1, 0.0), 0.0), ((0.3, -1.0), 50.0), ((-0.5, 1.5), -50.0), ((1.0, 0.5), 7.0)],
)
def test_rk4_step_matches_solve_ivp(state, force):
    def derivatives(_t, y):
        return [y[1], reference_acceleration(y[0], y[1], force)]

    exact = solve_ivp(derivatives, (0.0, 0.1), list(state), rtol=1e-11, atol=1e-12).y[:, -1]
    np.testing.assert_allclose(pendulum_rk4(state[0], state[1], force, 0.1), exact, atol=5e-4)


def test_domain_step_uses_rk4_with_nominal_force():
    domain = InvertedPendulum(force_noise=0.0)
    domain.reset(seed=0)
    obs = domain.step(2)[0]  # +50 N from (0, 0)
    expected = solve_ivp(
        lambda _t, y: [y[1], reference_acceleration(y[0], y[1], 50.0)],
        (0.0, 0.1),
        [0.0, 0.0],
        rtol=1e-11,
        atol=1e-12,
    ).y[:, -1]
    np.testing.assert_allclose(obs, expected, atol=5e-4)
    assert obs[0] < 0  # pushing the cart right tips the pole left


def test_force_noise_is_uniform_within_ten_newtons():
    domain = InvertedPendulum(force_noise=10.0)
    rates = []
    for seed in range(200):
        domain.reset(seed=seed)
        rates.append(domain.step(1)[0][1])  # 0 N nominal: the spread is the noise alone
    rates = np.array(rates)
    _, limit = pendulum_step(0.0, 0.0, -10.0)  # θ̇ after a constant -10 N push
    assert limit > 0
    assert np.all(np.abs(rates) <= limit)
    assert np.abs(rates).max() > 0.9 * limit  # noise reaches close to ±10 N
    assert (rates > 0).mean() == pytest.approx(0.5, abs=0.12)


@pytest.mark.parametrize(
    "params",
    [{"force_noise": -1.0}, {"start_noise": 2.0}, {"force_noise": "x"}, {"start_noise": -0.1}],
)
def test_bad_parameters(params):
    with pytest.raises(InvalidParameterError):
        InvertedPendulum(**params)


def test_bad_action_names_the_value():
    domain = InvertedPendulum()
    domain.reset(seed=0)
    for action in (3, -1, 1.5, "a"):
        with pytest.raises(InvalidParameterError, match=repr(action).replace(".", r"\.")):
            domain.step(action)


def test_clone_and_set_params_rebuild():
    domain = InvertedPendulum(force_noise=2.0)
    clone = domain.clone()
    assert clone == domain and clone is not domain
    domain.set_params(force_noise=0.0)
    domain.reset(seed=0)
    np.testing.assert_array_equal(domain.step(1)[0], [0.0, 0.0])
    with pytest.raises(InvalidParameterError):
        domain.set_params(force_noise=-3.0)


def test_the_fall_is_marked_as_cost_and_constrained():
    domain = InvertedPendulum(force_noise=0.0)
    domain.reset(seed=0)
    costs = []
    for _ in range(3000):
        obs, _, terminated, _, info = domain.step(2)  # push one way until it falls
        costs.append(info["cost"])
        assert domain.is_constrained(obs) == terminated
        if terminated:
            break
    assert costs[-1] == 1.0 and set(costs[:-1]) == {0.0}
    assert not domain.is_constrained(np.array([math.pi / 2 - 1e-9, 0.0]))
    with pytest.raises(InvalidParameterError, match="shape"):
        domain.is_constrained(np.zeros(3))
