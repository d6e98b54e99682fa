import tempfile

import numpy as np
import pytest
from safety_fakes import CountingPlanner, FixedRiskAnalyzer

from conjure.agents import SARSA
from conjure.domains import GridWorld
from conjure.experiments.loop import LearningLoop
from conjure.models.approximate_model import ApproximateModel
from conjure.planners import ModelPlanner, ShortestPathPlanner, SwitchingPlanner
from conjure.representations import Tabular
from conjure.safety import AdaptiveCooperativeLearner, MonteCarloRiskAnalyzer


def am_icca(**params):
    parts = {
        "learner": SARSA(representation=Tabular()),
        "planner": SwitchingPlanner(
            conservative=ShortestPathPlanner.conservative(),
            aggressive=ShortestPathPlanner.aggressive(),
        ),
        "risk": MonteCarloRiskAnalyzer(),
        "model": ApproximateModel(
            domain=GridWorld.gridworld_2(), initial_noise=0.4, prior_weight=100.0, is_adaptive=True
        ),
    }
    return AdaptiveCooperativeLearner(**{**parts, **params})


def learn_in_calm_gridworld2(agent, seed=0):
    """A loop on GridWorld-2 without wind: every move is intended, so after m learning steps
    η̂ = 40 / (100 + m)."""
    domain = GridWorld.gridworld_2(noise=0.0)
    agent.setup(domain.domain_spec, seed=seed)
    return LearningLoop(domain, agent, seed=seed)


def test_counts_reset_exactly_when_the_planner_switches():
    # η̂ = 40 / (100 + m) < 0.25 first at m = 61 (Section 5.5.2's prior 0.4, weight 100).
    agent = am_icca()
    loop = learn_in_calm_gridworld2(agent)
    for _ in range(60):
        loop.advance(1)
        assert agent.counts_.sum() > 0 and agent.num_policy_changes_ == 0
    assert agent.model_.noise_ == pytest.approx(0.25)
    loop.advance(1)
    assert agent.planner_.is_aggressive_ and agent.num_policy_changes_ == 1
    assert agent.counts_.sum() == 0  # line 15: all counts restart
    assert agent.planned_noise_ == pytest.approx(40 / 161)
    for _ in range(100):
        loop.advance(1)
    assert agent.num_policy_changes_ == 1 and agent.counts_.sum() > 0


def test_replanning_waits_for_the_model_to_drift_more_than_delta_t():
    # ΔT = 0.05 (by hand): replans when η̂ < 0.35 (m = 15: 40/115), then < 0.2978 (m = 35:
    # 40/135), then < 0.2463 (m = 63: 40/163, below 0.25): the switch comes two moves late.
    agent = am_icca(replan_threshold=0.05)
    loop = learn_in_calm_gridworld2(agent)
    replanned_at = []
    for m in range(1, 70):
        before = agent.planned_noise_
        loop.advance(1)
        if agent.planned_noise_ != before:
            replanned_at.append(m)
    assert replanned_at == [15, 35, 63]
    assert agent.num_policy_changes_ == 1 and agent.planner_.is_aggressive_


def test_a_restored_agent_continues_with_the_switched_planner():
    agent = am_icca()
    loop = learn_in_calm_gridworld2(agent)
    loop.advance(80)
    with tempfile.TemporaryDirectory() as directory:
        agent.save(directory)
        restored = AdaptiveCooperativeLearner.restore(directory)
    assert restored.planner_.is_aggressive_ and restored.num_policy_changes_ == 1
    assert restored.model_.noise_ == agent.model_.noise_
    assert restored.model_.num_moves_ == 80
    np.testing.assert_array_equal(restored.counts_, agent.counts_)
    states = [np.array([2.0, c]) for c in range(11, 22)]
    assert [restored.act(s) for s in states] == [agent.act(s) for s in states]


def test_am_icca_on_a_noisy_uav_mission_switches_to_aggressive_cbba():
    # Section 5.5.2, UAV 7-2 with 5% traverse failures: the prior η̂ = 0.4 (weight 100) falls
    # below 25% once about 60 traversals succeed; conservative → aggressive CBBA is a change
    # of π^p, so the counts restart (Algorithm 26, lines 13-14).
    from conjure.domains import UAVMission
    from conjure.planners import CBBAPlanner
    from conjure.representations import HashedTabular

    domain = UAVMission(traverse_failure=0.05)
    agent = AdaptiveCooperativeLearner(
        learner=SARSA(representation=HashedTabular(capacity=20_000)),
        planner=SwitchingPlanner(
            conservative=CBBAPlanner(variant="conservative"),
            aggressive=CBBAPlanner(variant="aggressive"),
        ),
        risk=MonteCarloRiskAnalyzer(),
        model=ApproximateModel(domain=UAVMission(), initial_noise=0.4, is_adaptive=True),
        num_known_visits=10,
        index=HashedTabular(capacity=20_000),
    ).setup(domain.domain_spec, seed=0)
    assert not agent.planner_.is_aggressive_
    LearningLoop(domain, agent, seed=0).advance(3000)
    model = agent.model_
    assert agent.planner_.is_aggressive_ and agent.num_policy_changes_ >= 1
    assert model.num_moves_ > 1000
    expected = (model.num_unintended_ + 100 * 0.4) / (model.num_moves_ + 100)
    assert model.noise_ == pytest.approx(expected) and 0.03 < model.noise_ < 0.1


def test_the_analyser_is_updated_whenever_the_model_changes():
    # Issue 22: `RiskAnalyzer.update` is for a change of π^p *or* T̂; it used to run only when
    # π^p changed. In calm GridWorld-2 every move lowers η̂ = 40 / (100 + m); π^p switches once.
    agent = am_icca(risk=FixedRiskAnalyzer(value=0.0))
    loop = learn_in_calm_gridworld2(agent)
    assert agent.risk_.num_updates_ == 1  # setup's
    flags = []
    for _ in range(70):
        noise, updates = agent.model_.noise_, agent.risk_.num_updates_
        loop.advance(1)
        assert agent.model_.noise_ != noise
        assert agent.risk_.num_updates_ == updates + 1
        flags.append(agent.risk_.last_update_)
    assert flags == [False] * 60 + [True] + [False] * 9  # π^p switched at m = 61


def test_a_static_model_never_replans_or_updates_the_analyser():
    agent = am_icca(risk=FixedRiskAnalyzer(value=0.0))
    agent.set_params(planner=CountingPlanner(planner=agent.planner), model__is_adaptive=False)
    loop = learn_in_calm_gridworld2(agent)
    loop.advance(100)
    assert agent.planner_.num_updates_ == 0 and agent.risk_.num_updates_ == 1


def test_a_model_planner_replans_exactly_when_the_estimate_moves():
    # ΔT = 0: a ModelPlanner plans (value iteration at η̂) once per change of η̂, and a step
    # that leaves η̂ where it was (none counted by the model) plans nothing.
    agent = am_icca(planner=CountingPlanner(planner=ModelPlanner()))
    loop = learn_in_calm_gridworld2(agent)
    changes = 0
    for _ in range(30):
        noise = agent.model_.noise_
        loop.advance(1)
        changes += int(agent.model_.noise_ != noise)
    assert agent.planner_.num_updates_ == changes == 30
    agent.model_.is_adaptive = False  # T̂ frozen from here on
    loop.advance(20)
    assert agent.planner_.num_updates_ == 30
