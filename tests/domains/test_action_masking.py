"""Legal-action masks and the illegal-action modes of the constrained domains."""

import itertools
import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import conjure  # noqa: F401  (registers the Gymnasium ids)
from conjure.core.errors import InvalidParameterError
from conjure.domains import (
    BlocksWorld,
    GridWorld,
    PersistentSurveillance,
    RescueMission,
    UAVMission,
)
from conjure.domains.compiled_domain import step_into
from conjure.testing.checks import check_action_masks

CONSTRAINED = [BlocksWorld, PersistentSurveillance, RescueMission, UAVMission]


def mask_of(domain, observation):
    mask = np.zeros(domain.domain_spec.num_actions, dtype=bool)
    mask[domain.legal_actions(observation)] = True
    return mask


def first_illegal(domain, observation):
    return int(np.flatnonzero(~mask_of(domain, observation))[0])


@pytest.mark.parametrize("cls", CONSTRAINED)
def test_masks_on_reset_and_step_match_legal_actions(cls):
    domain = cls()
    observation, info = domain.reset(seed=0)
    rng = np.random.default_rng(0)
    num_constrained = 0  # states where some action is illegal: the masks tell something
    for _ in range(30):
        expected = mask_of(domain, observation)
        num_constrained += int(expected.sum() < expected.size)
        assert info["action_mask"].dtype == bool
        np.testing.assert_array_equal(info["action_mask"], expected)
        np.testing.assert_array_equal(domain.action_masks(), expected)
        action = int(rng.choice(np.flatnonzero(expected)))
        observation, _, terminated, _, info = domain.step(action)
        if terminated:
            observation, info = domain.reset()
    assert num_constrained > 0
    check_action_masks(domain)


def test_blocks_world_mask_by_hand():
    domain = BlocksWorld(num_blocks=3, drop_probability=0.0)
    _, info = domain.reset(seed=0)
    # All on the table: every block onto another block (1, 2, 3, 5, 6, 7), none to the table.
    assert np.flatnonzero(info["action_mask"]).tolist() == [1, 2, 3, 5, 6, 7]
    _, _, _, _, info = domain.step(1 * 3 + 0)  # block 1 onto 0
    # Clear: 1 and 2. move(1, table)=4, move(1, 2)=5, move(2, 1)=7.
    assert np.flatnonzero(info["action_mask"]).tolist() == [4, 5, 7]


@pytest.mark.parametrize("cls", CONSTRAINED)
def test_raise_names_the_action_and_the_legal_ones(cls):
    domain = cls()
    observation, _ = domain.reset(seed=0)
    action = first_illegal(domain, observation)
    legal = domain.legal_actions(observation).tolist()
    with pytest.raises(InvalidParameterError, match=rf"action {action} .*legal actions: ") as err:
        domain.step(action)
    assert str(legal) in str(err.value) and "illegal_action='ignore'" in str(err.value)


@pytest.mark.parametrize("cls", CONSTRAINED)
@pytest.mark.parametrize(("mode", "reward"), [("ignore", 0.0), ("penalize", -2.5)])
def test_ignore_and_penalize_are_no_ops(cls, mode, reward):
    domain = cls(illegal_action=mode, illegal_action_penalty=2.5)
    observation, info = domain.reset(seed=0)
    action = first_illegal(domain, observation)
    after, r, terminated, truncated, step_info = domain.step(action)
    np.testing.assert_array_equal(after, observation)
    assert (r, terminated, truncated, step_info["illegal_action"]) == (reward, False, False, True)
    np.testing.assert_array_equal(step_info["action_mask"], info["action_mask"])
    after[:] = -1.0  # the returned observation is a copy, not the domain's own state
    np.testing.assert_array_equal(domain._current_observation(), observation)
    legal = int(domain.legal_actions(observation)[0])
    moved = domain.step(legal)  # the episode goes on with a legal action
    assert "illegal_action" not in moved[4]


def test_ignored_action_leaves_the_random_stream_alone():
    twins = [BlocksWorld(illegal_action="ignore"), BlocksWorld()]
    observations = [twin.reset(seed=4)[0] for twin in twins]
    twins[0].step(first_illegal(twins[0], observations[0]))
    rng = np.random.default_rng(4)
    for _ in range(40):
        action = int(rng.choice(twins[1].legal_actions(observations[1])))
        steps = [twin.step(action) for twin in twins]
        np.testing.assert_array_equal(steps[0][0], steps[1][0])
        observations = [step[0] for step in steps]
        if steps[1][2]:
            break


@pytest.mark.parametrize("mode", ["ignore", "penalize"])
def test_check_env_passes_in_every_mode(mode):
    for cls in CONSTRAINED:
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            check_env(cls(illegal_action=mode), skip_render_check=True)


@pytest.mark.parametrize(
    ("params", "name"),
    [
        ({"illegal_action": "skip"}, "illegal_action"),
        ({"illegal_action": "Raise"}, "illegal_action"),
        ({"illegal_action_penalty": -1.0}, "illegal_action_penalty"),
        ({"illegal_action_penalty": float("inf")}, "illegal_action_penalty"),
        ({"illegal_action_penalty": True}, "illegal_action_penalty"),
    ],
)
def test_bad_mode_or_penalty_is_rejected(params, name):
    for cls in CONSTRAINED:
        with pytest.raises(InvalidParameterError, match=rf"`{cls.__name__}.{name}` must be"):
            cls(**params)


