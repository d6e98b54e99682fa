"""Tests of the figure catalogue: names, scales, costs, and every claim against its config."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import yaml

from conjure.core.errors import InvalidParameterError
from conjure.sweeps.reproduction import (
    FIGURES,
    METRICS,
    QUICK_SEEDS,
    above,
    best_at_every_x,
    comparison_markdown,
    every_run_within,
    figure_cost,
    figure_names,
    finals_markdown,
    finals_table,
    level,
    load_figure_sweep,
    no_better,
    summary_table,
    worst_above_worst,
)
from conjure.sweeps.sweep import expand_sweep

ROOT = Path(__file__).resolve().parents[2]


#: Figures whose grid is the plot's x-axis: their finals keep a ``setting`` per row.
X_AXIS_FIGURES = ("fig_4_11",)


def fake_finals(name, seeds=3):
    """Finals of every agent of the figure's config, with random metrics."""
    config = yaml.safe_load((ROOT / FIGURES[name].config).read_text())
    rng = np.random.default_rng(0)
    rows = []
    metric = config.get("metric", "return")
    for label in config["agents"]:
        for seed in range(seeds):
            row = {"label": label, "seed": seed, "learning_steps": 100}
            row.update({m: rng.uniform(0.0, 1.0) for m in dict.fromkeys([*METRICS, metric])})
            row[f"auc_{metric}"] = rng.uniform(0.0, 1.0)
            if name in X_AXIS_FIGURES:
                row["setting"] = f"num_buckets={seed + 1}"
            rows.append(row)
    return pd.DataFrame(rows)


@pytest.mark.parametrize("name", list(FIGURES))
def test_every_claim_measures_methods_its_config_runs(name):
    text = comparison_markdown(name, fake_finals(name), scale="quick")
    assert "not measured" not in text
    texts = [claim.text for claim in FIGURES[name].claims]
    rows = [line for line in text.splitlines() if line.split(" | ")[0][2:] in texts]
    assert [row.split(" | ")[0][2:] for row in rows] == texts
    assert (ROOT / FIGURES[name].config).is_file()


def test_a_claim_on_a_missing_method_says_so_in_its_row():
    finals = fake_finals("fig_5_8")
    text = comparison_markdown("fig_5_8", finals[finals["label"] != "csarsa"], scale="thesis")
    assert text.count("not measured") == 3  # the three claims about csarsa
    assert "No results for 'csarsa'" in text


def test_claims_over_the_x_axis_compare_methods_at_each_cut_count():
    # Fig. 4-11's x-axis is each method's own grid parameter; the number ending the setting.
    rows = [
        ("arifdd", "initial_tiles_per_dim=1", 2000.0),
        ("arifdd", "initial_tiles_per_dim=2", 2400.0),
        ("arifdd", "initial_tiles_per_dim=2", 2600.0),  # mean 2,500 at 2 cuts
        ("ifdd", "base.num_buckets=1", 15.0),
        ("ifdd", "base.num_buckets=2", 3000.0),
    ]
    finals = pd.DataFrame(rows, columns=["label", "setting", "episode_length"])
    text, holds = best_at_every_x("arifdd", ("ifdd",), "episode_length")(finals)
    assert not holds and text == "arifdd best at 1 of 2; behind at 2 (ifdd 3,000 vs 2,500)"
    text, holds = worst_above_worst("arifdd", ("ifdd",), "episode_length")(finals)
    assert holds and text == "worst over x: arifdd 2,000, ifdd 15"
    text, holds = best_at_every_x("arifdd", ("ifdd",), "episode_length")(finals[:4])
    assert holds and text == "arifdd best at 2 of 2"  # no rival at 2 cuts: nothing to lose to
    with pytest.raises(InvalidParameterError, match="no grid settings"):
        best_at_every_x("arifdd", ("ifdd",), "episode_length")(finals.drop(columns="setting"))


def test_each_word_of_the_thesis_has_its_test():
    # "above": the 95% Welch interval of the difference lies above 0; "level" (the same
    # level, not significant): it holds 0; "could not outperform": it does not lie above 0.
    rows = [("a", v) for v in (1.0, 1.2, 1.4)] + [("b", v) for v in (1.1, 1.3, 1.5)]
    rows += [("c", v) for v in (3.0, 3.1, 3.2)]
    finals = pd.DataFrame(rows, columns=["label", "return"])
    assert not above("b", "a")(finals)[1] and above("c", "a")(finals)[1]
    assert level("b", "a")(finals)[1] and not level("c", "a")(finals)[1]
    assert no_better("b", "a")(finals)[1] and not no_better("c", "a")(finals)[1]
    assert no_better("a", "c")(finals)[1]  # below is "not above"
    text, holds = every_run_within("c", "return", 3.0, 3.1)(finals)
    assert not holds and text == "c: 2 of 3 runs in [3, 3.1]"
    assert every_run_within("c", "return", 3.0, 3.2)(finals)[1]


