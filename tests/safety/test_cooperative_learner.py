import pytest
from safety_fakes import FakeLearner, FixedRiskAnalyzer, cell, gridworld_model

from conjure.agents import SARSA
from conjure.core.errors import InvalidParameterError
from conjure.domains import GridWorld
from conjure.experiments import run
from conjure.experiments.loop import LearningLoop
from conjure.planners import ModelPlanner, ShortestPathPlanner
from conjure.policies import EpsilonGreedy
from conjure.representations import Tabular
from conjure.safety import CooperativeLearner, NominalRiskAnalyzer, PlannerAgent

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
