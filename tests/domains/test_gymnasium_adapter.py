import pickle
import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

from conjure.core.errors import IncompatibleComponentsError, InvalidParameterError
from conjure.domains import GymnasiumDomain, from_gymnasium
from cost_corridor import CORRIDOR_ID
from cost_corridor import register as register_corridor

CLASSIC = ["CartPole-v1", "MountainCar-v0", "Acrobot-v1"]


@pytest.mark.parametrize("env_id", [*CLASSIC, "FrozenLake-v1"])
def test_check_env_passes_with_warnings_as_errors(env_id):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(from_gymnasium(env_id), skip_render_check=True)


@pytest.mark.parametrize("env_id", CLASSIC)
def test_wraps_and_steps(env_id):
    domain = from_gymnasium(env_id)
    reference = gym.make(env_id)
    spec = domain.domain_spec
    assert spec.num_actions == reference.action_space.n
    assert spec.max_episode_steps == reference.spec.max_episode_steps
    assert spec.discount == 0.99
    assert np.all(np.isfinite(spec.low)) and np.all(np.isfinite(spec.high))
    obs, _ = domain.reset(seed=0)
    for t in range(300):
        obs, reward, terminated, truncated, info = domain.step(t % spec.num_actions)
        assert obs.dtype == np.float64 and domain.observation_space.contains(obs)
        assert isinstance(reward, float) and isinstance(info, dict)
        assert truncated is False
        if terminated:
            obs, _ = domain.reset()


@pytest.mark.parametrize("env_id", CLASSIC)
def test_seed_passes_through_to_the_wrapped_env(env_id):
    domain = from_gymnasium(env_id)
    reference = gym.make(env_id).unwrapped
    obs, _ = domain.reset(seed=11)
    ref_obs, _ = reference.reset(seed=11)
    np.testing.assert_allclose(obs, np.clip(ref_obs, domain._low, domain._high))
    for action in [0, 1, 1, 0, 1]:
        obs = domain.step(action)[0]
        ref_obs = reference.step(action)[0]
        np.testing.assert_allclose(obs, np.clip(ref_obs, domain._low, domain._high))
    a, _ = domain.reset(seed=11)
    b, _ = domain.reset(seed=12)
    assert not np.array_equal(a, b)


def test_cartpole_default_velocity_bounds_and_clipping():
    domain = from_gymnasium("CartPole-v1")
    np.testing.assert_allclose(domain.domain_spec.low[[1, 3]], [-3.0, -3.5])
    np.testing.assert_allclose(domain.domain_spec.high[[1, 3]], [3.0, 3.5])
    tight = from_gymnasium("CartPole-v1", bounds=[None, (-0.01, 0.01), None, (-0.01, 0.01)])
    tight.reset(seed=0)
    for _ in range(5):
        obs = tight.step(1)[0]
    assert obs[1] == 0.01  # clipped into the declared bounds


def test_infinite_bounds_without_defaults_name_the_dimensions():
    gym.register(id="ConjureTestInfinite-v0", entry_point=_InfiniteBox, max_episode_steps=10)
    try:
        with pytest.raises(InvalidParameterError, match=r"dimension\(s\) \[1\].*bounds="):
            from_gymnasium("ConjureTestInfinite-v0")
        domain = from_gymnasium("ConjureTestInfinite-v0", bounds=[None, (-5.0, 5.0)])
        assert domain.domain_spec.high.tolist() == [1.0, 5.0]
    finally:
        del gym.registry["ConjureTestInfinite-v0"]


class _InfiniteBox(gym.Env):
    def __init__(self):
        self.observation_space = gym.spaces.Box(
            np.array([-1.0, -np.inf]), np.array([1.0, np.inf]), dtype=np.float64
        )
        self.action_space = gym.spaces.Discrete(2)

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        return np.zeros(2), {}

    def step(self, action):
        return np.zeros(2), 0.0, False, False, {}


