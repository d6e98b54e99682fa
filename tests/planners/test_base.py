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
