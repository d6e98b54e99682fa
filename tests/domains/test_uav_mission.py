import copy
import re
import textwrap
import warnings

import gymnasium as gym
import numpy as np
import pytest
from click.testing import CliRunner
from gymnasium.utils.env_checker import check_env

import conjure.domains  # noqa: F401  (registers the Gymnasium ids)
from conjure.cli.main import main
from conjure.core.errors import InvalidParameterError
from conjure.domains import UAVMission
from conjure.domains._mission_kernels import mission_step
from conjure.testing.checks import check_pickle_round_trip, check_seeded_rollout


def line(fuel, horizon, *, reward=10.0, probability=0.5, window=None, num_nodes=2):
    """A path 0 - 1 - ... with one target at the far end (node num_nodes - 1)."""
    target = {"reward": reward, "probability": probability}
    if window is not None:
        target["window"] = window
    return {
        "num_nodes": num_nodes,
        "edges": [[k, k + 1] for k in range(num_nodes - 1)],
        "fuel": list(fuel),
        "horizon": horizon,
        "targets": {num_nodes - 1: target},
    }


def state(*uavs, visited=(), num_nodes=2, t=0):
    """A state vector: uavs as (location, fuel), the visited nodes, the time."""
    v = [1.0 if j in visited else 0.0 for j in range(num_nodes)]
    return np.array([x for uav in uavs for x in uav] + v + [t], dtype=np.float64)


def rollout(domain, policy, num_episodes, seed):
    """Returns of ``policy(domain, obs, rng)`` over episodes of ``domain.step``."""
    rng = np.random.default_rng(seed)
    returns = np.empty(num_episodes)
    obs, _ = domain.reset(seed=seed)
    for e in range(num_episodes):
        total, terminated = 0.0, False
        while not terminated:
            obs, reward, terminated, _, _ = domain.step(policy(domain, obs, rng))
            total += reward
        returns[e] = total
        obs, _ = domain.reset()
    return returns


# ---------------------------------------------------------------------------------- interface


@pytest.mark.filterwarnings("ignore:.*is out of date:DeprecationWarning")  # v0 beside v1
@pytest.mark.parametrize(
    ("env_id", "dims", "actions", "horizon"),
    [
        ("conjure/UAV-7-2-v0", 12, 49, 8),
        ("conjure/UAV-10-2-v0", 15, 100, 11),
        ("conjure/UAV-7-2-v1", 12, 49, 8),
        ("conjure/UAV-10-2-v1", 15, 100, 11),
    ],
)
def test_gymnasium_ids_and_spec(env_id, dims, actions, horizon):
    # v0 keeps spec 2.2's first reconstruction, v1 the calibrated default (issue 19)
    scenario = env_id.split("/")[1].lower().rsplit("-", 1)[0] + ("-spec" if "v0" in env_id else "")
    assert gym.spec(env_id).kwargs == {"scenario": scenario}
    env = gym.make(env_id)
    obs, _ = env.reset(seed=0)
    spec = env.unwrapped.domain_spec
    assert (spec.num_dims, spec.num_actions, spec.discount, spec.max_episode_steps) == (
        dims,
        actions,
        1.0,
        horizon,
    )
    assert spec.has_action_constraints and spec.is_discrete.all()
    assert obs[-1] == 0 and obs[1] == spec.high[1] and obs[3] == spec.high[3]  # full, t = 0
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(env.unwrapped, skip_render_check=True)


def test_graph_attribute_and_state_action_counts():
    small, large = UAVMission(), UAVMission(scenario="uav-10-2")
    assert small.graph_.num_nodes == 7 and large.graph_.num_nodes == 10
    assert small.state_action_count() == 137_682_944  # "more than 100 million" (T:3113)
    assert large.state_action_count() == pytest.approx(9.0e9, rel=0.01)  # "about 9 billion"
    spec = UAVMission(scenario="uav-7-2-spec")
    assert spec.state_action_count() == 120_472_576
    assert UAVMission(graph=line([3], 4)).graph_.num_nodes == 2


def test_seeded_rollouts_and_pickle_with_noise():
    domain = UAVMission(traverse_failure=0.3)
    check_seeded_rollout(domain)
    check_pickle_round_trip(domain)


# ---------------------------------------------------------------------------------- dynamics


