"""Safe exploration (Geramifard 2012, Chapter 5): risk analysers, cooperative learners, a shield.

- Risk analysers (`RiskAnalyzer`, Sections 5.3.3 and 5.5): `NominalRiskAnalyzer` (GridWorld-1),
  `FuelRiskAnalyzer` (UAV missions), `MonteCarloRiskAnalyzer` (Algorithm 25).
- Cooperative learners: agents composing a learner, a cooperative planner, a risk analyser
  and an approximate model (Figure 5-11): `CooperativeActorCritic` (Algorithm 23, iCCA),
  `CooperativeLearner` (Algorithm 24, CSARSA with SARSA), `AdaptiveCooperativeLearner`
  (Algorithm 26, AM-iCCA); `PlannerAgent` runs a planner alone.
- `ShieldedLearner`: a learner choosing only among the actions the risk analyser finds safe
  (a preemptive shield, without the planner's guidance).
- `SafetyShield`: the risk filter as a Gymnasium wrapper, for agents of any library.
"""

from __future__ import annotations

from conjure.core.lazy import lazy_exports

#: Each public name and the submodule defining it, imported on first use.
_EXPORTS = {
    "AdaptiveCooperativeLearner": "adaptive_cooperative_learner",
    "CooperativeActorCritic": "cooperative_actor_critic",
    "CooperativeAgent": "cooperative_agent",
    "CooperativeLearner": "cooperative_learner",
    "FuelRiskAnalyzer": "fuel_risk",
    "MonteCarloRiskAnalyzer": "monte_carlo_risk",
    "NominalRiskAnalyzer": "nominal_risk",
    "PlannerAgent": "planner_agent",
    "SafetyShield": "shield",
    "ShieldedLearner": "shielded_learner",
}

__all__ = sorted(_EXPORTS)
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
