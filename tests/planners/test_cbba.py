"""Tests of CBBA: a hand-checked allocation, Table I, bundle release, equality with greedy."""

from __future__ import annotations

import math

import numpy as np
import pytest

from conjure.core.errors import InvalidParameterError
from conjure.planners._cbba_kernels import (
    LEAVE,
    NONE,
    RESET,
    UPDATE,
    consensus_action,
    consensus_round,
    release_bundle,
)
from conjure.planners.cbba import CBBA, Allocation

LINE = np.abs(np.subtract.outer(np.arange(5), np.arange(5))).astype(float)  # 0-1-2-3-4


def paths(allocation: Allocation) -> list[list[int]]:
    return [p.tolist() for p in allocation.paths]


# ----------------------------------------------------------------------------- hand-checked


def three_tasks(fuel_of_first_agent: int) -> Allocation:
    """Line 0-1-2-3-4, base 0, t = 0, horizon 10; A0 has the given fuel, A1 has 8.

    T0 at 2 worth 10 with window [3, 5]; T1 at 4 worth 30; T2 at 1 worth 20.
    """
    return CBBA().allocate(
        distances=LINE,
        agent_locations=[0, 0],
        agent_fuel=[fuel_of_first_agent, 8],
        task_locations=[2, 4, 1],
        task_values=[10.0, 30.0, 20.0],
        task_windows=[[3, 5], [0, 10], [0, 10]],
        horizon=10,
    )


def test_two_agents_three_tasks_by_hand():
    # A0 has fuel 4. Greedy: T1 (30) needs a round trip of 8; only A1 has it: A1 = [T1],
    # reaching it at 4 and back at 8.
    # T2 (20): A0 [T2] and A1 [T2, T1] both feasible, equal bids -> lower index: A0 = [T2].
    # T0 (10): A0 [T2, T0] reaches T0 at 3 (2 + a wait) and is back at 5; waiting at the base
    # for free it leaves at 1, so it burns 5 - 1 = 4 <= 4 fuel: feasible, tie with A1 -> A0.
    # [T0, T2] (T0 at 3, T2 at 4, back at 5, leaving at 1) burns the same and returns as
    # early, so the earlier insertion position wins: A0's path is [T0, T2].
    # All 60 is collected, the optimum.
    allocation = three_tasks(fuel_of_first_agent=4)
    assert paths(allocation) == [[0, 2], [1]]
    assert [b.tolist() for b in allocation.bundles] == [[2, 0], [1]]
    assert [a.tolist() for a in allocation.arrivals] == [[3.0, 4.0], [4.0]]
    assert allocation.departures.tolist() == [1.0, 0.0]
    assert allocation.returns.tolist() == [5.0, 8.0]
    assert allocation.fuel_used.tolist() == [4.0, 8.0]
    assert allocation.assignment.tolist() == [0, 1, 0]
    assert allocation.converged and allocation.is_conflict_free
    assert np.all(allocation.winners == [[0, 1, 0], [0, 1, 0]])  # consensus reached


def test_less_fuel_hands_the_windowed_task_to_the_other_agent():
    # A0 has fuel 3: [T2, T0] and [T0, T2] both burn 4 > 3, so T0 goes to A1,
    # whose [T0, T1] reaches T0 at 3 and T1 at 5 and is back at 9, leaving the base at 1.
    allocation = three_tasks(fuel_of_first_agent=3)
    assert paths(allocation) == [[2], [0, 1]]
    assert allocation.arrivals[1].tolist() == [3.0, 5.0]
    assert allocation.departures[1] == 1.0 and allocation.returns[1] == 9.0


def test_horizon_and_window_end_make_tasks_infeasible():
    allocation = CBBA().allocate(
        distances=LINE,
        agent_locations=[0],
        agent_fuel=[100],
        task_locations=[4, 2],
        task_values=[5.0, 5.0],
        task_windows=[[0, 10], [0, 1]],  # T1 at 2 cannot be reached by 1
        horizon=7,  # T0 at 4 needs 8 steps there and back
    )
    assert paths(allocation) == [[]]
    assert allocation.returns.tolist() == [0.0]


def test_equal_bids_go_to_the_lower_index_and_fuel_weight_to_the_nearer_agent():
    common = dict(distances=LINE, agent_fuel=[10, 10], task_locations=[3], task_values=[9.0])
    assert paths(CBBA().allocate(agent_locations=[0, 2], **common)) == [[0], []]
    # with ρ = 1 A0 bids 9 - 3 = 6 and A1 (one hop away) bids 9 - 1 = 8
    weighted = CBBA(fuel_weight=1.0).allocate(agent_locations=[0, 2], base=0, **common)
    assert paths(weighted) == [[], [0]]
    assert weighted.bids[0, 0] == 8.0 and weighted.winners[0, 0] == 1