def test_legal_actions_stay_or_move_to_a_neighbour_with_fuel():
    domain = UAVMission()
    obs, _ = domain.reset(seed=0)
    encode = domain.graph_.encode_action
    expected = sorted(encode([a, b]) for a in (0, 1, 2) for b in (0, 1, 2))
    assert domain.legal_actions(obs).tolist() == expected
    empty = obs.copy()
    empty[1] = 0  # UAV 0 at the base without fuel: it can only stay
    assert domain.legal_actions(empty).tolist() == [encode([0, b]) for b in (0, 1, 2)]
    with pytest.raises(InvalidParameterError, match=r"action 3 \(UAV 0 to node 3"):
        domain.step(encode([3, 0]))  # node 3 is not a neighbour of the base
    with pytest.raises(InvalidParameterError, match=r"dimension 0 \(location of UAV 0\)"):
        domain.legal_actions(np.where(np.arange(obs.size) == 0, 7.0, obs))


def test_fuel_burn_and_free_loitering_at_the_base():
    domain = UAVMission(scenario="uav-7-2-spec")
    domain.reset(seed=0)
    encode = domain.graph_.encode_action
    obs, reward, terminated, _, info = domain.step(encode([1, 0]))  # node 1 has no value
    assert obs[:4].tolist() == [1, 5, 0, 6] and reward == -1.0 and obs[-1] == 1
    assert not terminated and info["cost"] == 0.0
    obs, reward, *_ = domain.step(encode([1, 0]))  # loitering away from the base burns fuel
    assert obs[:4].tolist() == [1, 4, 0, 6] and reward == -1.0
    obs, reward, *_ = domain.step(encode([0, 0]))
    assert obs[:4].tolist() == [0, 3, 0, 6] and reward == -1.0 and not obs[4:-1].any()


def test_window_is_tested_at_arrival_and_loitering_retries():
    domain = UAVMission(graph=line([4], 5, probability=1.0, window=[2, 3]))
    domain.reset(seed=0)
    obs, reward, *_ = domain.step(1)  # arrives at t = 1, before the window
    assert reward == -1.0 and obs[3] == 0
    obs, reward, *_ = domain.step(1)  # loiters into t = 2: obtained
    assert reward == 10.0 - 1.0 and obs[3] == 1
    obs, reward, *_ = domain.step(1)  # already visited: nothing more
    assert reward == -1.0 and obs[3] == 1


def test_target_probability_grows_with_the_number_of_uavs():
    domain = UAVMission(graph=line([2, 2], 2, probability=0.5))
    rng = np.random.default_rng(0)
    start = state((0, 2), (0, 2))
    for action, expected in ((1, 0.5), (1 + 2, 0.75)):  # one UAV, then both, fly to node 1
        hits = [domain.simulate(start, action, 0.0, rng)[0][5] for _ in range(4000)]
        assert np.mean(hits) == pytest.approx(expected, abs=0.03)


def test_traverse_failures_burn_fuel_and_are_counted():
    domain = UAVMission(graph=line([2, 2], 2, probability=0.0), traverse_failure=0.3)
    rng = np.random.default_rng(1)
    start = state((0, 2), (0, 2))
    totals = np.zeros(2, dtype=int)
    for _ in range(3000):
        after, reward, _ = domain.simulate(start, 1, 0.3, rng)  # UAV 0 flies, UAV 1 stays
        assert after[1] == 1 and after[3] == 2 and reward == -1.0
        counts = domain.count_unintended(start, 1, after)
        assert counts == ((1, 1) if after[0] == 0 else (0, 1))
        totals += counts
    assert totals[0] / totals[1] == pytest.approx(0.3, abs=0.03)
    assert domain.count_unintended(start, 0, start) == (0, 0)  # nobody tried to move


def test_running_out_of_fuel_away_from_the_base_crashes():
    domain = UAVMission(graph=line([1], 4, probability=1.0))
    domain.reset(seed=0)
    obs, reward, terminated, _, info = domain.step(1)
    assert terminated and info["cost"] == 1.0 and domain.is_constrained(obs)
    assert reward == -10.0 == domain.graph_.crash_penalty  # replaces fuel and target
    assert obs.tolist() == [1, 0, 0, 0, 1]  # nothing obtained on the crashing step


