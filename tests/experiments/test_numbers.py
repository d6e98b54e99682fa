"""Tests of how numbers print: significant digits, thousands separators, cut intervals."""

from __future__ import annotations

import math

import yaml

from conjure.experiments.numbers import format_interval, format_number, format_value


def test_numbers_read_with_four_significant_digits_and_thousands_separators():
    # Issue 21: tables printed `2e+05` and `0.05002000000000905`.
    assert format_number(200000.0) == "200,000"
    assert format_number(0.05002000000000905) == "0.05002"
    assert format_number(-3170.4) == "-3,170"
    assert format_number(12.5) == "12.50"
    assert format_number(0.0) == "0"
    assert format_number(math.inf) == format_number(None) == "n/a"


def test_an_interval_past_its_range_reads_as_its_cut_ends():
    # Issue 21: `0.300 ± 1.271` for a probability.
    assert format_interval(0.3, 1.271, bounds=(0.0, 1.0)) == "0.300 [0.000, 1.000]"
    assert format_interval(2950.0, 220.0, bounds=(0.0, 3000.0)) == "2,950 [2,730, 3,000]"
    assert format_interval(0.5, 0.25, bounds=(0.0, 1.0)) == "0.5000 ± 0.2500"  # inside: ±
    assert format_interval(0.5, math.nan, bounds=(0.0, 1.0)) == "0.5000"  # one seed
    assert format_interval(123456.0, 7890.0) == "123,456 ± 7,890"


def test_config_values_read_back_as_the_same_yaml_value():
    for value, text in (
        (0.05002000000000905, "0.05002"),
        (1.0, "1.0"),
        (1000000, "1000000"),
        (200000.0, "200000.0"),
        (1e-7, "0.0000001"),
        (123456789.125, "123456789.1"),
    ):
        assert format_value(value) == text
        assert type(yaml.safe_load(text)) is type(value)
    assert "e" not in format_value(2.5e-5) and format_value(True) == "True"
