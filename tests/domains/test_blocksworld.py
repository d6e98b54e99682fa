import pickle
import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import conjure.domains  # noqa: F401  (registers the Gymnasium ids)
from conjure.core.errors import InvalidParameterError
from conjure.domains import BlocksWorld
from conjure.domains.blocksworld import blocks_world_state_action_count
from conjure.domains.compiled_domain import reset_into, step_into
from conjure.testing.checks import check_pickle_round_trip, check_seeded_rollout


def move(n, block, target=None):
    """Action index of move(block, target); target None means the table."""
    return block * n + (block if target is None else target)


def on_vector(n, supports):
    """On vector from supports[i] = block under i (i itself = table)."""
    state = np.zeros(n * n)
    for i, j in enumerate(supports):
        state[i * n + j] = 1.0
    return state


@pytest.mark.parametrize("make", [BlocksWorld, lambda: BlocksWorld(num_blocks=3)])
def test_check_env_passes_with_warnings_as_errors(make):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(make(), skip_render_check=True)


def test_gymnasium_make_and_spec():
    env = gym.make("conjure/BlocksWorld-v0")
    obs, _ = env.reset(seed=0)
    assert env.observation_space.contains(obs)
    spec = env.unwrapped.domain_spec
    assert (spec.num_dims, spec.num_actions, spec.discount, spec.max_episode_steps) == (
        36,
        36,
        1.0,
        1000,
    )
    assert spec.has_action_constraints and spec.is_discrete.all()
    assert env.spec.max_episode_steps == 1000