def test_the_horizon_ends_the_mission_home_or_crashed():
    home = UAVMission(graph=line([2], 2, probability=1.0))
    home.reset(seed=0)
    assert home.step(1)[1] == 10.0 - 1.0
    obs, reward, terminated, _, info = home.step(0)  # home at t = H: success
    assert terminated and reward == -1.0 and info["cost"] == 0.0
    assert not home.is_constrained(obs)
    late = UAVMission(graph=line([3], 2, probability=1.0))
    late.reset(seed=0)
    late.step(0)
    obs, reward, terminated, _, info = late.step(1)  # away at t = H: failure
    assert terminated and reward == -10.0 and info["cost"] == 1.0 and late.is_constrained(obs)
    again, reward, terminated = late.simulate(obs, 0, 0.0, np.random.default_rng(0))
    assert again.tolist() == obs.tolist() and reward == 0.0 and terminated  # absorbs


def test_simulate_leaves_the_episode_and_its_generator_alone():
    domain = UAVMission(traverse_failure=0.5)
    twin = UAVMission(traverse_failure=0.5)
    obs, _ = domain.reset(seed=3)
    twin.reset(seed=3)
    rng = np.random.default_rng(0)
    for _ in range(20):
        domain.simulate(obs, 1, 0.5, rng)
    assert domain.step(1)[0].tolist() == twin.step(1)[0].tolist()
    assert domain.np_random.random() == twin.np_random.random()


def test_step_replays_the_compiled_kernel_with_the_same_generator():
    domain = UAVMission(traverse_failure=0.2)
    obs, _ = domain.reset(seed=5)
    rng = copy.deepcopy(domain.np_random)
    state_ints = obs.astype(np.int64)
    actions = np.random.default_rng(5)
    terminated = False
    while not terminated:
        legal = domain.legal_actions(obs)
        action = int(legal[actions.integers(legal.size)])
        obs, reward, terminated, _, info = domain.step(action)
        state_ints, kernel_reward, kernel_terminated, cost = mission_step(
            state_ints, action, domain._layout, domain._node_table, 0.2, rng
        )
        assert state_ints.tolist() == obs.tolist()
        assert (kernel_reward, kernel_terminated, cost) == (reward, terminated, info["cost"])


def test_nominal_next_state_moves_and_obtains_nothing():
    domain = UAVMission(graph=line([2], 3, probability=1.0), traverse_failure=1.0)
    after = domain.nominal_next_state(state((0, 2)), 1)
    assert after.tolist() == [1, 1, 0, 0, 1]
    failed, *_ = domain.simulate(state((0, 2)), 1, 1.0, np.random.default_rng(0))
    assert failed.tolist() == [0, 1, 0, 0, 1]


# ---------------------------------------------------------------------------------- exact DP


@pytest.mark.parametrize(
    ("params", "worst", "best"),
    [
        # go (-1, then +10 w.p. 0.5) and come back (-1); worst: fly out at the last step
        ({"graph": line([2], 2)}, -10.0, 0.5 * 10 - 2),
        # retry when the first try fails: 0.5 (10 - 2) + 0.5 (0.5 * 10 - 3)
        ({"graph": line([3], 3)}, -10.0, 5.0),
        # two UAVs together: 10 (1 - 0.5²) - 4 beats one UAV's 5 - 2
        ({"graph": line([2, 2], 2)}, -10.0, 3.5),
        # window [2, 2]: wait at the base (free), arrive at t = 2, return: 10 - 2; worst: out
        # before the window and back (-2), out again at the last step (-10)
        ({"graph": line([3], 3, probability=1.0, window=[2, 2])}, -12.0, 8.0),
        # η = 0.5: out 0.5 (9 + 0.5 (-1) + 0.5 (-10)) + 0.5 (-1) = 1.25; worst: stay, then
        # fly out at the last step: 0.5 (-10) + 0.5 (-1)
        ({"graph": line([2], 2, probability=1.0), "traverse_failure": 0.5}, -5.5, 1.25),
    ],
)
def test_exact_values_of_hand_solved_missions(params, worst, best):
    assert UAVMission(**params).value_bounds() == pytest.approx((worst, best))


