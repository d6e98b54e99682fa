import numpy as np
import pytest

from conjure.core.errors import InvalidParameterError
from conjure.domains import ChainMDP, GridWorld
from conjure.domains.gridworld import open_grid
from conjure.models import ModelSampler, TabularModel
from conjure.testing.planner_checks import three_state_model


def test_backup_and_policy_views():
    model = three_state_model()
    v = np.array([1.0, 2.0, 3.0])
    q = model.q_values(v)
    assert np.allclose(q[:, 0], [0.9 * 2, 0.9 * 3, 1 + 0.9 * 1])
    assert np.allclose(q[:, 1], 0.1 + 0.9 * v)
    assert model.policy_matrix(np.array([0, 1, 0])).toarray().tolist() == [
        [0, 1, 0],
        [0, 1, 0],
        [1, 0, 0],
    ]
    assert model.state_index([2.0]) == 2
    with pytest.raises(InvalidParameterError, match="no state"):
        model.state_index([7.0])


def test_shape_errors_are_clear():
    with pytest.raises(InvalidParameterError, match="rewards must have shape"):
        TabularModel(
            transitions=[np.eye(2)],
            rewards=np.zeros((3, 1)),
            is_terminal=np.zeros(2, bool),
            discount=0.9,
            states=np.zeros((2, 1)),
            start_distribution=np.array([1.0, 0.0]),
        )


@pytest.mark.parametrize(
    "domain",
    [
        GridWorld(),
        GridWorld.gridworld_2(),
        GridWorld(map_name="4x5", noise=0.0),
        GridWorld.from_grid(open_grid(12, 9, blocked_fraction=0.2), noise=0.4),
        ChainMDP(num_states=5, num_actions=2, slip=0.3),
    ],
)
def test_domain_models_are_valid_and_match_sampled_transitions(domain):
    model = domain.model()
    model.check()
    rng = np.random.default_rng(0)
    live = np.flatnonzero(~model.is_terminal)[:6]
    for s in live:
        for a in range(model.num_actions):
            counts = np.zeros(model.num_states)
            rewards = 0.0
            for _ in range(400):
                domain.reset(seed=int(rng.integers(1 << 30)))
                domain.set_state(model.states[s])
                obs, reward, *_ = domain.step(a)
                counts[model.state_index(obs)] += 1
                rewards += reward
            expected = model.transitions[a][s].toarray().ravel()
            assert np.abs(counts / 400 - expected).max() < 0.1
            assert abs(rewards / 400 - model.rewards[s, a]) < 0.15


def test_gridworld_model_terminals_absorb_with_zero_reward():
    model = GridWorld().model()
    terminal = np.flatnonzero(model.is_terminal)
    codes = GridWorld().grid_.reshape(-1)
    assert terminal.size == int(np.isin(codes, (3, 4)).sum())  # goals and pits
    assert np.all(model.rewards[terminal] == 0.0)
    assert model.start_distribution.sum() == 1.0


def test_model_sampler_follows_the_model():
    model = three_state_model()
    sampler = ModelSampler(model)
    rng = np.random.default_rng(0)
    next_state, reward, terminated = sampler.sample(np.array([2.0]), 0, rng)
    assert next_state.tolist() == [0.0] and reward == 1.0 and not terminated
