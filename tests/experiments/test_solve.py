from pathlib import Path

from click.testing import CliRunner

from conjure.core.errors import InvalidParameterError
from conjure.domains import GridWorld
from conjure.experiments.solve import solve_command
from conjure.planners import ValueIteration

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "solve_gridworld.yaml"


def test_solve_reports_the_planners_start_value_and_renders(tmp_path):
    png = tmp_path / "gridworld1.png"
    result = CliRunner().invoke(solve_command, [str(EXAMPLE), "--render", str(png)])
    assert result.exit_code == 0, result.output
    plan = ValueIteration(tolerance=1e-8).plan(GridWorld.gridworld_1().model())
    assert f"{plan.start_value():.6f}" in result.output
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
    config = tmp_path / "bad.yaml"
    config.write_text("domain: {kind: GridWorld}\n")
    result = CliRunner().invoke(solve_command, [str(config)])
    assert isinstance(result.exception, InvalidParameterError)
    assert "planner" in str(result.exception)


def test_unknown_planner_suggests(tmp_path):
    config = tmp_path / "typo.yaml"
    config.write_text("domain: {kind: GridWorld}\nplanner: {kind: ValueIteraton}\n")
    result = CliRunner().invoke(solve_command, [str(config)])
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
