"""Numba kernels of CBBA (Choi, Brunet & How 2009) and of conservative CBBA (Algorithm 27).

Layout of the packed arrays (all float64 so that one kernel signature serves every problem):

- ``distances`` (L, L): travel time between locations (hop counts on a mission graph);
- ``agents`` (n, 2): per agent ``[location, fuel]``;
- ``tasks`` (m, 4): per task ``[location, value, window start, window end]``;
- ``settings`` (3,): ``[min_first_leg, time_discount λ, fuel_weight ρ]``.

Per-agent beliefs are ``bids`` y (n, m), ``winners`` z (n, m; `NONE` = nobody) and
``stamps`` s (n, n); bundles and paths are (n, L_t) int64 rows padded with -1.
Parameters are validated by the callers (`conjure.planners.cbba`, `.cbba_planner`).
"""

from __future__ import annotations

import numpy as np
from numba import njit

NONE = -1
LEAVE, UPDATE, RESET = 0, 1, 2
LOC, VALUE, START, END = 0, 1, 2, 3
LOCATION, FUEL = 0, 1
MIN_FIRST_LEG, TIME_DISCOUNT, FUEL_WEIGHT = 0, 1, 2


# --------------------------------------------------------------------------- scoring (Phase 1)


@njit(cache=True)
def forward_pass(distances, here, t, path, path_len, tasks, settings, arrivals):
    """Leave ``here`` at ``t`` and reach each task at max(window start, t + travel).

    Return (every arrival within its window, time at the last task, last location).
    """
    for k in range(path_len):
        task = path[k]
        node = int(tasks[task, LOC])
        travel = distances[here, node]
        if k == 0 and travel < settings[MIN_FIRST_LEG]:
            travel = settings[MIN_FIRST_LEG]
        t = max(tasks[task, START], t + travel)
        if t > tasks[task, END]:
            return False, t, node
        arrivals[k] = t
        here = node
    return True, t, here


@njit(cache=True)
def schedule(distances, agents, i, path, path_len, tasks, base, now, horizon, settings, arrivals):
    """Arrival times of agent ``i`` along ``path[:path_len]``; return (feasible, return, departure).

    Each task is reached at max(window start, previous arrival + travel) (loitering allowed);
    the path is feasible when every arrival is within its window, the agent is back at
    ``base`` by ``horizon`` and the fuel it burns, (return − departure), is within its fuel.
    An agent at the base departs as late as its earliest return time allows (loitering at the
    base is free); anywhere else it departs now. ``arrivals[:path_len]`` receives the arrival
    times after that departure.
    """
    location = int(agents[i, LOCATION])
    ok, t, here = forward_pass(distances, location, now, path, path_len, tasks, settings, arrivals)
    if not ok:
        return False, np.inf, now
    back = t + distances[here, base]
    if path_len == 0:
        return True, back, now
    if back > horizon:
        return False, back, now
    departure = now
    if location == base:
        latest = back  # backward pass: the latest arrivals that still return at `back`
        after = base
        for k in range(path_len - 1, -1, -1):
            node = int(tasks[path[k], LOC])
            latest = min(tasks[path[k], END], latest - distances[node, after])
            after = node
        departure = latest - max(distances[base, after], settings[MIN_FIRST_LEG])
        if departure > now:  # feasible again, and back by `back` (latest-start argument)
            forward_pass(distances, base, departure, path, path_len, tasks, settings, arrivals)
    return back - departure <= agents[i, FUEL], back, departure


@njit(cache=True)
def path_score(distances, agents, i, path, path_len, tasks, settings, arrivals):
    """S_i(p) = Σ_j value_j·exp(−λ(arrival_j − start_j)) − ρ·d(agent, task_j) (ACL's score)."""
    location = int(agents[i, LOCATION])
    score = 0.0
    for k in range(path_len):
        task = path[k]
        value = tasks[task, VALUE]
        if settings[TIME_DISCOUNT] > 0.0:
            value *= np.exp(-settings[TIME_DISCOUNT] * (arrivals[k] - tasks[task, START]))
        score += value - settings[FUEL_WEIGHT] * distances[location, int(tasks[task, LOC])]
    return score