def test_time_discount_scores_insertion_positions():
    # λ = ln 2 halves a task's value per step after its window opens (both open at 0).
    # Task A at 1 bids 10/2 = 5 and B at 3 bids 10/8 = 1.25, so A comes first. B after A
    # gains 1.25; B before A (A then reached at 5) gains 1.25 + 10/32 - 5 < 0: B goes last.
    allocation = CBBA(time_discount=math.log(2.0)).allocate(
        distances=LINE, agent_locations=[0], agent_fuel=[10], task_locations=[1, 3],
        task_values=[10.0, 10.0],
    )  # fmt: skip
    assert paths(allocation) == [[0, 1]]
    assert allocation.bids[0].tolist() == pytest.approx([5.0, 1.25])


def test_bundle_limit():
    allocation = CBBA(max_bundle_size=1).allocate(
        distances=LINE, agent_locations=[0, 0], agent_fuel=[10, 10], task_locations=[1, 2, 3],
        task_values=[3.0, 2.0, 1.0],
    )  # fmt: skip
    assert paths(allocation) == [[0], [1]]


def test_giving_up_is_reported():
    allocation = CBBA(max_rounds=1).allocate(
        distances=LINE, agent_locations=[0, 0], agent_fuel=[10, 10], task_locations=[1, 2],
        task_values=[3.0, 2.0],
    )  # fmt: skip
    assert allocation.rounds == 1 and not allocation.converged
    assert not allocation.is_conflict_free  # both agents still claim both tasks


# ----------------------------------------------------------------------------- Table I

RECEIVER, SENDER, M, N = 0, 1, 2, 3  # i, k and two third agents m, n
ROLE = {"i": RECEIVER, "k": SENDER, "m": M, "n": N, "none": NONE}

# (case, sender thinks, receiver thinks, y_kj, y_ij, newer(m), newer(n), expected)
TABLE = [
    (1, "k", "i", 5.0, 4.0, False, False, UPDATE),
    (1, "k", "i", 4.0, 5.0, False, False, LEAVE),
    (1, "k", "i", 5.0, 5.0, False, False, LEAVE),  # equal bids: the lower index i keeps it
    (2, "k", "k", 1.0, 5.0, False, False, UPDATE),
    (3, "k", "m", 1.0, 5.0, True, False, UPDATE),
    (3, "k", "m", 6.0, 5.0, False, False, UPDATE),
    (3, "k", "m", 4.0, 5.0, False, False, LEAVE),
    (4, "k", "none", 1.0, 0.0, False, False, UPDATE),
    (5, "i", "i", 1.0, 5.0, True, True, LEAVE),
    (6, "i", "k", 1.0, 5.0, False, False, RESET),
    (7, "i", "m", 1.0, 5.0, True, False, RESET),
    (7, "i", "m", 1.0, 5.0, False, False, LEAVE),
    (8, "i", "none", 1.0, 0.0, True, True, LEAVE),
    (9, "m", "i", 6.0, 5.0, True, False, UPDATE),
    (9, "m", "i", 4.0, 5.0, True, False, LEAVE),
    (9, "m", "i", 6.0, 5.0, False, False, LEAVE),
    (10, "m", "k", 1.0, 5.0, True, False, UPDATE),
    (10, "m", "k", 1.0, 5.0, False, False, RESET),
    (11, "m", "m", 1.0, 5.0, True, False, UPDATE),
    (11, "m", "m", 9.0, 5.0, False, False, LEAVE),
    (12, "m", "n", 1.0, 5.0, True, True, UPDATE),
    (12, "m", "n", 6.0, 5.0, True, False, UPDATE),
    (12, "m", "n", 4.0, 5.0, True, False, LEAVE),
    (12, "m", "n", 9.0, 5.0, False, True, RESET),
    (12, "m", "n", 9.0, 5.0, False, False, LEAVE),
    (13, "m", "none", 1.0, 0.0, True, False, UPDATE),
    (13, "m", "none", 1.0, 0.0, False, False, LEAVE),
    (14, "none", "i", 0.0, 5.0, True, True, LEAVE),
    (15, "none", "k", 0.0, 5.0, False, False, UPDATE),
    (16, "none", "m", 0.0, 5.0, True, False, UPDATE),
    (16, "none", "m", 0.0, 5.0, False, True, LEAVE),
    (17, "none", "none", 0.0, 0.0, True, True, LEAVE),
]


