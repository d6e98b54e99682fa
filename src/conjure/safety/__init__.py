"""Safe exploration (Geramifard 2012, Chapter 5): risk analysers, cooperative learners, a shield.

- Risk analysers (`RiskAnalyzer`, Sections 5.3.3 and 5.5): `NominalRiskAnalyzer` (GridWorld-1),
  `FuelRiskAnalyzer` (UAV missions), `MonteCarloRiskAnalyzer` (Algorithm 25).
- Cooperative learners: agents composing a learner, a cooperative planner, a risk analyser
  and an approximate model (Figure 5-11): `CooperativeActorCritic` (Algorithm 23, iCCA),
  `CooperativeLearner` (Algorithm 24, CSARSA with SARSA), `AdaptiveCooperativeLearner`
  (Algorithm 26, AM-iCCA); `PlannerAgent` runs a planner alone.
- `SafetyShield`: the risk filter as a Gymnasium wrapper, for agents of any library.
"""

from conjure.safety.adaptive_cooperative_learner import AdaptiveCooperativeLearner
from conjure.safety.cooperative_actor_critic import CooperativeActorCritic
from conjure.safety.cooperative_agent import CooperativeAgent
from conjure.safety.cooperative_learner import CooperativeLearner
from conjure.safety.fuel_risk import FuelRiskAnalyzer
from conjure.safety.monte_carlo_risk import MonteCarloRiskAnalyzer
from conjure.safety.nominal_risk import NominalRiskAnalyzer
from conjure.safety.planner_agent import PlannerAgent
from conjure.safety.shield import SafetyShield

__all__ = [
    "AdaptiveCooperativeLearner",
    "CooperativeActorCritic",
    "CooperativeAgent",
    "CooperativeLearner",
    "FuelRiskAnalyzer",
    "MonteCarloRiskAnalyzer",
    "NominalRiskAnalyzer",
    "PlannerAgent",
    "SafetyShield",
]
