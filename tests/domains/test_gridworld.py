import dataclasses
import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import conjure.domains  # noqa: F401  (registers the Gymnasium ids)
from conjure.core.errors import InvalidParameterError
from conjure.domains import GridWorld
from conjure.domains.gridworld import load_map, shipped_maps
from conjure.models.approximate_model import ApproximateModel
from conjure.planners import ShortestPathPlanner, ValueIteration
from conjure.planners._kernels import evaluate_policy

UP, DOWN, LEFT, RIGHT = 0, 1, 2, 3


def walk(domain, actions, seed=0):
    domain.reset(seed=seed)
    out = []
    for action in actions:
        obs, reward, terminated, truncated, _ = domain.step(action)
        out.append((tuple(obs.tolist()), reward, terminated))
        assert not truncated
        if terminated:
            break
    return out


@pytest.mark.parametrize(
    "make", [GridWorld, GridWorld.gridworld_2, lambda: GridWorld(map_name="4x5", noise=0.0)]
)
def test_check_env_passes_with_warnings_as_errors(make):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(make(), skip_render_check=True)


@pytest.mark.parametrize(
    "env_id",
    [
        "conjure/GridWorld-v0",
        "conjure/GridWorld1-v0",
        "conjure/GridWorld2-v0",
        "conjure/GridWorld3-v0",
    ],
)
def test_gymnasium_make(env_id):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        env = gym.make(env_id)
        obs, _ = env.reset(seed=0)
        assert env.observation_space.contains(obs)
        assert len(env.step(RIGHT)) == 5


def test_registered_variants_have_thesis_settings():
    one = gym.make("conjure/GridWorld1-v0").unwrapped
    two = gym.make("conjure/GridWorld2-v0").unwrapped
    assert (one.map_name, one.step_reward, one.noise) == ("gridworld1", -0.001, 0.3)
    assert (two.map_name, two.step_reward, two.noise) == ("gridworld2", -0.01, 0.2)
    assert GridWorld.gridworld_2(noise=0.0).noise == 0.0
    three = gym.make("conjure/GridWorld3-v0").unwrapped
    assert three.get_params() == GridWorld.gridworld_3().get_params()


def test_shipped_maps_parse():
    assert set(shipped_maps()) >= {"gridworld1", "gridworld2", "gridworld3", "4x5"}
    one = GridWorld.gridworld_1()
    assert one.grid_.shape == (10, 7)
    assert one.start_ == (0, 0)
    assert one.grid_[9, 6] == 3  # goal bottom-right
    assert sorted(map(tuple, np.argwhere(one.grid_ == 4).tolist())) == [(2, 0), (6, 2)]
    two = GridWorld.gridworld_2()
    assert two.grid_.shape == (5, 22)
    assert two.start_ == (4, 11)
    assert sorted(map(tuple, np.argwhere(two.grid_ == 3).tolist())) == [(0, 0), (0, 21)]
    assert list(map(tuple, np.argwhere(two.grid_ == 4).tolist())) == [(1, 17)]
    assert two.domain_spec.high.tolist() == [4.0, 21.0]
    assert two.domain_spec.is_discrete.tolist() == [True, True]
    assert not two.grid_.flags.writeable


def test_reset_observation():
    obs, info = GridWorld.gridworld_2().reset(seed=0)
    assert obs.dtype == np.float64 and obs.tolist() == [4.0, 11.0] and info == {}


def test_walls_and_edges_block_without_noise():
    domain = GridWorld(map_name="4x5", noise=0.0)
    # From the start (0, 0): up and left leave the map; (1, 1) is blocked.
    assert walk(domain, [UP]) == [((0.0, 0.0), -0.001, False)]
    assert walk(domain, [LEFT]) == [((0.0, 0.0), -0.001, False)]
    assert walk(domain, [DOWN, RIGHT]) == [
        ((1.0, 0.0), -0.001, False),
        ((1.0, 0.0), -0.001, False),  # (1, 1) is blocked
    ]
    assert domain.feasible_moves_[1, 0].tolist() == [True, True, False, False]


def test_pit_gives_minus_one_and_terminates():
    domain = GridWorld(map_name="4x5", noise=0.0)
    steps = walk(domain, [RIGHT, RIGHT, DOWN, DOWN])
    assert steps[-1] == ((2.0, 2.0), -1.0, True)
    assert [s[2] for s in steps] == [False, False, False, True]


def test_goal_gives_plus_one_and_terminates():
    domain = GridWorld(map_name="4x5", noise=0.0)
    steps = walk(domain, [RIGHT] * 4 + [DOWN] * 3)
    assert steps[-1] == ((3.0, 4.0), 1.0, True)
    assert all(reward == -0.001 for _, reward, _ in steps[:-1])


