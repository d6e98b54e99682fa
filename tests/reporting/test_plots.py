"""Tests of the learning-curve plots."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from conjure.core.errors import InvalidParameterError
from conjure.reporting import plots
from conjure.reporting.plots import (
    AXES_INCHES,
    curve_bands,
    learning_curve_figure,
    method_labels,
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


def sweep_frame() -> pd.DataFrame:
    """Fig. 5-12's sweep: three learners x a 3 x 3 step-size grid, and two planners: 29 lines."""
    rows = []
    settings = [
        f"learner.step_size.alpha_0={a}, learner.step_size.n_0={n}"
        for a in (0.01, 0.1, 1.0)
        for n in (100, 1000, 1000000)
    ]
    methods = [(label, s) for label in ("icca", "am_icca", "icca_printed") for s in settings]
    for k, (label, setting) in enumerate([*methods, ("conservative", ""), ("aggressive", "")]):
        for seed in range(2):
            for step in (0, 15000, 30000):
                rows.append((label, setting, seed, step, 0.01 * k * step / 30000 + 0.05 * seed))
    columns = ["label", "setting", "seed", "learning_steps", "return"]
    return pd.DataFrame(rows, columns=columns)


def test_29_methods_leave_the_axes_most_of_the_figure():
    # Issue 21: Fig. 5-12's legend took more than half the figure; the figure grows instead.
    frame = sweep_frame()
    frame = frame.assign(label=method_labels(frame))
    assert frame["label"].nunique() == 29
    figure = learning_curve_figure(frame, "return", "fig_5_12")
    axes = figure.axes[0]
    box = axes.get_position()
    assert box.width * box.height >= 0.6
    width, height = figure.get_size_inches()
    assert box.width * width >= AXES_INCHES[0] and box.height * height >= AXES_INCHES[1]
    renderer = figure.canvas.get_renderer()
    legend = axes.get_legend().get_window_extent(renderer)
    assert legend.x0 >= axes.get_window_extent(renderer).x1
    assert legend.x1 <= figure.bbox.x1 and legend.y0 >= figure.bbox.y0  # all of it is seen
    texts = [t.get_text() for t in axes.get_legend().texts]
    assert "icca [alpha_0=0.01, n_0=100]" in texts
    assert "icca [alpha_0=0.01, n_0=1,000,000]" in texts  # issue 21: no `n_0=1000000`


def test_identical_curves_differ_in_line_style_marker_and_colour():
    # Issue 21: the iCCA curve was hidden under its planner's.
    planner = results_frame().query("label == 'a'")
    frame = pd.concat([planner, planner.assign(label="icca")])
    lines = learning_curve_figure(frame, "return").axes[0].get_lines()
    assert len(lines) == 2
    np.testing.assert_array_equal(lines[0].get_ydata(), lines[1].get_ydata())
    assert lines[0].get_linestyle() != lines[1].get_linestyle()
    assert lines[0].get_marker() != lines[1].get_marker()
    assert lines[0].get_color() != lines[1].get_color()


def test_a_plot_is_titled_by_the_configs_name_and_the_metric(tmp_path, monkeypatch):
    # Issue 21: plots were titled by their folder's name.
    figure = learning_curve_figure(results_frame(), "num_features", "fig_5_12")
    assert figure.axes[0].get_title() == "fig_5_12: num_features"
    folder = tmp_path / "some_folder"
    folder.mkdir()
    (folder / "config.resolved.yaml").write_text("name: fig_5_12\nmetric: return\n")
    sweep_frame().to_parquet(folder / "results.parquet")
    drawn = []

    def drawing(frame, metric, title=""):
        drawn.append(learning_curve_figure(frame, metric, title))
        return drawn[-1]

    monkeypatch.setattr(plots, "learning_curve_figure", drawing)
    plot_results_dir(folder)
    assert drawn[0].axes[0].get_title() == "fig_5_12: return"
    assert len(drawn[0].axes[0].get_lines()) == 29  # one line per grid setting