def test_masks_through_gymnasium_make_and_its_wrappers():
    env = gym.make("conjure/BlocksWorld-v0", illegal_action="penalize", illegal_action_penalty=0.5)
    observation, info = env.reset(seed=0)
    mask = env.get_wrapper_attr("action_masks")()  # how sb3-contrib reads it
    np.testing.assert_array_equal(mask, info["action_mask"])
    action = int(np.flatnonzero(~mask)[0])
    after, reward, *_ = env.step(action)
    np.testing.assert_array_equal(after, observation)
    assert reward == -0.5


def test_unconstrained_domains_allow_every_action():
    domain = GridWorld()
    _, info = domain.reset(seed=0)
    assert domain.action_masks().tolist() == [True] * 4 and "action_mask" not in info


def _loop_steps(domain, num_steps, seed=0):
    """Step as the run loop does: ``legal_actions`` of each state, then a legal action."""
    observation, _ = domain.reset(seed=seed)
    rng = np.random.default_rng(seed)
    visited = []
    for _ in range(num_steps):
        legal = domain.legal_actions(observation)
        visited.append((observation.copy(), legal))
        observation, _, terminated, _, _ = domain.step(int(rng.choice(legal)))
        if terminated:
            observation, _ = domain.reset()
    return visited


@pytest.mark.parametrize("cls", CONSTRAINED)
def test_legality_is_computed_once_per_state(cls, monkeypatch):
    # The step computes the new state's mask; legal_actions of that state reads it instead of
    # a second compiled pass, and equals that pass. Any other state still gets its own pass.
    domain = cls()
    computed = []

    def counting(state, compute=domain._legal_actions_of):
        computed.append(state.copy())
        return compute(state)

    monkeypatch.setattr(domain, "_legal_actions_of", counting)
    visited = _loop_steps(domain, 60)
    assert computed == []
    for observation, legal in visited:
        np.testing.assert_array_equal(legal, cls()._legal_actions_of(observation))
        assert legal.dtype == np.int64
    current = domain._current_observation()
    older = next(obs for obs, _ in visited if not np.array_equal(obs, current))
    np.testing.assert_array_equal(domain.legal_actions(older), cls()._legal_actions_of(older))
    assert len(computed) == 1  # a state other than the current one: its own pass
    legal = domain.legal_actions(current)
    legal[:] = -1  # the caller owns the returned array
    assert (domain.legal_actions(current) >= 0).all() and len(computed) == 1


def test_uav_mission_computes_one_mask_per_state(monkeypatch):
    import conjure.domains.uav_mission as module

    calls = []

    def counting(*args, compute=module.checked_legal_mask):
        calls.append(1)
        return compute(*args)

    monkeypatch.setattr(module, "checked_legal_mask", counting)
    domain = UAVMission(traverse_failure=0.1)
    calls.clear()
    observation, _ = domain.reset(seed=0)
    visits = [observation.tolist()]
    for _ in range(40):
        domain.action_masks()
        legal = domain.legal_actions(observation)
        observation, _, terminated, _, _ = domain.step(int(legal[-1]))
        visits.append(observation.tolist())
        if terminated:
            observation, _ = domain.reset()
            visits.append(observation.tolist())
    # one pass per visit, but none for a state the domain is still in (the start state, whose
    # mask the constructor computed before counting; a step that left the state as it was):
    # the mask is kept with the state's bytes
    changes = sum(before != after for before, after in itertools.pairwise(visits))
    assert len(calls) == changes and changes > 30


def test_blocks_world_compiled_state_keeps_the_mask_current():
    # The compiled loop steps the domain's own state and mask (its compiled form holds them).
    domain = BlocksWorld(num_blocks=3, drop_probability=0.0)
    start, _ = domain.reset(seed=0)
    tower = np.array([1.0, 0, 0, 1, 0, 0, 0, 1, 0])  # 0 on the table, 1 on 0, 2 on 1
    form, obs, rng = domain.compiled_form(), np.empty(9), np.random.default_rng(0)
    for move in (3, 7):  # move(1, 0), then move(2, 1)
        step_into(form, move, obs, rng)
    np.testing.assert_array_equal(obs, tower)
    assert form.state.tolist() == [*tower.astype(int), 0, 0, 1, 1, 2, -1]  # On, supports, above
    assert domain.action_masks().tolist() == mask_of(BlocksWorld(num_blocks=3), tower).tolist()
    np.testing.assert_array_equal(domain.legal_actions(start), [1, 2, 3, 5, 6, 7])
    assert domain.legal_actions(tower).tolist() == [8]  # only move(2, table)
    _, reward, terminated, _, _ = domain.step(8)
    assert domain.compiled_form().state[9:].tolist() == [0, 0, 2, 1, -1, -1]
    assert (reward, terminated) == (-0.001, False)
