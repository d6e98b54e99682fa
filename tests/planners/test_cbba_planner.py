"""Tests of CBBAPlanner: plans on the UAV 7-2 / 10-2 missions, Algorithm 27, safety, cache."""

from __future__ import annotations

import itertools
from types import SimpleNamespace

import numpy as np
import pytest

from conjure.core.errors import IncompatibleComponentsError, InvalidParameterError, NotSetUpError
from conjure.domains.mission_graph import (
    MissionGraph,
    uav_7_2,
    uav_7_2_spec,
    uav_10_2,
    uav_10_2_spec,
)
from conjure.domains.uav_mission import UAVMission
from conjure.planners.cbba_planner import CBBAPlanner


def model_of(graph: MissionGraph) -> SimpleNamespace:
    """A stand-in for an ApproximateModel of a UAVMission: all CBBAPlanner reads."""
    return SimpleNamespace(domain_=SimpleNamespace(graph_=graph))


def planner(graph: MissionGraph, **params) -> CBBAPlanner:
    return CBBAPlanner(**params).setup(model_of(graph), seed=0)


def state(graph: MissionGraph, locations, fuels, time=0, visited=()) -> np.ndarray:
    s = graph.initial_state()
    s[0 : 2 * graph.num_uavs : 2] = locations
    s[1 : 2 * graph.num_uavs : 2] = fuels
    for node in visited:
        s[2 * graph.num_uavs + node] = 1.0
    s[-1] = time
    return s


def step(graph: MissionGraph, s: np.ndarray, action: int, rng: np.random.Generator):
    """Noise-free movement with random visit draws (the mission of Section 5.3.5)."""
    n, nxt = graph.num_uavs, s.copy()
    destinations = graph.decode_action(action)
    for i, (here, there) in enumerate(zip(graph.locations(s), destinations, strict=True)):
        assert there == here or there in graph.neighbours[here], "illegal move"
        nxt[2 * i] = there
        if not (there == here == graph.base):
            nxt[2 * i + 1] -= 1
    nxt[-1] += 1
    t = graph.time(nxt)
    for there in destinations:
        a, b = graph.windows[there]
        is_open = a <= t <= b and graph.rewards[there] > 0 and nxt[2 * n + there] < 0.5
        if is_open and rng.random() < graph.probabilities[there]:
            nxt[2 * n + there] = 1.0
    return nxt


def is_fuel_safe(graph: MissionGraph, s: np.ndarray) -> bool:
    """The deterministic check of Section 5.3.5: fuel (and time) to fly home on a shortest path."""
    home = graph.distances[graph.locations(s), graph.base]
    return bool(np.all(graph.fuels(s) >= home) and np.all(graph.horizon - graph.time(s) >= home))


# ----------------------------------------------------------------------------- hand-checked plans


def test_aggressive_plan_of_uav_7_2():
    # UAV 7-2 of spec 2.2 (nodes 0-based, base 0): targets 2 (40 = 50·0.8), 3 (90, window
    # [2, 4]), 4 (50), 5 (180, window [3, 5]), 6 (140); hops from the base 1, 2, 2, 3, 3; fuel
    # 6 each. UAV 0 bids on 5 first (180 - 3 hops = 177), then adds 3 (0 -> 3 at t = 2 -> 5 at
    # 3 -> home at 6: all 6 fuel); nothing else fits. UAV 0 wins every tie, so UAV 1 takes 6
    # (137), then 4 and 2 in front of it: 0 -> 2 (t 1) -> 4 (2) -> 6 (3) -> home at 6.
    graph = uav_7_2_spec()
    plan = planner(graph, variant="aggressive").plan(graph.initial_state())
    assert [p.tolist() for p in plan.paths] == [[3, 5], [2, 4, 6]]
    assert [a.tolist() for a in plan.arrivals] == [[2.0, 3.0], [1.0, 2.0, 3.0]]
    assert plan.allocation.returns.tolist() == [6.0, 6.0]
    assert plan.assignment == {2: 1, 3: 0, 4: 1, 5: 0, 6: 1}
    assert plan.fuel.tolist() == [6.0, 6.0] and plan.cbba_runs == 1
    # first moves: node 1 is the lowest neighbour of 0 on a shortest path to 3; 2 is adjacent
    assert plan.destinations.tolist() == [1, 2]
    assert plan.action == graph.encode_action([1, 2])


