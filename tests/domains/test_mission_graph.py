import numpy as np
import pytest

from conjure.core.errors import InvalidParameterError
from conjure.domains.mission_graph import (
    MissionGraph,
    sample_mission,
    uav_7_2,
    uav_7_2_spec,
    uav_10_2,
    uav_10_2_spec,
)


def test_floyd_warshall_hop_distances_from_the_base_match_the_reconstruction():
    # spec 2.2: d(2) = d(3) = 1, d(4) = d(5) = 2, d(6) = d(7) = 3 (thesis numbering); the
    # calibrated graphs keep the edges
    for make in (uav_7_2, uav_7_2_spec):
        assert make().distances[0].tolist() == [0, 1, 1, 2, 2, 3, 3]
    for make in (uav_10_2, uav_10_2_spec):
        assert make().distances[0].tolist() == [0, 1, 1, 2, 2, 3, 3, 4, 4, 4]


def test_distances_are_symmetric_shortest_paths():
    g = uav_10_2()
    d = g.distances
    assert np.array_equal(d, d.T)
    # triangle inequality holds everywhere, and edges have length 1
    assert np.all(d[:, :, None] <= d[:, None, :] + d.T[None, :, :].transpose(0, 2, 1) + 0)
    for u, v in g.edges:
        assert d[u, v] == 1


def test_state_action_counts_match_the_thesis_orders_of_magnitude():
    assert uav_7_2_spec().state_action_count() == 49 * 49 * 128 * 8 * 49
    assert uav_10_2_spec().state_action_count() == 100 * 81 * 1024 * 11 * 100
    # fuel 6 and 7, 9 and 7: each UAV's fuel levels multiply
    assert uav_7_2().state_action_count() == 49 * (7 * 8) * 128 * 8 * 49
    assert uav_10_2().state_action_count() == 100 * (10 * 8) * 1024 * 11 * 100


def test_crash_penalty_is_minus_the_sum_of_rewards():
    assert uav_7_2_spec().crash_penalty == -750.0
    assert uav_10_2_spec().crash_penalty == -1400.0
    assert uav_7_2().crash_penalty == -1750.0
    assert uav_10_2().crash_penalty == -2700.0


def test_state_layout_and_joint_actions_round_trip():
    g = uav_7_2()
    s = g.initial_state()
    assert g.locations(s).tolist() == [0, 0]
    assert g.fuels(s).tolist() == [6, 7]
    assert not g.visited(s).any() and g.time(s) == 0
    for destinations in ([0, 0], [3, 5], [6, 1]):
        assert g.decode_action(g.encode_action(destinations)).tolist() == destinations
    assert g.encode_action([3, 5]) == 3 + 5 * 7


def test_config_round_trip():
    g = uav_7_2()
    again = MissionGraph.from_dict(g.to_dict())
    assert again.to_dict() == g.to_dict()
    assert again.windows[1].tolist() == [1, 1] and again.windows[2].tolist() == [0, 8]
    assert again.fuel == (6, 7) and again.probabilities[4] == 0.3


def test_target_keys_may_be_digit_strings_as_json_writes_them():
    data = uav_7_2().to_dict()
    data["targets"] = {str(node): target for node, target in data["targets"].items()}
    assert MissionGraph.from_dict(data).to_dict() == uav_7_2().to_dict()
    data["targets"] = {"three": {"reward": 1.0}}
    with pytest.raises(InvalidParameterError, match="'three'"):
        MissionGraph.from_dict(data)


@pytest.mark.parametrize(
    ("data", "message"),
    [
        ({"num_nodes": 3, "edges": [(1, 2)], "fuel": [1], "horizon": 3}, "base"),
        ({"num_nodes": 3, "edges": [(0, 1)], "fuel": [1], "horizon": 3}, "disconnected"),
        ({"num_nodes": 3, "edges": [(0, 1), (1, 2)], "fuel": [-1], "horizon": 3}, "fuel"),
        ({"num_nodes": 3, "edges": [(0, 3)], "fuel": [1], "horizon": 3}, "edges"),
        (
            {
                "num_nodes": 2,
                "edges": [(0, 1)],
                "fuel": [1],
                "horizon": 3,
                "targets": {1: {"reward": 1, "probability": 1.5}},
            },
            "probabilities",
        ),
        (
            {
                "num_nodes": 2,
                "edges": [(0, 1)],
                "fuel": [1],
                "horizon": 3,
                "targets": {1: {"reward": 1, "window": [3, 2]}},
            },
            "a <= b",
        ),
        ({"num_nodes": 2, "edges": [(0, 1)], "fuel": [1]}, "horizon"),
    ],
)
def test_bad_graphs_are_refused_with_the_value_named(data, message):
    with pytest.raises(InvalidParameterError, match=message):
        MissionGraph.from_dict(data)


def test_a_graph_too_large_for_its_distance_table_is_refused_before_allocating_it():
    # Issue 20: 10⁶ nodes asked Floyd-Warshall for 7.28 TiB (a raw numpy MemoryError).
    data = {"num_nodes": 10**6, "edges": [(0, 1)], "fuel": [2], "horizon": 3}
    with pytest.raises(InvalidParameterError, match=r"at most 1,000 .* got 1,000,000\.$"):
        MissionGraph.from_dict(data)
    with pytest.raises(InvalidParameterError, match="num_nodes"):
        MissionGraph(num_nodes=10**6, edges=((0, 1),), fuel=(2,), horizon=3)
    assert MissionGraph.from_dict({**data, "num_nodes": 2}).num_nodes == 2


def test_a_uav_without_fuel_is_refused_by_name():
    # Issue 20: fuel 0 only failed at run time, as value_bounds() = (0, 0).
    data = {"num_nodes": 2, "edges": [(0, 1)], "fuel": [3, 0], "horizon": 3}
    with pytest.raises(InvalidParameterError, match=r"`MissionGraph\.fuel\[1\]` .* fuel 0"):
        MissionGraph.from_dict(data)


def test_a_sampled_mission_is_a_function_of_its_generator_seed():
    draw = lambda seed: sample_mission(np.random.default_rng(seed), uav_7_2_spec()).to_dict()  # noqa: E731
    assert draw(3) == draw(3)
    assert draw(3) != draw(4)
    mission = MissionGraph.from_dict(draw(3))
    assert mission.edges == uav_7_2_spec().edges and mission.horizon == uav_7_2_spec().horizon
    assert mission.fuel in {(6, 6), (6, 7), (7, 6), (7, 7)}


def test_sampled_missions_plant_the_base_target_only_when_asked():
    for seed in range(30):
        free = sample_mission(np.random.default_rng(seed), uav_7_2_spec())
        assert free.rewards.max() <= 450  # the motif's 400-700 at node 1 needs the rate
        planted = sample_mission(np.random.default_rng(seed), uav_7_2_spec(), 1.0)
        assert planted.rewards[1] >= 400 and planted.windows[1].tolist() == [1, 1]
        assert planted.probabilities[1] in (0.3, 0.4, 0.5)


def test_a_base_target_rate_outside_zero_one_is_refused_by_value():
    with pytest.raises(InvalidParameterError, match=r"base_target_rate.*1.5"):
        sample_mission(np.random.default_rng(0), uav_7_2_spec(), 1.5)
