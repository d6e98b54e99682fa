import numpy as np
import pytest

from conjure.core.errors import IncompatibleComponentsError
from conjure.domains import GridWorld
from conjure.experiments import run
from conjure.planners import PlanAgent, ValueIteration
from conjure.testing.planner_checks import three_state_model


def test_plan_as_agent_is_evaluated_by_the_experiment_loop():
    domain = GridWorld(map_name="4x5", noise=0.0)
    plan = ValueIteration().plan(domain.model())
    result = run(domain=domain, agent=plan.as_agent(), budget_steps=1, seed=0, num_policy_checks=1)
    assert result.curve["return"].iloc[-1] == pytest.approx(plan.start_value(), abs=1e-9)


def test_plan_lookups():
    plan = ValueIteration(tolerance=1e-9).plan(three_state_model())
    assert plan.action([1.0]) == 0
    assert plan.value([2.0]) == pytest.approx(1 / (1 - 0.9**3), abs=1e-6)
    assert np.allclose(plan.action_values([0.0]), plan.q_values[0])


def test_plan_agent_rejects_a_mismatched_domain_and_cannot_be_saved(tmp_path):
    agent = ValueIteration().plan(three_state_model()).as_agent()
    assert isinstance(agent, PlanAgent)
    with pytest.raises(IncompatibleComponentsError, match="actions"):
        agent.setup(GridWorld().domain_spec, seed=0)
    with pytest.raises(IncompatibleComponentsError, match="re-run"):
        agent.save(tmp_path)


def _model_with_terminal_states():
    """A 6-state chain with a stochastic move and two terminal ends reachable from the middle."""
    from conjure.domains import ChainMDP

    return ChainMDP(num_states=6, num_actions=2, slip=0.2).model()


def test_tabular_planners_agree_on_every_state_terminal_states_included():
    from conjure.planners import QAPI, VAPI, PolicyIteration
    from conjure.representations import Tabular

    model = _model_with_terminal_states()
    terminal = np.flatnonzero(model.is_terminal)
    assert terminal.size > 0
    reference = ValueIteration(tolerance=1e-12).plan(model)
    assert reference.q_values.shape == (model.num_states, model.num_actions)  # q[s, a]
    for seed in range(4):
        planners = (
            PolicyIteration(seed=seed),
            VAPI(representation=Tabular(), seed=seed),
            QAPI(representation=Tabular(), seed=seed),
        )
        for planner in planners:
            plan = planner.plan(model)
            assert plan.policy.tolist() == reference.policy.tolist(), planner
            assert plan.q_values.shape == reference.q_values.shape, planner
            np.testing.assert_allclose(plan.q_values, reference.q_values, atol=1e-6)
    assert reference.policy[terminal].tolist() == [0] * terminal.size  # the convention


def test_the_model_bellman_backup_is_state_major_like_plan_q_values():
    model = _model_with_terminal_states()
    values = np.arange(model.num_states, dtype=float)
    q = model.q_values(values)
    assert q.shape == (model.num_states, model.num_actions)
    s, a = 2, 0
    successors = model.transitions[a][s].toarray().ravel()
    expected = model.rewards[s, a] + model.discount * successors @ np.where(
        model.is_terminal, 0.0, values
    )
    assert q[s, a] == pytest.approx(expected)
    assert q[model.is_terminal].tolist() == [[0.0, 0.0]] * int(model.is_terminal.sum())