@pytest.mark.parametrize(
    ("refuel", "paths", "fuel", "runs", "destinations"),
    [
        # Algorithm 27 plans with 6 - 3 = 3 fuel: UAV 0 takes target 2 (round trip 2); nothing
        # else is within a round trip of 3. UAV 1 has no target but is home: it is ok and
        # stays, keeping its reserve.
        ("home", [[2], []], [3.0, 3.0], 1, [2, 0]),
        # The printed test Plan[u] = ∅ alone gives UAV 1 a 4th unit, with which it takes
        # target 3 (at t = 2, home at 4; 3 then 4 would need 5).
        ("empty_plan", [[2], [3]], [3.0, 4.0], 2, [2, 1]),
    ],
)
def test_conservative_plan_of_uav_7_2(refuel, paths, fuel, runs, destinations):
    graph = uav_7_2_spec()
    plan = planner(graph, variant="conservative", refuel=refuel).plan(graph.initial_state())
    assert [p.tolist() for p in plan.paths] == paths
    assert plan.fuel.tolist() == fuel and plan.cbba_runs == runs
    assert plan.destinations.tolist() == destinations


def test_conservative_fuel_comes_back_one_unit_at_a_time_until_the_uav_can_get_home():
    # UAV 0 stands on target 3 (2 hops from the base, window [2, 4]) at t = 2 with 4 fuel;
    # UAV 1 is home and empty. Planned with 4 - 3 = 1, UAV 0 cannot reach the base: a 2nd unit
    # brings it home (no target fits in 2), and that is all it gets back.
    graph = uav_7_2_spec()
    s = state(graph, [3, 0], [4, 0], time=2)
    plan = planner(graph).plan(s)
    assert plan.cbba_runs == 2 and plan.fuel.tolist() == [2.0, 0.0]
    assert [p.tolist() for p in plan.paths] == [[], []]
    assert plan.destinations.tolist() == [1, 0]
    # The printed test alone hands back the whole reserve: UAV 0 loiters to retry target 3.
    spent = planner(graph, refuel="empty_plan").plan(s)
    assert spent.cbba_runs == 3 and spent.fuel.tolist() == [3.0, 0.0]
    assert [p.tolist() for p in spent.paths] == [[3], []]
    assert spent.destinations.tolist() == [3, 0]


def test_conservative_fuel_is_capped_at_the_real_fuel():
    # fuel 2 each at the base, empty plans: home is reachable, so nothing is added; with the
    # printed test alone fuel comes back 0 -> 1 -> 2 and stops at the real fuel.
    graph = uav_7_2_spec()
    s = state(graph, [0, 0], [2, 2])
    assert planner(graph).plan(s).fuel.tolist() == [0.0, 0.0]
    spent = planner(graph, refuel="empty_plan").plan(s)
    assert spent.cbba_runs == 3 and spent.fuel.tolist() == [2.0, 2.0]
    assert [p.tolist() for p in spent.paths] == [[2], []]
    assert spent.destinations.tolist() == [2, 0]


#: One UAV on a line 0 - 1 - 2 with a sure target of 100 at node 2 and 4 fuel: a round trip
#: to the target takes all of it.
LINE = {
    "num_nodes": 3,
    "edges": [[0, 1], [1, 2]],
    "fuel": [4],
    "horizon": 6,
    "targets": {2: {"reward": 100.0}},
}


def test_the_reserve_holds_under_replanning_and_the_printed_test_spends_it():
    # Mid-mission, UAV at node 1 (one hop from home) with 3 fuel at t = 1. fuel - 3 = 0 does
    # not reach the base, so it gets one unit, with which no target fits: it flies home with
    # 2 units to spare. The printed test alone gives back all 3 and sends it to node 2, where
    # it has 2 fuel for the 2 hops home: no reserve left.
    domain = UAVMission(graph=LINE)
    graph = domain.graph_
    s = np.array([1.0, 3.0, 0.0, 0.0, 0.0, 1.0])
    kept = planner(graph).plan(s)
    assert kept.destinations.tolist() == [0] and kept.fuel.tolist() == [1.0]
    assert kept.cbba_runs == 2
    spent = planner(graph, refuel="empty_plan").plan(s)
    assert spent.destinations.tolist() == [2] and spent.fuel.tolist() == [3.0]
    after = domain.nominal_next_state(s, spent.action)
    assert graph.fuels(after)[0] == graph.distances[2, 0] == 2