@njit(cache=True)
def best_insertion(
    distances, agents, i, path, path_len, current, task, tasks, base, now, horizon, settings,
    scratch, times,
):  # fmt: skip
    """c_ij and n_ij: the best marginal score of inserting ``task`` into the path, and where.

    ``current`` is S_i(path). Infeasible positions are skipped; ties go to the least fuel
    burnt, then the earliest return, then the earliest position. Return (found, gain, position).
    """
    found, best_gain, best_fuel, best_back, best_position = False, 0.0, 0.0, 0.0, -1
    for position in range(path_len + 1):
        for k in range(position):
            scratch[k] = path[k]
        scratch[position] = task
        for k in range(position, path_len):
            scratch[k + 1] = path[k]
        ok, back, departure = schedule(
            distances, agents, i, scratch, path_len + 1, tasks, base, now, horizon, settings, times
        )
        if not ok:
            continue
        gain = path_score(distances, agents, i, scratch, path_len + 1, tasks, settings, times)
        gain -= current
        fuel = back - departure
        better = not found or gain > best_gain
        if found and gain == best_gain:
            better = fuel < best_fuel or (fuel == best_fuel and back < best_back)
        if better:
            found, best_gain, best_fuel, best_back, best_position = True, gain, fuel, back, position
    return found, best_gain, best_position


@njit(cache=True)
def build_bundle(
    distances, agents, i, tasks, base, now, horizon, settings,
    bundles, bundle_len, paths, bids, winners, max_bundle,
):  # fmt: skip
    """Phase 1 (bundle construction) for agent ``i``: add the best task while its bid wins.

    Return whether a new bid was placed.
    """
    m = tasks.shape[0]
    scratch = np.empty(max_bundle + 1, dtype=np.int64)
    times = np.empty(max_bundle + 1, dtype=np.float64)
    in_bundle = np.zeros(m, dtype=np.bool_)
    for k in range(bundle_len[i]):
        in_bundle[bundles[i, k]] = True
    placed = False
    while bundle_len[i] < max_bundle:
        chosen, chosen_gain, chosen_position = -1, 0.0, -1
        path, length = paths[i], bundle_len[i]
        schedule(distances, agents, i, path, length, tasks, base, now, horizon, settings, times)
        current = path_score(distances, agents, i, path, length, tasks, settings, times)
        for task in range(m):
            if in_bundle[task]:
                continue
            found, gain, position = best_insertion(
                distances, agents, i, path, length, current, task, tasks, base, now, horizon,
                settings, scratch, times,
            )  # fmt: skip
            if not found or gain <= 0.0:
                continue
            y, z = bids[i, task], winners[i, task]
            if not (gain > y or (gain == y and (z == NONE or i < z))):  # h_ij = 0
                continue
            if (
                chosen < 0
                or gain > chosen_gain
                or (gain == chosen_gain and tasks[task, START] < tasks[chosen, START])
            ):  # J = argmax c_ij h_ij; ties: earliest window start, then lowest index
                chosen, chosen_gain, chosen_position = task, gain, position
        if chosen < 0:
            break
        for k in range(length, chosen_position, -1):  # insert J into p_i at n_iJ
            paths[i, k] = paths[i, k - 1]
        paths[i, chosen_position] = chosen
        bundles[i, length] = chosen  # append J to b_i
        bundle_len[i] = length + 1
        in_bundle[chosen] = True
        bids[i, chosen] = chosen_gain
        winners[i, chosen] = i
        placed = True
    return placed


# --------------------------------------------------------------------------- consensus (Phase 2)


@njit(cache=True)
def outbids(bid, winner, other_bid, other_winner):
    """Whether (bid, winner) beats (other_bid, other_winner): higher bid, ties to lower index."""
    return bid > other_bid or (bid == other_bid and winner < other_winner)


@njit(cache=True)
def consensus_action(i, k, sender_winner, sender_bid, winner, bid, sender_stamps, stamps):
    """The action of receiver ``i`` on a message from ``k`` about one task (Table I, 17 cases).

    ``sender_winner``/``sender_bid`` are z_kj, y_kj; ``winner``/``bid`` are z_ij, y_ij;
    newer(m) means s_km > s_im. Return `LEAVE`, `UPDATE` or `RESET`.
    """
    if sender_winner == k:  # cases 1-4: the sender thinks it wins
        if winner == i:
            return UPDATE if outbids(sender_bid, k, bid, i) else LEAVE
        if winner == k or winner == NONE:
            return UPDATE
        if sender_stamps[winner] > stamps[winner] or outbids(sender_bid, k, bid, winner):
            return UPDATE
        return LEAVE
    if sender_winner == i:  # cases 5-8: the sender thinks the receiver wins
        if winner == k:
            return RESET
        if winner != i and winner != NONE and sender_stamps[winner] > stamps[winner]:
            return RESET
        return LEAVE
    if sender_winner == NONE:  # cases 14-17: the sender thinks nobody wins
        if winner == k:
            return UPDATE
        if winner != i and winner != NONE and sender_stamps[winner] > stamps[winner]:
            return UPDATE
        return LEAVE
    # cases 9-13: the sender thinks a third agent m wins
    m = sender_winner
    newer_m = sender_stamps[m] > stamps[m]
    if winner == i:
        return UPDATE if newer_m and outbids(sender_bid, m, bid, i) else LEAVE
    if winner == k:
        return UPDATE if newer_m else RESET
    if winner == m or winner == NONE:
        return UPDATE if newer_m else LEAVE
    newer_n = sender_stamps[winner] > stamps[winner]  # the receiver thinks a fourth agent n wins
    if newer_m and (newer_n or outbids(sender_bid, m, bid, winner)):
        return UPDATE
    if newer_n and not newer_m:
        return RESET
    return LEAVE


