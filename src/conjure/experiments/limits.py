"""Sense bounds on an experiment's counts: seeds, budgets, policy checks and evaluation episodes.

A count inside its declared type can still be past what a run can do (``budget_steps=10**20``
never ends; ``num_policy_checks`` above ``budget_steps`` checks one step many times). These
bounds refuse such values before any run starts, with one line naming the value. The configs
(`conjure.experiments.config`) and `conjure.experiments.run.run` use the same checks.

Notes
-----
- Choice: a run learns at most ``MAX_BUDGET_STEPS`` = 10^12 steps (about 12 days at the
  fastest compiled loop's 1 us per step); ``num_policy_checks`` is at most ``budget_steps``
  (a check per learning step) and at most ``MAX_POLICY_CHECKS``; ``eval_episodes`` is at most
  ``MAX_EVAL_EPISODES``; an experiment has at most ``MAX_SEED_COUNT`` seeds, each in
  [0, 2^63) (what the seed streams and the results' int64 column hold).
- A seed range ``START..END`` is inclusive: ``100..129`` is 30 seeds.
"""

from __future__ import annotations

import re
from typing import Any

import numpy as np

from conjure.core.errors import InvalidParameterError
from conjure.core.params import INT_MAX

__all__ = [
    "MAX_BUDGET_STEPS",
    "MAX_COMPILE_STEPS",
    "MAX_EVAL_EPISODES",
    "MAX_POLICY_CHECKS",
    "MAX_SEED",
    "MAX_SEED_COUNT",
    "check_checks_within_budget",
    "check_count",
    "check_run_counts",
    "parse_seeds",
]

MAX_BUDGET_STEPS = 10**12
MAX_POLICY_CHECKS = 10**6
MAX_EVAL_EPISODES = 10**6
MAX_SEED_COUNT = 100_000
MAX_SEED = INT_MAX
#: The steps a cold compile is weighed against (`run`'s compile_steps; the warm-up's maximum).
MAX_COMPILE_STEPS = 2**62

_RANGE = re.compile(r"^\s*(-?\d+)\s*\.\.\s*(-?\d+)\s*$")


def check_count(name: str, value: Any, low: int, high: int) -> int:
    """Return ``value`` as an int in [``low``, ``high``], else raise naming ``name``.

    Examples
    --------
    >>> check_count("eval_episodes", 3, 1, 10)
    3
    >>> check_count("eval_episodes", 10**20, 1, 10)
    Traceback (most recent call last):
    ...
    conjure.core.errors.InvalidParameterError: `eval_episodes` must be an int in [1, 10]; \
got 100000000000000000000.
    """
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise InvalidParameterError(
            f"`{name}` must be an int in [{low:,}, {high:,}]; got {_short(value)}."
        )
    if not low <= value <= high:
        raise InvalidParameterError(
            f"`{name}` must be an int in [{low:,}, {high:,}]; got {_short(int(value))}."
        )
    return int(value)


def check_run_counts(
    budget_steps: Any, num_policy_checks: Any, eval_episodes: Any, prefix: str = ""
) -> tuple[int, int, int]:
    """Check a run's budget, policy checks and evaluation episodes against their sense bounds.

    ``prefix`` goes before each name in the message (``run.`` for the Python API).
    """
    budget = check_count(f"{prefix}budget_steps", budget_steps, 1, MAX_BUDGET_STEPS)
    checks = check_count(f"{prefix}num_policy_checks", num_policy_checks, 1, MAX_POLICY_CHECKS)
    check_checks_within_budget(checks, budget)
    episodes = check_count(f"{prefix}eval_episodes", eval_episodes, 1, MAX_EVAL_EPISODES)
    return budget, checks, episodes


def check_checks_within_budget(num_policy_checks: int, budget_steps: int) -> None:
    """Refuse more policy checks than learning steps (one check per learning step at most)."""
    if num_policy_checks > budget_steps:
        raise InvalidParameterError(
            f"`num_policy_checks` ({num_policy_checks:,}) must be at most `budget_steps` "
            f"({budget_steps:,}): one policy check per learning step at most."
        )


def parse_seeds(value: Any, *, name: str = "seeds", allow_zero: bool = False) -> int | list[int]:
    """Return the seeds as a count or a list: a count, a list, or a range string ``START..END``.

    A range becomes its list of seeds (both ends included). ``allow_zero`` accepts a count of 0
    (no seeds, e.g. a selection without fresh seeds).

    Examples
    --------
    >>> parse_seeds("100..103")
    [100, 101, 102, 103]
    >>> parse_seeds(3)
    3
    """
    low = 0 if allow_zero else 1
    if isinstance(value, str):
        match = _RANGE.match(value)
        if match is None:
            raise ValueError(
                f"{name} as text must be a range START..END (both ends included, e.g. "
                f"100..129); got {_short(value)}"
            )
        start, end = int(match[1]), int(match[2])
        if not 0 <= start <= end <= MAX_SEED:
            raise ValueError(
                f"a seed range START..END needs 0 <= START <= END < 2^63; got {_short(value)}"
            )
        if end - start + 1 > MAX_SEED_COUNT:
            raise ValueError(
                f"a seed range holds at most {MAX_SEED_COUNT:,} seeds; {_short(value)} holds "
                f"{end - start + 1:,}"
            )
        return list(range(start, end + 1))
    if isinstance(value, (int, np.integer)) and not isinstance(value, bool):
        if not low <= value <= MAX_SEED_COUNT:
            raise ValueError(
                f"a seed count must be an int in [{low}, {MAX_SEED_COUNT:,}]; got {_short(value)}"
            )
        return int(value)
    if isinstance(value, list) and value and len(value) <= MAX_SEED_COUNT:
        is_seed = [
            isinstance(v, (int, np.integer)) and not isinstance(v, bool) and 0 <= v <= MAX_SEED
            for v in value
        ]
        if all(is_seed):
            if len(set(value)) != len(value):
                raise ValueError(f"seeds must be distinct; got {_short(value)}")
            return [int(v) for v in value]
    raise ValueError(
        f"{name} must be a count (an int in [{low}, {MAX_SEED_COUNT:,}], seeds 0..N-1), a range "
        f"START..END, or a non-empty list of distinct ints in [0, 2^63); got {_short(value)}"
    )


def _short(value: Any) -> str:
    """``repr(value)``, cut to 60 characters (a 5,000-digit literal stays one readable line)."""
    try:
        text = repr(value)
    except ValueError:  # an int past Python's digit limit for str()
        return f"an int of about {int(value).bit_length() * 0.30103:.0f} digits"
    return text if len(text) <= 60 else f"{text[:40]}...({len(text):,} characters)"
