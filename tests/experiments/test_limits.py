"""Tests of the sense bounds on an experiment's counts (conjure.experiments.limits)."""

import numpy as np
import pytest

from conjure.core.errors import InvalidParameterError
from conjure.experiments.limits import (
    MAX_BUDGET_STEPS,
    MAX_SEED_COUNT,
    check_count,
    check_run_counts,
    parse_seeds,
)


def test_seeds_are_a_count_a_list_or_an_inclusive_range():
    assert parse_seeds(3) == 3 and parse_seeds(np.int64(2)) == 2
    assert parse_seeds([5, 1]) == [5, 1]
    assert parse_seeds(" 100 .. 102 ") == [100, 101, 102]
    assert parse_seeds(0, allow_zero=True) == 0


@pytest.mark.parametrize(
    "bad",
    [0, -1, True, 1.5, 1e30, MAX_SEED_COUNT + 1, [], [1, 1], [-1], [2**63], "3..1", "x", "1..2..3"],
)
def test_bad_seeds_are_one_line_naming_the_value(bad):
    with pytest.raises(ValueError, match="seed") as info:
        parse_seeds(bad)
    assert "\n" not in str(info.value)


def test_a_range_past_the_seed_count_bound_is_refused_without_building_it():
    with pytest.raises(ValueError, match="holds at most"):
        parse_seeds(f"0..{2**62}")


def test_counts_are_checked_against_their_bounds_and_the_budget():
    assert check_run_counts(100, 10, 1) == (100, 10, 1)
    with pytest.raises(InvalidParameterError, match=r"`run.budget_steps` must be an int in"):
        check_run_counts(MAX_BUDGET_STEPS + 1, 10, 1, prefix="run.")
    with pytest.raises(InvalidParameterError, match=r"at most `budget_steps` \(5\)"):
        check_run_counts(5, 10, 1)
    with pytest.raises(InvalidParameterError, match=r"an int of about \d+ digits"):
        check_count("eval_episodes", 10**4999, 1, 10)