def test_gridworld1_nominal_route_reaches_goal_without_noise():
    domain = GridWorld.gridworld_1(noise=0.0)
    route = [DOWN, RIGHT] + [DOWN] * 6 + [RIGHT] * 5 + [DOWN] * 2  # passes both pits
    steps = walk(domain, route)
    assert steps[-1] == ((9.0, 6.0), 1.0, True)
    assert len(steps) == len(route)


def test_same_seed_same_rollout_different_seed_differs():
    rng = np.random.default_rng(0)
    actions = rng.integers(4, size=300).tolist()
    domain = GridWorld.gridworld_2()
    a = walk(domain, actions, seed=5)
    b = walk(GridWorld.gridworld_2(), actions, seed=5)
    assert a == b
    runs = {tuple(walk(domain, actions, seed=s)) for s in range(5)}
    assert len(runs) > 1


def test_noise_statistics(tmp_path):
    path = tmp_path / "open.txt"
    path.write_text("3 0 0\n0 2 0\n0 0 0\n")
    noise = 0.4
    domain = GridWorld(map_name=str(path), noise=noise)
    counts = {}
    domain.reset(seed=123)
    trials = 4000
    for _ in range(trials):
        domain.reset()
        obs = tuple(domain.step(RIGHT)[0].tolist())
        counts[obs] = counts.get(obs, 0) + 1
    # Four feasible moves from the centre: right w.p. 1 - η + η/4, each other move η/4.
    assert counts[(1.0, 2.0)] / trials == pytest.approx(1 - noise + noise / 4, abs=0.03)
    for other in [(0.0, 1.0), (2.0, 1.0), (1.0, 0.0)]:
        assert counts[other] / trials == pytest.approx(noise / 4, abs=0.025)


def test_noise_draws_only_feasible_moves(tmp_path):
    path = tmp_path / "corridor.txt"
    path.write_text("1 1 1\n2 0 3\n1 1 1\n")
    domain = GridWorld(map_name=path, noise=1.0)
    seen = set()
    domain.reset(seed=0)
    for _ in range(200):
        domain.reset()
        obs = tuple(domain.step(UP)[0].tolist())
        seen.add(obs)
    assert seen == {(1.0, 1.0)}  # the start's only feasible move is right


def test_bad_map_name_lists_shipped_maps():
    with pytest.raises(InvalidParameterError, match="Did you mean 'gridworld1'") as info:
        GridWorld(map_name="gridwrld1")
    for name in ("4x5", "gridworld1", "gridworld2"):
        assert name in str(info.value)


@pytest.mark.parametrize(
    "text, message",
    [
        ("0 0\n0 3\n", "start"),
        ("2 0\n0 0\n", "goal"),
        ("2 0 3\n0 0\n", "rectangle"),
        ("2 7\n0 3\n", "unknown cell codes"),
        ("2 x\n0 3\n", "rectangle"),
    ],
)
def test_bad_map_files(tmp_path, text, message):
    path = tmp_path / "bad.txt"
    path.write_text(text)
    with pytest.raises(InvalidParameterError, match=message):
        load_map(path)


@pytest.mark.parametrize(
    "params",
    [
        {"noise": 1.5},
        {"noise": -0.1},
        {"discount": 1.1},
        {"max_episode_steps": 0},
        {"step_reward": float("inf")},
        {"map_name": 3},
    ],
)
def test_bad_parameters(params):
    with pytest.raises(InvalidParameterError):
        GridWorld(**params)


def test_bad_action():
    domain = GridWorld()
    domain.reset(seed=0)
    with pytest.raises(InvalidParameterError, match="got 4"):
        domain.step(4)


def test_set_params_rebuilds_the_map():
    domain = GridWorld()
    domain.set_params(map_name="gridworld2")
    assert domain.grid_.shape == (5, 22)
    assert domain.observation_space.high.tolist() == [4.0, 21.0]
    assert domain.clone() == domain


@pytest.mark.parametrize("make", [GridWorld.gridworld_2, GridWorld.gridworld_3])
def test_transitions_are_linear_in_the_noise(make):
    # P_η = (1 − η)·P_0 + η·P_1 (one wind draw per step); GridWorld-3's calm cells have P_1 = P_0.
    calm, windy = make().noise_decomposition()
    mixed = make(noise=0.3).model()
    for a in range(4):
        expected = 0.7 * calm.transitions[a] + 0.3 * windy.transitions[a]
        assert abs(mixed.transitions[a] - expected).max() < 1e-12


# ------------------------------------------------------------------ GridWorld-3 (Section 5.5.3)


def planner_policy(make, domain, model):
    """π^p of a hand-coded GridWorld-2 policy at each state of ``model``."""
    approx = ApproximateModel(domain=domain).setup(domain.domain_spec, seed=0)
    planner = make().setup(approx, seed=0)
    return np.array([planner.action(s) for s in model.states])


def with_rewards(model, rewards):
    """``model`` earning ``rewards`` (|S| x |A|) instead, nothing after a terminal state."""
    return dataclasses.replace(model, rewards=np.where(model.is_terminal[:, None], 0.0, rewards))


