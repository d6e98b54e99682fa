"""Tests of the learning-curve plots."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from conjure.core.errors import InvalidParameterError
from conjure.reporting.plots import (
    curve_bands,
    learning_curve_figure,
    plot_learning_curves,
    plot_results_dir,
)


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
    assert plot_results_dir(tmp_path).name == "learning_curve_return.png"
    assert plot_results_dir(tmp_path, metric="num_features").name == (
        "learning_curve_num_features.png"
    )
    assert np.isfinite(results_frame()["return"]).all()


def test_bands_stay_within_the_metrics_possible_range():
    # Three seeds failing 1, 1, 0 times in 1: the Student-t interval is mean ± 2.48, far past
    # [0, 1]; the band is clipped there, and an unbounded metric keeps its full interval.
    frame = pd.DataFrame(
        {"label": "a", "seed": [0, 1, 2], "learning_steps": 5, "failure_rate": [1.0, 1.0, 0.0]}
    )
    band = curve_bands(frame, "failure_rate").iloc[0]
    assert band["low"] == 0.0 and band["high"] == 1.0
    assert band["mean"] == pytest.approx(2 / 3)
    unbounded = curve_bands(frame.rename(columns={"failure_rate": "return"}), "return").iloc[0]
    assert unbounded["high"] - unbounded["mean"] == pytest.approx(
        4.303 * (1 / 3) ** 0.5 / 3**0.5, rel=1e-3
    )


def test_the_legend_names_the_band_and_stays_off_the_curves():
    frame = results_frame()
    frame = pd.concat(
        [frame.assign(label=f"{c}-a-long-sweep-setting-{i}") for i, c in enumerate("abcdef")]
    )
    figure = learning_curve_figure(frame, "return")
    axes = figure.axes[0]
    legend = axes.get_legend()
    texts = [t.get_text() for t in legend.get_texts()]
    assert any("95% confidence interval" in t for t in texts)
    renderer = figure.canvas.get_renderer()
    box, plot_area = legend.get_window_extent(renderer), axes.get_window_extent(renderer)
    assert box.x0 >= plot_area.x1  # right of the axes: no curve is hidden under it