@pytest.mark.parametrize(
    ("case", "sender", "receiver", "sender_bid", "bid", "newer_m", "newer_n", "expected"),
    TABLE,
    ids=[f"case{row[0]}-{row[1]}/{row[2]}-{row[7]}-{n}" for n, row in enumerate(TABLE)],
)
def test_consensus_table(case, sender, receiver, sender_bid, bid, newer_m, newer_n, expected):
    stamps = np.full(4, 5.0)
    sender_stamps = stamps.copy()
    sender_stamps[M] += 1.0 if newer_m else -1.0
    sender_stamps[N] += 1.0 if newer_n else 0.0  # equal stamps are not newer
    action = consensus_action(
        RECEIVER, SENDER, ROLE[sender], sender_bid, ROLE[receiver], bid, sender_stamps, stamps
    )
    assert action == expected


def test_table_covers_all_seventeen_cases():
    assert sorted({row[0] for row in TABLE}) == list(range(1, 18))


def test_equal_bids_update_towards_a_lower_index_sender():
    # receiver 1 thinks it wins at 5; sender 0 thinks it wins at 5: lower index 0 wins
    assert consensus_action(1, 0, 0, 5.0, 1, 5.0, np.zeros(2), np.zeros(2)) == UPDATE


def test_consensus_round_time_stamps_on_a_line():
    # agents 0 - 1 - 2 (0 and 2 do not talk); agent 2 knows about agent 0 from round 3
    adjacency = np.array([[0, 1, 0], [1, 0, 1], [0, 1, 0]], dtype=bool)
    bids, winners = np.zeros((3, 1)), np.full((3, 1), NONE)
    stamps = np.zeros((3, 3))
    stamps[1, 0] = 3.0
    consensus_round(bids, winners, stamps, adjacency, 4)
    assert stamps[0].tolist() == [0.0, 4.0, 0.0]  # s_01 = round
    assert stamps[1].tolist() == [4.0, 0.0, 4.0]
    assert stamps[2].tolist() == [3.0, 4.0, 0.0]  # s_20 = s_10 relayed by 1


def test_consensus_round_spreads_the_highest_bid():
    bids = np.array([[7.0], [0.0], [9.0]])
    winners = np.array([[0], [NONE], [2]])
    stamps = np.zeros((3, 3))
    consensus_round(bids, winners, stamps, np.ones((3, 3), dtype=bool), 1)
    assert winners.ravel().tolist() == [2, 2, 2] and bids.ravel().tolist() == [9.0, 9.0, 9.0]


# ----------------------------------------------------------------------------- bundle release


def test_bundle_release_drops_the_lost_task_and_resets_later_ones():
    bundles = np.array([[4, 1, 2, 0]])
    paths_ = np.array([[2, 4, 0, 1]])  # execution order
    bundle_len = np.array([4])
    winners = np.array([[0, 1, 0, NONE, 0]])  # task 1 (2nd in b) was lost to agent 1
    bids = np.array([[3.0, 8.0, 5.0, 0.0, 9.0]])
    winners[0, 0] = 2  # task 0 (4th in b) is already known to be agent 2's
    bids[0, 0] = 6.0
    assert release_bundle(0, bundles, bundle_len, paths_, bids, winners)
    assert bundle_len[0] == 1
    assert bundles[0].tolist() == [4, NONE, NONE, NONE]
    assert paths_[0].tolist() == [4, NONE, NONE, NONE]
    assert winners[0].tolist() == [2, 1, NONE, NONE, 0]  # task 2 reset, 0 and 1 kept
    assert bids[0].tolist() == [6.0, 8.0, 0.0, 0.0, 9.0]


def test_bundle_release_keeps_a_bundle_it_still_wins():
    bundles, paths_ = np.array([[1, 0]]), np.array([[0, 1]])
    bundle_len = np.array([2])
    winners, bids = np.array([[0, 0]]), np.array([[2.0, 3.0]])
    assert not release_bundle(0, bundles, bundle_len, paths_, bids, winners)
    assert bundle_len[0] == 2 and paths_[0].tolist() == [0, 1]


# ----------------------------------------------------------------------------- sequential greedy


def reference_schedule(dist, location, fuel, path, locs, windows, horizon):
    """(arrivals, return, departure) of a feasible path (base 0, t = 0), else None.

    Straight from the rules in CBBA's docstring; an agent at the base tries every departure.
    """
    departures = range(int(horizon) + 1) if location == 0 and path else [0]
    best = None
    for departure in departures:
        t, here, arrivals = departure, location, []
        for task in path:
            t = max(windows[task][0], t + dist[here, locs[task]])
            arrivals.append(t)
            here = locs[task]
        back = t + dist[here, 0]
        on_time = all(a <= windows[task][1] for a, task in zip(arrivals, path, strict=True))
        if best is not None and back > best[1]:
            break  # leaving later would return later
        if on_time and (best is None or back <= best[1]):
            best = (arrivals, back, departure)
    if best is None or (path and best[1] > horizon) or (path and best[1] - best[2] > fuel):
        return None
    return best


