"""Tests of memory sizes and the per-run memory limit (RLIMIT_AS) in a worker process."""

from __future__ import annotations

import multiprocessing
import os

import pytest

from conjure.core.errors import InvalidParameterError
from conjure.experiments.memory import (
    check_memory_limit,
    explain_memory_error,
    format_memory_size,
    limit_memory,
    memory_limit,
    parse_memory_size,
)

GiB = 2**30


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("4GiB", 4 * GiB),
        ("4 gib", 4 * GiB),
        ("512MiB", 512 * 2**20),
        ("2G", 2 * GiB),
        ("1.5GiB", 3 * 2**29),
        ("4GB", 4_000_000_000),
        ("10kB", 10_000),
        ("1TiB", 2**40),
        ("123", 123),
        (123, 123),
        (None, None),
    ],
)
def test_sizes_parse_to_bytes(text, expected):
    assert parse_memory_size(text) == expected


@pytest.mark.parametrize("bad", ["4XB", "GiB", "-1GiB", "0", 0, -5, True, 1.5, "4 Gi B"])
def test_bad_sizes_are_named(bad):
    with pytest.raises(InvalidParameterError, match="memory size") as error:
        parse_memory_size(bad)
    assert repr(bad) in str(error.value)


def test_sizes_format_in_binary_units():
    assert format_memory_size(4 * GiB) == "4 GiB"
    assert format_memory_size(1536 * 2**10) == "1.5 MiB"
    assert format_memory_size(parse_memory_size("2GB")) == "1.863 GiB"
    assert format_memory_size(1023) == "1023 B"


def _limited(max_bytes, connection):
    limit_memory(max_bytes)
    try:
        bytearray(2 * max_bytes)
    except MemoryError as exc:
        connection.send((memory_limit(), explain_memory_error(f"MemoryError: {exc}")))


def _address_space_bytes() -> int:
    """This process's current virtual memory size (a forked child starts with all of it)."""
    with open("/proc/self/statm") as statm:
        return int(statm.read().split()[0]) * os.sysconf("SC_PAGE_SIZE")


def test_a_limited_process_cannot_allocate_past_its_limit_and_says_so():
    # The limit must exceed what the forked child already maps (a pytest-xdist worker with
    # numba loaded maps more than 1 GiB), so it is this process's size plus 1 GiB, in GiB.
    limit = (_address_space_bytes() // GiB + 2) * GiB
    context = multiprocessing.get_context("fork")  # the child only allocates: fork is safe
    receiver, sender = context.Pipe(duplex=False)  # a pipe needs no feeder thread
    process = context.Process(target=_limited, args=(limit, sender))
    process.start()
    assert receiver.poll(60), "the limited child sent nothing"
    seen_limit, message = receiver.recv()
    process.join()
    assert seen_limit == limit
    expected = f"the run exceeded its memory limit, max_memory = {format_memory_size(limit)}"
    assert message.startswith(expected)
    assert memory_limit() is None  # this process is not limited
    assert explain_memory_error("MemoryError: x") == "MemoryError: x"


def test_a_limit_above_the_hard_limit_is_refused(monkeypatch):
    import resource

    monkeypatch.setattr(resource, "getrlimit", lambda _: (GiB, GiB))
    with pytest.raises(InvalidParameterError, match="exceeds this system's hard limit"):
        check_memory_limit(2 * GiB)
