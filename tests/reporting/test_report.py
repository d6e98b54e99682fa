"""Tests of `conjure report`: the table, the markdown report, figures and interval maths."""

from __future__ import annotations

import errno
import os
import re
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner
from sweep_fakes import fail_writes, fake_sweep, isolated_fakes, run_with_fakes

from conjure.cli.main import main
from conjure.core.errors import InvalidParameterError
from conjure.reporting.report import report_command
from conjure.sweeps.sweep import run_sweep

pytestmark = pytest.mark.usefixtures(isolated_fakes.__name__)


def test_report_of_a_sweep_with_selection(tmp_path):
    sweep = fake_sweep(selection={"criterion": "auc", "fresh_seeds": 2})
    run_sweep(sweep, tmp_path, max_workers=1, run_fn=run_with_fakes, progress=False)
    (tmp_path / "results.parquet").unlink()
    result = CliRunner().invoke(report_command, [str(tmp_path)])
    assert result.exit_code == 0, result.output
    table = pd.read_parquet(tmp_path / "results.parquet")
    assert table["run_id"].nunique() == 12
    text = (tmp_path / "report.md").read_text()
    for expected in (
        "## Domain short",
        "## Domain long",
        "mean return ± 95% t",
        "IQM return [95% bootstrap]",
        "learning steps/s",
        "a [step_size=0.1]",
        "## Selected settings",
        "selected/report.md",
    ):
        assert expected in text
    assert "errors/" not in text and "none failed" in text  # no errors/ folder to point at
    for name in ("learning_curve_return_short", "features_long"):
        assert (tmp_path / "figures" / f"{name}.png").stat().st_size > 1000
    assert (tmp_path / "selected" / "report.md").is_file()


def test_report_errors_are_clear(tmp_path):
    with pytest.raises(InvalidParameterError, match="No runs"):
        from conjure.reporting.report import write_report

        write_report(tmp_path)


def _safety_results(tmp_path, with_bounds: bool):
    """Two methods x two seeds whose curves carry the safety columns of `run`."""
    from conjure.experiments.results import save_run
    from conjure.experiments.run import CURVE_COLUMNS

    for label, failure_rate in (("careful", 0.0), ("reckless", 0.5)):
        for seed in (0, 1):
            curve = {column: [0.0, 1.0] for column in CURVE_COLUMNS}
            curve.update(
                learning_steps=[0, 100],
                learning_failures=[0, 4 + seed],
                failure_rate=[1.0, failure_rate],
                optimality=[0.2, 0.9 - failure_rate] if with_bounds else [np.nan, np.nan],
            )
            spec = {"label": label, "seed": seed, "domain": {"kind": "GridWorld"}}
            save_run(tmp_path, spec, curve)
    return tmp_path


def test_report_tables_show_failure_rate_learning_failures_and_optimality(tmp_path):
    from conjure.reporting.report import write_report

    text = write_report(_safety_results(tmp_path, with_bounds=True)).read_text()
    assert "final failure rate ± 95% t" in text and "final optimality ± 95% t" in text
    assert "learning failures" in text
    assert "| reckless | 2 |" in text and "| 0.5000 ± 0.0000 |" in text  # rate 0.5, no spread
    assert "| 4.500 |" in text  # learning failures, mean of 4 and 5
    curve = write_report(tmp_path, metric="optimality", out_dir=tmp_path / "by_optimality")
    text = curve.read_text()
    assert "mean optimality ± 95% t" in text
    # The IQM (rliable) of two runs at 0.4, its bootstrap interval of equal values.
    assert "| reckless | 2 | 0.4000 ± 0.0000 | 0.4000 [0.4000, 0.4000] |" in text


def test_report_and_plot_skip_all_nan_columns(tmp_path):
    from conjure.reporting.plots import plot_results_dir
    from conjure.reporting.report import write_report

    results = _safety_results(tmp_path, with_bounds=False)
    text = write_report(results).read_text()
    assert "failure rate" in text and "optimality" not in text
    with pytest.raises(InvalidParameterError, match=r"optimality.*no finite value"):
        write_report(results, metric="optimality")
    with pytest.raises(InvalidParameterError, match=r"optimality.*no finite value"):
        plot_results_dir(results, metric="optimality")
    assert plot_results_dir(results, metric="failure_rate").is_file()


def test_report_points_at_errors_only_when_a_run_failed(tmp_path):
    sweep = fake_sweep(grid={}, seeds=1)
    sweep["agents"]["b"] = {"kind": "FakeAgent", "params": {"diverge_at": 3}}
    run_sweep(sweep, tmp_path, max_workers=1, run_fn=run_with_fakes, progress=False)
    assert CliRunner().invoke(report_command, [str(tmp_path)]).exit_code == 0
    text = (tmp_path / "report.md").read_text()
    assert "2 failed (tracebacks in `errors/`)" in text


