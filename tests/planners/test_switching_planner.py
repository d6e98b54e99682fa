import numpy as np

from conjure.domains import GridWorld
from conjure.models.approximate_model import ApproximateModel
from conjure.planners import ShortestPathPlanner, SwitchingPlanner
from conjure.planners.switching_planner import switch_by_noise

START = np.array([4.0, 11.0])
UP = 0


def setup_gridworld2(**model_params):
    domain = GridWorld.gridworld_2()
    model = ApproximateModel(domain=domain, **model_params).setup(domain.domain_spec, seed=0)
    planner = SwitchingPlanner(
        conservative=ShortestPathPlanner.conservative(),
        aggressive=ShortestPathPlanner.aggressive(),
    ).setup(model, seed=0)
    return model, planner


def test_switches_on_the_61st_intended_move_from_the_thesis_prior():
    # Section 5.5.2: η̂ starts at 0.4 with weight 100; after m intended moves
    # η̂ = (0 + 100 * 0.4) / (m + 100) < 0.25  <=>  m > 60.
    model, planner = setup_gridworld2(initial_noise=0.4, prior_weight=100.0, is_adaptive=True)
    switched_at = []
    for m in range(1, 80):
        model.update(START, UP, np.array([3.0, 11.0]))  # up, as intended
        if planner.update(model):
            switched_at.append(m)
    assert switched_at == [61]
    assert planner.is_aggressive_
    assert planner.action(np.array([2.0, 11.0])) == 3  # right, toward the right goal


def test_at_exactly_the_threshold_it_stays_conservative():
    model, planner = setup_gridworld2(initial_noise=0.4, is_adaptive=True)
    model.load_counts(num_unintended=0, num_moves=60)  # η̂ = 40 / 160 = 0.25
    assert planner.update(model) is False and not planner.is_aggressive_
    assert planner.action(np.array([2.0, 11.0])) == 2  # left, toward the left goal


def test_switches_back_when_the_noise_rises():
    model, planner = setup_gridworld2(initial_noise=0.1, is_adaptive=True)
    assert planner.is_aggressive_
    model.load_counts(num_unintended=60, num_moves=100)  # η̂ = (60 + 10) / 200 = 0.35
    assert planner.update(model) is True and not planner.is_aggressive_


def test_a_kernels_switch_is_the_planners_own_state():
    # The compiled form shares the planner's switch: nothing is copied back
    _, planner = setup_gridworld2(initial_noise=0.4, is_adaptive=True)
    form = planner.compiled_form()
    assert switch_by_noise(form, 0.1) and planner.is_aggressive_
    assert planner.action(np.array([2.0, 11.0])) == 3  # the aggressive planner's
    assert switch_by_noise(form, 0.25) and not planner.is_aggressive_
    assert not switch_by_noise(form, 0.3)
