"""Tests of the learning-curve plots."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from conjure.core.errors import InvalidParameterError
from conjure.reporting.plots import plot_learning_curves, plot_results_dir


def results_frame() -> pd.DataFrame:
    rows = []
    for label, slope in (("a", 1.0), ("b", 2.0)):
        for seed in range(3):
            for step in (0, 50, 100):
                rows.append((label, seed, step, slope * step + seed, 10 + step))
    return pd.DataFrame(rows, columns=["label", "seed", "learning_steps", "return", "num_features"])


def test_plot_writes_a_png(tmp_path):
    path = plot_learning_curves(results_frame(), tmp_path / "sub" / "curve.png")
    data = path.read_bytes()
    assert data.startswith(b"\x89PNG") and len(data) > 1000


def test_plot_other_metric_and_single_seed(tmp_path):
    frame = results_frame()
    plot_learning_curves(frame, tmp_path / "f.png", metric="num_features")
    single = frame[frame["seed"] == 0]
    assert plot_learning_curves(single, tmp_path / "s.png").is_file()


def test_plot_unknown_metric_lists_choices(tmp_path):
    with pytest.raises(InvalidParameterError, match="Plottable metrics: return, num_features"):
        plot_learning_curves(results_frame(), tmp_path / "x.png", metric="reward")


def test_plot_empty_results_is_an_error(tmp_path):
    empty = results_frame().iloc[0:0]
    with pytest.raises(InvalidParameterError, match="empty"):
        plot_learning_curves(empty, tmp_path / "x.png")


def test_plot_results_dir(tmp_path):
    with pytest.raises(InvalidParameterError, match="conjure run"):
        plot_results_dir(tmp_path)
    results_frame().to_parquet(tmp_path / "results.parquet")
    assert plot_results_dir(tmp_path).name == "learning_curve.png"
    assert plot_results_dir(tmp_path, metric="num_features").name == (
        "learning_curve_num_features.png"
    )
    assert np.isfinite(results_frame()["return"]).all()
