"""Planners: dynamic programming and approximate DP on models (Algorithms 1-9, 13).

Cooperative planners π^p of iCCA (Section 5.3.1): `CBBAPlanner` (Algorithm 27), `ModelPlanner`,
`ShortestPathPlanner`, `SwitchingPlanner`.
"""

from __future__ import annotations

from conjure.core.lazy import lazy_exports

#: Each public name and the submodule defining it, imported on first use.
_EXPORTS = {
    "Plan": "base",
    "PlanAgent": "base",
    "Planner": "base",
    "CBBA": "cbba",
    "Allocation": "cbba",
    "CBBAPlanner": "cbba_planner",
    "MissionPlan": "cbba_planner",
    "FittedValueIteration": "fitted_vi",
    "ModelPlanner": "model_planner",
    "PolicyIteration": "policy_iteration",
    "QAPI": "q_api",
    "QAVI": "q_avi",
    "SampledQAPI1": "sampled_q_api",
    "SampledQAPI2": "sampled_q_api",
    "SampledQAVI": "sampled_q_avi",
    "ShortestPathPlanner": "shortest_path",
    "SwitchingPlanner": "switching_planner",
    "TrajectoryQAPI": "trajectory_q_api",
    "VAPI": "v_api",
    "ValueIteration": "value_iteration",
}

__all__ = sorted(_EXPORTS)
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
