"""Tests of `conjure report`: the table, the markdown report, figures and interval maths."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner
from sweep_fakes import fake_sweep, isolated_fakes, run_with_fakes

from conjure.core.errors import InvalidParameterError
from conjure.experiments.parallel import run_sweep
from conjure.experiments.report import iqm, iqm_interval, report_command, stratified_bootstrap

pytestmark = pytest.mark.usefixtures(isolated_fakes.__name__)


def test_iqm_and_stratified_bootstrap():
    assert iqm([1, 2, 3, 4]) == 2.5
    assert iqm([0, 1, 2, 3, 4, 5, 6, 1000]) == 3.5
    point, low, high = iqm_interval([[1.0, 2.0, 3.0, 4.0], [10.0, 11.0]], num_resamples=500)
    assert low <= point <= high
    # Within-stratum resampling: a stratum of equal values never varies.
    _, low, high = stratified_bootstrap([[5.0] * 6], np.mean, num_resamples=100)
    assert low == high == 5.0
    assert np.isnan(stratified_bootstrap([[1.0]])[1])


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
    for name in ("learning_curve_short", "features_long"):
        assert (tmp_path / "figures" / f"{name}.png").stat().st_size > 1000
    assert (tmp_path / "selected" / "report.md").is_file()


def test_report_errors_are_clear(tmp_path):
    with pytest.raises(InvalidParameterError, match="No runs"):
        from conjure.experiments.report import write_report

        write_report(tmp_path)
