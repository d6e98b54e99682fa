from pathlib import Path

import pytest
from click.testing import CliRunner

from conjure.core.errors import IncompatibleComponentsError, InvalidParameterError
from conjure.domains import GridWorld, InvertedPendulum, UAVMission
from conjure.experiments.solve import EXACT, fitting_planners, solve, solve_command
from conjure.planners import CBBAPlanner, ShortestPathPlanner, ValueIteration

ROOT = Path(__file__).resolve().parents[2]
EXAMPLE = ROOT / "examples" / "solve_gridworld.yaml"
UAV_EXAMPLE = ROOT / "examples" / "solve_uav.yaml"


def solve_text(tmp_path, text, *args):
    """Run `conjure solve` on a config holding ``text``."""
    config = tmp_path / "solve.yaml"
    config.write_text(text)
    return CliRunner().invoke(solve_command, [str(config), *args])


def test_solve_reports_the_planners_start_value_and_renders(tmp_path):
    png = tmp_path / "gridworld1.png"
    result = CliRunner().invoke(solve_command, [str(EXAMPLE), "--render", str(png)])
    assert result.exit_code == 0, result.output
    plan = ValueIteration(tolerance=1e-8).plan(GridWorld.gridworld_1().model())
    assert f"{plan.start_value():,.7g}" in result.output
    for word in ("V(start)", "mean return", "iterations", "wall time"):
        assert word in result.output
    assert png.is_file() and png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_solve_without_render(tmp_path):
    config = tmp_path / "small.yaml"
    config.write_text(
        "domain: {kind: GridWorld, params: {map_name: 4x5, noise: 0.0}}\n"
        "planner: {kind: ValueIteration}\n"
    )
    result = CliRunner().invoke(solve_command, [str(config), "--episodes", "2"])
    assert result.exit_code == 0, result.output


def test_bad_config(tmp_path):
    result = solve_text(tmp_path, "domain: {kind: GridWorld}\n")
    assert isinstance(result.exception, InvalidParameterError)
    assert "planner" in str(result.exception)


def test_unknown_planner_suggests(tmp_path):
    result = solve_text(tmp_path, "domain: {kind: GridWorld}\nplanner: {kind: ValueIteraton}\n")
    assert isinstance(result.exception, InvalidParameterError)
    assert "ValueIteration" in str(result.exception)


def test_render_needs_a_gridworld_and_says_so_before_solving(tmp_path, monkeypatch):
    import conjure.experiments.solve as solve_module

    solved = []
    monkeypatch.setattr(solve_module, "solve", lambda *a, **k: solved.append(a))
    config = tmp_path / "chain.yaml"
    config.write_text("domain: {kind: ChainMDP}\nplanner: {kind: ValueIteration}\n")
    result = CliRunner().invoke(
        solve_command, [str(config), "--episodes", "1", "--render", str(tmp_path / "x.png")]
    )
    assert result.exception is not None and "GridWorld" in str(result.exception)
    assert solved == []  # refused before planning, not after


def test_uav_example_prints_the_exact_optimum_the_worst_value_and_the_first_moves():
    result = CliRunner().invoke(solve_command, [str(UAV_EXAMPLE)])
    assert result.exit_code == 0, result.output
    solution = UAVMission(traverse_failure=0.05).exact_solution()
    assert f"{solution.optimal_return:,.7g}" in result.output  # 1,087.548
    assert f"{solution.worst_return:,.7g}" in result.output
    assert "crash probability" in result.output and "First moves" in result.output
    assert "(UAV 0 to node 1, UAV 1 to node 1)" in result.output  # both meet at node 1


@pytest.mark.parametrize("variant", ["aggressive", "conservative"])
def test_cbba_solves_uav_missions_and_is_evaluated_exactly(tmp_path, variant):
    result = solve_text(
        tmp_path,
        "domain: {kind: UAVMission, params: {traverse_failure: 0.05}}\n"
        f"planner: {{kind: CBBAPlanner, params: {{variant: {variant}}}}}\n",
    )
    assert result.exit_code == 0, result.output
    domain = UAVMission(traverse_failure=0.05)
    model = type("Model", (), {"domain_": domain})()
    planner = CBBAPlanner(variant=variant).setup(model, seed=0)
    exact = domain.evaluate_policy(planner.action)
    assert f"{exact.value:,.7g}" in result.output and "V(start), exact" in result.output
    assert f"{exact.crash_probability:.4f}" in result.output
    assert f"{domain.value_bounds()[1]:,.7g}" in result.output  # V* beside it


def test_solve_returns_the_exact_solution_as_a_policy():
    domain = UAVMission()
    solution = solve(domain, EXACT)
    assert solution.numbers["value"] == domain.exact_solution().optimal_return
    assert solution.numbers["crash_probability"] == 0.0  # no traverse failures, no crash
    start = domain.reset(seed=0)[0]
    assert solution.policy(start) == domain.exact_solution().action(start)


def test_a_planner_that_does_not_fit_is_refused_naming_the_planners_that_do(tmp_path):
    result = solve_text(tmp_path, "domain: {kind: UAVMission}\nplanner: {kind: ValueIteration}\n")
    assert isinstance(result.exception, IncompatibleComponentsError)
    message = str(result.exception)
    assert "ValueIteration needs the domain's tabular model" in message
    assert message.endswith("planners that fit UAVMission: exact, CBBAPlanner, SwitchingPlanner.")
    assert "sampled planner" not in message  # the old hint led nowhere


def test_cbba_on_a_grid_world_and_exact_without_a_solver_name_what_fits():
    with pytest.raises(IncompatibleComponentsError, match=r"MissionGraph.*ValueIteration"):
        solve(GridWorld(), CBBAPlanner())
    with pytest.raises(IncompatibleComponentsError, match="PolicyIteration and ValueIteration"):
        solve(GridWorld(), EXACT)
    with pytest.raises(IncompatibleComponentsError, match="no planner fits InvertedPendulum"):
        solve(InvertedPendulum(), EXACT)


def test_fitting_planners_by_domain():
    assert fitting_planners(UAVMission()) == [EXACT, "CBBAPlanner", "SwitchingPlanner"]
    grid = fitting_planners(GridWorld())
    assert EXACT not in grid and "CBBAPlanner" not in grid
    assert {"ValueIteration", "SampledQAVI", "ShortestPathPlanner", "ModelPlanner"} <= set(grid)
    assert fitting_planners(InvertedPendulum()) == []


def test_a_cooperative_planner_without_exact_evaluation_is_evaluated_by_episodes():
    solution = solve(GridWorld.gridworld_2(), ShortestPathPlanner(goal=[0, 21]), episodes=3)
    assert solution.evaluation == "mean of 3 episodes"
    assert solution.numbers["value"] == solution.numbers["mean_return"] > 0


def test_an_agent_kind_is_not_a_planner(tmp_path):
    result = solve_text(tmp_path, "domain: {kind: GridWorld}\nplanner: {kind: SARSA}\n")
    assert isinstance(result.exception, InvalidParameterError)
    assert "'SARSA' is in the 'agent' registry, not a planner" in str(result.exception)
