import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import conjure.domains  # noqa: F401  (registers the Gymnasium ids)
from conjure.core.errors import InvalidParameterError
from conjure.domains import RescueMission
from conjure.domains.rescue_mission import PEOPLE, rescue_mission_state_action_count
from conjure.testing.checks import check_pickle_round_trip, check_seeded_rollout

# Medic slots: 0 hover, 1..3 k-th neighbour. Comm slots: 0 hover, 1 perch, 2..4 k-th neighbour.
# Neighbours (0-based): 0: [1, 2]; 1: [0, 3]; 2: [0, 3, 4]; 3: [1, 2, 5].
HOVER, PERCH = 0, 1


def joint(medic_slot, comm_slot):
    return medic_slot * 5 + comm_slot


def test_check_env_passes_with_warnings_as_errors():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(RescueMission(), skip_render_check=True)


def test_gymnasium_make_spec_and_seeded_rollouts():
    env = gym.make("conjure/RescueMission-v0")
    obs, _ = env.reset(seed=0)
    assert obs.tolist() == [0, 10, 0, 10, 0] + [0] * 7 + [0]
    spec = env.unwrapped.domain_spec
    assert (spec.num_dims, spec.num_actions, spec.discount, spec.max_episode_steps) == (
        13,
        20,
        1.0,
        10,
    )
    assert spec.has_action_constraints and sum(PEOPLE) == 23
    check_seeded_rollout(RescueMission())
    check_pickle_round_trip(RescueMission())


def test_rescue_needs_the_comm_uav_within_one_edge():
    successes = 0
    for seed in range(400):
        domain = RescueMission()
        domain.reset(seed=seed)
        # Medic to node 1 (2 people, p 0.9); comm hovers at the base, one edge away (free).
        obs, reward, *_ = domain.step(joint(1, HOVER))
        assert reward in (2.0 - 0.1, -0.1)
        successes += reward > 0
        assert obs[5] == (reward > 0) and obs[1] == 9 and obs[3] == 10
    assert abs(successes / 400 - 0.9) < 0.05
    for seed in range(50):  # node 3 is two edges from the base: never rescued from there
        domain = RescueMission()
        domain.reset(seed=seed)
        domain.step(joint(1, HOVER))
        obs, reward, *_ = domain.step(joint(2, HOVER))
        assert obs[0] == 3 and obs[5 + 2] == 0 and reward == -0.1
    hits = 0
    for seed in range(50):  # with the comm UAV at node 2 (adjacent to 3) it works
        domain = RescueMission()
        domain.reset(seed=seed)
        domain.step(joint(1, 3))  # medic -> 1, comm -> 2
        obs, reward, *_ = domain.step(joint(2, HOVER))  # medic -> 3, comm hovers at 2
        hits += obs[5 + 2] == 1
        assert reward in (1.0 - 0.2, -0.2)
    assert 25 <= hits <= 45  # p = 0.7


def test_perch_costs_no_fuel_and_must_hover_before_moving():
    domain = RescueMission()
    domain.reset(seed=0)
    obs, reward, *_ = domain.step(joint(HOVER, 3))  # comm -> node 2 (1 fuel)
    assert obs[2:5].tolist() == [2, 9, 0] and reward == pytest.approx(-0.1)
    obs, reward, *_ = domain.step(joint(HOVER, PERCH))
    assert obs[2:5].tolist() == [2, 9, 1] and reward == 0.0  # medic at base: free too
    legal = domain.legal_actions(obs)
    assert all(a % 5 in (HOVER, PERCH) for a in legal.tolist())
    with pytest.raises(InvalidParameterError, match=r"comm: move to neighbour 1.*legal"):
        domain.step(joint(HOVER, 2))
    obs, reward, *_ = domain.step(joint(HOVER, HOVER))  # take off: 1 fuel away from base
    assert obs[2:5].tolist() == [2, 8, 0] and reward == pytest.approx(-0.1)
    assert joint(HOVER, 2) in domain.legal_actions(obs).tolist()


