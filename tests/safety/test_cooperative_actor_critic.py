import numpy as np
import pytest
from safety_fakes import CountingPlanner, FixedRiskAnalyzer, cell, gridworld_model

from conjure.agents import SARSA, ActorCritic
from conjure.core.errors import InvalidParameterError
from conjure.domains import GridWorld
from conjure.planners import ShortestPathPlanner
from conjure.representations import Tabular
from conjure.safety import CooperativeActorCritic

START = cell(0, 0)  # the 4x5 map's start; the planner heads down (1)
PLANNER_ACTION = 1


def icca(risk_value=0.0, bias=100.0, seed=0, bias_half_life=None):
    domain = GridWorld(map_name="4x5", noise=0.0)
    agent = CooperativeActorCritic(
        learner=ActorCritic(representation=Tabular()),
        planner=ShortestPathPlanner(),
        risk=FixedRiskAnalyzer(value=risk_value),
        model=gridworld_model(),
        bias=bias,
        bias_half_life=bias_half_life,
    )
    return agent.setup(domain.domain_spec, seed=seed)


def test_the_planners_action_is_biased_by_lambda_on_the_first_visit_only():
    agent = icca(bias=100.0)
    assert agent.learner_.preferences(START).tolist() == [0.0] * 4
    assert agent.act(START) == PLANNER_ACTION  # Gibbs: e^100 against 1
    assert agent.learner_.preferences(START).tolist() == [0.0, 100.0, 0.0, 0.0]
    agent.act(START)
    assert agent.learner_.preferences(START).tolist() == [0.0, 100.0, 0.0, 0.0]
    assert np.count_nonzero(agent.visits_) == 1


def test_a_fading_bias_leaves_lambda_nb_over_nb_plus_n_after_n_visits():
    agent = icca(bias=10.0, bias_half_life=4.0)
    for n in range(1, 30):
        agent.act(START)
        # b(n − 1) after the n-th visit: λ on the first, then λ·N_b/(N_b + n − 1).
        expected = 10.0 * 4.0 / (4.0 + n - 1)
        assert agent.learner_.preferences(START)[PLANNER_ACTION] == pytest.approx(expected)
        assert agent.planner_bias(n - 1) == pytest.approx(expected)
    assert agent.visits_.max() == 29
    assert agent.learner_.preferences(START)[[0, 2, 3]].tolist() == [0.0, 0.0, 0.0]


def test_an_unsafe_learner_action_is_replaced_and_penalised_by_lambda():
    agent = icca(risk_value=1.0, bias=0.5)  # every non-planner action is unsafe
    penalised = []
    for _ in range(40):
        before = agent.learner_.preferences(START).copy()
        assert agent.act(START) == PLANNER_ACTION  # lines 4-5
        change = agent.learner_.preferences(START) - before
        penalised += [a for a in range(4) if change[a] == pytest.approx(-0.5)]
        assert sum(change != 0) <= 2  # the first visit's bias, or one penalty (line 6)
    assert penalised and PLANNER_ACTION not in penalised
    preferences = agent.learner_.preferences(START)
    assert preferences[PLANNER_ACTION] == 0.5
    assert sum(preferences[a] for a in (0, 2, 3)) == pytest.approx(-0.5 * len(penalised))


def test_greedy_acting_treats_unvisited_states_as_biased_and_replaces_unsafe_actions():
    agent = icca(bias=100.0)
    assert agent.act(START, greedy=True) == PLANNER_ACTION
    assert agent.visits_.sum() == 0  # nothing recorded
    agent.learner_.shift_preference(START, 3, 1000.0)  # the actor now prefers right
    assert agent.act(START, greedy=True) == 3
    unsafe = icca(risk_value=1.0)
    unsafe.learner_.shift_preference(START, 3, 1000.0)
    assert unsafe.act(START, greedy=True) == PLANNER_ACTION


def test_the_learner_must_be_an_actor_critic():
    agent = CooperativeActorCritic(
        learner=SARSA(representation=Tabular()),
        planner=ShortestPathPlanner(),
        risk=FixedRiskAnalyzer(),
        model=gridworld_model(),
    )
    with pytest.raises(InvalidParameterError, match="learner"):
        agent.setup(GridWorld(map_name="4x5").domain_spec, seed=0)


def test_the_shipped_gridworld1_example_runs_icca_as_the_planner_at_first():
    from pathlib import Path

    from conjure.experiments.config import load_config
    from conjure.experiments.run import run_config

    path = Path(__file__).resolve().parents[2] / "examples" / "gridworld_icca.yaml"
    config = load_config(path, ["budget_steps=300", "num_policy_checks=1", "eval_episodes=5"])
    returns = {
        label: run_config(config, agent_name=label, seed=0).curve["return"].iloc[0]
        for label in ("actor_critic", "icca", "vi_planner")
    }
    assert returns["icca"] == returns["vi_planner"] > returns["actor_critic"]