def test_solutions_are_cached_per_graph_and_noise():
    first = UAVMission().exact_solution()
    assert UAVMission().exact_solution() is first
    assert UAVMission(traverse_failure=0.05).exact_solution() is not first


def test_uav_7_2_optimum_bounds_static_policies():
    domain = UAVMission()
    worst, best = domain.value_bounds()
    encode = domain.graph_.encode_action
    tour = [[1, 2], [3, 4], [5, 6], [3, 4], [1, 2], [0, 0], [0, 0], [0, 0]]  # both full tanks

    def stay_home(d, obs, rng):
        return 0

    def hand_tour(d, obs, rng):
        return encode(tour[int(obs[-1])])

    def random_legal(d, obs, rng):
        legal = d.legal_actions(obs)
        return int(legal[rng.integers(legal.size)])

    for policy in (stay_home, hand_tour, random_legal):
        returns = rollout(domain, policy, 1000, seed=0)
        margin = 3 * returns.std() / np.sqrt(returns.size)
        assert worst - margin <= returns.mean() <= best + margin, policy.__name__
    assert worst < 0.0 < best


@pytest.mark.parametrize("traverse_failure", [0.0, 0.05])
def test_simulated_optimal_and_worst_policies_earn_their_values(traverse_failure):
    domain = UAVMission(traverse_failure=traverse_failure)
    solution = domain.exact_solution()
    for choose, value in (
        (solution.action, solution.optimal_return),
        (solution.worst_action, solution.worst_return),
    ):
        returns = rollout(domain, lambda d, obs, rng, f=choose: f(obs), 2000, seed=1)
        margin = 4 * returns.std() / np.sqrt(returns.size) + 1e-9
        assert returns.mean() == pytest.approx(value, abs=margin)
    start = domain.graph_.initial_state()
    assert solution.value(start) == solution.optimal_return
    assert solution.layer_sizes[0] == 1 and solution.num_states == solution.layer_sizes.sum()


@pytest.mark.parametrize("scenario", ["uav-7-2", "uav-7-2-spec"])
@pytest.mark.parametrize("traverse_failure", [0.0, 0.05])
def test_exact_evaluation_of_the_optimal_and_worst_policies(scenario, traverse_failure):
    domain = UAVMission(scenario=scenario, traverse_failure=traverse_failure)
    solution = domain.exact_solution()
    best = domain.evaluate_policy(solution.action)
    worst = domain.evaluate_policy(solution.worst_action)
    assert best.value == pytest.approx(solution.optimal_return, abs=1e-9)
    assert worst.value == pytest.approx(solution.worst_return, abs=1e-9)
    assert worst.crash_probability > 0.99  # the worst policy always crashes
    assert best.reach_probabilities[0] == 1.0 and best.states[0].tolist() == (
        domain.graph_.initial_state().tolist()
    )
    times = best.states[:, -1]
    running = [best.reach_probabilities[times == t].sum() for t in range(domain.graph_.horizon)]
    assert np.all(np.diff(running) <= 1e-12)  # missions only end
    assert running[-1] >= 1.0 - best.crash_probability - 1e-12  # the rest come home
    for state_, action in zip(best.states[:50], best.actions[:50], strict=True):
        actions, q = solution.q_values(state_)
        assert q.max() == pytest.approx(solution.value(state_), abs=1e-9)
        assert action == actions[np.argmax(q)]  # ties: lowest action, as in the DP


def test_exact_evaluation_of_a_hand_solved_policy():
    # line([3], 4) with η = 0.5: fly to the target once, then home. The first traversal (-1)
    # fails (1/2: stay home, free) or arrives (a draw: +10 w.p. 1/2) and turns back (-1): home
    # (1/2), or stuck at the target with 1 fuel, where the draw repeats if it failed
    # (1/4 · 10), and then home (-1, 1/2) or a crash (-10 replacing the step's reward, 1/2).
    domain = UAVMission(graph=line([3], 4), traverse_failure=0.5)

    def out_and_back(obs):
        at_base, fuel = obs[0] == 0, obs[1]
        return 1 if at_base and fuel == 3 else 0

    result = domain.evaluate_policy(out_and_back)
    stuck = 0.25 * 10 + 0.5 * -1 + 0.5 * -10
    assert result.crash_probability == pytest.approx(0.5 * 0.5 * 0.5)
    assert result.value == pytest.approx(-1 + 0.5 * (0.5 * 10 - 1 + 0.5 * stuck))
    returns = rollout(domain, lambda d, obs, rng: out_and_back(obs), 4000, seed=2)
    assert returns.mean() == pytest.approx(result.value, abs=4 * returns.std() / np.sqrt(4000))


