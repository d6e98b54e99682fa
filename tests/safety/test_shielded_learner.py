import numpy as np
from safety_fakes import CountingPlanner, FakeLearner, FixedRiskAnalyzer, cell

from conjure.agents import SARSA
from conjure.domains import GridWorld
from conjure.experiments import run
from conjure.models.approximate_model import ApproximateModel
from conjure.planners import ShortestPathPlanner
from conjure.representations import Tabular
from conjure.safety import NominalRiskAnalyzer, ShieldedLearner

UP, DOWN, LEFT, RIGHT = range(4)


def shielded(learner=None, risk=None, is_set_up=True):
    """The shield on GridWorld-1 (noise-free), set up or not, and its learning domain."""
    domain = GridWorld.gridworld_1(noise=0.0)
    agent = ShieldedLearner(
        learner=SARSA(representation=Tabular()) if learner is None else learner,
        planner=CountingPlanner(planner=ShortestPathPlanner()),
        risk=NominalRiskAnalyzer() if risk is None else risk,
        model=ApproximateModel(domain=GridWorld.gridworld_1(noise=0.0)),
    )
    return (agent.setup(domain.domain_spec, seed=0) if is_set_up else agent), domain


def test_the_shield_removes_the_move_into_the_pit():
    agent, _ = shielded()
    assert GridWorld.gridworld_1().is_constrained(cell(2, 0))  # the pit below (1, 0)
    assert agent.safe_actions(cell(1, 0)).tolist() == [UP, LEFT, RIGHT]
    assert agent.safe_actions(cell(1, 0), np.array([DOWN, RIGHT])).tolist() == [RIGHT]
    assert agent.safe_actions(cell(0, 0)).tolist() == [UP, DOWN, LEFT, RIGHT]


def test_with_no_safe_action_the_least_risky_one_is_taken():
    agent, _ = shielded(learner=FakeLearner(action=RIGHT), risk=FixedRiskAnalyzer(value=1.0))
    assert agent.safe_actions(cell(0, 0)).tolist() == [UP]  # all risks equal: the first
    # the fake learner ignores the set it is given, so only the count shows the shield
    agent.act(cell(0, 0))
    assert agent.num_shielded_steps_ == 1


def test_the_planner_is_never_consulted():
    agent, domain = shielded(is_set_up=False)
    run(domain=domain, agent=agent, budget_steps=300, seed=1, num_policy_checks=1)
    assert agent.planner_.num_actions_ == 0


def test_learning_behind_the_shield_enters_no_pit_where_learning_alone_does():
    agent, domain = shielded(is_set_up=False)
    result = run(domain=domain, agent=agent, budget_steps=3000, seed=2, num_policy_checks=2)
    alone = run(domain=GridWorld.gridworld_1(noise=0.0), agent=SARSA(representation=Tabular()),
                budget_steps=3000, seed=2, num_policy_checks=2)  # fmt: skip
    assert int(result.curve["learning_failures"].iloc[-1]) == 0
    assert int(alone.curve["learning_failures"].iloc[-1]) > 0
    assert agent.num_shielded_steps_ > 0
    again, domain = shielded(is_set_up=False)
    repeat = run(domain=domain, agent=again, budget_steps=3000, seed=2, num_policy_checks=2)
    assert repeat.curve["return"].tolist() == result.curve["return"].tolist()
    assert np.array_equal(again.learner_.weights_, agent.learner_.weights_)


def test_conjure_run_drives_the_shield_from_a_config(tmp_path):
    from click.testing import CliRunner

    from conjure.cli.main import main
    from conjure.experiments.results import read_run

    config = tmp_path / "shield.yaml"
    config.write_text(
        """\
name: shield
domain: {kind: GridWorld, params: {map_name: gridworld1, noise: 0.0}}
agents:
  shielded:
    kind: ShieldedLearner
    params:
      learner: {kind: SARSA, params: {representation: {kind: Tabular}}}
      planner: {kind: ShortestPathPlanner}
      risk: {kind: NominalRiskAnalyzer}
      model: {kind: ApproximateModel, params: {domain: {kind: GridWorld, params: {map_name: gridworld1, noise: 0.0}}}}
budget_steps: 500
num_policy_checks: 2
seeds: 2
"""  # noqa: E501
    )
    out = tmp_path / "out"
    ran = CliRunner().invoke(
        main, ["run", str(config), "--out", str(out), "--quiet", "--max-workers", "1"]
    )
    assert ran.exit_code == 0, ran.output
    runs = sorted((out / "runs").iterdir())
    assert len(runs) == 2
    assert all(read_run(path)["curve"]["learning_failures"].iloc[-1] == 0 for path in runs)


def test_the_shield_takes_the_python_path():
    # The compiled loop has no shield kernel: running the learner alone there would drop it.
    from conjure.compiled.combination import select

    agent, domain = shielded()
    reason = select(domain, agent)
    assert isinstance(reason, str) and "ShieldedLearner" in reason
