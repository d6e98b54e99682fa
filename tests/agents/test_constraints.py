"""Cost constraints of the linear TD learners: λ's rules, θ_C's update, acting on Q − λQ_C."""

from __future__ import annotations

import numpy as np
import pytest

from conjure.agents import SARSA, ActorCritic, QLearning
from conjure.agents import compiled_agent as forms
from conjure.agents.constraints import Lagrangian, PIDLagrangian, Saute
from conjure.core.errors import IncompatibleComponentsError, InvalidParameterError
from conjure.core.interfaces import Transition
from conjure.domains import ChainMDP, GridWorld
from conjure.experiments import run
from conjure.experiments.loop import Stepper, run_episode
from conjure.experiments.registry import build
from conjure.models.approximate_model import ApproximateModel
from conjure.planners import ShortestPathPlanner
from conjure.policies import EpsilonGreedy
from conjure.representations import IndependentDiscretization, OnlineIFDD, Tabular
from conjure.safety import CooperativeLearner, NominalRiskAnalyzer
from conjure.testing.checks import check_component
from cost_corridor import register as register_corridor


def _multipliers(constraint, costs: list[float]) -> list[float]:
    """λ after each episode of the given costs (`update_multiplier` on a fresh state)."""
    state = np.zeros(4)
    out = []
    for cost in costs:
        state[forms.EPISODE_COST] = cost
        forms.update_multiplier(constraint.compiled_form(), state)
        out.append(round(float(state[forms.MULTIPLIER]), 12))
    return out


def test_lagrangian_dual_ascent_by_hand():
    # λ ← max(0, λ + η (J − d)), η = 0.5, d = 0.1.
    rule = Lagrangian(cost_limit=0.1, multiplier_step_size=0.5)
    assert _multipliers(rule, [1.0, 0.0, 0.0, 2.0]) == [0.45, 0.4, 0.35, 1.3]
    assert _multipliers(rule, [0.0]) == [0.0]  # never below 0


def test_pid_lagrangian_by_hand():
    # Δ = J − d; I ← max(0, I + Δ); ∂ = max(0, J − J_prev); λ = max(0, KpΔ + KiI + Kd∂).
    rule = PIDLagrangian(cost_limit=0.1, kp=1.0, ki=0.5, kd=0.25)
    # J = 1: Δ .9, I .9, ∂ 1 → .9 + .45 + .25; J = 0: Δ −.1, I .8, ∂ 0 → −.1 + .4;
    # J = 0: Δ −.1, I .7 → −.1 + .35; J = 3: Δ 2.9, I 3.6, ∂ 3 → 2.9 + 1.8 + .75.
    assert _multipliers(rule, [1.0, 0.0, 0.0, 3.0]) == [1.6, 0.3, 0.25, 5.45]
    # K_p = K_d = 0 is the Lagrangian with η = K_i.
    plain = _multipliers(Lagrangian(cost_limit=0.1, multiplier_step_size=0.5), [1.0, 0.0, 2.0])
    assert _multipliers(PIDLagrangian(cost_limit=0.1, kp=0.0, ki=0.5), [1.0, 0.0, 2.0]) == plain


@pytest.mark.parametrize(
    ("constraint", "message"),
    [
        (lambda: Lagrangian(cost_limit=0.0), r"cost_limit` must be a float in \(0, inf\)"),
        (
            lambda: Lagrangian(cost_limit=1.0, multiplier_step_size=-1.0),
            "multiplier_step_size",
        ),
        (lambda: PIDLagrangian(cost_limit=1.0, kp=0, ki=0, kd=0), "needs a positive gain"),
        (lambda: PIDLagrangian(cost_limit=1.0, kd=-0.1), "kd"),
    ],
)
def test_a_limit_or_gain_that_cannot_work_is_refused_in_one_line(constraint, message):
    domain = ChainMDP(num_actions=2)
    agent = SARSA(representation=Tabular(), constraint=constraint())
    with pytest.raises(InvalidParameterError, match=message) as caught:
        agent.setup(domain.domain_spec, 0)
    assert "\n" not in str(caught.value)
    with pytest.raises(InvalidParameterError, match="a CostConstraint or None"):
        SARSA(representation=Tabular(), constraint=0.1).setup(domain.domain_spec, 0)


