"""docs/reproduction/am_icca_switch.py runs in a short mode and records what it says."""

from doc_script import load_doc_script


def load():
    return load_doc_script("am_icca_switch")


def test_the_variants_differ_from_am_icca_by_one_parameter_each():
    agents = load().experiment()["agents"]
    base = agents["am_icca"]["params"]
    start = agents["am_icca_aggressive_start"]["params"]
    assert start["model"]["params"]["initial_noise"] == 0.05
    assert {**start, "model": base["model"]} == base
    assert agents["am_icca_fuel_rule"]["params"]["risk"] == {"kind": "FuelRiskAnalyzer"}
    assert agents["am_icca_trusted"]["params"] == {**base, "trusted_knownness": 1.0}


def test_a_short_trace_switches_early_and_counts_vetoes_among_proposals():
    script = load()
    table, switches = script.trace(script.FIRST_SEED, steps=400, chunk=200)
    assert table["learning_steps"].tolist() == [200, 400]
    assert (table["vetoes"] <= table["proposals"]).all()
    # η̂ starts at 40% (weight 100) and the wind is 5%: π^p turns aggressive within the run
    (switch,) = switches
    assert switch["is_aggressive"] and 0 < switch["step"] <= 400 and switch["noise"] < 0.25
    assert table["is_aggressive"].all()


def test_a_short_judgement_counts_greedy_vetoes_and_judges_the_planner():
    script = load()
    summary = script.judge(script.FIRST_SEED, budget=300, episodes=2, max_planner_states=20)
    assert summary["learning_steps"] == 300 and summary["planner_states"] == 20
    assert 0 <= summary["greedy_vetoes"] <= summary["greedy_proposals"]
    assert 0.0 <= summary["planner_unsafe_share"] <= 1.0
    row = script.final("csarsa", script.FIRST_SEED, budget=200)
    assert row["label"] == "csarsa" and row["learning_failures"] >= 0