def test_the_printed_test_crashes_where_the_reserve_stays_home():
    # Exact evaluation with 5% traverse failures, replanning at every step. With the reserve
    # held, fuel 4 - 3 = 1 reaches no target from the base, so the UAV stays: nothing gained,
    # nothing lost. The printed test spends the reserve on the round trip: it reaches node 2
    # (0.95²), then either return move fails (1 - 0.95²) and it lands one unit short; a UAV
    # that failed 1 -> 2 turns home with 2 fuel and still crashes after two more failures.
    eta = 0.05
    domain = UAVMission(graph=LINE, traverse_failure=eta)
    kept = domain.evaluate_policy(planner(domain.graph_).action)
    assert kept.value == 0.0 and kept.crash_probability == 0.0
    spent = domain.evaluate_policy(planner(domain.graph_, refuel="empty_plan").action)
    crash = (1 - eta) ** 2 * (1 - (1 - eta) ** 2) + (1 - eta) * eta**3
    assert spent.crash_probability == pytest.approx(crash, rel=1e-12)
    assert spent.crash_probability > 0.08


@pytest.mark.parametrize("refuel", ["home", "empty_plan"])
def test_conservative_crash_rates_on_the_spec_graph(refuel):
    # Spec 2.2's UAV 7-2 at 5% traverse failures, evaluated exactly: the printed test erodes
    # the reserve (issue 19 measured 17.5% crashes by simulation); the held reserve does not.
    domain = UAVMission(scenario="uav-7-2-spec", traverse_failure=0.05)
    result = domain.evaluate_policy(planner(domain.graph_, refuel=refuel).action)
    if refuel == "home":
        assert result.crash_probability < 0.01
    else:
        assert 0.15 < result.crash_probability < 0.2


def test_conservative_keeps_the_reserve_when_every_uav_has_a_plan():
    graph = uav_7_2_spec()
    plan = planner(graph, fuel_reserve=0).plan(graph.initial_state())
    aggressive = planner(graph, variant="aggressive").plan(graph.initial_state())
    assert plan.cbba_runs == 1
    assert [p.tolist() for p in plan.paths] == [p.tolist() for p in aggressive.paths]


def test_a_uav_at_the_base_waits_there_when_it_is_early():
    # UAV 10-2 of spec 2.2: UAV 0's path ends at target 9 (window [5, 8]); leaving at once
    # would reach 9 at 4 and wait there, burning 9 fuel; leaving at t = 1 burns 8, all it has.
    graph = uav_10_2_spec()
    plan = planner(graph, variant="aggressive").plan(graph.initial_state())
    assert plan.paths[0].tolist()[-1] == 9
    assert plan.allocation.departures[0] == 1.0 and plan.allocation.returns[0] == 9.0
    assert plan.arrivals[0][0] == 1.0 + graph.distances[graph.base, plan.paths[0][0]]
    assert plan.arrivals[0][-1] == 5.0  # target 9 as its window opens, home at 9
    assert plan.destinations[0] == graph.base


def test_a_uav_on_an_unvisited_target_loiters_to_try_again():
    # spec 2.2's UAV 7-2: UAV 0 stands on target 4 at t = 2 (its draw failed); the others
    # are visited
    graph = uav_7_2_spec()
    s = state(graph, [4, 0], [4, 0], time=2, visited=[2, 3, 5, 6])
    plan = planner(graph, variant="aggressive").plan(s)
    assert plan.paths[0].tolist() == [4] and plan.arrivals[0].tolist() == [3.0]
    assert plan.destinations.tolist() == [4, 0]


def test_visited_targets_are_not_planned():
    graph = uav_7_2_spec()
    plan = planner(graph, variant="aggressive").plan(
        state(graph, [0, 0], [6, 6], visited=[2, 3, 4, 5, 6])
    )
    assert plan.task_nodes.size == 0 and plan.destinations.tolist() == [0, 0]


def test_without_fuel_everyone_goes_home():
    graph = uav_10_2_spec()
    p = planner(graph, variant="aggressive")
    at_base = p.plan(state(graph, [0, 0], [0, 0]))
    assert at_base.destinations.tolist() == [0, 0]
    # away from the base with just enough (UAV 0) or too little (UAV 1) fuel to get home;
    # target 9 is still open but out of reach
    visited = [2, 4, 5, 6, 7, 8]
    away = p.plan(state(graph, [5, 9], [3, 2], time=3, visited=visited))
    assert away.task_nodes.tolist() == [9]
    assert all(len(path) == 0 for path in away.paths)
    for here, there in zip([5, 9], away.destinations, strict=True):
        assert graph.distances[there, 0] == graph.distances[here, 0] - 1