def _terminal(state: float, action: int, reward: float, cost: float) -> Transition:
    s = np.array([state])
    return Transition(s, action, reward, s, 0, True, cost=cost)


def test_the_cost_critic_learns_the_cost_by_the_learners_own_td_rule():
    domain = ChainMDP(num_states=4, num_actions=2)
    for cls in (SARSA, QLearning):
        agent = cls(representation=Tabular(), step_size=0.5, constraint=Lagrangian(cost_limit=1))
        agent.setup(domain.domain_spec, 0)
        agent.begin_episode()
        agent.learn(_terminal(2.0, 1, reward=3.0, cost=1.0))
        assert agent.weights_[2, 1] == 1.5  # θ ← θ + α (r − θ)
        assert agent.cost_weights_[2, 1] == 0.5  # θ_C ← θ_C + α (c − θ_C)
        assert agent.cost_weights_.sum() == 0.5
        agent.begin_episode()  # the episode's cost 1 against d = 1: λ stays 0
        assert agent.multiplier_ == 0.0


def test_sarsa_bootstraps_the_cost_from_a_prime_and_q_learning_from_the_penalized_argmax():
    domain = ChainMDP(num_states=4, num_actions=2, discount=1.0)
    s, s2 = np.array([0.0]), np.array([1.0])
    for cls in (SARSA, QLearning):
        agent = cls(representation=Tabular(), step_size=0.5, constraint=Lagrangian(cost_limit=1))
        agent.setup(domain.domain_spec, 0)
        agent.weights_[1] = [10.0, 9.0]  # Q(s', ·)
        agent.cost_weights_[1] = [4.0, 2.0]  # Q_C(s', ·)
        agent.arrays_.constraint_state[forms.MULTIPLIER] = 1.0  # Q − λQ_C = [6, 7]: a* = 1
        # a' = 0 is given (SARSA reads it); Q-Learning's a* = argmax(Q − λQ_C) = 1.
        agent.learn(Transition(s, 0, 0.0, s2, 0, False, cost=0.0))
        target = 10.0 if cls is SARSA else 9.0
        assert agent.weights_[0, 0] == 0.5 * target
        # θ_C: c + γ Q_C(s', a') with a' = 0 for SARSA (4.0), a* = 1 for Q-Learning (2.0).
        assert agent.cost_weights_[0, 0] == (2.0 if cls is SARSA else 1.0)


def test_sarsa_and_q_learning_act_on_q_minus_lambda_q_c():
    domain = ChainMDP(num_states=4, num_actions=2)
    for cls in (SARSA, QLearning):
        agent = cls(representation=Tabular(), constraint=Lagrangian(cost_limit=1)).setup(
            domain.domain_spec, 0
        )
        state = np.array([2.0])
        agent.weights_[2] = [1.0, 2.0]
        agent.cost_weights_[2] = [0.0, 0.6]
        assert agent.act(state, greedy=True) == 1  # λ = 0: Q alone
        agent.arrays_.constraint_state[forms.MULTIPLIER] = 2.0  # [1, 2 − 1.2]
        assert agent.act(state, greedy=True) == 0
        assert agent.q_values(state).tolist() == [1.0, 2.0]  # Q itself is unchanged


def test_the_actor_steps_on_delta_minus_lambda_delta_c():
    domain = ChainMDP(num_states=4, num_actions=2)
    agent = ActorCritic(
        representation=Tabular(), step_size=0.5, constraint=Lagrangian(cost_limit=1)
    ).setup(domain.domain_spec, 0)
    agent.arrays_.constraint_state[forms.MULTIPLIER] = 3.0
    agent.learn(_terminal(1.0, 0, reward=1.0, cost=1.0))
    # δ = 1, δ_C = 1: ω ← ω + α' (δ − λδ_C) = 0.5 (1 − 3).
    assert agent.actor_weights_[1, 0] == -1.0
    assert agent.weights_[1, 0] == 0.5 and agent.cost_weights_[1, 0] == 0.5


