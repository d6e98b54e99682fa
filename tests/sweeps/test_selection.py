"""Tests of grid selection: scores, the best setting per method, the fresh-seed rerun."""

from __future__ import annotations

import math

import pandas as pd
import pytest
from sweep_fakes import fake_sweep, isolated_fakes, run_with_fakes

from conjure.core.errors import InvalidParameterError
from conjure.sweeps.selection import fresh_seeds, score_runs, select_best
from conjure.sweeps.sweep import run_sweep

pytestmark = pytest.mark.usefixtures(isolated_fakes.__name__)


def frame(rows):
    return pd.DataFrame(
        rows, columns=["run_id", "label", "setting", "seed", "learning_steps", "return"]
    )


def test_scores_and_eligibility():
    results = frame(
        [
            ("r1", "m", "x=1", 0, 0, 0.0),
            ("r1", "m", "x=1", 0, 10, 4.0),
            ("r2", "m", "x=1", 1, 0, 0.0),
            ("r2", "m", "x=1", 1, 10, 2.0),
            ("r3", "m", "x=2", 0, 0, 3.0),  # best area and final, but one seed only
            ("r3", "m", "x=2", 0, 10, 9.0),
        ]
    )
    assert score_runs(results, criterion="auc").to_dict() == {"r1": 2.0, "r2": 1.0, "r3": 6.0}
    assert score_runs(results, criterion="final").to_dict() == {"r1": 4.0, "r2": 2.0, "r3": 9.0}
    best = select_best(results, criterion="final")
    row = best.iloc[0]
    assert row["setting"] == "x=1" and row["score_mean"] == 3.0 and row["num_settings"] == "1/2"
    assert select_best(results, mode="min").iloc[0]["setting"] == "x=1"
    with pytest.raises(InvalidParameterError, match="criterion"):
        score_runs(results, criterion="area")
    assert math.isnan(select_best(results.query("run_id == 'r3'")).iloc[0]["score_ci95"])


def test_a_cost_limit_makes_only_settings_within_it_eligible():
    rows = []
    for run, setting, ret, cost in (
        ("a0", "x=1", 9.0, 0.5), ("a1", "x=1", 9.0, 0.3),  # best return, mean cost 0.4
        ("b0", "x=2", 5.0, 0.1), ("b1", "x=2", 5.0, 0.1),  # within d = 0.2
        ("c0", "x=3", 1.0, 0.0), ("c1", "x=3", 1.0, 0.0),
    ):  # fmt: skip
        seed = int(run[1])
        rows += [(run, "m", setting, seed, 0, 0.0, 0.0), (run, "m", setting, seed, 10, ret, cost)]
    columns = ["run_id", "label", "setting", "seed", "learning_steps", "return", "episode_cost"]
    results = pd.DataFrame(rows, columns=columns)
    assert select_best(results).iloc[0]["setting"] == "x=1"
    row = select_best(results, cost_limit=0.2).iloc[0]
    assert (row["setting"], row["num_settings"]) == ("x=2", "2/3")
    # None within the limit: the lowest mean final cost.
    row = select_best(results.query("setting != 'x=3'"), cost_limit=0.05).iloc[0]
    assert (row["setting"], row["num_settings"]) == ("x=2", "0/2")


def test_fresh_seeds():
    assert fresh_seeds([0, 1, 2], 2) == [3, 4]
    assert fresh_seeds([0, 1], [10, 11]) == [10, 11]
    with pytest.raises(InvalidParameterError, match="must not repeat"):
        fresh_seeds([0, 1], [1, 2])


def test_sweep_selects_best_setting_and_reruns_it_on_fresh_seeds(tmp_path):
    sweep = fake_sweep(
        grid={"agents.a.params.greedy_action": [0, 1]},  # 0 never reaches the goal
        selection={"criterion": "final", "fresh_seeds": 3},
    )
    outcome = run_sweep(sweep, tmp_path, max_workers=1, run_fn=run_with_fakes, progress=False)
    best = pd.read_csv(tmp_path / "selection.csv", keep_default_na=False)
    a_rows = best[best["label"] == "a"]
    assert set(a_rows["setting"]) == {"greedy_action=1"} and len(best) == 4
    selected = outcome.selected.results
    assert set(selected["seed"]) == {2, 3, 4}  # after the grid's seeds 0, 1
    assert set(selected.loc[selected["label"] == "a", "setting"]) == {"greedy_action=1"}
    assert selected["run_id"].nunique() == 4 * 3


def test_no_fresh_seeds_prints_the_best_settings_on_the_search_seeds(tmp_path):
    # Issue 21: `fresh_seeds: 0` printed an empty "selected" table.
    from rich.console import Console

    sweep = fake_sweep(
        grid={"agents.a.params.greedy_action": [0, 1]},
        selection={"criterion": "final", "fresh_seeds": 0},
    )
    console = Console(width=160, record=True)
    outcome = run_sweep(sweep, tmp_path, max_workers=1, run_fn=run_with_fakes, console=console)
    chosen = outcome.selected.summary
    assert len(chosen) == 4 and chosen["num_seeds"].eq(2).all()  # seeds 0, 1 of the search
    assert set(chosen.loc[chosen["label"] == "a", "setting"]) == {"greedy_action=1"}
    assert not (tmp_path / "selected").exists()
    text = console.export_text()
    table = text.split("fresh_seeds: 0")[1]  # the second table, after the search's
    assert table.count("greedy_action=1") == 2 and "greedy_action=0" not in table
    assert table.count("│ b ") == 2
