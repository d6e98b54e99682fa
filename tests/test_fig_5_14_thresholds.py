"""docs/reproduction/fig_5_14_thresholds.py runs in a short mode."""

from doc_script import load_doc_script


def test_a_short_run_sets_the_threshold_and_reports_the_final_check():
    module = load_doc_script("fig_5_14_thresholds")
    threshold, seed, final_return, pits = module.final(0.5, 10005, budget=300)
    assert (threshold, seed) == (0.5, 10005)
    assert -10.0 <= final_return <= 1.0 and pits >= 0  # GridWorld-3's return range
    assert module.final(0.5, 10005, budget=300) == (threshold, seed, final_return, pits)