def test_continuous_actions_are_incompatible():
    with pytest.raises(IncompatibleComponentsError, match="Discrete action space"):
        from_gymnasium("Pendulum-v1")


def test_bad_action_names_the_value():
    domain = from_gymnasium("CartPole-v1")
    domain.reset(seed=0)
    with pytest.raises(InvalidParameterError, match="got 7"):
        domain.step(7)


@pytest.mark.parametrize(
    "params",
    [
        {"env_id": "CartPole-v9"},
        {"env_id": "CartPole-v1", "discount": 1.5},
        {"env_id": "CartPole-v1", "max_episode_steps": 0},
        {"env_id": "CartPole-v1", "bounds": [(0.0, 1.0)]},
        {"env_id": "CartPole-v1", "bounds": [None, (1.0, 0.0), None, None]},
        {"env_id": "CartPole-v1", "env_kwargs": "x"},
        {"env_id": 3},
    ],
)
def test_bad_parameters(params):
    with pytest.raises(InvalidParameterError):
        GymnasiumDomain(**params)


def test_unknown_id_suggests_a_fix():
    with pytest.raises(InvalidParameterError, match="Did you mean 'CartPole-v1'"):
        from_gymnasium("CartPole-v9")


def test_instance_is_reused_and_cloneable():
    env = gym.make("MountainCar-v0")
    domain = from_gymnasium(env, discount=0.9, max_episode_steps=50)
    assert domain.env_ is env.unwrapped
    assert domain.domain_spec.max_episode_steps == 50
    clone = domain.clone()
    assert clone == domain and clone.env_ is not domain.env_
    capped = from_gymnasium(gym.make("CartPole-v1", max_episode_steps=77))
    assert capped.domain_spec.max_episode_steps == 77 == capped.max_episode_steps
    with pytest.raises(InvalidParameterError, match=r"gymnasium\.make"):
        from_gymnasium(_InfiniteBox())


def test_pickle_round_trip_continues_identically():
    domain = from_gymnasium("CartPole-v1")
    domain.reset(seed=2)
    copy = pickle.loads(pickle.dumps(domain))
    for action in [0, 1, 0, 0]:
        np.testing.assert_array_equal(domain.step(action)[0], copy.step(action)[0])


@pytest.fixture
def hazard_corridor():
    yield register_corridor()
    del gym.registry[CORRIDOR_ID]


def test_six_value_step_puts_the_cost_in_info(hazard_corridor):
    domain = from_gymnasium(hazard_corridor)
    domain.reset(seed=0)
    costs = [domain.step(action)[4]["cost"] for action in (1, 0, 0, 0)]  # 1 -> 2 -> 1 -> 0 -> 0
    assert costs == [0.0, 0.0, 1.0, 1.0]
    obs, reward, terminated, truncated, info = domain.step(1)
    assert (obs.tolist(), reward, terminated, truncated, info) == ([1.0], 0.0, False, False,
                                                                   {"cost": 0.0})  # fmt: skip


@pytest.mark.parametrize("bad", [-1.0, float("nan"), "high"])
def test_a_bad_cost_names_the_value(hazard_corridor, bad):
    domain = from_gymnasium(gym.make(hazard_corridor, cost_value=bad))
    domain.reset(seed=0)
    with pytest.raises(IncompatibleComponentsError, match=rf"step cost {bad!r}.*≥ 0"):
        domain.step(0)


def test_a_run_counts_the_costs_the_environment_reported(hazard_corridor):
    from conjure.agents import SARSA
    from conjure.experiments import run
    from conjure.representations import Tabular

    domain = from_gymnasium(hazard_corridor)
    agent = SARSA(representation=Tabular())
    result = run(domain=domain, agent=agent, budget_steps=300, seed=3, num_policy_checks=1)
    failures = int(result.curve["learning_failures"].iloc[-1])
    assert failures == domain.env_.costs_reported > 0
