"""Tests of `conjure.reporting.statistics`: rliable's estimators behind conjure's checks."""

from __future__ import annotations

import math

import numpy as np
import pytest

from conjure.core.errors import InvalidParameterError
from conjure.reporting.statistics import (
    PROFILE_COLUMNS,
    iqm,
    iqm_interval,
    performance_profile,
    probability_of_improvement,
    score_matrix,
)


def test_iqm_known_values():
    assert iqm([1, 2, 3, 4]) == 2.5
    # The middle half of 0..6 and 1000 is 2, 3, 4, 5: the outlier does not count.
    assert iqm([0, 1, 2, 3, 4, 5, 6, 1000]) == 3.5
    # A runs x tasks matrix pools every run of every task.
    assert iqm([[0.0, 4.0], [1.0, 5.0], [2.0, 6.0], [3.0, 1000.0]]) == 3.5


def test_iqm_interval_brackets_and_is_seeded():
    scores = np.arange(12.0) ** 2
    point, low, high = iqm_interval(scores, reps=300, seed=5)
    assert point == iqm(scores) and low <= point <= high and low < high
    assert iqm_interval(scores, reps=300, seed=5) == (point, low, high)
    assert iqm_interval(scores, reps=300, seed=6) != (point, low, high)
    # Resampling within each task: a task of equal values never varies.
    assert iqm_interval([5.0] * 6, reps=100)[1:] == (5.0, 5.0)
    # One run: no interval.
    point, low, high = iqm_interval([3.0], reps=100)
    assert point == 3.0 and math.isnan(low) and math.isnan(high)


def test_numpy_global_state_is_restored():
    np.random.seed(123)  # noqa: NPY002
    expected = np.random.random()  # noqa: NPY002
    np.random.seed(123)  # noqa: NPY002
    iqm_interval([1.0, 2.0, 3.0], reps=50, seed=1)
    probability_of_improvement([1.0, 2.0], [0.0, 3.0], reps=50, seed=1)
    performance_profile({"a": [1.0, 2.0]}, [1.5], reps=50, seed=1)
    assert np.random.random() == expected  # noqa: NPY002


def test_probability_of_improvement_known_values():
    # Every run of X above every run of Y: X improves on Y with probability 1, in every resample.
    assert probability_of_improvement([3.0, 4.0, 5.0], [0.0, 1.0], reps=100) == (1.0, 1.0, 1.0)
    assert probability_of_improvement([0.0, 1.0], [3.0, 4.0, 5.0], reps=100) == (0.0, 0.0, 0.0)
    # Identical sets: one half.
    assert probability_of_improvement([1.0, 2.0], [1.0, 2.0], reps=100)[0] == 0.5
    # 0..9 against 0, 1, 2: of the 30 pairs X wins 24 and ties 3, which count one half.
    x, y = np.arange(10.0), [0.0, 1.0, 2.0]
    point, low, high = probability_of_improvement(x, y, reps=200, seed=3)
    assert point == pytest.approx(25.5 / 30) and low <= point <= high <= 1.0 and low < high
    assert probability_of_improvement(x, y, reps=200, seed=3) == (point, low, high)
    # Averaged over tasks: a win on one task and a loss on the other.
    assert probability_of_improvement([[1.0, 0.0], [2.0, 0.0]], [[0.0, 5.0]], reps=50)[0] == 0.5


def test_performance_profile_known_values():
    scores = {"a": [1.0, 2.0, 3.0, 4.0], "b": [[0.0, 10.0], [0.0, 10.0]]}
    table = performance_profile(scores, [0.0, 2.5, 4.0], reps=200, seed=2)
    assert tuple(table.columns) == PROFILE_COLUMNS
    a = table[table["method"] == "a"]
    # The fraction of runs scoring strictly above each threshold.
    assert a["fraction"].tolist() == [1.0, 0.5, 0.0]
    assert (a["low"] <= a["fraction"]).all() and (a["fraction"] <= a["high"]).all()
    b = table[table["method"] == "b"]
    assert b["fraction"].tolist() == [0.5, 0.5, 0.5]
    assert b["low"].tolist() == b["high"].tolist() == [0.5, 0.5, 0.5]  # each task constant
    again = performance_profile(scores, [0.0, 2.5, 4.0], reps=200, seed=2)
    assert again.equals(table)
    single = performance_profile({"one": [1.0]}, [0.0], reps=10)
    assert single["fraction"].tolist() == [1.0] and single["low"].isna().all()


@pytest.mark.parametrize(
    ("call", "message"),
    [
        (lambda: iqm([]), r"`scores` must be a non-empty"),
        (lambda: iqm([1.0, np.nan]), r"`scores` must be finite; run 1 of task 0 is nan"),
        (lambda: iqm_interval([1.0, np.inf]), r"must be finite; run 1 of task 0 is inf"),
        (lambda: iqm([[1.0], [2.0, 3.0]]), r"`scores` must be numbers"),
        (lambda: iqm(np.zeros((2, 2, 2))), r"runs x tasks matrix; got shape \(2, 2, 2\)"),
        (lambda: iqm(["a"]), r"`scores` must be numbers"),
        (lambda: iqm_interval([1.0, 2.0], reps=0), r"`reps` must be a positive int; got 0"),
        (lambda: iqm_interval([1.0, 2.0], level=1.0), r"`level` must be within \(0, 1\)"),
        (lambda: iqm_interval([1.0, 2.0], level="0.9"), r"`level` must be within"),
        (lambda: iqm_interval([1.0, 2.0], seed=-1), r"`seed` must be a non-negative int"),
        (
            lambda: probability_of_improvement([[1.0, 2.0]], [1.0]),
            r"same tasks \(columns\); got 2 and 1",
        ),
        (lambda: probability_of_improvement([1.0], []), r"`scores_y` must be a non-empty"),
        (lambda: performance_profile({}, [0.0]), r"at least one method"),
        (lambda: performance_profile({"a": [1.0, np.nan]}, [0.0]), r"`scores\['a'\]` must be"),
        (lambda: performance_profile({"a": [1.0]}, [np.nan]), r"`thresholds` must be finite"),
        (lambda: performance_profile({"a": [1.0]}, [[0.0, 1.0]]), r"`thresholds` must be 1-D"),
    ],
)
def test_bad_input_is_one_clear_line(call, message):
    with pytest.raises(InvalidParameterError, match=message) as info:
        call()
    assert "\n" not in str(info.value)


def test_score_matrix_shapes():
    assert score_matrix([1, 2]).tolist() == [[1.0], [2.0]]
    assert score_matrix([[1, 2], [3, 4]]).shape == (2, 2)
