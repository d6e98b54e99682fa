import numpy as np
import pytest
from safety_fakes import CountingPlanner, FakeLearner, FixedRiskAnalyzer, cell, gridworld_model

from conjure.agents import SARSA, ActorCritic, QLearning
from conjure.core.errors import InvalidParameterError
from conjure.core.interfaces import Transition
from conjure.core.schedules import EpisodicDecay
from conjure.domains import GridWorld
from conjure.experiments import run
from conjure.experiments.loop import LearningLoop
from conjure.models.approximate_model import ApproximateModel
from conjure.planners import ModelPlanner, ShortestPathPlanner
from conjure.policies import EpsilonGreedy
from conjure.representations import HashedTabular, Tabular
from conjure.safety import (
    AdaptiveCooperativeLearner,
    CooperativeLearner,
    MonteCarloRiskAnalyzer,
    NominalRiskAnalyzer,
    PlannerAgent,
)

START = cell(0, 0)  # the 4x5 map's start; the planner heads down (1)
PLANNER_ACTION = 1


def csarsa(learner=None, risk=None, **params):
    agent = CooperativeLearner(
        learner=FakeLearner(action=3) if learner is None else learner,
        planner=ShortestPathPlanner(),
        risk=FixedRiskAnalyzer(value=0.0) if risk is None else risk,
        model=gridworld_model(),
        **params,
    )
    domain = GridWorld(map_name="4x5", noise=0.0)
    return agent.setup(domain.domain_spec, seed=0)


def test_the_count_grows_only_when_the_planner_acts_unconsulted():
    agent = csarsa(num_known_visits=4)
    assert agent.planner_.action(START) == PLANNER_ACTION
    for _ in range(60):
        count = int(agent.counts_[agent.state_row(START), PLANNER_ACTION])
        assert agent.knownness(START, PLANNER_ACTION) == min(1.0, count / 4)
        consulted_before = agent.learner_.num_acts_
        action = agent.act(START)
        consulted = agent.learner_.num_acts_ > consulted_before
        new_count = int(agent.counts_[agent.state_row(START), PLANNER_ACTION])
        if consulted:  # lines 4-6: the safe learner action runs, the count stays
            assert action == 3 and new_count == count
        else:  # line 8
            assert action == PLANNER_ACTION and new_count == count + 1
    assert agent.counts_.sum() == 4  # known after 4 unconsulted visits, then always consulted
    assert agent.learner_.num_acts_ > 40


def test_the_first_visits_follow_the_planner_for_certain():
    # knownness 0, 1/3, 2/3: the first call cannot consult; with K = 1 the second must.
    agent = csarsa(num_known_visits=1)
    assert agent.act(START) == PLANNER_ACTION and agent.learner_.num_acts_ == 0
    assert agent.act(START) == 3 and agent.learner_.num_acts_ == 1


def test_an_unsafe_learner_action_is_replaced_and_not_counted():
    agent = csarsa(risk=FixedRiskAnalyzer(value=1.0), num_known_visits=1)
    agent.act(START)  # count 1: known
    for _ in range(5):
        assert agent.act(START) == PLANNER_ACTION
    assert agent.learner_.num_acts_ == 5
    assert agent.counts_[agent.state_row(START), PLANNER_ACTION] == 1


def test_greedy_acting_consults_the_learner_only_in_known_pairs_and_changes_nothing():
    agent = csarsa(num_known_visits=2)
    rng_before = agent.rng_.bit_generator.state
    assert agent.act(START, greedy=True) == PLANNER_ACTION  # unknown: the planner
    assert agent.counts_.sum() == 0 and agent.learner_.num_acts_ == 0
    while agent.knownness(START, PLANNER_ACTION) < 1.0:
        agent.act(START)
    assert agent.act(START, greedy=True) == 3  # known: the learner, if safe
    agent.risk_ = FixedRiskAnalyzer(value=1.0).setup(agent.model_, agent.planner_, seed=0)
    assert agent.act(START, greedy=True) == PLANNER_ACTION  # unsafe: replaced
    assert agent.counts_.sum() == 2
    assert agent.rng_.bit_generator.state != rng_before  # learning acts drew at knownness 1/2
    rng_now = agent.rng_.bit_generator.state
    agent.act(START, greedy=True)
    assert agent.rng_.bit_generator.state == rng_now  # greedy acts draw nothing