def sequential_greedy(dist, agent_locs, fuel, locs, values, windows, horizon, rho):
    """Sequential greedy assignment with CBBA's tie rules."""
    n = len(agent_locs)
    paths_ = [[] for _ in range(n)]
    free = set(range(len(locs)))
    while True:
        best = None
        for i in range(n):
            for task in sorted(free):
                options = []
                for position in range(len(paths_[i]) + 1):
                    path = [*paths_[i][:position], task, *paths_[i][position:]]
                    result = reference_schedule(
                        dist, agent_locs[i], fuel[i], path, locs, windows, horizon
                    )
                    if result is not None:
                        _, back, departure = result
                        options.append((back - departure, back, position))
                gain = values[task] - rho * dist[agent_locs[i], locs[task]]
                if not options or gain <= 0:
                    continue
                rank = (-gain, i, windows[task][0], task)
                if best is None or rank < best[0]:
                    best = (rank, i, task, min(options)[2])
        if best is None:
            return paths_
        _, i, task, position = best
        paths_[i].insert(position, task)
        free.remove(task)


def random_problem(rng):
    num_locations = int(rng.integers(3, 7))
    points = rng.integers(0, 4, size=(num_locations, 2))
    dist = np.abs(points[:, None, :] - points[None, :, :]).sum(axis=2).astype(float)
    n, m = int(rng.integers(2, 4)), int(rng.integers(2, 7))
    agent_locs = rng.integers(0, num_locations, size=n).tolist()
    fuel = rng.integers(2, 16, size=n).tolist()
    locs = rng.integers(1, num_locations, size=m).tolist()
    values = rng.integers(1, 6, size=m).astype(float).tolist()  # small values force ties
    starts = rng.integers(0, 6, size=m)
    windows = np.column_stack([starts, starts + rng.integers(0, 8, size=m)]).tolist()
    return dist, agent_locs, fuel, locs, values, windows, 14


@pytest.mark.parametrize("rho", [0.0, 1.0])
def test_cbba_reproduces_sequential_greedy(rho):
    rng = np.random.default_rng(2009)
    nontrivial = 0
    for _ in range(150):
        dist, agent_locs, fuel, locs, values, windows, horizon = random_problem(rng)
        allocation = CBBA(fuel_weight=rho).allocate(
            distances=dist, agent_locations=agent_locs, agent_fuel=fuel, task_locations=locs,
            task_values=values, task_windows=windows, horizon=horizon,
        )  # fmt: skip
        expected = sequential_greedy(dist, agent_locs, fuel, locs, values, windows, horizon, rho)
        assert paths(allocation) == expected
        assert allocation.converged and allocation.is_conflict_free
        nontrivial += sum(len(p) > 0 for p in expected) > 1
    assert nontrivial > 30  # many instances really share tasks between agents


def test_a_line_network_reaches_the_same_assignment():
    rng = np.random.default_rng(7)
    line = np.array([[0, 1, 0], [1, 0, 1], [0, 1, 0]], dtype=bool)
    for _ in range(60):
        dist, agent_locs, fuel, locs, values, windows, horizon = random_problem(rng)
        if len(agent_locs) != 3:
            continue
        problem = dict(
            distances=dist, agent_locations=agent_locs, agent_fuel=fuel, task_locations=locs,
            task_values=values, task_windows=windows, horizon=horizon,
        )  # fmt: skip
        full = CBBA().allocate(**problem)
        relayed = CBBA().allocate(communication=line, **problem)
        assert paths(relayed) == paths(full) and relayed.converged


# ----------------------------------------------------------------------------- validation


@pytest.mark.parametrize(
    ("change", "named"),
    [
        ({"distances": np.ones((2, 3))}, "distances"),
        ({"distances": -LINE}, "distances"),
        ({"agent_locations": [0, 9]}, "agent_locations"),
        ({"agent_fuel": [1]}, "agent_fuel"),
        ({"task_windows": [[3, 1]]}, "task_windows"),
        ({"task_values": [np.nan]}, "task_values"),
        ({"communication": np.ones((3, 3), dtype=bool)}, "communication"),
        ({"base": 7}, "base"),
        ({"time": "now"}, "time"),
    ],
)
def test_bad_problems_name_the_argument(change, named):
    problem = dict(
        distances=LINE, agent_locations=[0, 1], agent_fuel=[3, 3], task_locations=[2],
        task_values=[1.0],
    )  # fmt: skip
    with pytest.raises(InvalidParameterError, match=f"`{named}`"):
        CBBA().allocate(**{**problem, **change})
