"""Every registered component against every applicable common check (STYLE §6)."""

import inspect

import pytest

from conjure.agents import SARSA, ActorCritic, QLearning
from conjure.agents.constraints import Saute
from conjure.domains import BlocksWorld, GridWorld, UAVMission
from conjure.experiments.registry import LAYERS
from conjure.models.approximate_model import ApproximateModel
from conjure.planners import CBBAPlanner, ModelPlanner, ShortestPathPlanner, SwitchingPlanner
from conjure.representations import (
    RBF,
    HashedTabular,
    IndependentDiscretization,
    OnlineIFDD,
    Tabular,
    TileCoding,
)
from conjure.safety import (
    AdaptiveCooperativeLearner,
    CooperativeLearner,
    MonteCarloRiskAnalyzer,
    NominalRiskAnalyzer,
)
from conjure.testing import applicable_checks


def grid_model(**params):
    """T̂ of the 4x5 grid (pit at (2, 2)) with short episodes, for the cooperative learners."""
    domain = GridWorld(map_name="4x5", noise=0.1, max_episode_steps=40)
    return ApproximateModel(domain=domain, **params)


#: Values for required constructor parameters, by parameter name.
REQUIRED = {
    "representation": lambda: Tabular(num_buckets=5),
    "base": lambda: IndependentDiscretization(num_buckets=5),
    "env_id": lambda: "CartPole-v1",
    "domain": lambda: GridWorld(map_name="4x5"),
    "learner": lambda: ActorCritic(representation=Tabular()),
    "planner": lambda: ModelPlanner(),
    "risk": lambda: NominalRiskAnalyzer(),
    "model": grid_model,
    "conservative": lambda: ShortestPathPlanner(),
    "aggressive": lambda: ModelPlanner(),
    "cost_limit": lambda: 1.0,
}

#: Variants beyond each registered class's defaults.
VARIANTS = [
    SARSA(representation=TileCoding(num_tilings=4, tiles_per_dim=4), trace_decay=0.8),
    SARSA(representation=TileCoding(num_tilings=3, tiles_per_dim=4, memory_size=64)),
    QLearning(representation=RBF()),
    SARSA(representation=HashedTabular(capacity=64)),
    ActorCritic(representation=Tabular(), actor_representation=RBF()),
    ActorCritic(representation=Tabular(), constraint=Saute(cost_limit=0.5, num_budget_bins=2)),
    GridWorld(map_name="gridworld2", step_reward=-0.01, noise=0.2),
    UAVMission(scenario="uav-10-2", traverse_failure=0.05),
    BlocksWorld(num_blocks=4, illegal_action="penalize", illegal_action_penalty=0.5),
    TileCoding(num_tilings=2, tiles_per_dim=3, dimension_groups=[[0], [1], [0, 1]]),
    OnlineIFDD(base=TileCoding(num_tilings=2, tiles_per_dim=3), relevance="ifdd_plus"),
    SARSA(
        representation=OnlineIFDD(base=IndependentDiscretization(), discovery_threshold=0.01),
        trace_decay=0.7,
    ),
    ActorCritic(representation=OnlineIFDD(base=Tabular(), discovery_threshold=0.01)),
    MonteCarloRiskAnalyzer(num_rollouts=3, horizon=20, risk_tolerance=0.5),
    CooperativeLearner(
        learner=SARSA(representation=OnlineIFDD(base=IndependentDiscretization())),
        planner=ShortestPathPlanner(),
        risk=MonteCarloRiskAnalyzer(),
        model=grid_model(),
        num_known_visits=2,
    ),
    CooperativeLearner(
        learner=QLearning(representation=Tabular()),
        planner=ModelPlanner(),
        risk=NominalRiskAnalyzer(),
        model=grid_model(),
        num_known_visits=1,
    ),
    AdaptiveCooperativeLearner(
        learner=SARSA(representation=Tabular()),
        planner=SwitchingPlanner(
            conservative=ShortestPathPlanner(goal=(3, 4)), aggressive=ModelPlanner()
        ),
        risk=MonteCarloRiskAnalyzer(),
        model=grid_model(initial_noise=0.4, prior_weight=10.0, is_adaptive=True),
        num_known_visits=2,
        trusted_knownness=0.5,
    ),
    # compilable switches and AM-iCCA, so that the compiled-form check runs on them
    SwitchingPlanner(
        conservative=ShortestPathPlanner(), aggressive=ShortestPathPlanner(goal=(3, 4))
    ),
    SwitchingPlanner(conservative=CBBAPlanner(), aggressive=CBBAPlanner(variant="aggressive")),
    AdaptiveCooperativeLearner(
        learner=SARSA(representation=Tabular()),
        planner=SwitchingPlanner(
            conservative=ShortestPathPlanner(), aggressive=ShortestPathPlanner(goal=(3, 4))
        ),
        risk=MonteCarloRiskAnalyzer(),
        model=grid_model(initial_noise=0.4, prior_weight=10.0, is_adaptive=True),
        num_known_visits=2,
    ),
]


def example(cls):
    params = {}
    for name, parameter in inspect.signature(cls.__init__).parameters.items():
        if name != "self" and parameter.default is inspect.Parameter.empty:
            params[name] = REQUIRED[name]()
    return cls(**params)


COMPONENTS = [example(cls) for registry in LAYERS.values() for cls in registry.values()]
COMPONENTS += VARIANTS
CASES = [
    pytest.param(component, check, id=f"{component!r}-{check.__name__}")
    for component in COMPONENTS
    for check in applicable_checks(component)
]
SLOW_CASES = [
    pytest.param(component, check, id=f"{component!r}-{check.__name__}")
    for component in COMPONENTS
    for check in applicable_checks(component, slow=True)
]


@pytest.mark.parametrize(("component", "check"), CASES)
def test_common_check(component, check):
    check(component)


@pytest.mark.slow
@pytest.mark.parametrize(("component", "check"), SLOW_CASES)
def test_slow_common_check(component, check):
    check(component)