def test_any_online_learner_fits_and_learns_from_the_executed_action():
    model = gridworld_model(GridWorld.gridworld_1(noise=0.0))
    agent = CooperativeLearner(
        learner=SARSA(representation=Tabular()),
        planner=ModelPlanner(),
        risk=NominalRiskAnalyzer(),
        model=model,
    )
    result = run(domain=GridWorld.gridworld_1(), agent=agent, budget_steps=2000, seed=1)
    planner = PlannerAgent(planner=ModelPlanner(), model=model)
    baseline = run(domain=GridWorld.gridworld_1(), agent=planner, budget_steps=10, seed=1)
    first_check = result.curve["return"].iloc[0]
    assert first_check == baseline.curve["return"].iloc[0]  # greedy = the planner at first
    assert agent.learner_.num_learning_steps_ == 2000
    assert agent.counts_.sum() > 0
    assert agent.num_features == agent.learner_.num_features == 70


def test_the_learner_never_deliberately_steps_into_a_pit():
    # Section 5.4: with the nominal analyser, CSARSA enters a pit only by the wind. With no
    # wind it never does, while SARSA alone does.
    pits = {}
    for name, make in (("csarsa", cooperative_sarsa), ("sarsa", plain_sarsa)):
        domain = PitCounter(map_name="gridworld1", noise=0.0, max_episode_steps=200)
        agent = make().setup(domain.domain_spec, seed=0)
        LearningLoop(domain, agent, seed=0).advance(3000)
        pits[name] = domain.num_pits
    assert pits["csarsa"] == 0 < pits["sarsa"]


class PitCounter(GridWorld):
    def step(self, action):
        outcome = super().step(action)
        self.num_pits = getattr(self, "num_pits", 0) + int(outcome[-1]["cost"])
        return outcome


def plain_sarsa():
    return SARSA(representation=Tabular(), policy=EpsilonGreedy(epsilon=0.1))


def cooperative_sarsa():
    return CooperativeLearner(
        learner=plain_sarsa(),
        planner=ModelPlanner(),
        risk=NominalRiskAnalyzer(),
        model=gridworld_model(GridWorld.gridworld_1(noise=0.0)),
        num_known_visits=1,
    )


def test_greedy_acting_keeps_the_planner_among_the_learners_ties():
    # An untrained SARSA has Q(s, ·) = 0: its first maximiser (up, into the wall) would loop
    # until the cap; the planner's action is among the maximisers, so it is kept.
    agent = csarsa(learner=SARSA(representation=Tabular()), num_known_visits=1)
    agent.counts_[agent.state_row(START), PLANNER_ACTION] = 1  # known: the learner is asked
    assert agent.learner_.act(START, greedy=True) == 0
    assert agent.act(START, greedy=True) == PLANNER_ACTION
    row = agent.learner_.representation_.active_features(START)[0]
    agent.learner_.weights_[row, 3] = 0.5  # the learner now ranks "right" strictly higher
    assert agent.act(START, greedy=True) == 3


@pytest.mark.parametrize("visits", [0, -3])
def test_a_knownness_threshold_below_one_is_refused_naming_the_value(visits):
    with pytest.raises(InvalidParameterError, match=rf"num_known_visits.*{visits}"):
        csarsa(num_known_visits=visits)


RIGHT = 3  # the learner's proposal below; the planner heads down (1) from START


def vetoing_agent(learner, **params):
    """Every proposal but the planner's is unsafe; ⟨START, down⟩ is already known (K = 1)."""
    agent = csarsa(learner=learner, risk=FixedRiskAnalyzer(value=1.0), num_known_visits=1, **params)
    agent.act(START)  # the planner acts unconsulted: count 1, known
    return agent


def greedy_sarsa(**params):
    return SARSA(
        representation=Tabular(), policy=EpsilonGreedy(epsilon=0.0), step_size=0.5, **params
    )


