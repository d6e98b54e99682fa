import re

import numpy as np
import pytest

from conjure.core.errors import InvalidParameterError
from conjure.domains import GridWorld
from conjure.models.approximate_model import ApproximateModel
from conjure.planners import ModelPlanner
from conjure.safety import NominalRiskAnalyzer

UP, DOWN, LEFT, RIGHT = 0, 1, 2, 3


def test_exactly_the_moves_into_gridworld1_pits_are_unsafe():
    # Section 5.3.5: "an action was assumed safe if it does not deliberately move the UAV to
    # one of the off-limit grid cells". GridWorld-1's pits are (2, 0) and (6, 2); the moves
    # into them (by hand): into (2, 0) from (1, 0) down, (3, 0) up, (2, 1) left; into (6, 2)
    # from (5, 2) down, (7, 2) up, (6, 1) right, (6, 3) left.
    domain = GridWorld.gridworld_1()
    model = ApproximateModel(domain=domain, initial_noise=0.0).setup(domain.domain_spec, seed=0)
    analyser = NominalRiskAnalyzer().setup(model, ModelPlanner().setup(model, seed=0), seed=0)
    unsafe = {
        (r, c, a)
        for r, c in np.argwhere((domain.grid_ != 1) & (domain.grid_ != 4)).tolist()
        for a in range(4)
        if analyser.risk(np.array([r, c], dtype=float), a) == 1.0
    }
    expected = {
        (1, 0, DOWN), (3, 0, UP), (2, 1, LEFT),
        (5, 2, DOWN), (7, 2, UP), (6, 1, RIGHT), (6, 3, LEFT),
    }  # fmt: skip
    assert unsafe == expected
    for r, c, a in expected:
        assert not analyser.is_safe(np.array([r, c], dtype=float), a)


def test_the_planners_action_beside_a_pit_is_safe():
    domain = GridWorld.gridworld_1(noise=0.0)
    model = ApproximateModel(domain=domain).setup(domain.domain_spec, seed=0)
    planner = ModelPlanner().setup(model, seed=0)
    analyser = NominalRiskAnalyzer().setup(model, planner, seed=0)
    beside = np.array([6.0, 1.0])  # the pit (6, 2) is to the right
    assert analyser.is_safe(beside, planner.action(beside))


def test_the_risk_tolerance_is_a_parameter():
    # Issue 22: ε was a class attribute standing in for a parameter.
    analyser = NominalRiskAnalyzer()
    assert analyser.get_params() == {"risk_tolerance": 1.0}
    assert analyser.clone().set_params(risk_tolerance=0.5).risk_tolerance == 0.5
    for bad in (0.0, 1.5, "1"):
        message = f"`NominalRiskAnalyzer.risk_tolerance` must be a float in (0, 1]; got {bad!r}."
        with pytest.raises(InvalidParameterError, match=re.escape(message)):
            NominalRiskAnalyzer(risk_tolerance=bad).validate_params()