@pytest.mark.parametrize("name", list(FIGURES))
def test_every_claim_quotes_its_sentence_of_the_thesis_or_says_it_has_none(name):
    for claim in FIGURES[name].claims:
        if claim.quote:
            assert claim.quote.startswith(("Section ", "Fig. ")) and '"' in claim.quote
        else:
            assert claim.thesis.startswith("("), claim.text  # "(not in the thesis)", ...
    text = comparison_markdown(name, fake_finals(name), scale="thesis")
    assert text.count("\n- ") == len(FIGURES[name].claims)  # what each claim quotes


def test_names_take_short_forms_and_unknown_ones_suggest():
    assert figure_names(["5-8", "fig_5_8", "FIG_5_12", "ifdd_csarsa"]) == [
        "fig_5_8",
        "fig_5_12",
        "ifdd_csarsa",
    ]
    with pytest.raises(InvalidParameterError, match="Did you mean 'fig_5_12'"):
        figure_names(["fig_5_2"])


def test_quick_runs_the_selected_settings_on_fresh_seeds():
    thesis = load_figure_sweep("fig_5_8", "thesis", ROOT)
    quick = load_figure_sweep("fig_5_8", "quick", ROOT)
    assert quick.grid == {} and quick.selection is None
    assert quick.seed_list() == [5, 6, 7]  # after search seeds 0-4
    assert quick.budget_steps == thesis.budget_steps
    assert quick.agents == thesis.agents
    shrunk = load_figure_sweep("fig_5_8", "quick", ROOT, ["budget_steps=50"])
    assert shrunk.budget_steps == 50


def test_quick_keeps_a_grid_that_is_the_figures_axis():
    thesis = load_figure_sweep("fig_4_11", "thesis", ROOT)
    quick = load_figure_sweep("fig_4_11", "quick", ROOT)
    assert quick.grid == thesis.grid and thesis.selection is None
    assert quick.seed_list() == thesis.seed_list()[:QUICK_SEEDS]


def test_cost_counts_the_runs_the_sweep_expands():
    quick = load_figure_sweep("fig_5_8", "quick", ROOT)
    assert figure_cost("fig_5_8", "quick", ROOT) == (len(expand_sweep(quick)), 15 * 10_000)
    thesis = load_figure_sweep("fig_4_8_pendulum_ifdd_plus", "thesis", ROOT)
    runs, steps = figure_cost("fig_4_8_pendulum_ifdd_plus", "thesis", ROOT)
    assert runs == len(expand_sweep(thesis)) + thesis.selection.fresh_seeds
    assert steps == runs * thesis.budget_steps


def test_an_unknown_scale_is_refused():
    with pytest.raises(InvalidParameterError, match="Unknown scale 'huge'"):
        load_figure_sweep("fig_5_8", "huge", ROOT)


def test_finals_and_summary_of_a_results_frame():
    frame = pd.DataFrame(
        {
            "run_id": ["a", "a", "b", "b"],
            "label": ["x", "x", "x", "x"],
            "setting": ["k=1"] * 4,
            "seed": [0, 0, 1, 1],
            "learning_steps": [0, 10, 0, 10],
            "return": [0.0, 1.0, 0.0, 3.0],
        }
    )
    finals = finals_table(frame)
    assert list(finals.columns) == ["label", "seed", "learning_steps", "return", "auc_return"]
    assert finals["auc_return"].tolist() == [0.5, 1.5]
    summary = summary_table(finals)
    assert summary.loc[0, "seeds"] == 2 and summary.loc[0, "return_mean"] == 2.0


def test_a_methods_settings_are_listed_in_numeric_order():
    finals = pd.DataFrame(
        {
            "label": ["b", "b", "a", "a"],
            "setting": ["x=10", "x=2", "x=1", "x=1"],
            "seed": [0, 0, 0, 1],
            "learning_steps": [10] * 4,
            "return": [1.0, 2.0, 3.0, 4.0],
        }
    )
    rows = [line.split(" | ")[0] for line in finals_markdown(finals).splitlines()[2:]]
    assert rows == ["| b x=2", "| b x=10", "| a x=1"]  # methods as they come, numbers by value


def test_a_relative_difference_is_printed_only_against_a_baseline_away_from_zero():
    from conjure.sweeps.reproduction import above

    def finals(baseline):
        rows = [("better", v) for v in (1.0, 1.1, 0.9)] + [("base", v) for v in baseline]
        return pd.DataFrame(rows, columns=["label", "return"])

    away, _ = above("better", "base")(finals([0.5, 0.6, 0.4]))
    assert away.endswith("(+100.0%)")
    near, holds = above("better", "base")(finals([0.04, -0.05, 0.02]))
    assert "%" not in near and holds