def test_bands_stop_at_the_cap_and_value_bounds_the_runs_declared():
    # Issue 21: a pendulum band reached 3,170 steps above the 3,000-step cap.
    lengths = pd.DataFrame(
        {
            "label": "pendulum",
            "seed": [0, 1, 2],
            "learning_steps": 100,
            "episode_length": [3000.0, 3000.0, 2600.0],
            "max_episode_steps": 3000.0,
        }
    )
    band = curve_bands(lengths, "episode_length").iloc[0]
    assert band["high"] == 3000.0 and band["low"] < band["mean"] < 3000.0
    figure = learning_curve_figure(lengths, "episode_length")
    texts = [t.get_text() for t in figure.axes[0].get_legend().get_texts()]
    assert any("cut at the range [0, 3,000]" in t for t in texts)
    optimality = lengths.rename(columns={"episode_length": "optimality"}).assign(
        optimality=[1.0, 1.0, 0.4]
    )
    assert curve_bands(optimality, "optimality").iloc[0]["high"] == 1.0  # it reached 1.75


def test_a_return_band_stops_at_declared_return_bounds_and_says_when_it_is_not_cut():
    # Issue 21: GridWorld-1's returns (at most 1) had bands reaching 8.5.
    returns = pd.DataFrame(
        {"label": "icca", "seed": [0, 1], "learning_steps": 100, "return": [1.0, -0.5]}
    )
    declared = returns.assign(lowest_return=-1.999, highest_return=1.0)
    band = curve_bands(declared, "return").iloc[0]
    assert (band["low"], band["high"]) == (-1.999, 1.0)
    for frame, said in ((declared, "cut at the range [-1.999, 1]"), (returns, "not cut")):
        figure = learning_curve_figure(frame, "return")
        texts = [t.get_text() for t in figure.axes[0].get_legend().get_texts()]
        assert any(said in t for t in texts), texts


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


def test_panels_draw_each_method_on_its_own_axes_over_the_others_in_grey(tmp_path):
    from conjure.reporting.plots import panel_figure

    frame = pd.concat([results_frame(), results_frame().assign(label=lambda f: f.label + "2")])
    figure = panel_figure(frame, "return", "chain")
    shown = [axes for axes in figure.axes if axes.get_visible()]
    assert [axes.get_title() for axes in shown] == ["a (n=3)", "b (n=3)", "a2 (n=3)", "b2 (n=3)"]
    assert len(figure.axes) == 6  # a 2 x 3 grid, the last two hidden
    first = shown[0].get_lines()
    assert len(first) == 4 and [line.get_color() for line in first[:3]] == ["0.7"] * 3
    np.testing.assert_allclose(first[-1].get_ydata(), [1.0, 51.0, 101.0])  # a's mean
    path = plot_learning_curves(frame, tmp_path / "panels.png", panels=True)
    assert path.read_bytes().startswith(b"\x89PNG")


def test_performance_profiles_are_drawn_by_rliable_on_our_axes(tmp_path):
    from conjure.reporting.statistics import performance_profile

    table = performance_profile(
        {"a": [1.0, 2.0, 3.0, 4.0], "b": [0.0, 0.0, 5.0, 5.0]}, [0.0, 2.5, 4.5], reps=50
    )
    figure = plots.performance_profile_figure(table, score="return", title="profiles")
    axes = figure.axes[0]
    lines = {line.get_label(): line for line in axes.get_lines()}
    assert lines["a"].get_ydata().tolist() == [1.0, 0.5, 0.0]
    assert lines["b"].get_ydata().tolist() == [0.5, 0.5, 0.5]
    assert lines["a"].get_linestyle() != lines["b"].get_linestyle()
    assert axes.get_xlabel() == "return (τ)" and axes.get_title() == "profiles"
    assert "stratified-bootstrap" in axes.get_legend().get_texts()[-1].get_text()
    path = plots.plot_performance_profiles(table, tmp_path / "profiles.png")
    assert path.stat().st_size > 1000
    with pytest.raises(InvalidParameterError, match=r"no column\(s\) fraction"):
        plots.plot_performance_profiles(table.drop(columns="fraction"), tmp_path / "x.png")
    with pytest.raises(InvalidParameterError, match="an empty table"):
        plots.performance_profile_figure(table.iloc[:0])
