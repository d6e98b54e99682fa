"""Tests of the results folder helpers: confidence intervals, summaries, tables."""

from __future__ import annotations

import math

import pandas as pd
import pytest
import yaml

from conjure.experiments.results import (
    flatten_params,
    load_results,
    run_dir,
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
        directory = run_dir(tmp_path, label, 0)
        write_atomic(directory / "curve.csv", "learning_steps,return\n0,1.0\n")
        spec = {"agent": {"kind": "SARSA", "params": {"step_size": step}}}
        write_atomic(directory / "config.resolved.yaml", yaml.safe_dump(spec))
    table = load_results(tmp_path)
    assert len(table) == 2
    table.to_parquet(tmp_path / "t.parquet")  # mixed parameter types still serialise
