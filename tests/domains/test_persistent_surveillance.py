import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import conjure.domains  # noqa: F401  (registers the Gymnasium ids)
from conjure.core.errors import InvalidParameterError
from conjure.domains import PersistentSurveillance
from conjure.domains._uav_kernels import pst_fill_legal_mask
from conjure.domains.persistent_surveillance import persistent_surveillance_state_action_count
from conjure.testing.checks import check_pickle_round_trip, check_seeded_rollout

BASE, REFUEL, COMMS, SURVEIL = 0, 1, 2, 3
RETREAT, LOITER, ADVANCE = 0, 1, 2


def joint(*actions):
    """Joint action index: UAV 0 is the least significant base-3 digit."""
    return sum(a * 3**i for i, a in enumerate(actions))


def uav(fuel, location, actuator=1, sensor=1):
    return [fuel, location, actuator, sensor]


def put(domain, *uavs):
    """Place the domain in a hand-built state (white box: tests only)."""
    domain._state[:] = np.concatenate(uavs)
    pst_fill_legal_mask(domain._state, domain.num_uavs, domain._mask)


@pytest.mark.parametrize("make", [PersistentSurveillance, PersistentSurveillance.rlpy])
def test_check_env_passes_with_warnings_as_errors(make):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(make(), skip_render_check=True)


def test_gymnasium_make_spec_and_start():
    env = gym.make("conjure/PersistentSurveillance-v0")
    obs, _ = env.reset(seed=0)
    assert obs.tolist() == uav(10, BASE) * 3 and env.observation_space.contains(obs)
    spec = env.unwrapped.domain_spec
    assert (spec.num_dims, spec.num_actions, spec.discount, spec.max_episode_steps) == (
        12,
        27,
        0.9,
        1000,
    )
    assert spec.has_action_constraints and spec.is_discrete.all()
    assert spec.high.tolist() == [10, 3, 1, 1] * 3


def test_seeded_rollouts_are_equal():
    check_seeded_rollout(PersistentSurveillance())
    check_pickle_round_trip(PersistentSurveillance())


def test_fuel_burn_and_refuel_at_refuel():
    domain = PersistentSurveillance(failure_probability=0.0)
    domain.reset(seed=0)
    obs, reward, terminated, _, _ = domain.step(joint(ADVANCE, ADVANCE, ADVANCE))
    assert obs.tolist() == uav(9, REFUEL) * 3 and reward == -3.0 and not terminated
    obs, reward, *_ = domain.step(joint(ADVANCE, LOITER, LOITER))  # UAV 0 on to COMMS
    assert obs.tolist() == uav(8, COMMS) + uav(10, REFUEL) * 2 and reward == -1.0
    obs, reward, *_ = domain.step(joint(LOITER, LOITER, LOITER))  # loitering at COMMS burns
    assert obs[0] == 7 and reward == -1.0


def test_repair_at_base_happens_after_failures():
    domain = PersistentSurveillance(failure_probability=1.0)
    domain.reset(seed=0)
    obs, reward, *_ = domain.step(joint(LOITER, LOITER, LOITER))  # fail, then repaired
    assert obs.tolist() == uav(10, BASE) * 3 and reward == 0.0
    obs, *_ = domain.step(joint(ADVANCE, ADVANCE, ADVANCE))
    assert obs.tolist() == uav(9, REFUEL, 0, 0) * 3
    obs, *_ = domain.step(joint(RETREAT, RETREAT, RETREAT))  # arriving does not repair
    assert obs.tolist() == uav(8, BASE, 0, 0) * 3
    obs, *_ = domain.step(joint(LOITER, LOITER, LOITER))  # staying does
    assert obs.tolist() == uav(8, BASE) * 3


@pytest.mark.parametrize(
    ("make", "expected"),
    [(PersistentSurveillance, 40.0 - 3.0), (PersistentSurveillance.rlpy, 20.0 - 3.0)],
)
def test_surveillance_reward_needs_a_relay_at_comms(make, expected):
    domain = make(failure_probability=0.0)
    domain.reset(seed=0)
    domain.step(joint(ADVANCE, ADVANCE, ADVANCE))
    domain.step(joint(ADVANCE, ADVANCE, ADVANCE))  # all at COMMS, nobody at SURVEIL yet
    _, reward, *_ = domain.step(joint(ADVANCE, ADVANCE, LOITER))
    assert reward == -3.0  # reward uses the pre-step state
    _, reward, *_ = domain.step(joint(LOITER, LOITER, LOITER))
    assert reward == expected


def test_relay_actuator_and_sensor_rules():
    thesis = PersistentSurveillance(failure_probability=0.0)
    rlpy = PersistentSurveillance.rlpy(failure_probability=0.0)
    for domain, expected in ((thesis, -3.0), (rlpy, 20.0 - 3.0)):
        domain.reset(seed=0)
        put(domain, uav(5, SURVEIL), uav(5, SURVEIL, sensor=0), uav(5, COMMS, actuator=0))
        _, reward, *_ = domain.step(joint(LOITER, LOITER, RETREAT))
        assert reward == expected  # broken relay counts only in RLPy; broken camera never
    thesis.reset(seed=0)
    put(thesis, uav(5, SURVEIL), uav(5, SURVEIL, sensor=0), uav(5, COMMS))
    assert thesis.step(joint(LOITER, LOITER, LOITER))[1] == 20.0 - 3.0