def test_icca_with_cbba_never_crashes_while_learning_a_deterministic_mission():
    # Section 5.3.5, UAV 7-2 without noise: the fuel rule filters the actor, CBBA is safe, so
    # iCCA never crashes while learning; Actor-Critic alone does, often.
    from conjure.domains import UAVMission
    from conjure.experiments.loop import LearningLoop
    from conjure.models.approximate_model import ApproximateModel
    from conjure.planners import CBBAPlanner
    from conjure.representations import HashedTabular
    from conjure.safety import FuelRiskAnalyzer

    def crashes(agent):
        domain = UAVMission()
        agent.setup(domain.domain_spec, seed=0)
        count = 0
        step = domain.step

        def counting_step(action):
            nonlocal count
            outcome = step(action)
            count += int(outcome[-1]["cost"])
            return outcome

        domain.step = counting_step
        LearningLoop(domain, agent, seed=0).advance(2000)
        return count

    def actor_critic():
        return ActorCritic(representation=HashedTabular(capacity=20_000))

    icca = CooperativeActorCritic(
        learner=actor_critic(),
        planner=CBBAPlanner(variant="aggressive"),
        risk=FuelRiskAnalyzer(),
        model=ApproximateModel(domain=UAVMission()),
        index=HashedTabular(capacity=20_000),
        bias=100.0,
        bias_half_life=None,
    )
    assert crashes(icca) == 0
    assert crashes(actor_critic()) > 50


def test_the_tabular_actor_is_the_critic_plus_the_bias_so_lambda_100_never_yields():
    # Algorithm 23 with a tabular actor sharing the critic's step size: ω and θ get the same
    # increments αδ, so ρ(s, a) = Q(s, a) + λ·[a = π^p(s)] while no proposal is unsafe. On
    # GridWorld-1 |Q| <= ~1, so with λ = 100 the planner's action leads every other by ~98
    # (Gibbs at τ = 1: probability ~e^-98 of trying another) and the greedy policy is π^p:
    # the mechanism behind iCCA staying at the planner's return (docs/reproduction/fig_5_5.md).
    from conjure.core.schedules import EpisodicDecay
    from conjure.experiments.loop import LearningLoop
    from conjure.models.approximate_model import ApproximateModel
    from conjure.planners import ModelPlanner
    from conjure.safety import NominalRiskAnalyzer

    domain = GridWorld.gridworld_1()
    agent = CooperativeActorCritic(
        learner=ActorCritic(
            representation=Tabular(), step_size=EpisodicDecay(alpha_0=1.0, n_0=100)
        ),
        planner=ModelPlanner(),
        risk=NominalRiskAnalyzer(),
        model=ApproximateModel(domain=GridWorld.gridworld_1(noise=0.0)),
        bias=100.0,
        bias_half_life=None,
    ).setup(domain.domain_spec, seed=0)
    LearningLoop(domain, agent, seed=0).advance(3000)
    visited = [
        np.array([r, c], dtype=float)
        for r in range(10)
        for c in range(7)
        if agent.visits_[agent.state_row(np.array([r, c], dtype=float), store=False)]
    ]
    assert len(visited) > 20
    for state in visited:
        planner_action = agent.planner_.action(state)
        expected = agent.learner_.q_values(state)
        expected[planner_action] += 100.0
        np.testing.assert_allclose(agent.learner_.preferences(state), expected, atol=1e-9)
        assert agent.act(state, greedy=True) == planner_action


@pytest.mark.slow
def test_the_default_icca_learns_past_its_planner_on_gridworld1_and_the_printed_one_does_not():
    # Issue 19 / Fig. 5-5: a V critic with a fading bias (the defaults, λ = 30, N_b = 2) ends
    # above value iteration's noise-free plan; Algorithm 23 as printed (Q critic, λ = 100)
    # stays the planner, to the last digit.
    from conjure.core.schedules import EpisodicDecay
    from conjure.experiments import run
    from conjure.models.approximate_model import ApproximateModel
    from conjure.planners import ModelPlanner
    from conjure.safety import NominalRiskAnalyzer, PlannerAgent

    def final_return(agent, seed):
        result = run(
            domain=GridWorld.gridworld_1(),
            agent=agent,
            budget_steps=10_000,
            seed=seed,
            num_policy_checks=1,
            eval_episodes=100,
        )
        return result.curve["return"].iloc[-1]

    def cooperative(critic, **bias):
        learner = ActorCritic(
            representation=Tabular(), step_size=EpisodicDecay(alpha_0=1.0, n_0=100), critic=critic
        )
        return CooperativeActorCritic(
            learner=learner,
            planner=ModelPlanner(),
            risk=NominalRiskAnalyzer(),
            model=calm(),
            **bias,
        )

    def calm():
        return ApproximateModel(domain=GridWorld.gridworld_1(noise=0.0))

    seeds = range(4)
    planner = [final_return(PlannerAgent(planner=ModelPlanner(), model=calm()), s) for s in seeds]
    learned = [final_return(cooperative("v"), s) for s in seeds]
    printed = [final_return(cooperative("q", bias=100.0, bias_half_life=None), s) for s in seeds]
    assert printed == planner
    assert np.mean(learned) > np.mean(planner) + 0.15  # measured: 0.59 vs 0.26 on 60 seeds


@pytest.mark.parametrize("greedy", [False, True])
def test_the_planner_is_asked_once_per_step(greedy):
    # Issue 22: `is_safe` asked π^p again for the action `act` already had.
    domain = GridWorld(map_name="4x5", noise=0.0)
    agent = CooperativeActorCritic(
        learner=ActorCritic(representation=Tabular()),
        planner=CountingPlanner(planner=ShortestPathPlanner()),
        risk=FixedRiskAnalyzer(value=0.0),
        model=gridworld_model(),
        bias=0.0,
    ).setup(domain.domain_spec, seed=0)
    proposals = set()
    for _ in range(20):
        before = agent.planner_.num_actions_
        proposals.add(agent.act(START, greedy=greedy))
        assert agent.planner_.num_actions_ == before + 1
    assert proposals - {PLANNER_ACTION} or greedy  # learning proposes other actions too