def test_seeded_rollouts_are_equal_and_pickle_continues():
    check_seeded_rollout(BlocksWorld())
    check_pickle_round_trip(BlocksWorld())
    domain = BlocksWorld()
    domain.reset(seed=3)
    twin = pickle.loads(pickle.dumps(domain))
    for _ in range(50):
        legal = domain.legal_actions(domain._current_observation())
        a = int(legal[len(legal) // 2])
        first, second = domain.step(a), twin.step(a)
        assert np.array_equal(first[0], second[0]) and first[1:3] == second[1:3]
        if first[2]:
            break


def test_start_state_and_move_onto_block_without_drop():
    domain = BlocksWorld(drop_probability=0.0)
    obs, _ = domain.reset(seed=0)
    np.testing.assert_array_equal(obs, on_vector(6, range(6)))
    obs, reward, terminated, truncated, info = domain.step(move(6, 1, 0))
    np.testing.assert_array_equal(obs, on_vector(6, [0, 0, 2, 3, 4, 5]))
    assert (reward, terminated, truncated, list(info)) == (-0.001, False, False, ["action_mask"])
    # Block 0 is covered now: every move of another block onto 0 and move(0, ·) are illegal.
    legal = domain.legal_actions(obs)
    assert info["action_mask"].dtype == bool and np.flatnonzero(info["action_mask"]).tolist() == (
        legal.tolist()
    )
    assert move(6, 2, 0) not in legal and move(6, 0, 2) not in legal and move(6, 2, 1) in legal


def test_tower_completing_move_earns_one_and_terminates():
    domain = BlocksWorld(drop_probability=0.0)
    domain.reset(seed=0)
    rewards = []
    for block in range(1, 6):
        obs, reward, terminated, _, _ = domain.step(move(6, block, block - 1))
        rewards.append((reward, terminated))
    assert rewards == [(-0.001, False)] * 4 + [(1.0, True)]
    np.testing.assert_array_equal(obs, on_vector(6, [0, 0, 1, 2, 3, 4]))


def test_legal_actions_of_a_hand_built_state():
    # 3 blocks: 1 on 0, 2 on the table.
    state = on_vector(3, [0, 0, 2])
    legal = BlocksWorld(num_blocks=3).legal_actions(state)
    # move(1, table)=4, move(1, 2)=5, move(2, 1)=7; block 0 is covered, 2 is on the table.
    assert legal.tolist() == [4, 5, 7] and legal.dtype == np.int64
    # All on the table: every block-onto-block move, no move to the table.
    start = BlocksWorld().legal_actions(on_vector(6, range(6)))
    assert start.size == 30 and not any(a // 6 == a % 6 for a in start.tolist())


def test_illegal_move_raises_naming_the_legal_ones():
    domain = BlocksWorld(num_blocks=3, drop_probability=0.0)
    domain.reset(seed=0)
    with pytest.raises(InvalidParameterError, match=r"move\(0, table\).*legal actions: \[1, 2"):
        domain.step(move(3, 0))
    domain.step(move(3, 1, 0))
    with pytest.raises(InvalidParameterError, match=r"action 6 \(move\(2, 0\)\).*\[4, 5, 7\]"):
        domain.step(move(3, 2, 0))
    with pytest.raises(InvalidParameterError, match="action must be an int"):
        domain.step(9)


def test_random_rollouts_legal_actions_match_step():
    domain = BlocksWorld()
    obs, _ = domain.reset(seed=1)
    rng = np.random.default_rng(1)
    for _ in range(2000):
        legal = domain.legal_actions(obs)
        illegal = np.setdiff1d(np.arange(36), legal)
        assert obs.sum() == 6 and domain.observation_space.contains(obs)
        if illegal.size:
            with pytest.raises(InvalidParameterError):
                domain.step(int(rng.choice(illegal)))
        new_obs, _, terminated, _, _ = domain.step(int(rng.choice(legal)))
        assert new_obs is not obs and not np.shares_memory(new_obs, obs)
        obs = domain.reset()[0] if terminated else new_obs


def test_malformed_states_are_rejected():
    domain = BlocksWorld(num_blocks=3)
    with pytest.raises(InvalidParameterError, match="exactly one support"):
        domain.legal_actions(np.zeros(9))
    with pytest.raises(InvalidParameterError, match="two blocks on the same block"):
        domain.legal_actions(on_vector(3, [0, 0, 0]))
    with pytest.raises(InvalidParameterError, match="cycle"):
        domain.legal_actions(on_vector(3, [1, 0, 2]))
    with pytest.raises(InvalidParameterError, match=r"shape \(9,\)"):
        domain.legal_actions(np.zeros(36))


def test_drop_probability_is_about_thirty_percent():
    domain = BlocksWorld()
    domain.reset(seed=0)
    drops = 0
    for _ in range(5000):
        obs, _ = domain.reset()
        obs, *_ = domain.step(move(6, 1, 0))
        drops += obs[6 + 1] == 1.0  # block 1 landed on the table
    assert abs(drops / 5000 - 0.3) < 0.025
    domain = BlocksWorld(drop_probability=1.0)
    domain.reset(seed=0)
    assert domain.step(move(6, 1, 0))[0][7] == 1.0


def test_state_action_count_matches_the_thesis():
    assert BlocksWorld().state_action_count() == 368_316
    assert blocks_world_state_action_count(6) == 36 * 10_231
    assert BlocksWorld(num_blocks=3).state_action_count() == 9 * 13


@pytest.mark.parametrize(
    "params", [{"num_blocks": 1}, {"drop_probability": 1.5}, {"step_reward": float("inf")}]
)
def test_bad_parameters_raise(params):
    with pytest.raises(InvalidParameterError, match=next(iter(params))):
        BlocksWorld(**params)


def test_step_replays_the_compiled_kernel():
    # One implementation of the move: `BlocksWorld.step` and the compiled loop's `step_into`
    # follow the same trajectory from the same seed (one uniform per move). The loop steps
    # the twin's own state and mask (its compiled form holds them): nothing is copied back.
    domain, twin = BlocksWorld(), BlocksWorld()
    observation, _ = domain.reset(seed=3)
    form, obs, rng = twin.compiled_form(), np.empty(36), np.random.default_rng(3)
    assert reset_into(form, obs, rng)
    choices = np.random.default_rng(9)
    np.testing.assert_array_equal(obs, observation)
    for _ in range(300):
        action = int(choices.choice(domain.legal_actions(observation)))
        observation, reward, terminated, _, _ = domain.step(action)
        assert step_into(form, action, obs, rng) == (reward, terminated, 0.0)
        np.testing.assert_array_equal(obs, observation)
        np.testing.assert_array_equal(twin.action_masks(), domain.action_masks())
        np.testing.assert_array_equal(twin._current_observation(), observation)
        if terminated:
            break
    assert rng.bit_generator.state == domain.np_random.bit_generator.state