def test_running_out_of_fuel_crashes_with_per_uav_penalty():
    thesis = PersistentSurveillance(failure_probability=0.0)
    rlpy = PersistentSurveillance.rlpy(failure_probability=0.0)
    for domain, penalty in ((thesis, 100.0), (rlpy, 50.0)):
        domain.reset(seed=0)
        put(domain, uav(1, COMMS), uav(1, COMMS), uav(10, BASE))
        obs, reward, terminated, truncated, _ = domain.step(joint(LOITER, LOITER, LOITER))
        assert terminated and not truncated and reward == -2.0 - penalty
        assert domain.observation_space.contains(obs)
    thesis.reset(seed=0)
    put(thesis, uav(1, COMMS), uav(10, BASE), uav(10, BASE))
    assert thesis.step(joint(LOITER, LOITER, LOITER))[1:3] == (-51.0, True)


def test_empty_tank_at_refuel_is_not_a_crash_and_refuels():
    domain = PersistentSurveillance(failure_probability=0.0)
    domain.reset(seed=0)
    put(domain, uav(1, COMMS), uav(10, BASE), uav(10, BASE))
    obs, reward, terminated, *_ = domain.step(joint(RETREAT, LOITER, LOITER))
    assert obs[:2].tolist() == [0, REFUEL] and reward == -1.0 and not terminated
    assert domain.legal_actions(obs).tolist() == [
        joint(LOITER, LOITER, LOITER),
        joint(LOITER, ADVANCE, LOITER),
        joint(LOITER, LOITER, ADVANCE),
        joint(LOITER, ADVANCE, ADVANCE),
    ]
    obs, reward, *_ = domain.step(joint(LOITER, LOITER, LOITER))
    assert obs[0] == 10 and reward == 0.0


@pytest.mark.parametrize(
    ("state", "legal"),
    [
        (uav(10, BASE), [LOITER, ADVANCE]),
        (uav(10, BASE, actuator=0), [LOITER]),
        (uav(5, REFUEL, actuator=0), [RETREAT, LOITER]),
        (uav(5, COMMS, actuator=0), [RETREAT]),
        (uav(5, COMMS), [RETREAT, LOITER, ADVANCE]),
        (uav(5, SURVEIL), [RETREAT, LOITER]),
        (uav(0, REFUEL), [LOITER]),
        (uav(0, COMMS, actuator=0), [LOITER]),  # crashed: dummy LOITER
    ],
)
def test_single_uav_legal_action_rules(state, legal):
    domain = PersistentSurveillance(num_uavs=1)
    assert domain.legal_actions(np.array(state, dtype=float)).tolist() == legal


def test_joint_legal_actions_and_illegal_step():
    domain = PersistentSurveillance()
    state = np.array(uav(10, BASE, 0) + uav(5, COMMS, 0) + uav(5, SURVEIL), dtype=float)
    assert domain.legal_actions(state).tolist() == [
        joint(LOITER, RETREAT, RETREAT),
        joint(LOITER, RETREAT, LOITER),
    ]
    domain.reset(seed=0)
    with pytest.raises(InvalidParameterError, match=r"\(RETREAT, LOITER, LOITER\).*\[13, 14"):
        domain.step(joint(RETREAT, LOITER, LOITER))
    with pytest.raises(InvalidParameterError, match="UAV 1 location"):
        domain.legal_actions(np.array(uav(10, 0) + uav(10, 7) + uav(10, 0), dtype=float))
    with pytest.raises(InvalidParameterError, match=r"shape \(12,\)"):
        domain.legal_actions(np.zeros(4))


def test_random_rollout_stays_in_space_and_failures_are_about_five_percent():
    domain = PersistentSurveillance()
    obs, _ = domain.reset(seed=2)
    rng = np.random.default_rng(2)
    failures = trials = 0
    for _ in range(3000):
        legal = domain.legal_actions(obs)
        new_obs, reward, terminated, _, _ = domain.step(int(rng.choice(legal)))
        assert domain.observation_space.contains(new_obs) and np.isfinite(reward)
        for i in range(3):
            if obs[4 * i + 2] == 1 and new_obs[4 * i + 1] != BASE:
                trials += 1
                failures += new_obs[4 * i + 2] == 0
        obs = domain.reset()[0] if terminated else new_obs
    assert abs(failures / trials - 0.05) < 0.015


def test_state_action_count_matches_the_thesis():
    assert PersistentSurveillance().state_action_count() == 147_197_952
    assert persistent_surveillance_state_action_count(3, 10) == (4 * 11 * 2 * 2) ** 3 * 27
    assert abs(PersistentSurveillance().state_action_count() - 1.5e8) < 0.05e8


def test_running_out_of_fuel_is_marked_as_cost_and_constrained():
    domain = PersistentSurveillance(failure_probability=0.0)
    domain.reset(seed=0)
    put(domain, uav(2, COMMS), uav(10, BASE), uav(10, BASE))
    obs, _, terminated, _, info = domain.step(joint(LOITER, LOITER, LOITER))  # fuel 1
    assert not terminated and info["cost"] == 0.0 and not domain.is_constrained(obs)
    obs, _, terminated, _, info = domain.step(joint(LOITER, LOITER, LOITER))  # fuel 0
    assert terminated and info["cost"] == 1.0 and domain.is_constrained(obs)
    empty_at_refuel = np.array(uav(0, REFUEL) + uav(10, BASE) + uav(10, BASE), dtype=float)
    assert not domain.is_constrained(empty_at_refuel)
    with pytest.raises(InvalidParameterError, match="shape"):
        domain.is_constrained(np.zeros(3))
