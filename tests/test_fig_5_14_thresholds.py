"""docs/reproduction/fig_5_14_thresholds.py runs in a short mode."""

import importlib.util
import sys
from pathlib import Path

SCRIPT = Path(__file__).resolve().parents[1] / "docs" / "reproduction" / "fig_5_14_thresholds.py"


def test_a_short_run_sets_the_threshold_and_reports_the_final_check():
    spec = importlib.util.spec_from_file_location("fig_5_14_thresholds", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    sys.modules["fig_5_14_thresholds"] = module
    spec.loader.exec_module(module)
    threshold, seed, final_return, pits = module.final(0.5, 10005, budget=300)
    assert (threshold, seed) == (0.5, 10005)
    assert -10.0 <= final_return <= 1.0 and pits >= 0  # GridWorld-3's return range
    assert module.final(0.5, 10005, budget=300) == (threshold, seed, final_return, pits)
