"""Numbers as conjure prints them: a fixed number of significant digits, no float noise.

Tables, summaries and messages print a number with 4 significant digits and thousands
separators (`format_number`: ``200,000``, ``0.05002``), and a confidence interval as
``mean ± half-width`` at the mean's precision (`format_interval`). A value that goes back
into a config (a grid setting, a tuned parameter) prints as YAML that ``--set`` and a grid
accept (`format_value`: ``0.05002``, ``1000000``); shown to a reader (a table, a plot's
legend, report.md) a setting's whole numbers get separators (`readable_setting`:
``n_0=200,000``).

Notes
-----
- Choice: no exponents. ``f"{200000:.4g}"`` reads ``2e+05``; `format_number` gives
  ``200,000``. Only magnitudes below 1e-4, which a fixed 8 decimals would print as zeros,
  use one (``1.000e-07``).
- Choice: an interval cut at its metric's range (`conjure.experiments.metric_ranges`) reads
  ``mean [low, high]`` with the cut ends, not ``mean ± half-width``: after the cut it is no
  longer symmetric about the mean, and the brackets show at a glance that it was cut.
- Choice: a value for a config keeps every integer digit and no separators
  (``n_0=1000000``, so it can be pasted into ``--set``) and at most 6 significant digits of a
  float that is not whole (``0.05002000000000905`` reads ``0.05002``); whole floats keep their
  point (``1.0``), as YAML read them.
- Choice: the setting text (`conjure.experiments.results.describe_setting`) stays the key of
  a method in results tables and ``selection.csv``; only its display changes: a whole number
  (``1000000``, ``200000.0``) reads as an int with separators (``1,000,000``, ``200,000``),
  other values as they are.
"""

from __future__ import annotations

import math
import re
from typing import Any

import numpy as np

__all__ = [
    "format_estimate",
    "format_interval",
    "format_number",
    "format_value",
    "readable_setting",
]

#: The most decimals a number prints with.
MAX_DECIMALS = 8
#: Significant digits of a non-whole float in a config value (`format_value`).
VALUE_DIGITS = 6
#: A whole number after a setting's ``key=`` (ending the setting or before ``, ``).
_WHOLE_VALUE = re.compile(r"(?<==)(-?\d+)(?:\.0)?(?=, |$)")


def _decimals(scale: float, digits: int) -> int:
    """Decimals that give ``digits`` significant digits to a number of magnitude ``scale``."""
    if scale == 0 or not math.isfinite(scale):
        return digits - 1
    return min(max(digits - 1 - math.floor(math.log10(scale)), 0), MAX_DECIMALS)


def format_number(value: float | None, digits: int = 4) -> str:
    """Return ``value`` with ``digits`` significant digits and thousands separators.

    ``n/a`` for a missing or non-finite value, ``0`` for zero.

    Examples
    --------
    >>> format_number(200000.0), format_number(0.05002000000000905), format_number(3170.4)
    ('200,000', '0.05002', '3,170')
    >>> format_number(2.5), format_number(0.0), format_number(float("nan")), format_number(1e-7)
    ('2.500', '0', 'n/a', '1.000e-07')
    """
    if value is None or not math.isfinite(value):
        return "n/a"
    if value == 0:
        return "0"
    if abs(value) < 1e-4:
        return f"{value:.{digits - 1}e}"
    return f"{value:,.{_decimals(abs(value), digits)}f}"


def format_estimate(point: float, low: float, high: float) -> str:
    """Return ``point [low, high]``, each by `format_number` (an estimate and its interval).

    Examples
    --------
    >>> format_estimate(0.5675, 0.5277, 0.6172)
    '0.5675 [0.5277, 0.6172]'
    """
    return f"{format_number(point)} [{format_number(low)}, {format_number(high)}]"


def format_interval(
    mean: float, half: float, bounds: tuple[float, float] = (-math.inf, math.inf)
) -> str:
    """Return ``mean ± half`` with 4 significant digits of the larger, both to the same decimals.

    A half-width that is NaN (one seed) is left out; a non-finite mean reads ``n/a``. An
    interval that reaches past ``bounds`` (the metric's range) is cut there and reads
    ``mean [low, high]``.

    Examples
    --------
    >>> format_interval(-1.0, 1.674e-16), format_interval(1234.56, 12.3)
    ('-1.000 ± 0.000', '1,235 ± 12')
    >>> format_interval(0.01234, 0.0021), format_interval(2.5, float("nan"))
    ('0.01234 ± 0.00210', '2.500')
    >>> format_interval(0.3, 1.271, bounds=(0.0, 1.0))
    '0.300 [0.000, 1.000]'
    """
    if not math.isfinite(mean):
        return "n/a"
    scale = max(abs(mean), abs(half) if math.isfinite(half) else 0.0)
    decimals = _decimals(scale, 4)
    text = f"{mean:,.{decimals}f}"
    if not math.isfinite(half):
        return text
    low, high = float(np.clip(mean - half, *bounds)), float(np.clip(mean + half, *bounds))
    if low == mean - half and high == mean + half:
        return f"{text} ± {half:,.{decimals}f}"
    return f"{text} [{low:,.{decimals}f}, {high:,.{decimals}f}]"


def format_value(value: Any) -> str:
    """Return a config value as YAML reads it back: floats to 6 significant digits, no exponent.

    Examples
    --------
    >>> format_value(0.05002000000000905), format_value(1.0), format_value(1000000)
    ('0.05002', '1.0', '1000000')
    >>> format_value(123456789.123), format_value(1e-7), format_value(None), format_value([0, 0])
    ('123456789.1', '0.0000001', 'None', '[0, 0]')
    """
    if not isinstance(value, float) or not math.isfinite(value) or value.is_integer():
        return str(value)
    integer_digits = math.floor(math.log10(abs(value))) + 1
    digits = max(VALUE_DIGITS, integer_digits + 1)  # every integer digit, one decimal at least
    return np.format_float_positional(
        value, precision=digits, unique=True, fractional=False, trim="-"
    )


def readable_setting(setting: str) -> str:
    """Return a setting's text (``key=value, ...``) for a reader: whole numbers with separators.

    Examples
    --------
    >>> readable_setting("step_size.alpha_0=0.1, step_size.n_0=200000.0")
    'step_size.alpha_0=0.1, step_size.n_0=200,000'
    >>> readable_setting("n_0=1000000"), readable_setting("alpha_0=1.0"), readable_setting("")
    ('n_0=1,000,000', 'alpha_0=1', '')
    """
    return _WHOLE_VALUE.sub(lambda match: f"{int(match[1]):,}", setting)
