import numpy as np
import pytest

from conjure.core.errors import IncompatibleComponentsError, InvalidParameterError
from conjure.domains import GridWorld, UAVMission
from conjure.models.approximate_model import ApproximateModel
from conjure.planners import CBBAPlanner
from conjure.safety import FuelRiskAnalyzer


def set_up(domain):
    model = ApproximateModel(domain=domain).setup(domain.domain_spec, seed=0)
    return FuelRiskAnalyzer().setup(model, CBBAPlanner().setup(model, seed=0), seed=0)


def mission_state(graph, locations, fuels, time):
    state = graph.initial_state()
    state[0 : 2 * graph.num_uavs : 2] = locations
    state[1 : 2 * graph.num_uavs : 2] = fuels
    state[-1] = time
    return state


def test_unsafe_iff_a_uav_cannot_fly_home_after_the_move():
    # UAV 7-2 [R]: node 3 is two hops from the base (0 - 1 - 3), node 5 three (0 - 1 - 3 - 5).
    domain = UAVMission()
    graph = domain.graph_
    analyser = set_up(domain)
    state = mission_state(graph, [1, 0], [3, 6], time=1)
    out = graph.encode_action([3, 0])  # UAV 1 to node 3: fuel 2 = distance 2
    assert analyser.risk(state, out) == 0.0 and analyser.is_safe(state, out)
    farther = mission_state(graph, [3, 0], [2, 6], time=2)
    assert analyser.risk(farther, graph.encode_action([5, 0])) == 1.0  # fuel 1 < distance 3
    assert analyser.is_safe(farther, graph.encode_action([1, 0]))  # heading home
    # Loitering away from the base burns fuel (2 -> 1 < 2 hops); at the base it burns none.
    assert analyser.risk(farther, graph.encode_action([3, 0])) == 1.0
    empty_at_base = mission_state(graph, [3, 0], [2, 0], time=2)
    assert analyser.risk(empty_at_base, graph.encode_action([1, 0])) == 0.0


def test_the_time_left_to_the_horizon_also_counts():
    # [choice] spec 2.1: unsafe when the horizon (8) comes before the way home.
    domain = UAVMission()
    graph = domain.graph_
    analyser = set_up(domain)
    state = mission_state(graph, [1, 0], [6, 6], time=5)  # plenty of fuel, t = 5
    assert analyser.risk(state, graph.encode_action([3, 0])) == 0.0  # t = 6, 2 hops left
    late = mission_state(graph, [1, 0], [6, 6], time=6)
    assert analyser.risk(late, graph.encode_action([3, 0])) == 1.0  # t = 7, 2 hops > 1 step


def test_an_analyser_of_missions_refuses_a_grid_world():
    domain = GridWorld(map_name="4x5")
    model = ApproximateModel(domain=domain).setup(domain.domain_spec, seed=0)
    with pytest.raises(IncompatibleComponentsError, match="GridWorld has none"):
        FuelRiskAnalyzer().setup(model, planner=None, seed=0)


def test_is_unsafe_outcome_reads_the_state_layout():
    graph = UAVMission().graph_
    assert not FuelRiskAnalyzer.is_unsafe_outcome(graph, graph.initial_state())
    crashed = mission_state(graph, [2, 0], [0, 6], time=3)
    assert FuelRiskAnalyzer.is_unsafe_outcome(graph, crashed)


def test_judgements_match_the_real_domain_flown_home_without_noise():
    # Safe iff, after the action, flying every UAV home along shortest paths never crashes in
    # UAVMission itself (η = 0), over the states and legal actions of CBBA-guided rollouts.
    domain = UAVMission(traverse_failure=0.0)
    analyser = set_up(domain)
    hops = analyser.planner_.next_hop_
    rng = np.random.default_rng(0)
    checked = {True: 0, False: 0}
    for episode in range(15):
        state, _ = domain.reset(seed=episode)
        terminated = False
        while not terminated:
            for action in domain.legal_actions(state):
                safe = analyser.risk(state, int(action)) == 0.0  # is_safe trusts π^p(s)
                checked[safe] += 1
                assert safe == (not crashes_flying_home(domain, hops, state, int(action), rng))
            legal = domain.legal_actions(state)
            action = analyser.planner_.action(state) if episode % 2 else rng.choice(legal)
            state, _, terminated, _, _ = domain.step(int(action))
    assert checked[True] > 100 and checked[False] > 100


def crashes_flying_home(domain, hops, state, action, rng):
    graph = domain.graph_
    state, _, terminated = domain.simulate(state, action, 0.0, rng)
    while not terminated:
        home = [hops[node, graph.base] for node in graph.locations(state)]
        state, _, terminated = domain.simulate(state, graph.encode_action(home), 0.0, rng)
    return domain.is_constrained(state)


def test_the_risk_tolerance_is_a_parameter_checked_in_setup():
    # Issue 22: ε was a class attribute standing in for a parameter.
    assert FuelRiskAnalyzer().get_params() == {"risk_tolerance": 1.0}
    domain = UAVMission()
    model = ApproximateModel(domain=domain).setup(domain.domain_spec, seed=0)
    planner = CBBAPlanner().setup(model, seed=0)
    with pytest.raises(InvalidParameterError, match=r"risk_tolerance` must be .*; got -0\.2\."):
        FuelRiskAnalyzer(risk_tolerance=-0.2).setup(model, planner, seed=0)
    graph = domain.graph_
    farther = mission_state(graph, [3, 0], [2, 6], time=2)
    moves = [graph.encode_action(move) for move in ([5, 0], [1, 0], [3, 0])]
    for tolerance in (0.5, 1.0):  # risk is 0 or 1: every ε in (0, 1] judges alike
        analyser = FuelRiskAnalyzer(risk_tolerance=tolerance).setup(model, planner, seed=0)
        assert [analyser.is_safe(farther, a) for a in moves] == [False, True, False]
