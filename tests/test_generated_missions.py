"""docs/reproduction/generated_missions.py runs in a short mode and measures what it says."""

import pandas as pd

from doc_script import load_doc_script


def load():
    return load_doc_script("generated_missions")


def test_one_short_run_measures_exact_values_and_the_gain(tmp_path):
    script = load()
    row = script.measure(mission=0, seed=script.FIRST_SEED, budget=200, eval_episodes=2)
    assert row["v_cbba"] <= row["v_star"] + 1e-9 and row["v_icca"] <= row["v_star"] + 1e-9
    assert row["gain"] == row["v_icca"] / row["v_cbba"] - 1.0
    assert row["cbba_ratio"] == row["v_cbba"] / row["v_star"]
    again = script.measure(mission=0, seed=script.FIRST_SEED, budget=200, eval_episodes=2)
    assert {k: v for k, v in again.items() if k != "run_seconds"} == {
        k: v for k, v in row.items() if k != "run_seconds"
    }
    table = pd.DataFrame([row, {**row, "seed": row["seed"] + 1}])
    script.plot(table, tmp_path / "gain.png")
    assert (tmp_path / "gain.png").stat().st_size > 0
    assert "1 missions x 2 seeds, 200 steps" in script.summary(table)