def test_minus_23_at_the_horizon_away_from_base():
    domain = RescueMission()
    domain.reset(seed=0)
    domain.step(joint(2, HOVER))  # medic -> node 2 (3 people): may or may not rescue
    for t in range(2, 11):
        obs, reward, terminated, truncated, _ = domain.step(joint(HOVER, PERCH))
        assert terminated == (t == 10) and not truncated
    assert obs[12] == 10 and domain.observation_space.contains(obs)
    assert reward == pytest.approx(-0.1 - 23.0)
    home = RescueMission()
    home.reset(seed=0)
    for _ in range(10):
        obs, reward, terminated, *_ = home.step(joint(HOVER, PERCH))
    assert terminated and reward == 0.0


def test_running_out_of_fuel_away_from_base_crashes():
    domain = RescueMission(max_fuel=2)
    domain.reset(seed=0)
    domain.step(joint(2, PERCH))  # medic -> 2, fuel 1
    obs, reward, terminated, *_ = domain.step(joint(HOVER, PERCH))  # fuel 0 at node 2
    assert terminated and obs[1] == 0 and reward <= -0.1 - 23.0 + 3.0


def test_legal_actions_follow_degree_and_fuel():
    domain = RescueMission()
    obs, _ = domain.reset(seed=0)
    # Base has 2 neighbours: medic slots 0-2, comm slots 0-3.
    expected = [joint(m, c) for m in range(3) for c in range(4)]
    assert domain.legal_actions(obs).tolist() == expected
    state = obs.copy()
    state[1] = 0  # medic without fuel at the base: may only hover
    assert domain.legal_actions(state).tolist() == list(range(4))
    with pytest.raises(InvalidParameterError, match="dimension 0"):
        state[0] = 8
        domain.legal_actions(state)


def test_random_rollouts_stay_in_space():
    domain = RescueMission()
    obs, _ = domain.reset(seed=4)
    rng = np.random.default_rng(4)
    for _ in range(3000):
        legal = domain.legal_actions(obs)
        illegal = np.setdiff1d(np.arange(20), legal)
        if illegal.size:
            with pytest.raises(InvalidParameterError):
                domain.step(int(rng.choice(illegal)))
        obs, reward, terminated, _, _ = domain.step(int(rng.choice(legal)))
        assert domain.observation_space.contains(obs) and np.isfinite(reward)
        if terminated:
            obs, _ = domain.reset()


def test_state_action_count_exceeds_the_thesis_bound():
    count = RescueMission().state_action_count()
    assert count == 8**2 * 11**2 * 2 * 2**7 * 10 * 20 == rescue_mission_state_action_count()
    assert count > 2e8


def test_failures_are_marked_as_cost_and_constrained():
    late = RescueMission()  # away from the base at the horizon
    late.reset(seed=0)
    late.step(joint(2, HOVER))
    for _ in range(9):
        obs, _, terminated, _, info = late.step(joint(HOVER, PERCH))
        assert info["cost"] == (1.0 if terminated else 0.0)
        assert late.is_constrained(obs) == terminated
    assert terminated
    dry = RescueMission(max_fuel=2)  # out of fuel away from the base
    dry.reset(seed=0)
    assert dry.step(joint(2, PERCH))[4]["cost"] == 0.0
    obs, _, terminated, _, info = dry.step(joint(HOVER, PERCH))
    assert terminated and info["cost"] == 1.0 and dry.is_constrained(obs)
    home = RescueMission()  # home at the horizon: ends, but no failure
    home.reset(seed=0)
    for _ in range(10):
        obs, _, terminated, _, info = home.step(joint(HOVER, PERCH))
    assert terminated and info["cost"] == 0.0 and not home.is_constrained(obs)
    with pytest.raises(InvalidParameterError, match="shape"):
        home.is_constrained(np.zeros(3))
