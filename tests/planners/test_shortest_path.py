import numpy as np
import pytest

from conjure.core.errors import IncompatibleComponentsError, InvalidParameterError
from conjure.domains import GridWorld, UAVMission
from conjure.domains.gridworld import GOAL
from conjure.models.approximate_model import ApproximateModel
from conjure.planners import ShortestPathPlanner

PIT = (1, 17)


def set_up(planner, domain):
    model = ApproximateModel(domain=domain).setup(domain.domain_spec, seed=0)
    return planner.setup(model, seed=0)


def walk(domain, planner, start):
    """The nominal path from ``start`` until a goal or pit (at most 100 moves)."""
    state = np.array(start, dtype=float)
    path = [tuple(start)]
    for _ in range(100):
        if domain.grid_[path[-1]] == GOAL or domain.is_constrained(state):
            break
        state = domain.nominal_next_state(state, planner.action(state))
        path.append(tuple(int(x) for x in state))
    return path


def test_conservative_policy_is_the_31_move_snake_to_the_left_goal():
    domain = GridWorld.gridworld_2()
    path = walk(domain, set_up(ShortestPathPlanner.conservative(), domain), domain.start_)
    assert len(path) - 1 == 31 and path[-1] == (0, 0)
    assert max(col for _, col in path) == 11  # never east of the start: far from the pit


def test_aggressive_policy_runs_along_row_2_below_the_pit_in_14_moves():
    domain = GridWorld.gridworld_2()
    path = walk(domain, set_up(ShortestPathPlanner.aggressive(), domain), domain.start_)
    assert len(path) - 1 == 14 and path[-1] == (0, 21)
    assert path[:3] == [(4, 11), (3, 11), (2, 11)]
    assert [(2, c) for c in range(11, 22)] == path[2:13]  # row 2 passes (2, 17), below the pit


@pytest.mark.parametrize("make", [ShortestPathPlanner.conservative, ShortestPathPlanner.aggressive])
def test_policies_are_defined_in_every_cell(make):
    domain = GridWorld.gridworld_2()
    planner = set_up(make(), domain)
    goal = tuple(make().goal)
    for cell in np.argwhere((domain.grid_ != 1) & (domain.grid_ != GOAL)):
        cell = tuple(int(x) for x in cell)
        if cell == PIT:
            continue
        path = walk(domain, planner, cell)
        assert path[-1] == goal, f"from {cell} the policy ends at {path[-1]}"
        assert len(path) - 1 == planner.distances_[cell]


def test_without_a_goal_the_nearest_goal_is_taken():
    domain = GridWorld.gridworld_2()
    planner = set_up(ShortestPathPlanner(), domain)
    assert walk(domain, planner, domain.start_)[-1] == (0, 21)  # 14 moves beat 31
    assert walk(domain, planner, (4, 0))[-1] == (0, 0)


def test_paths_never_cross_pits():
    domain = GridWorld.gridworld_1()  # pits at (2, 0) and (6, 2), goal at (9, 6)
    planner = set_up(ShortestPathPlanner(), domain)
    assert planner.distances_[2, 0] == -1
    assert planner.action(np.array([1.0, 0.0])) == 3  # right, around the pit below


def test_bad_goals_and_domains_are_refused():
    domain = GridWorld.gridworld_2()
    with pytest.raises(InvalidParameterError, match=r"goal cell .* got \(4, 11\), not a goal"):
        set_up(ShortestPathPlanner(goal=(4, 11)), domain)
    # Issue 20: a goal off the map (the pre-flight check runs this before any run).
    with pytest.raises(InvalidParameterError, match=r"map; got \(100, 100\), off the map"):
        set_up(ShortestPathPlanner(goal=(100, 100)), domain)
    with pytest.raises(InvalidParameterError, match="goal"):
        ShortestPathPlanner(goal="left").validate_params()
    with pytest.raises(IncompatibleComponentsError, match="GridWorld"):
        set_up(ShortestPathPlanner(), UAVMission())