@pytest.mark.parametrize(
    "make",
    [
        greedy_sarsa,
        lambda: QLearning(
            representation=Tabular(), policy=EpsilonGreedy(epsilon=0.0), step_size=0.5
        ),
    ],
)
def test_a_vetoed_proposal_is_learned_as_a_terminal_step_earning_the_veto_reward(make):
    # Q(START, right) = 0.4 makes "right" the greedy proposal; the analyser vetoes it, so the
    # learner learns ⟨START, right⟩ → failure: a terminal target of −2, step size 0.5:
    # Q ← 0.4 + 0.5·(−2 − 0.4) = −0.8. Nothing else changes and no learning step is counted.
    agent = vetoing_agent(make(), veto_reward=-2.0)
    learner = agent.learner_
    row = learner.representation_.active_features(START)[0]
    learner.weights_[row, RIGHT] = 0.4
    expected = learner.weights_.copy()
    expected[row, RIGHT] = -0.8
    assert agent.act(START) == PLANNER_ACTION
    np.testing.assert_allclose(learner.weights_, expected, rtol=0, atol=1e-15)
    assert learner.num_learning_steps_ == 0
    assert agent.act(START, greedy=True) == PLANNER_ACTION  # greedy acting learns nothing
    np.testing.assert_allclose(learner.weights_, expected, rtol=0, atol=1e-15)


def test_the_printed_algorithm_leaves_the_learner_unchanged_by_a_veto():
    agent = vetoing_agent(greedy_sarsa(), veto_reward=None)
    row = agent.learner_.representation_.active_features(START)[0]
    agent.learner_.weights_[row, RIGHT] = 0.4
    before = agent.learner_.weights_.copy()
    assert agent.act(START) == PLANNER_ACTION
    np.testing.assert_array_equal(agent.learner_.weights_, before)


def test_a_veto_leaves_the_eligibility_traces_of_the_episode_alone():
    # SARSA(λ): the imagined failure is a one-step episode of its own, so the real episode's
    # traces are neither decayed, extended nor cleared, and only θ(START, right) moves.
    agent = vetoing_agent(greedy_sarsa(trace_decay=0.9), veto_reward=-1.0)
    learner = agent.learner_
    learner.learn(Transition(cell(1, 0), 0, -0.001, START, PLANNER_ACTION, False))
    traces = [
        learner.trace_count_.copy(),
        learner.trace_values_.copy(),
        learner.trace_slots_.copy(),
    ]
    row = learner.representation_.active_features(START)[0]
    learner.weights_[row, RIGHT] = 0.4
    expected = learner.weights_.copy()
    expected[row, RIGHT] = 0.4 + 0.5 * (-1.0 - 0.4)
    assert agent.act(START) == PLANNER_ACTION
    np.testing.assert_allclose(learner.weights_, expected, rtol=0, atol=1e-15)
    for before, after in zip(
        traces, [learner.trace_count_, learner.trace_values_, learner.trace_slots_], strict=True
    ):
        np.testing.assert_array_equal(after, before)


def test_a_veto_lowers_an_actor_critics_preference_through_its_own_update():
    # Actor-Critic (Algorithm 12): δ = −1 − Q(START, right) = −1 moves the critic's Q and the
    # actor's ρ(START, right) by αδ = −0.5 each (no λ needed: the learner's own update).
    actor_critic = ActorCritic(representation=Tabular(), step_size=0.5)
    agent = vetoing_agent(actor_critic, veto_reward=-1.0)
    learner = agent.learner_
    learner.shift_preference(START, RIGHT, 50.0)  # the Gibbs actor proposes "right" for sure
    preferences = learner.preferences(START)
    assert agent.act(START) == PLANNER_ACTION
    preferences[RIGHT] -= 0.5
    np.testing.assert_allclose(learner.preferences(START), preferences, rtol=0, atol=1e-12)
    assert learner.q_values(START)[RIGHT] == pytest.approx(-0.5)


@pytest.mark.parametrize("reward", [float("inf"), float("nan"), "high", True])
def test_a_veto_reward_that_is_not_a_finite_float_is_refused(reward):
    with pytest.raises(InvalidParameterError, match=r"veto_reward.*finite float or None"):
        csarsa(veto_reward=reward)