def test_evaluate_policy_refuses_illegal_actions_and_non_callables():
    domain = UAVMission()
    with pytest.raises(InvalidParameterError, match="illegal in state"):
        domain.evaluate_policy(lambda obs: domain.graph_.encode_action([6, 0]))
    with pytest.raises(InvalidParameterError, match="policy must map"):
        domain.evaluate_policy(3)


def test_solution_lookups_of_terminal_and_unreachable_states():
    domain = UAVMission(graph=line([2], 2))
    solution = domain.exact_solution()
    assert solution.value(state((1, 0), t=1)) == 0.0  # a crash: terminal
    with pytest.raises(InvalidParameterError, match="not reachable"):
        solution.action(state((1, 2), t=1))  # fuel cannot still be 2 there


def test_exact_solution_refuses_graphs_too_large_for_memory():
    graph = {
        "num_nodes": 20,
        "edges": [[k, k + 1] for k in range(19)],
        "fuel": [30, 30],
        "horizon": 40,
        "targets": {k: {"reward": 1.0} for k in range(1, 16)},
    }
    with pytest.raises(InvalidParameterError, match="exact_solution: one time layer"):
        UAVMission(graph=graph).exact_solution()


# ---------------------------------------------------------------------------------- bad input

BAD_GRAPHS = [
    ({"num_nodes": 3, "edges": [[0, 1]], "fuel": [2], "horizon": 3}, "disconnected"),
    ({"num_nodes": 3, "edges": [[1, 2]], "fuel": [2], "horizon": 3}, "no edge"),
    ({"num_nodes": 2, "edges": [[0, 1]], "fuel": [-1], "horizon": 3}, r"fuel\[0\]"),
    ({**line([2], 3), "targets": {1: {"reward": 1, "probability": 1.5}}}, "probabilities"),
    ({**line([2], 3), "targets": {1: {"reward": 1, "window": [3, 1]}}}, "a > b"),
    ({**line([2], 3), "edges": "01"}, "list"),
    (
        {**line([2, 2, 2, 2], 3), "num_nodes": 40, "edges": [[k, k + 1] for k in range(39)]},
        "40\\^4 = 2560000 joint actions",
    ),
    ({**line([2], 3), "num_nodes": 10**6}, r"num_nodes` must be at most 1,000"),
    ({**line([2, 0], 3)}, r"fuel\[1\]` must be an int in \[1, inf\)"),
]


@pytest.mark.parametrize(("graph", "message"), BAD_GRAPHS)
def test_bad_graphs_are_refused_with_the_value(graph, message):
    with pytest.raises(InvalidParameterError, match=r"UAVMission\.graph") as error:
        UAVMission(graph=graph)
    assert re.search(message, str(error.value))


@pytest.mark.parametrize(
    ("params", "message"),
    [
        ({"scenario": "uav-7-3"}, "Did you mean 'uav-7-2'"),
        ({"traverse_failure": 1.5}, r"traverse_failure` must be a float in \[0, 1\]; got 1.5"),
        ({"traverse_failure": -0.1}, "got -0.1"),
        ({"graph": [1, 2]}, "mission-graph mapping"),
    ],
)
def test_bad_parameters_name_the_value(params, message):
    with pytest.raises(InvalidParameterError, match=message):
        UAVMission(**params)