def test_a_constrained_learner_saves_and_restores_theta_c_and_lambda(tmp_path):
    domain = GridWorld.gridworld_1()
    agent = SARSA(representation=Tabular(), step_size=0.5, constraint=PIDLagrangian(cost_limit=0.1))
    run(domain=domain, agent=agent, budget_steps=3000, seed=5, num_policy_checks=1)
    assert agent.multiplier_ > 0.0 and agent.cost_weights_.any()
    restored = SARSA.restore(agent.save(tmp_path / "agent"))
    np.testing.assert_array_equal(restored.cost_weights_, agent.cost_weights_)
    np.testing.assert_array_equal(restored.arrays_.constraint_state, agent.arrays_.constraint_state)


@pytest.mark.parametrize(
    ("learner", "constraint"),
    [
        ("SARSA", PIDLagrangian(cost_limit=0.2, kp=0.5)),
        ("SARSA", Lagrangian(cost_limit=0.3)),
        ("QLearning", Saute(cost_limit=0.5, num_budget_bins=2)),
    ],
)
def test_a_constraint_is_built_from_a_config_and_passes_the_common_checks(learner, constraint):
    spec = {
        "kind": learner,
        "params": {
            "representation": {"kind": "Tabular"},
            "constraint": {"kind": type(constraint).__name__, "params": constraint.get_params()},
        },
    }
    agent = build("agent", spec)
    assert agent.constraint == constraint
    check_component(agent)
    check_component(constraint)


def test_a_box_refuses_a_constrained_learner():
    domain = GridWorld.gridworld_1()
    learner = SARSA(representation=Tabular(), constraint=Lagrangian(cost_limit=0.1))
    box = CooperativeLearner(
        learner=learner,
        planner=ShortestPathPlanner(),
        risk=NominalRiskAnalyzer(),
        model=ApproximateModel(domain=GridWorld.gridworld_1(noise=0.0)),
    )
    with pytest.raises(IncompatibleComponentsError, match="cost constraint"):
        box.setup(domain.domain_spec, 0)


# ---------------------------------------------------------------------------------------------
# Sauté: the remaining budget z = 1 − spent/d as budget blocks of θ


def test_budget_bins_by_hand():
    # d = 2, B = 4: z = 1, .75, .5, .05 fall in bins 4, 3, 2, 1; z ≤ 0 in bin 0.
    bins = [forms.budget_bin(spent, 2.0, 4) for spent in (0.0, 0.5, 1.0, 1.9, 2.0, 2.5)]
    assert bins == [4, 3, 2, 1, 0, 0]
    assert [forms.budget_bin(spent, 1.0, 1) for spent in (0.0, 0.999, 1.0)] == [1, 1, 0]


def _saute_sarsa(**params) -> SARSA:
    constraint = Saute(cost_limit=2.0, unsafe_reward=-5.0, num_budget_bins=2)
    domain = ChainMDP(num_states=4, num_actions=2, discount=1.0)
    agent = SARSA(representation=Tabular(), step_size=0.5, constraint=constraint, **params)
    return agent.setup(domain.domain_spec, 0)


def test_saute_learns_on_the_block_of_z_and_bootstraps_from_the_block_of_z_prime():
    agent = _saute_sarsa()  # n = 4 states, blocks b = 0 (z ≤ 0), 1 (z ≤ .5), 2 (z ≤ 1)
    assert agent.weights_.shape == (12, 2) and agent.observes_budget
    s0, s1, s2, s3 = (np.array([float(x)]) for x in range(4))
    agent.weights_[4 + 1] = [4.0, 0.0]  # Q(s1, z = .5, ·) in block 1
    agent.begin_episode()
    agent.observe_episode_cost(0.0)
    agent.act(s0)
    agent.observe_episode_cost(1.0)  # the step s0 → s1 cost 1: z' = 1 − 1/2 = .5, bin 1
    agent.act(s1)
    agent.learn(Transition(s0, 0, 1.0, s1, 0, False, cost=1.0))
    assert agent.weights_[8 + 0, 0] == 0.5 * (1.0 + 4.0)  # block 2 at s0, target r + Q_1(s1, 0)
    agent.observe_episode_cost(2.0)  # z' = 0: the budget is spent, r̃ = unsafe_reward
    agent.act(s2)
    agent.learn(Transition(s1, 1, 1.0, s2, 1, False, cost=1.0))
    assert agent.weights_[4 + 1, 1] == 0.5 * -5.0  # block 1 at s1, target −5 + Q_0(s2, 1) = −5
    agent.learn(Transition(s2, 0, 1.0, s3, 0, True, cost=0.0))  # terminal: no act at s3
    assert agent.weights_[0 + 2, 0] == 0.5 * -5.0  # block 0 at s2 (z = 0 stays spent)
    assert np.count_nonzero(agent.weights_) == 4  # the three updates and the preset row


