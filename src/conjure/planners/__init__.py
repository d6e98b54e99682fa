"""Planners: dynamic programming and approximate DP on models (Algorithms 1-9, 13).

Cooperative planners π^p of iCCA (Section 5.3.1): `CBBAPlanner` (Algorithm 27), `ModelPlanner`,
`ShortestPathPlanner`, `SwitchingPlanner`.
"""

from conjure.planners.base import Plan, PlanAgent, Planner
from conjure.planners.cbba import CBBA, Allocation
from conjure.planners.cbba_planner import CBBAPlanner, MissionPlan
from conjure.planners.fitted_vi import FittedValueIteration
from conjure.planners.model_planner import ModelPlanner
from conjure.planners.policy_iteration import PolicyIteration
from conjure.planners.q_api import QAPI
from conjure.planners.q_avi import QAVI
from conjure.planners.sampled_q_api import SampledQAPI1, SampledQAPI2
from conjure.planners.sampled_q_avi import SampledQAVI
from conjure.planners.shortest_path import ShortestPathPlanner
from conjure.planners.switching_planner import SwitchingPlanner
from conjure.planners.trajectory_q_api import TrajectoryQAPI
from conjure.planners.v_api import VAPI
from conjure.planners.value_iteration import ValueIteration

__all__ = [
    "CBBA",
    "QAPI",
    "QAVI",
    "VAPI",
    "Allocation",
    "CBBAPlanner",
    "FittedValueIteration",
    "MissionPlan",
    "ModelPlanner",
    "Plan",
    "PlanAgent",
    "Planner",
    "PolicyIteration",
    "SampledQAPI1",
    "SampledQAPI2",
    "SampledQAVI",
    "ShortestPathPlanner",
    "SwitchingPlanner",
    "TrajectoryQAPI",
    "ValueIteration",
]