def test_bad_states_actions_and_generators_are_refused_clearly():
    domain = UAVMission(graph=line([2], 3))
    rng = np.random.default_rng(0)
    start = state((0, 2))
    with pytest.raises(InvalidParameterError, match=r"dimension 1 \(fuel of UAV 0\)"):
        domain.simulate(state((0, 3)), 0, 0.0, rng)
    with pytest.raises(InvalidParameterError, match="time step"):
        domain.is_constrained(state((0, 2), t=0.5))
    with pytest.raises(InvalidParameterError, match="shape"):
        domain.nominal_next_state(np.zeros(3), 0)
    with pytest.raises(InvalidParameterError, match="numeric state"):
        domain.legal_actions(["a"] * 5)
    with pytest.raises(InvalidParameterError, match="illegal"):
        domain.simulate(state((0, 0)), 1, 0.0, rng)
    with pytest.raises(InvalidParameterError, match="noise"):
        domain.simulate(start, 0, 2.0, rng)
    with pytest.raises(InvalidParameterError, match="Generator"):
        domain.simulate(start, 0, 0.0, 0)
    with pytest.raises(InvalidParameterError, match=r"action must be an int in \[0, 1\]"):
        domain.step(2)


@pytest.mark.parametrize(
    ("graph", "message"),
    [
        ("{num_nodes: 3, edges: [[0, 1]], fuel: [2], horizon: 3}", "disconnected"),
        # Issue 20: Floyd-Warshall's 7.28 TiB MemoryError, and fuel 0's run-time
        # "value_bounds() must return finite (worst, best)" in every run.
        ("{num_nodes: 1000000, edges: [[0, 1]], fuel: [2], horizon: 3}", "at most 1,000"),
        ("{num_nodes: 2, edges: [[0, 1]], fuel: [0], horizon: 3}", "fuel[0]` must be an int"),
    ],
)
def test_bad_graph_in_a_yaml_config_is_one_clean_error(tmp_path, graph, message):
    config = textwrap.dedent(
        f"""\
        name: uav
        domain:
          kind: UAVMission
          params:
            graph: {graph}
        agents:
          sarsa: {{kind: SARSA, params: {{representation: {{kind: Tabular}}}}}}
        budget_steps: 10
        """
    )
    path = tmp_path / "uav.yaml"
    path.write_text(config)
    result = CliRunner().invoke(main, ["run", str(path), "--out", str(tmp_path / "out")])
    assert result.exit_code == 2 and "Traceback" not in result.output
    assert "`UAVMission.graph` is not a valid mission graph" in result.output
    assert message in result.output
    assert not (tmp_path / "out").exists()  # refused when the config was loaded


def test_the_joint_action_limit_is_checked_before_the_distances(monkeypatch):
    # Issue 20: the documented N^n limit came after Floyd-Warshall's Θ(N³) work.
    import conjure.domains.mission_graph as mission_graph

    def refuse(*args):
        raise AssertionError("the distances were computed first")

    monkeypatch.setattr(mission_graph, "_floyd_warshall", refuse)
    graph = {**line([2, 2, 2], 3, num_nodes=1000)}
    with pytest.raises(InvalidParameterError, match=r"1000\^3 = 1000000000 joint actions"):
        UAVMission(graph=graph)


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"fuel": [10**6, 7]}, r"states \(fuel \[1000000, 7\]\), more than the 2e\+07"),
        ({"horizon": 10**6}, r"horizon 1,000,000 × 1\.76e\+05 states per time layer"),
    ],
)
def test_exact_solutions_too_large_for_memory_or_time_name_the_fuel_or_horizon(change, message):
    # Issue 20: huge fuel or horizons; a huge horizon used to grind in the backward induction.
    graph = {**UAVMission().graph_.to_dict(), **change}
    with pytest.raises(InvalidParameterError, match=message):
        UAVMission(graph=graph).exact_solution()


def test_a_generated_mission_keeps_the_scenarios_edges_and_draws_targets_from_its_seed():
    first, again = UAVMission(mission_seed=5), UAVMission(mission_seed=5)
    assert first.graph_.to_dict() == again.graph_.to_dict()
    other = UAVMission(mission_seed=6)
    assert other.graph_.to_dict() != first.graph_.to_dict()
    shipped = UAVMission().graph_
    assert first.graph_.edges == shipped.edges and first.graph_.horizon == shipped.horizon
    assert first.graph_.to_dict()["targets"] != shipped.to_dict()["targets"]
    assert "mission 5" in first.domain_spec.name
    assert UAVMission(mission_seed=5).get_params()["mission_seed"] == 5


@pytest.mark.parametrize("seed", [-1, 1.5, "0"])
def test_a_bad_mission_seed_is_refused_by_value(seed):
    with pytest.raises(InvalidParameterError, match="mission_seed"):
        UAVMission(mission_seed=seed)