# ----------------------------------------------------------------------------- policy properties


def reachable_states(graph: MissionGraph, count: int, seed: int):
    """States met by random legal walks that keep the fuel check, from s0."""
    rng = np.random.default_rng(seed)
    out = []
    while len(out) < count:
        s = graph.initial_state()
        for _ in range(int(rng.integers(0, graph.horizon))):
            moves = []
            for here in graph.locations(s):
                options = [here, *graph.neighbours[here][graph.neighbours[here] >= 0]]
                moves.append(int(rng.choice(options)))
            nxt = step(graph, s, graph.encode_action(moves), rng)
            if not is_fuel_safe(graph, nxt):
                break
            s = nxt
        out.append(s)
    return out


@pytest.mark.parametrize("make_graph", [uav_7_2, uav_10_2])
@pytest.mark.parametrize("variant", ["aggressive", "conservative"])
def test_first_moves_follow_shortest_paths_and_keep_the_fuel_check(make_graph, variant):
    graph = make_graph()
    p = planner(graph, variant=variant)
    for s in reachable_states(graph, 150, seed=5):
        plan = p.plan(s)
        for i, (here, there) in enumerate(zip(graph.locations(s), plan.destinations, strict=True)):
            assert there == here or there in graph.neighbours[here]  # a legal move
            goal = plan.paths[i][0] if len(plan.paths[i]) else graph.base
            if there != here:
                assert graph.distances[there, goal] == graph.distances[here, goal] - 1
        alloc = plan.allocation
        for nodes, arrivals in zip(plan.paths, plan.arrivals, strict=True):
            assert np.all(arrivals >= graph.time(s) + 1)
            start, end = graph.windows[nodes, 0], graph.windows[nodes, 1]
            assert np.all((start <= arrivals) & (arrivals <= end))
        planned = [len(path) > 0 for path in plan.paths]
        assert np.all(alloc.returns[planned] <= graph.horizon)
        assert np.all(alloc.fuel_used[planned] <= plan.fuel[planned])
        assert np.all(plan.fuel <= graph.fuels(s))
        assert is_fuel_safe(graph, step(graph, s, plan.action, np.random.default_rng(0)))
        assert alloc.converged and alloc.is_conflict_free


@pytest.mark.parametrize("make_graph", [uav_7_2, uav_10_2])
@pytest.mark.parametrize("variant", ["aggressive", "conservative"])
def test_following_the_planner_brings_every_uav_home(make_graph, variant):
    graph = make_graph()
    p = planner(graph, variant=variant)
    rng = np.random.default_rng(11)
    for _ in range(40):
        s = graph.initial_state()
        for _ in range(graph.horizon):
            s = step(graph, s, p.action(s), rng)
            assert is_fuel_safe(graph, s)
        assert np.all(graph.locations(s) == graph.base) and np.all(graph.fuels(s) >= 0)


def test_aggressive_collects_more_than_conservative_on_uav_7_2():
    graph = uav_7_2()
    totals = {}
    for variant in ("aggressive", "conservative"):
        p, rng, total = planner(graph, variant=variant), np.random.default_rng(3), 0.0
        for _ in range(200):
            s = graph.initial_state()
            for _ in range(graph.horizon):
                s = step(graph, s, p.action(s), rng)
            total += float(graph.rewards @ graph.visited(s))
        totals[variant] = total
    assert totals["aggressive"] > totals["conservative"] > 0


# ----------------------------------------------------------------------------- cache, determinism


def test_same_state_same_plan():
    graph = uav_10_2()
    states = reachable_states(graph, 40, seed=9)
    first, second = planner(graph), planner(graph)
    for s in states:
        a, b = first.plan(s), second.plan(s)
        assert a.action == b.action == first.action(s) == first.action(s.copy())
        assert [x.tolist() for x in a.paths] == [x.tolist() for x in b.paths]


