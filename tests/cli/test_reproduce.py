"""Tests of ``conjure reproduce``: the list, one-line errors, a quick run and its resume."""

from __future__ import annotations

from pathlib import Path

import pandas as pd
import pytest
from click.testing import CliRunner

from conjure.cli.main import main
from conjure.cli.reproduce import default_out_dir
from conjure.sweeps.reproduction import FIGURES

ROOT = Path(__file__).resolve().parents[2]


def test_list_names_every_shipped_reproduction_config():
    result = CliRunner().invoke(main, ["reproduce", "--list"], terminal_width=250)
    assert result.exit_code == 0, result.output
    for path in sorted((ROOT / "examples" / "reproduction").glob("*.yaml")):
        assert path.stem in result.output
    assert "config: examples/reproduction/FIGURE.yaml" in result.output
    for name, figure in FIGURES.items():
        assert figure.config == f"examples/reproduction/{name}.yaml"  # as the title says
        assert name in result.output
    assert "budget_steps" in result.output  # how the cost is estimated


@pytest.mark.parametrize(
    ("args", "expected"),
    [
        (["fig_5_0"], "Error: Unknown figure 'fig_5_0'. Did you mean 'fig_5_8'?"),
        (["3-15"], "Error: Fig. 3-15 is a batch evaluation, not a sweep"),
        ([], "Error: Name the figures to reproduce"),
        (["fig_5_8", "--all"], "Error: Name the figures to reproduce"),
    ],
)
def test_bad_figures_and_scales_are_one_line(args, expected, tmp_path):
    result = CliRunner().invoke(main, ["reproduce", *args, "--out", str(tmp_path)])
    assert result.exit_code == 2
    assert result.output.startswith(expected)
    assert len(result.output.strip().splitlines()) == 1
    assert not any(tmp_path.iterdir())


def test_the_scale_is_a_choice_whose_help_lists_it():
    result = CliRunner().invoke(main, ["reproduce", "fig_5_8", "--scale", "huge"])
    assert result.exit_code == 2
    assert "'huge' is not one of 'quick', 'thesis'" in result.output
    assert "[quick|thesis]" in CliRunner().invoke(main, ["reproduce", "--help"]).output


def test_the_default_folder_keeps_the_scales_apart():
    assert default_out_dir("fig_5_8", "thesis") == Path("runs/reproduce/fig_5_8")
    assert default_out_dir("fig_5_8", "quick") == Path("runs/reproduce/fig_5_8_quick")


@pytest.mark.slow
def test_a_quick_run_writes_the_comparison_and_resumes(tmp_path):
    # fig_5_8 is chapter 5's cheapest figure (`--list`); shrunk further through --set.
    out = tmp_path / "fig_5_8"
    args = [
        "reproduce",
        "5-8",
        "--scale",
        "quick",
        "--out",
        str(out),
        "--max-workers",
        "1",
        "--quiet",
        "--set",
        "budget_steps=300",
        "--set",
        "num_policy_checks=2",
        "--set",
        "eval_episodes=2",
    ]
    first = CliRunner().invoke(main, args, terminal_width=200)
    assert first.exit_code == 0, first.output
    assert "15 runs run, 0 already finished" in first.output
    comparison = (out / "comparison.md").read_text()
    texts = [claim.text for claim in FIGURES["fig_5_8"].claims]
    rows = [line for line in comparison.splitlines() if line.split(" | ")[0][2:] in texts]
    assert [row.split(" | ")[0][2:] for row in rows] == texts  # a row per claim
    assert all(row.endswith(("| yes |", "| no |")) for row in rows)
    summary = pd.read_csv(out / "summary.csv")
    labels = ["sarsa", "csarsa", "csarsa_printed", "vi_planner", "optimal"]
    assert summary["label"].tolist() == labels
    assert (summary["seeds"] == 3).all() and "return_ci95" in summary
    assert (out / "fig_5_8_return.png").is_file()
    runs = sorted((out / "runs").iterdir())
    stamps = [path.stat().st_mtime_ns for path in runs]
    again = CliRunner().invoke(main, args, terminal_width=200)
    assert again.exit_code == 0, again.output
    assert "0 runs run, 15 already finished" in again.output
    assert [path.stat().st_mtime_ns for path in runs] == stamps
    assert (out / "comparison.md").read_text() == comparison


def test_all_runs_every_figure_each_in_its_folder(tmp_path, monkeypatch):
    from conjure.cli import reproduce

    calls = []

    def record(name, scale, out, *args, **kwargs):
        calls.append((name, scale, out))
        return False  # no run failed

    monkeypatch.setattr(reproduce, "_reproduce", record)
    result = CliRunner().invoke(
        main, ["reproduce", "--all", "--scale", "thesis", "--out", str(tmp_path)]
    )
    assert result.exit_code == 0, result.output
    assert calls == [(name, "thesis", tmp_path / name) for name in FIGURES]


@pytest.mark.slow
def test_the_thesis_scale_compares_the_fresh_seeds_of_the_selection(tmp_path):
    # The shipped selection, on a grid of one setting and 2 + 2 seeds of 300 steps.
    out = tmp_path / "fig_5_8"
    args = ["reproduce", "fig_5_8", "--scale", "thesis", "--out", str(out), "--max-workers", "1"]
    shrink = ["grid={}", "seeds=2", "selection.fresh_seeds=2", "budget_steps=300"]
    shrink += ["num_policy_checks=2", "eval_episodes=2"]
    result = CliRunner().invoke(main, [*args, "--quiet", *(f"--set={s}" for s in shrink)])
    assert result.exit_code == 0, result.output
    assert "20 runs run, 0 already finished" in result.output
    assert (out / "selection.csv").is_file() and (out / "selected" / "results.parquet").is_file()
    summary = pd.read_csv(out / "summary.csv")
    assert (summary["seeds"] == 2).all()
    assert "--scale thesis" in (out / "comparison.md").read_text()