def test_saute_acts_on_the_block_of_its_budget_and_a_policy_check_keeps_the_learning_one():
    agent = _saute_sarsa(policy=EpsilonGreedy(epsilon=0.0))
    state = np.array([2.0])
    agent.weights_[8 + 2] = [1.0, 0.0]  # z = 1: action 0
    agent.weights_[4 + 2] = [0.0, 1.0]  # z ∈ (0, .5]: action 1
    agent.weights_[0 + 2] = [0.0, 0.0]  # z ≤ 0: the first of the ties
    agent.observe_episode_cost(1.5)  # learning z = .25
    assert agent.act(state) == 1
    for spent, action in ((0.0, 0), (1.0, 1), (2.0, 0)):
        agent.observe_episode_cost(spent, greedy=True)
        assert agent.act(state, greedy=True) == action
        assert agent.q_values(state).tolist() == agent.weights_[4 * (2 - int(spent)) + 2].tolist()
    assert agent.act(state) == 1  # the learning budget is still z = .25
    state_slots = agent.arrays_.constraint_state
    assert state_slots[forms.ACTED_SPENT] == 1.5 and state_slots[forms.GREEDY_SPENT] == 2.0


def test_saute_reshapes_the_reward_once_the_budget_is_spent_in_a_run():
    # GridWorld's pit costs 1 and ends the episode: with d = 1 the pit's reward −1 becomes
    # the unsafe reward −3 in the target (z' = 1 − 1/1 = 0, spent); with d = 1.5 it is kept
    # (z' = 1/3 > 0); every other step stays in the z = 1 block B.
    for limit, (pit, other) in ((1.0, (-3.0, -1.0)), (1.5, (-1.0, -3.0))):
        agent = SARSA(
            representation=Tabular(),
            step_size=1.0,
            constraint=Saute(cost_limit=limit, unsafe_reward=-3.0, num_budget_bins=1),
        )
        result = run(domain=GridWorld.gridworld_1(), agent=agent, budget_steps=2000, seed=1,
                     num_policy_checks=1)  # fmt: skip
        assert result.curve["learning_failures"].iloc[-1] > 0
        spent_block, fresh_block = np.split(agent.weights_, 2)
        assert not spent_block.any()  # no state is ever reached with z ≤ 0
        # α = 1: θ(s, a) of a step into a pit is its last target, r̃ (terminal).
        assert pit in fresh_block and other not in fresh_block


def test_a_policy_check_mid_episode_leaves_the_learning_budget_alone():
    from conjure.domains import from_gymnasium

    agent = SARSA(representation=Tabular(), constraint=Saute(cost_limit=3.0))
    domain = from_gymnasium(register_corridor())
    agent.setup(domain.domain_spec, 0)
    stepper = Stepper(domain, agent, seed=0)
    stepper.advance(7)
    while not stepper.is_mid_episode or agent.arrays_.constraint_state[forms.ACTED_SPENT] == 0:
        stepper.advance(1)
    before = agent.arrays_.constraint_state.copy()
    run_episode(from_gymnasium(register_corridor()), agent, seed=1)
    after = agent.arrays_.constraint_state
    assert after[forms.ACTED_SPENT] == before[forms.ACTED_SPENT] > 0
    assert after[forms.PREVIOUS_SPENT] == before[forms.PREVIOUS_SPENT]


