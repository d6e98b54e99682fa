"""Planners: dynamic programming and approximate DP on models (Algorithms 1-4)."""

from conjure.planners.base import Plan, PlanAgent, Planner
from conjure.planners.policy_iteration import PolicyIteration
from conjure.planners.q_api import QAPI
from conjure.planners.v_api import VAPI
from conjure.planners.value_iteration import ValueIteration

__all__ = ["QAPI", "VAPI", "Plan", "PlanAgent", "Planner", "PolicyIteration", "ValueIteration"]