@njit(cache=True)
def consensus_round(bids, winners, stamps, adjacency, round_index):
    """One synchronous exchange of (y, z, s) over ``adjacency`` (k's message reaches i if [k, i]).

    Every receiver reads its neighbours' beliefs as they were at the start of the round and
    processes senders in increasing index, raising its time-stamps after each one. Return
    which receivers changed a bid or a winner.
    """
    n, m = bids.shape
    sent_bids, sent_winners, sent_stamps = bids.copy(), winners.copy(), stamps.copy()
    changed = np.zeros(n, dtype=np.bool_)
    for i in range(n):
        for k in range(n):
            if k == i or not adjacency[k, i]:
                continue
            for task in range(m):
                action = consensus_action(
                    i, k, sent_winners[k, task], sent_bids[k, task], winners[i, task],
                    bids[i, task], sent_stamps[k], stamps[i],
                )  # fmt: skip
                if action == UPDATE:
                    new_bid, new_winner = sent_bids[k, task], sent_winners[k, task]
                elif action == RESET:
                    new_bid, new_winner = 0.0, NONE
                else:
                    continue
                if new_bid != bids[i, task] or new_winner != winners[i, task]:
                    bids[i, task], winners[i, task] = new_bid, new_winner
                    changed[i] = True
            for other in range(n):
                if other != i and sent_stamps[k, other] > stamps[i, other]:
                    stamps[i, other] = sent_stamps[k, other]
            stamps[i, k] = round_index
    return changed


@njit(cache=True)
def release_bundle(i, bundles, bundle_len, paths, bids, winners):
    """Bundle release: drop the first task ``i`` no longer wins and every task added after it.

    The later tasks that ``i`` still believes it wins are reset (y = 0, z = none): their bids
    were conditioned on the lost task. Return whether anything was released.
    """
    cut = -1
    for position in range(bundle_len[i]):
        if winners[i, bundles[i, position]] != i:
            cut = position
            break
    if cut < 0:
        return False
    for position in range(cut + 1, bundle_len[i]):
        task = bundles[i, position]
        if winners[i, task] == i:
            bids[i, task] = 0.0
            winners[i, task] = NONE
    kept = 0
    for position in range(bundle_len[i]):
        task = paths[i, position]
        keep = False
        for b in range(cut):
            if bundles[i, b] == task:
                keep = True
        if keep:
            paths[i, kept] = task
            kept += 1
    for position in range(cut, bundle_len[i]):
        bundles[i, position] = NONE
        paths[i, position] = NONE
    bundle_len[i] = cut
    return True


# --------------------------------------------------------------------------- the CBBA loop


@njit(cache=True)
def run_cbba(
    distances, agents, tasks, adjacency, base, now, horizon, settings, max_bundle, max_rounds
):
    """CBBA: rounds of consensus, bundle release and bundle construction until convergence.

    Converged when no agent placed a new bid for more than n rounds; gives up after
    ``max_rounds``. An agent whose beliefs and bundle did not change since its last bundle
    construction skips it (it would place no bid). Return (bundles, bundle_len, paths,
    arrivals, departures, returns, bids, winners, rounds, converged).
    """
    n, m = agents.shape[0], tasks.shape[0]
    bundles = np.full((n, max(max_bundle, 1)), NONE, dtype=np.int64)
    paths = np.full((n, max(max_bundle, 1)), NONE, dtype=np.int64)
    bundle_len = np.zeros(n, dtype=np.int64)
    bids = np.zeros((n, m), dtype=np.float64)
    winners = np.full((n, m), NONE, dtype=np.int64)
    stamps = np.zeros((n, n), dtype=np.float64)
    rounds, last_bid, converged = 0, 0, False
    while rounds < max_rounds:
        rounds += 1
        changed = consensus_round(bids, winners, stamps, adjacency, rounds)
        placed = False
        for i in range(n):
            released = release_bundle(i, bundles, bundle_len, paths, bids, winners)
            if (rounds == 1 or changed[i] or released) and build_bundle(
                distances, agents, i, tasks, base, now, horizon, settings,
                bundles, bundle_len, paths, bids, winners, max_bundle,
            ):  # fmt: skip
                placed = True
        if placed:
            last_bid = rounds
        elif rounds - last_bid > n:
            converged = True
            break
    arrivals = np.full(paths.shape, np.nan)
    departures = np.empty(n)
    returns = np.empty(n)
    for i in range(n):
        _, back, departure = schedule(
            distances, agents, i, paths[i], bundle_len[i], tasks, base, now, horizon, settings,
            arrivals[i],
        )  # fmt: skip
        departures[i] = departure
        returns[i] = back
    return (
        bundles,
        bundle_len,
        paths,
        arrivals,
        departures,
        returns,
        bids,
        winners,
        rounds,
        converged,
    )