def pit_entries(model, domain):
    """``model`` earning P(the next state is a pit): its policy values are failure probabilities."""
    is_pit = np.array([domain.is_constrained(s) for s in model.states], dtype=float)
    return with_rewards(model, np.stack([p @ is_pit for p in model.transitions], axis=1))


def test_gridworld3_is_gridworld2_with_wind_everywhere_but_past_the_danger_cell():
    # Figure 5-14: "identical to GridWorld-2, yet the noise is only applied in windy grid
    # cells"; [R] the calm cells are the corridor from beside the danger cell (1, 17) to the
    # right goal (GridWorld's Notes).
    two, three = load_map("gridworld2"), load_map("gridworld3")
    assert np.array_equal(np.where(three == 5, 0, three), np.where(two == 5, 0, two))
    calm = {(int(r), int(c)) for r, c in np.argwhere(three == 0)}
    assert calm == {(2, 16), (2, 17), (2, 18), (2, 19), (2, 20), (2, 21), (1, 21)}
    assert (
        GridWorld.gridworld_3().get_params()
        == GridWorld(
            map_name="gridworld3", step_reward=-0.01, noise=0.55, noise_cells="windy"
        ).get_params()
    )


def test_gridworld3_makes_the_uniform_model_filter_a_safe_optimal_route():
    # What Section 5.5.3's figure needs, exactly from the models (γ = 1, Eq. 2.8):
    # 1. under the true wind the aggressive route never enters the pit, is (nearly) optimal
    #    and far better than the conservative one;
    true = GridWorld.gridworld_3()
    model = true.model()
    start = model.state_index(np.array(true.start_, dtype=float))
    conservative = planner_policy(ShortestPathPlanner.conservative, true, model)
    aggressive = planner_policy(ShortestPathPlanner.aggressive, true, model)
    assert evaluate_policy(pit_entries(model, true), aggressive)[start] == 0.0
    value_of = {
        name: evaluate_policy(model, policy)[start]
        for name, policy in (("conservative", conservative), ("aggressive", aggressive))
    }
    assert value_of == pytest.approx({"conservative": 0.3292, "aggressive": 0.7830}, abs=1e-4)
    assert ValueIteration().plan(model).start_value() == pytest.approx(0.7862, abs=1e-4)
    # 2. following the conservative policy, the uniform model's count (every move) finds
    #    27.2% of the moves unintended: η̂ stays above the 25% switch (Section 5.5.2), so
    #    AM-iCCA's planner stays conservative while the agent learns on the windy side;
    live = ~model.is_terminal
    nominal = [
        model.state_index(true.nominal_next_state(s, a))
        for s, a in zip(model.states[live], conservative[live], strict=True)
    ]
    unintended = np.zeros(model.num_states)
    unintended[live] = [
        1.0 - model.transitions[a][s, n]
        for s, a, n in zip(np.flatnonzero(live), conservative[live], nominal, strict=True)
    ]
    per_move = np.repeat(unintended[:, None], 4, axis=1)
    num_unintended = evaluate_policy(with_rewards(model, per_move), conservative)[start]
    num_moves = evaluate_policy(with_rewards(model, np.ones_like(per_move)), conservative)[start]
    noise_estimate = num_unintended / num_moves
    assert noise_estimate == pytest.approx(0.2724, abs=1e-4)
    # 3. at that η̂ the uniform model (GridWorld-2's form) makes Algorithm 25 (𝓜 = 5, ε = 0.2:
    #    safe iff no rollout fails; rollouts follow the conservative π^p) block each step from
    #    beside the danger cell to the right goal often, and the whole route almost always:
    #    P(safe) = (1 − p)^5 with p the exact failure probability of one rollout (𝓗 → ∞).
    uniform = GridWorld.gridworld_2(noise=noise_estimate)
    believed = uniform.model()
    pits = pit_entries(believed, uniform)
    risk = pits.q_values(
        evaluate_policy(pits, planner_policy(ShortestPathPlanner.conservative, uniform, believed))
    )
    route = [
        ((2, 16), RIGHT),
        ((2, 17), RIGHT),
        ((2, 18), RIGHT),
        ((2, 19), RIGHT),
        ((2, 20), RIGHT),
        ((2, 21), UP),
        ((1, 21), UP),
    ]
    passes = np.array(
        [(1.0 - risk[believed.state_index(np.array(c, dtype=float)), a]) ** 5 for c, a in route]
    )
    assert passes[:-1].max() < 0.7  # each step but the last one is vetoed at least 30% of times
    assert passes.prod() == pytest.approx(0.050, abs=1e-3)


def test_describe_action_names_the_move():
    domain = GridWorld()
    assert [domain.describe_action(a) for a in range(4)] == ["up", "down", "left", "right"]
    with pytest.raises(InvalidParameterError, match="action must be an int in"):
        domain.describe_action(4)
