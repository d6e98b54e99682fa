"""Cost constraints of the linear TD learners: λ's rules, θ_C's update, acting on Q − λQ_C."""

from __future__ import annotations

import numpy as np
import pytest

from conjure.agents import SARSA, ActorCritic, QLearning
from conjure.agents import compiled_agent as forms
from conjure.agents.constraints import Lagrangian, PIDLagrangian
from conjure.core.errors import IncompatibleComponentsError, InvalidParameterError
from conjure.core.interfaces import Transition
from conjure.domains import ChainMDP, GridWorld
from conjure.experiments import run
from conjure.experiments.registry import build
from conjure.models.approximate_model import ApproximateModel
from conjure.planners import ShortestPathPlanner
from conjure.representations import Tabular
from conjure.safety import CooperativeLearner, NominalRiskAnalyzer
from conjure.testing.checks import check_component


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


def test_a_constraint_is_built_from_a_config_and_passes_the_common_checks():
    spec = {
        "kind": "SARSA",
        "params": {
            "representation": {"kind": "Tabular"},
            "constraint": {"kind": "PIDLagrangian", "params": {"cost_limit": 0.2, "kp": 0.5}},
        },
    }
    agent = build("agent", spec)
    assert agent.constraint == PIDLagrangian(cost_limit=0.2, kp=0.5)
    check_component(agent)
    check_component(Lagrangian(cost_limit=0.3))


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