# --------------------------------------------------------------------------- UAV missions


@njit(cache=True)
def encode_destinations(destinations, num_nodes):
    """The joint action sending UAV i to ``destinations[i]``: Σ_i l_i⁺ N^i (Section 5.3.5)."""
    action = 0
    for i in range(destinations.shape[0] - 1, -1, -1):
        action = action * num_nodes + destinations[i]
    return action


@njit(cache=True)
def is_mission_state(state, num_uavs, num_nodes):
    """Whether ``state`` holds finite ints, nodes in [0, N), fuel >= 0 and time >= 0."""
    for k in range(state.shape[0]):
        if not (np.isfinite(state[k]) and state[k] == np.floor(state[k])):
            return False
    for i in range(num_uavs):
        if not (0 <= state[2 * i] < num_nodes and state[2 * i + 1] >= 0):
            return False
    return state[state.shape[0] - 1] >= 0


@njit(cache=True)
def plan_mission(
    state, distances, next_hop, node_tasks, num_uavs, base, horizon, settings,
    is_conservative, fuel_reserve, is_refuel_to_plan, max_rounds,
):  # fmt: skip
    """Conservative (Algorithm 27) or aggressive CBBA on a mission state, and its first moves.

    ``node_tasks`` (N, 4) holds every node as a task (value r_j p_j); the unvisited ones with a
    positive value whose window is still open become CBBA's tasks. A conservative UAV with an
    empty path gets one more fuel unit (up to its real fuel) while it cannot fly home within
    its planned fuel, or, with ``is_refuel_to_plan``, while its path is empty. Return
    (destinations, task_nodes, assumed fuel, CBBA runs, and `run_cbba`'s outputs).
    """
    n, num_nodes = num_uavs, distances.shape[0]
    now = state[state.shape[0] - 1]
    chosen = np.empty(num_nodes, dtype=np.int64)
    count = 0
    for node in range(num_nodes):
        is_open = node_tasks[node, END] >= now + settings[MIN_FIRST_LEG]
        if node_tasks[node, VALUE] > 0.0 and state[2 * n + node] < 0.5 and is_open:
            chosen[count] = node
            count += 1
    task_nodes = chosen[:count].copy()
    tasks = np.empty((count, 4))
    for k in range(count):
        tasks[k] = node_tasks[task_nodes[k]]
    agents = np.empty((n, 2))
    max_fuel = np.empty(n)
    for i in range(n):
        agents[i, LOCATION] = state[2 * i]
        max_fuel[i] = state[2 * i + 1]  # line 1: MaxFuel ← U.fuel
        agents[i, FUEL] = max(max_fuel[i] - fuel_reserve, 0.0) if is_conservative else max_fuel[i]
    adjacency = np.ones((n, n), dtype=np.bool_)
    runs = 0
    while True:  # lines 4-9, looping until ok or no UAV with an empty plan can get more fuel
        result = run_cbba(
            distances, agents, tasks, adjacency, base, now, horizon, settings, count, max_rounds
        )
        runs += 1
        if not is_conservative:
            break
        bundle_len = result[1]
        grew = False
        for i in range(n):
            if bundle_len[i] > 0 or agents[i, FUEL] >= max_fuel[i]:
                continue
            home = distances[int(agents[i, LOCATION]), base]
            if is_refuel_to_plan or agents[i, FUEL] < home:  # line 7: Plan[u] = ∅, not ok
                agents[i, FUEL] = min(max_fuel[i], agents[i, FUEL] + 1.0)  # line 8
                grew = True
        if not grew:
            break
    paths, bundle_len, departures = result[2], result[1], result[4]
    destinations = np.empty(n, dtype=np.int64)
    for i in range(n):
        here = int(agents[i, LOCATION])
        if bundle_len[i] == 0:
            destinations[i] = next_hop[here, base]
        elif here == base and departures[i] > now:
            destinations[i] = here  # wait at the base, where loitering burns no fuel
        else:
            destinations[i] = next_hop[here, int(tasks[paths[i, 0], LOC])]
    return destinations, task_nodes, agents[:, FUEL].copy(), runs, result
