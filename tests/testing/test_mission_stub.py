import numpy as np
import pytest

from conjure.core.errors import InvalidParameterError
from conjure.models.approximate_model import ApproximateModel
from conjure.testing.mission_stub import HomePlanner, MissionStub, tiny_mission


def test_moves_burn_fuel_except_waiting_at_the_base():
    domain = MissionStub(traverse_failure=0.0)
    graph = domain.graph_
    state, _ = domain.reset(seed=0)
    state, reward, terminated, _, info = domain.step(graph.encode_action([1, 0]))
    assert graph.locations(state).tolist() == [1, 0]
    assert graph.fuels(state).tolist() == [3, 4] and graph.time(state) == 1
    assert reward == -1.0 and not terminated and info["cost"] == 0.0


def test_a_failed_traverse_burns_fuel_without_moving():
    domain = MissionStub(traverse_failure=1.0)
    graph = domain.graph_
    start = graph.initial_state()
    state, _, _ = domain.simulate(start, graph.encode_action([1, 1]), 1.0, np.random.default_rng(0))
    assert graph.locations(state).tolist() == [0, 0] and graph.fuels(state).tolist() == [3, 3]
    assert domain.count_unintended(start, graph.encode_action([1, 1]), state) == (2, 2)
    nominal = domain.nominal_next_state(start, graph.encode_action([1, 0]))
    assert graph.locations(nominal).tolist() == [1, 0]


def test_running_dry_or_being_late_away_from_the_base_is_a_crash():
    domain = MissionStub(traverse_failure=0.0)
    graph = domain.graph_
    state = graph.initial_state()
    state[0], state[1] = 1, 1  # UAV 1 at node 1 with one fuel
    crashed, reward, terminated = domain.simulate(
        state, graph.encode_action([2, 0]), 0.0, np.random.default_rng(0)
    )
    assert domain.is_constrained(crashed) and terminated and reward == graph.crash_penalty
    late = graph.initial_state()
    late[0], late[-1] = 1, graph.horizon
    assert domain.is_constrained(late)


def test_legal_actions_are_stays_and_neighbours():
    domain = MissionStub()
    graph = domain.graph_
    state = graph.initial_state()
    state[0] = 1  # UAV 1 at node 1: 0, 1, 2; UAV 2 at the base: 0, 1
    expected = sorted(graph.encode_action([a, b]) for a in (0, 1, 2) for b in (0, 1))
    assert domain.legal_actions(state).tolist() == expected
    with pytest.raises(InvalidParameterError, match="past a neighbour"):
        domain.step(graph.encode_action([3, 0]))


def test_the_home_planner_flies_one_hop_closer():
    domain = MissionStub(graph=tiny_mission())
    model = ApproximateModel(domain=domain).setup(domain.domain_spec, seed=0)
    planner = HomePlanner().setup(model, seed=0)
    state = domain.graph_.initial_state()
    state[0], state[2] = 3, 1
    assert domain.graph_.decode_action(planner.action(state)).tolist() == [2, 0]
