"""Test doubles for the safety tests: a learner that records its calls, a fixed-risk analyser."""

from __future__ import annotations

import numpy as np

from conjure.core.cooperative import CooperativePlanner, RiskAnalyzer
from conjure.core.interfaces import Agent
from conjure.core.params import Interval
from conjure.domains import GridWorld
from conjure.models.approximate_model import ApproximateModel


class FakeLearner(Agent):
    """Always proposes ``action``; counts its ``act`` and ``learn`` calls."""

    def __init__(self, *, action: int = 0):
        self.action = action

    def setup(self, spec, seed):
        self.num_acts_ = 0
        self.num_learns_ = 0
        self.is_set_up_ = True
        return self

    def begin_episode(self):
        pass

    def act(self, state, greedy=False, legal_actions=None):
        self.num_acts_ += 1
        return self.action

    def learn(self, transition):
        self.num_learns_ += 1
        return 0.0

    @property
    def num_features(self):
        return 0


class FixedRiskAnalyzer(RiskAnalyzer):
    """risk(s, a) = ``value`` for every action but the planner's (1.0: nothing else is safe)."""

    parameter_constraints = {
        "value": Interval(float, 0.0, 1.0),
        "risk_tolerance": Interval(float, 0.0, 1.0, closed="right"),
    }

    def __init__(self, *, value: float = 1.0, risk_tolerance: float = 1.0):
        self.value = value
        self.risk_tolerance = risk_tolerance

    def update(self, *, is_policy_changed=True):
        """Count the calls (``setup`` makes the first) and keep the last flag."""
        self.num_updates_ = getattr(self, "num_updates_", 0) + 1
        self.last_update_ = is_policy_changed

    def risk(self, state, action, rng=None):
        return self.value


class CountingPlanner(CooperativePlanner):
    """Delegates to ``planner`` and counts the calls of ``action`` and ``update``."""

    def __init__(self, *, planner):
        self.planner = planner

    def setup(self, model, seed):
        self.planner_ = self.planner.clone().setup(model, seed)
        self.num_actions_ = 0
        self.num_updates_ = 0
        self.is_set_up_ = True
        return self

    def action(self, state):
        self.num_actions_ += 1
        return self.planner_.action(state)

    def update(self, model):
        self.num_updates_ += 1
        return self.planner_.update(model)


def gridworld_model(domain=None, **params):
    domain = GridWorld(map_name="4x5", noise=0.0) if domain is None else domain
    return ApproximateModel(domain=domain, **params)


def cell(row, col):
    return np.array([float(row), float(col)])
