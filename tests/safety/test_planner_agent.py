import pytest

from conjure.domains import GridWorld
from conjure.experiments import run
from conjure.models.approximate_model import ApproximateModel
from conjure.planners import ModelPlanner, ShortestPathPlanner
from conjure.safety import PlannerAgent


def test_the_vi_planner_earns_its_nominal_return_without_wind():
    # GridWorld-1's planner (Figure 5-1b): 15 moves, 14 steps of -0.001 then +1.
    agent = PlannerAgent(
        planner=ModelPlanner(), model=ApproximateModel(domain=GridWorld.gridworld_1(noise=0.0))
    )
    result = run(domain=GridWorld.gridworld_1(noise=0.0), agent=agent, budget_steps=60, seed=0)
    assert result.curve["return"].tolist() == pytest.approx([0.986] * 11)
    assert result.curve["episode_length"].tolist() == [15] * 11
    assert agent.num_features == 0


def test_gridworld2_conservative_and_aggressive_baselines():
    # Without wind the conservative snake takes 31 moves, the aggressive run 14 (step -0.01).
    for make, moves in (
        (ShortestPathPlanner.conservative, 31),
        (ShortestPathPlanner.aggressive, 14),
    ):
        agent = PlannerAgent(planner=make(), model=ApproximateModel(domain=GridWorld.gridworld_2()))
        result = run(domain=GridWorld.gridworld_2(noise=0.0), agent=agent, budget_steps=40, seed=0)
        assert result.curve["return"].iloc[-1] == pytest.approx(1.0 - 0.01 * (moves - 1))


def test_save_and_restore_plan_again(tmp_path):
    domain = GridWorld.gridworld_2()
    agent = PlannerAgent(planner=ShortestPathPlanner(), model=ApproximateModel(domain=domain))
    agent.setup(domain.domain_spec, seed=0).save(tmp_path)
    restored = PlannerAgent.restore(tmp_path)
    assert restored == agent
    assert restored.planner_.policy_.tolist() == agent.planner_.policy_.tolist()
