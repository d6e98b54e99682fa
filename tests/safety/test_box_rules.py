"""The control box's rules (Algorithms 23, 24, 26), one source for both paths."""

import numpy as np
import pytest

from conjure.safety._box_rules import (
    NEVER_TRUSTED,
    consult_planner,
    fading_bias,
    is_trusted,
    is_unvisited,
    mentor_greedy_action,
    needs_replan,
    visit_bias,
)
from conjure.safety.compiled_cooperative import (
    _consult_planner,
    _mentor_greedy_action,
    _visit_bias,
)


class NoDraws:
    """A generator that must not be drawn from."""

    def random(self):
        raise AssertionError("drew a random number")


def test_an_unknown_pair_is_counted_without_a_draw():
    counts = np.zeros((3, 4), dtype=np.int32)
    assert consult_planner(counts, 10.0, 1, 2, NoDraws(), False) == (0.0, False)
    assert counts[1, 2] == 1  # line 8
    assert consult_planner(counts, 10.0, -1, 2, NoDraws(), True) == (0.0, False)


def test_a_known_pair_consults_without_a_draw_or_count():
    counts = np.full((3, 4), 10, dtype=np.int32)
    assert consult_planner(counts, 10.0, 0, 1, NoDraws(), False) == (1.0, True)
    assert consult_planner(counts, 10.0, 0, 1, NoDraws(), True) == (1.0, True)
    assert counts.sum() == 10 * 12


def test_a_partly_known_pair_consults_with_probability_knownness():
    counts = np.zeros((1, 1), dtype=np.int32)
    counts[0, 0] = 3
    draws = np.random.default_rng(0).random(5)
    rng = np.random.default_rng(0)
    for draw in draws:
        before = counts[0, 0]
        knownness, is_consulted = consult_planner(counts, 10.0, 0, 0, rng, False)
        assert knownness == min(1.0, before / 10.0)
        assert is_consulted == (draw < knownness)
        assert counts[0, 0] == before + (not is_consulted)
    greedy = consult_planner(counts, 10.0, 0, 0, NoDraws(), True)
    assert not greedy[1]  # greedy acting consults only a known pair (knownness < 1)


def test_the_compiled_rule_draws_and_counts_as_the_python_one():
    python_counts = np.array([[0, 4, 10]], dtype=np.int32)
    compiled_counts = python_counts.copy()
    python_rng, compiled_rng = np.random.default_rng(3), np.random.default_rng(3)
    for step in range(60):
        action = step % 3
        assert consult_planner(python_counts, 10.0, 0, action, python_rng, False) == (
            _consult_planner(compiled_counts, 10.0, 0, action, compiled_rng, False)
        )
    np.testing.assert_array_equal(python_counts, compiled_counts)
    assert python_rng.random() == compiled_rng.random()


def test_the_visit_bias_holds_b_n_after_n_visits():
    visits = np.zeros(2, dtype=np.int64)
    total = 0.0
    for n in range(1, 6):
        is_shifted, shift = visit_bias(visits, 1, 30.0, 2.0, True)
        total += shift
        assert is_shifted and visits[1] == n
        assert total == pytest.approx(fading_bias(30.0, 2.0, n - 1))
    assert fading_bias(30.0, 2.0, 0) == 30.0 and fading_bias(30.0, 2.0, 2) == 15.0
    compiled = np.zeros(2, dtype=np.int64)
    assert [_visit_bias(compiled, 1, 30.0, 2.0, True) for _ in range(5)][-1] == visit_bias(
        np.array([0, 4]), 1, 30.0, 2.0, True
    )


def test_a_printed_bias_moves_only_on_the_first_visit():
    visits = np.zeros(1, dtype=np.int64)
    assert is_unvisited(visits, 0) and is_unvisited(visits, -1)
    assert visit_bias(visits, 0, 100.0, 0.0, False) == (True, 100.0)
    assert visit_bias(visits, 0, 100.0, 0.0, False) == (False, 0.0)
    assert not is_unvisited(visits, 0)


def test_ties_break_toward_the_planner():
    values, legal = np.array([1.0, 2.0, 2.0, 0.5]), np.arange(4)
    assert mentor_greedy_action(values, legal, 2) == 2
    assert mentor_greedy_action(values, legal, 3) == 1
    assert mentor_greedy_action(values, np.array([0, 3]), 3) == 0
    assert _mentor_greedy_action(values, legal, 2) == 2


def test_trust_and_replan_thresholds():
    assert not is_trusted(1.0, NEVER_TRUSTED)
    assert is_trusted(0.5, 0.5) and not is_trusted(0.4, 0.5)
    assert needs_replan(0.2, 0.4, 0.1) and not needs_replan(0.35, 0.4, 0.1)
    assert needs_replan(0.4 + 1e-12, 0.4, 0.0) and not needs_replan(0.4, 0.4, 0.0)