def test_report_of_a_cut_sweep_says_which_runs_are_missing(tmp_path):
    # Issue 20: a report of a folder whose sweep was cut read as complete.
    run_sweep(fake_sweep(), tmp_path, max_workers=1, run_fn=run_with_fakes, progress=False)
    results = pd.read_parquet(tmp_path / "results.parquet")
    long_b = (results["label"] == "b") & (results["domain_label"] == "long")
    one_a = (results["setting"] == "step_size=0.1") & (results["domain_label"] == "short")
    cut = results[long_b | (one_a & (results["seed"] == 0))]["run_id"]
    for identifier in cut.unique():
        (tmp_path / "runs" / f"{identifier}.json").unlink()
    result = CliRunner().invoke(report_command, [str(tmp_path)])
    assert result.exit_code == 0, result.output
    # The terminal names each incomplete setting, as report.md does (issue 20 audit).
    assert (
        "Incomplete: 9 of 12 runs present; runs missing for short a [step_size=0.1]: 1 of 2 "
        "missing; long b: 2 of 2 missing." in " ".join(result.output.split())
    )
    text = (tmp_path / "report.md").read_text()
    assert "**Incomplete: 9 of 12 runs present**" in text
    assert "- short a [step_size=0.1]: 1 of 2 missing\n- long b: 2 of 2 missing" in text


@pytest.mark.parametrize("code", [errno.ENOSPC, errno.EFBIG])
@pytest.mark.parametrize(
    "name", ["results.parquet", "report.md", "figures/learning_curve_return_long.png"]
)
def test_report_that_cannot_be_written_says_so_in_one_line(tmp_path, monkeypatch, name, code):
    # Issue 20: a report on a full disk (or past a file-size limit) printed tracebacks.
    run_sweep(fake_sweep(), tmp_path, max_workers=1, run_fn=run_with_fakes, progress=False)
    fail_writes(monkeypatch, Path(name).name, code)
    result = CliRunner().invoke(main, ["report", str(tmp_path)])
    assert result.exit_code == 2 and "Traceback" not in result.output, result.output
    assert result.output.strip() == (
        f"Error: Could not write {tmp_path / name}: {os.strerror(code)} (errno {code}); the "
        f"runs in {tmp_path / 'runs'} are untouched. Free space (or raise the file-size limit) and "
        "rerun the same command: it resumes."
    )
    assert len(list((tmp_path / "runs").glob("*.json"))) == 12


def test_report_says_nothing_of_completeness_when_every_run_is_there(tmp_path):
    run_sweep(fake_sweep(), tmp_path, max_workers=1, run_fn=run_with_fakes, progress=False)
    result = CliRunner().invoke(report_command, [str(tmp_path)])
    assert result.exit_code == 0 and "Incomplete" not in result.output
    assert "Incomplete" not in (tmp_path / "report.md").read_text()


def test_report_cuts_intervals_at_each_metrics_range_and_prints_short_numbers(tmp_path):
    # Issue 21: an episode band past the 3,000-step cap, `0.300 ± 1.271` for a probability,
    # and `2e+05` in the tables.
    from conjure.experiments.results import save_run
    from conjure.experiments.run import CURVE_COLUMNS
    from conjure.reporting.report import write_report

    for seed, (length, rate) in enumerate([(3000.0, 1.0), (3000.0, 0.0), (2500.0, 1.0)]):
        curve = {column: [0.0, 1.0] for column in CURVE_COLUMNS}
        curve.update(
            learning_steps=[0, 100],
            episode_length=[10.0, length],
            failure_rate=[0.0, rate],
            num_features=[1, 200000],
            learning_failures=[0, 200000],
        )
        spec = {"label": "pendulum", "seed": seed, "domain": {"kind": "InvertedPendulum"}}
        save_run(tmp_path, spec, curve, {"max_episode_steps": 3000.0})
    text = write_report(tmp_path, metric="episode_length").read_text()
    assert "| 2,833 [2,116, 3,000] |" in text  # t-interval 2,833 ± 717, cut at the cap
    assert "| 0.667 [0.000, 1.000] |" in text  # failure rate 0.667 ± 1.43, cut at 1
    assert "| 200,000 |" in text and "e+" not in text
    assert "cut at what each metric can be" in text


def test_report_of_a_selection_names_the_rerun_and_prints_its_scores_to_read(tmp_path):
    # Issue 21: a grid value 1000000 read `diverge_at=1000000` in report.md.
    grid = {"agents.a.params.diverge_at": [100000, 1000000]}
    sweep = fake_sweep(grid=grid, selection={"criterion": "auc", "fresh_seeds": 2})
    run_sweep(sweep, tmp_path, max_workers=1, run_fn=run_with_fakes, progress=False)
    from conjure.reporting.report import write_report

    text = write_report(tmp_path).read_text()
    table = text.split("## Selected settings")[1]
    assert "score ± 95% t" in table and "score_mean" not in table
    assert not re.search(r"\d\.\d{6,}", table)  # no float noise
    assert "a [diverge_at=1,000,000]" in text and "1000000" not in text
    chosen = pd.read_csv(tmp_path / "selection.csv")["setting"]  # the key stays YAML
    assert set(chosen.dropna()) <= {"diverge_at=100000", "diverge_at=1000000"}
    rerun = (tmp_path / "selected" / "report.md").read_text()
    assert rerun.startswith("# Report: fake_sweep (best settings, fresh seeds)")


def test_report_of_a_selection_without_fresh_seeds_says_its_scores_are_the_searchs(tmp_path):
    sweep = fake_sweep(selection={"criterion": "final", "fresh_seeds": 0})
    run_sweep(sweep, tmp_path, max_workers=1, run_fn=run_with_fakes, progress=False)
    from conjure.reporting.report import write_report

    text = write_report(tmp_path).read_text()
    assert "No rerun on fresh seeds (`fresh_seeds: 0`)" in text