@pytest.mark.slow
def test_static_model_icca_on_gridworld2_ends_at_the_conservative_policy():
    # Fig. 5-12's "iCCA": Algorithm 24 with the conservative policy and Algorithm 25 at a
    # static 40% noise, SARSA(0) at α₀ = 0.1, N₀ = 1000 (one of the two searched settings where
    # the veto rule decides; docs/reproduction/fig_5_12.md). With the
    # veto rule (the default) the learner stops proposing the moves toward the right goal the
    # analyser blocks and the greedy policy ends on the conservative route (V = 0.624, spec
    # 4.3); as printed, learner and planner pull the agent back and forth and the greedy
    # policy cycles until the episode cap, with many more pit entries while learning.
    finals, failures = {}, {}
    for veto_reward in (-1.0, None):
        for seed in range(3):
            agent = CooperativeLearner(
                learner=SARSA(
                    representation=Tabular(),
                    policy=EpsilonGreedy(epsilon=0.1),
                    step_size=EpisodicDecay(alpha_0=0.1, n_0=1000),
                ),
                planner=ShortestPathPlanner.conservative(),
                risk=MonteCarloRiskAnalyzer(),
                model=ApproximateModel(domain=GridWorld.gridworld_2(), initial_noise=0.4),
                veto_reward=veto_reward,
            )
            result = run(
                domain=GridWorld.gridworld_2(),
                agent=agent,
                budget_steps=30_000,
                seed=seed,
                num_policy_checks=1,
                eval_episodes=100,
            )
            last = result.curve.iloc[-1]
            finals.setdefault(veto_reward, []).append(last["return"])
            failures.setdefault(veto_reward, []).append(last["learning_failures"])
    assert min(finals[-1.0]) >= 0.6  # the conservative route on every seed
    assert np.mean(finals[None]) < 0.0  # as printed: cycling until the cap
    assert sum(failures[-1.0]) * 5 < sum(failures[None])


@pytest.mark.parametrize("kind", [CooperativeLearner, AdaptiveCooperativeLearner])
def test_trusted_knownness_skips_the_safety_check_in_algorithms_24_and_26(kind):
    # Section 5.5.3: from knownness 1 the learner's (here always unsafe) action is executed.
    # Issue 22: it was a subclass hook only AM-iCCA switched on; Algorithm 24 takes it too.
    domain = GridWorld(map_name="4x5", noise=0.0)
    start = cell(0, 0)
    for trusted, expected in ((None, 1), (1.0, 3)):
        agent = kind(
            learner=FakeLearner(action=3),
            planner=ShortestPathPlanner(),
            risk=FixedRiskAnalyzer(value=1.0),
            model=gridworld_model(),
            num_known_visits=1,
            trusted_knownness=trusted,
        ).setup(domain.domain_spec, seed=0)
        agent.act(start)  # the planner's action (down, 1) becomes known
        assert agent.act(start) == expected  # the learner's unsafe move, once trusted
        assert agent.act(start, greedy=True) == expected
    with pytest.raises(InvalidParameterError, match="trusted_knownness"):
        kind(
            learner=FakeLearner(action=3),
            planner=ShortestPathPlanner(),
            risk=FixedRiskAnalyzer(value=1.0),
            model=gridworld_model(),
            trusted_knownness=1.5,
        ).setup(domain.domain_spec, seed=0)


@pytest.mark.parametrize("greedy", [False, True])
def test_the_planner_is_asked_once_per_step(greedy):
    # Issue 22: `is_safe` asked π^p again for the action `act` already had (two CBBA plans per
    # step on UAV missions). K = 1: the learner's right (3) is proposed from the second visit.
    agent = CooperativeLearner(
        learner=FakeLearner(action=3),
        planner=CountingPlanner(planner=ShortestPathPlanner()),
        risk=FixedRiskAnalyzer(value=0.0),
        model=gridworld_model(),
        num_known_visits=1,
    )
    agent.setup(GridWorld(map_name="4x5", noise=0.0).domain_spec, seed=0)
    agent.act(START)  # the first visit makes the pair known
    for _ in range(5):
        before = agent.planner_.num_actions_
        assert agent.act(START, greedy=greedy) == 3  # consulted, safe, executed
        assert agent.planner_.num_actions_ == before + 1


def test_knownness_of_an_unseen_state_stores_no_row_in_a_hashed_index():
    # Issue 22: inspecting knownness inserted the state into the lazily indexed table.
    agent = csarsa(index=HashedTabular())
    agent.act(START)
    stored = agent.index_.num_stored_
    unseen = cell(3, 4)
    assert agent.knownness(unseen, PLANNER_ACTION) == 0.0
    assert agent.index_.num_stored_ == stored
    assert agent.state_row(unseen, store=False) == -1
    assert agent.knownness(START, PLANNER_ACTION) == 0.1  # a seen state: count 1 of 10
