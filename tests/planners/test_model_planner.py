import numpy as np
import pytest

from conjure.core.errors import IncompatibleComponentsError
from conjure.domains import GridWorld, UAVMission
from conjure.models.approximate_model import ApproximateModel
from conjure.planners import ModelPlanner, PolicyIteration, ValueIteration


def set_up_model(domain, **params):
    return ApproximateModel(domain=domain, **params).setup(domain.domain_spec, seed=0)


def nominal_path(domain, planner, limit=100):
    state = np.array(domain.start_, dtype=float)
    path = [tuple(int(x) for x in state)]
    while not domain.is_constrained(state) and domain.grid_[path[-1]] != 3 and len(path) < limit:
        state = domain.nominal_next_state(state, planner.action(state))
        path.append(tuple(int(x) for x in state))
    return path


def test_gridworld1_planner_follows_the_shortest_path_past_both_pits():
    # Figure 5-1b: value iteration on the noise-free model. The 15-move path goes down one
    # cell, right into column 1 (beside the pit at (2, 0)), down column 1 to row 7 (beside the
    # pit at (6, 2)), right along row 7 and down to the goal (spec 4.3).
    domain = GridWorld.gridworld_1(noise=0.0)
    planner = ModelPlanner().setup(set_up_model(domain), seed=0)
    expected = [(0, 0), (1, 0)] + [(r, 1) for r in range(1, 8)]
    expected += [(7, c) for c in range(2, 7)] + [(8, 6), (9, 6)]
    assert nominal_path(domain, planner) == expected
    assert planner.planned_noise_ == 0.0


def test_the_wrapped_planner_is_swappable():
    domain = GridWorld.gridworld_2()
    model = set_up_model(domain)
    by_vi = ModelPlanner(planner=ValueIteration()).setup(model, seed=0)
    by_pi = ModelPlanner(planner=PolicyIteration()).setup(model, seed=0)
    assert by_vi.plan_.start_value() == pytest.approx(by_pi.plan_.start_value(), abs=1e-5)


def test_update_replans_at_the_new_noise_and_reports_a_changed_policy():
    domain = GridWorld.gridworld_1(noise=0.0)
    model = set_up_model(domain, initial_noise=0.0, prior_weight=0.0, is_adaptive=True)
    planner = ModelPlanner().setup(model, seed=0)
    assert planner.update(model) is False  # same η̂: same plan
    model.load_counts(num_unintended=3, num_moves=10)  # η̂ = 0.3, the true wind
    assert planner.update(model) is True
    assert planner.planned_noise_ == pytest.approx(0.3)
    # With the wind known, the plan keeps away from the pit at (2, 0) (Figure 5-1c).
    assert planner.action(np.array([1.0, 0.0])) == 3  # right, not down beside the pit


def test_a_domain_without_an_exact_model_is_refused():
    with pytest.raises(IncompatibleComponentsError, match="UAVMission has no `model\\(\\)`"):
        ModelPlanner().setup(set_up_model(UAVMission()), seed=0)