@pytest.mark.parametrize(
    ("params", "message"),
    [
        ({"cost_limit": 0.0}, r"`Saute.cost_limit` must be a float in \(0, inf\); got 0.0"),
        ({"cost_limit": 1.0, "num_budget_bins": 0}, r"`Saute.num_budget_bins` must be an int"),
        ({"cost_limit": 1.0, "unsafe_reward": float("-inf")}, "`Saute.unsafe_reward`"),
        ({"cost_limit": 1.0, "unsafe_reward": float("nan")}, "`Saute.unsafe_reward`"),
    ],
)
def test_a_bad_saute_parameter_is_refused_in_one_line(params, message):
    domain = ChainMDP(num_actions=2)
    agent = QLearning(representation=Tabular(), constraint=Saute(**params))
    with pytest.raises(InvalidParameterError, match=message) as caught:
        agent.setup(domain.domain_spec, 0)
    assert "\n" not in str(caught.value)


@pytest.mark.parametrize(
    ("agent", "message"),
    [
        (SARSA(representation=OnlineIFDD(base=IndependentDiscretization()),
               constraint=Saute(cost_limit=1.0)), "adaptive"),
        (SARSA(representation=Tabular(), trace_decay=0.5, constraint=Saute(cost_limit=1.0)),
         "eligibility traces"),
        (ActorCritic(representation=Tabular(), trace_decay=0.5, constraint=Saute(cost_limit=1.0)),
         "eligibility traces"),
    ],
)  # fmt: skip
def test_saute_refuses_an_adaptive_representation_and_traces_in_one_line(agent, message):
    domain = GridWorld.gridworld_1()
    with pytest.raises(IncompatibleComponentsError, match=message) as caught:
        agent.setup(domain.domain_spec, 0)
    assert "\n" not in str(caught.value)


def test_a_saute_learner_saves_and_restores_its_blocks_and_budgets(tmp_path):
    agent = ActorCritic(representation=Tabular(), constraint=Saute(cost_limit=0.5))
    run(domain=GridWorld.gridworld_1(), agent=agent, budget_steps=1500, seed=2,
        num_policy_checks=1)  # fmt: skip
    agent.observe_episode_cost(0.3)
    agent.observe_episode_cost(0.2, greedy=True)
    restored = ActorCritic.restore(agent.save(tmp_path / "agent"))
    assert restored.weights_.shape == (5 * restored.representation_.num_features_, 4)
    np.testing.assert_array_equal(restored.weights_, agent.weights_)
    np.testing.assert_array_equal(restored.actor_weights_, agent.actor_weights_)
    np.testing.assert_array_equal(restored.arrays_.constraint_state, agent.arrays_.constraint_state)
    state = np.array([3.0, 2.0])
    assert restored.preferences(state).tolist() == agent.preferences(state).tolist()


def test_conjure_run_drives_every_constraint_from_a_config_and_records_the_costs(tmp_path):
    from click.testing import CliRunner

    from conjure.cli.main import main
    from conjure.experiments.results import read_run

    config = tmp_path / "constrained.yaml"
    config.write_text(
        """\
name: constrained
domain: {kind: GridWorld, params: {map_name: gridworld1}}
agents:
  lagrangian:
    kind: SARSA
    params:
      representation: {kind: Tabular}
      constraint: {kind: Lagrangian, params: {cost_limit: 0.1}}
  pid:
    kind: QLearning
    params:
      representation: {kind: Tabular}
      constraint: {kind: PIDLagrangian, params: {cost_limit: 0.1}}
  saute:
    kind: ActorCritic
    params:
      representation: {kind: Tabular}
      constraint: {kind: Saute, params: {cost_limit: 0.1, num_budget_bins: 1}}
budget_steps: 2000
num_policy_checks: 2
seeds: 1
"""
    )
    out = tmp_path / "out"
    ran = CliRunner().invoke(
        main, ["run", str(config), "--out", str(out), "--quiet", "--max-workers", "1"]
    )
    assert ran.exit_code == 0, ran.output
    for path in sorted((out / "runs").iterdir()):
        curve = read_run(path)["curve"]
        last = curve.iloc[-1]
        assert last["learning_cost"] == last["learning_failures"] > 0  # c_t = 1 per pit
        assert last["cost_rate"] == last["learning_cost"] / last["learning_steps"]
        assert 0.0 <= last["episode_cost"] <= 1.0
