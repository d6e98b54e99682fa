"""Test doubles for the safety tests: a learner that records its calls, a fixed-risk analyser."""

from __future__ import annotations

import numpy as np

from conjure.core.cooperative import RiskAnalyzer
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

    parameter_constraints = {"value": Interval(float, 0.0, 1.0)}

    def __init__(self, *, value: float = 1.0):
        self.value = value

    def risk(self, state, action, rng=None):
        return self.value


def gridworld_model(domain=None, **params):
    domain = GridWorld(map_name="4x5", noise=0.0) if domain is None else domain
    return ApproximateModel(domain=domain, **params)


def cell(row, col):
    return np.array([float(row), float(col)])
