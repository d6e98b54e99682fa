"""Tests of the results folder helpers: confidence intervals, summaries, tables."""

from __future__ import annotations

import math
import os

import pandas as pd
import pytest

from conjure.experiments.results import (
    describe_setting,
    flatten_params,
    load_results,
    read_run,
    remove_stale_temporaries,
    run_id,
    run_path,
    save_run,
    save_run_error,
    summarize,
    t_confidence,
    write_atomic,
)


def test_t_confidence_and_summary():
    mean, half = t_confidence([1.0, 2.0, 3.0, 4.0])
    assert mean == 2.5 and half == pytest.approx(2.0540, abs=1e-3)
    assert math.isnan(t_confidence([5.0])[1])
    frame = pd.DataFrame(
        {
            "label": ["a"] * 4,
            "seed": [0, 0, 1, 1],
            "learning_steps": [0, 10, 0, 10],
            "return": [0.0, 1.0, 0.0, 3.0],
            "num_features": [5, 7, 5, 9],
            "steps_per_second": [float("nan"), 100.0, float("nan"), 300.0],
        }
    )
    summary = summarize(frame)
    row = summary.iloc[0]
    assert row["final_return_mean"] == 2.0 and row["final_num_features"] == 8.0
    assert row["mean_steps_per_second"] == 200.0 and row["num_seeds"] == 2


def test_flatten_params_and_mixed_columns(tmp_path):
    flat = flatten_params(
        {"kind": "A", "params": {"x": {"kind": "B", "params": {"y": 1}}}}, "agent"
    )
    assert flat == {"agent": "A", "agent.x": "B", "agent.x.y": 1}
    for label, step in (("a", 0.1), ("b", {"kind": "ConstantStepSize", "params": {"alpha_0": 1}})):
        spec = {
            "label": label,
            "seed": 0,
            "agent": {"kind": "SARSA", "params": {"step_size": step}},
        }
        save_run(tmp_path, spec, {"learning_steps": [0], "return": [1.0]}, {"run_seconds": 2.0})
    table = load_results(tmp_path)
    assert len(table) == 2 and table["run_seconds"].tolist() == [2.0, 2.0]
    table.to_parquet(tmp_path / "t.parquet")  # mixed parameter types still serialise


def test_run_files_are_named_by_hash_and_written_atomically(tmp_path):
    spec = {"label": "a", "seed": 3, "agent": {"kind": "SARSA", "params": {}}}
    save_run_error(tmp_path, spec, "Traceback: boom", {"learning_steps": [0]})
    path = save_run(tmp_path, spec, {"learning_steps": [0, 5], "return": [0.0, 1.0]})
    assert path == run_path(tmp_path, run_id(spec))
    record = read_run(path)
    assert record["config"] == spec and record["curve"]["return"].tolist() == [0.0, 1.0]
    assert not list((tmp_path / "errors").iterdir())  # a success clears the old error
    stale = tmp_path / "runs" / ".x.json.tmp-h-1-ab"  # another host's, written long ago
    stale.write_text("half")
    os.utime(stale, (0, 0))
    assert remove_stale_temporaries(tmp_path) == 1
    write_atomic(tmp_path / "f.txt", "x")
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".")] == []


def test_intervals_read_at_the_means_precision():
    from conjure.experiments.numbers import format_interval

    assert format_interval(-1.0, 1.674e-16) == "-1.000 ± 0.000"  # not "-1 ± 1.674e-16"
    assert format_interval(0.5, 0.25) == "0.5000 ± 0.2500"  # 4 significant digits
    assert format_interval(-3012.4, 150.2) == "-3,012 ± 150"
    assert format_interval(0.0, 0.0) == "0.000 ± 0.000"
    assert format_interval(float("nan"), 1.0) == "n/a"


def test_the_summary_cuts_each_interval_at_what_the_metric_can_be(tmp_path):
    # Issue 21: a probability read 0.300 ± 1.271 and an episode length passed its cap.
    for seed, rate, length in ((0, 1.0, 3000.0), (1, 1.0, 2990.0), (2, 0.0, 2400.0)):
        curve = {
            "learning_steps": [10],
            "failure_rate": [rate],
            "episode_length": [length],
            "num_features": [1],
            "steps_per_second": [1.0],
        }
        save_run(tmp_path, {"label": "a", "seed": seed}, curve, {"max_episode_steps": 3000.0})
    table = load_results(tmp_path)
    assert table["max_episode_steps"].eq(3000.0).all() and table["best_return"].isna().all()
    rate = summarize(table, "failure_rate").iloc[0]
    assert rate["final_failure_rate_ci95"] > 1.0  # the t half-width, as computed
    assert (rate["final_failure_rate_low"], rate["final_failure_rate_high"]) == (0.0, 1.0)
    length = summarize(table, "episode_length").iloc[0]
    assert length["final_episode_length_mean"] + length["final_episode_length_ci95"] > 3000.0
    assert length["final_episode_length_high"] == 3000.0


def test_a_setting_reads_as_short_yaml_values():
    # Issue 21: `alpha_0=0.05002000000000905` in printed tables.
    setting = {
        "agents.sarsa.params.step_size.params.alpha_0": 0.05002000000000905,
        "agents.sarsa.params.step_size.params.n_0": 1000000,
        "agents.sarsa.params.trace_decay": 1.0,
    }
    assert describe_setting(setting) == "step_size.alpha_0=0.05002, step_size.n_0=1000000, " + (
        "trace_decay=1.0"
    )