def test_cache_is_bounded_and_never_changes_an_answer():
    graph = uav_7_2()
    states = reachable_states(graph, 30, seed=1)
    bounded, uncached = planner(graph, cache_size=4), planner(graph, cache_size=0)
    cached = []
    for s in states:
        assert bounded.action(s) == uncached.action(s)
        cached.append(bounded.num_cached_)
    assert len({s.tobytes() for s in states}) > 4
    assert max(cached) == 4  # filled up to its size ...
    assert any(now < before for before, now in itertools.pairwise(cached))  # emptied, refilled
    assert uncached.num_cached_ == 0
    for s in states:  # a second pass answers alike, from the cache or not
        assert bounded.action(s) == uncached.action(s)


def test_update_never_changes_the_plan():
    graph = uav_7_2()
    p = planner(graph)
    assert p.update(model_of(graph)) is False


# ----------------------------------------------------------------------------- errors


def test_setup_needs_a_mission_graph():
    with pytest.raises(IncompatibleComponentsError, match="MissionGraph"):
        CBBAPlanner().setup(SimpleNamespace(domain_=object()), seed=0)


def test_action_before_setup():
    with pytest.raises(NotSetUpError):
        CBBAPlanner().action(uav_7_2().initial_state())


@pytest.mark.parametrize(
    "bad",
    [
        np.zeros(5),
        np.array([9.0, 6, 0, 6, 0, 0, 0, 0, 0, 0, 0, 0]),  # node 9 of a 7-node graph
        np.array([0.0, -1, 0, 6, 0, 0, 0, 0, 0, 0, 0, 0]),  # negative fuel
        np.array([0.0, 6, 0, 6, 0, 0, 0, 0, 0, 0, 0, 0.5]),  # fractional time
    ],
)
def test_bad_states_are_rejected(bad):
    with pytest.raises(InvalidParameterError, match="CBBAPlanner"):
        planner(uav_7_2()).action(bad)


@pytest.mark.parametrize(
    ("name", "value"),
    [("variant", "greedy"), ("fuel_reserve", -1), ("refuel", "always"), ("cache_size", 1.5)],
)
def test_bad_parameters(name, value):
    with pytest.raises(InvalidParameterError, match=name):
        CBBAPlanner(**{name: value}).setup(model_of(uav_7_2()), seed=0)


@pytest.mark.parametrize("make_graph", [uav_7_2_spec, uav_10_2_spec])
def test_no_uav_is_planned_with_more_than_its_reserved_fuel_or_its_way_home(make_graph):
    # Issue 22: read as "Plan[u] = ∅ (an empty bundle) gets fuel", Algorithm 27 hands an idle
    # UAV its whole reserve, late in a mission with nothing left to do as anywhere else. The
    # default reading gives fuel back only to bring a UAV home: in any state, each UAV is
    # planned with at most max(fuel - reserve, its distance home), never its reserve.
    graph = make_graph()
    rng = np.random.default_rng(0)
    reserve, n = 3, graph.num_uavs
    exceeded = {"home": 0, "empty_plan": 0}
    for _ in range(300):
        locations = rng.integers(graph.num_nodes, size=n)
        fuels = [int(rng.integers(0, f + 1)) for f in graph.fuel]
        time = int(rng.integers(0, graph.horizon + 1))
        visited = np.flatnonzero(rng.random(graph.num_nodes) < 0.3)
        s = state(graph, locations, fuels, time, visited)
        for refuel in exceeded:
            planned = planner(graph, refuel=refuel, fuel_reserve=reserve).plan(s).fuel
            for i in range(n):
                home = graph.distances[locations[i], graph.base]
                allowed = min(fuels[i], max(fuels[i] - reserve, home))
                exceeded[refuel] += int(planned[i] > allowed)
    assert exceeded["home"] == 0
    assert exceeded["empty_plan"] > 0  # the printed test alone spends the reserve


def test_an_idle_uav_at_the_base_late_in_the_mission_keeps_its_reserve():
    # Every target's window has closed: both UAVs are idle at the base with full tanks.
    graph = uav_7_2_spec()
    late = state(graph, [0, 0], list(graph.fuel), time=graph.horizon - 1)
    kept = planner(graph).plan(late)
    assert [p.tolist() for p in kept.paths] == [[], []] and kept.cbba_runs == 1
    assert kept.fuel.tolist() == [f - 3.0 for f in graph.fuel]
    spent = planner(graph, refuel="empty_plan").plan(late)
    assert spent.fuel.tolist() == [float(f) for f in graph.fuel]  # the reserve handed back
