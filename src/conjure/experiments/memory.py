"""A run's memory limit (``max_memory``): sizes such as ``4GiB``, and the limit in a worker.

A local worker process caps its address space with ``RLIMIT_AS`` (`limit_memory`), so a run
that asks for more memory gets a `MemoryError` (numpy: "Unable to allocate ...") instead of
driving the machine into the kernel's out-of-memory killer, which kills some process, not
necessarily the greedy one. The run then fails alone, with a message that names the limit
(`explain_memory_error`).

Notes
-----
- Choice: the limit bounds the worker's whole address space (as ``ulimit -v``), its libraries
  included. Measured on this project's machine (Linux, Python 3.11): a worker that has
  imported the run machinery (numpy, numba/llvmlite, pandas, pyarrow) maps about 0.75 GiB
  before any run; under about 0.9 GiB, compiling numba code can abort in LLVM. Arrays count
  in full when allocated, written or not: every shipped example and reproduction config (one
  seed, 3,000 steps) runs under 1 GiB, except the tabular agents of the Fig. 4-5 rescue and
  surveillance configs, which allocate two tables of 3.25 GiB (they run under 7.5 GiB) and
  two of 1.1 GiB (under 3 GiB). Allocators reserve less under a limit (pyarrow otherwise
  reserves 1 GiB up front). There is no default limit; choose about the machine's memory
  divided by the workers, and at least 1 GiB.
- Choice: sizes with a binary unit (``KiB``, ``MiB``, ``GiB``, ``TiB``) or a bare letter
  (``K``, ``M``, ``G``, ``T``, as Docker and SLURM read them) are powers of 1024; ``kB``,
  ``MB``, ``GB``, ``TB`` are powers of 1000; a plain number is bytes.
"""

from __future__ import annotations

import re
from typing import Any

from conjure.core.errors import InvalidParameterError

__all__ = [
    "check_memory_limit",
    "explain_memory_error",
    "format_memory_size",
    "limit_memory",
    "memory_limit",
    "parse_memory_limit",
    "parse_memory_size",
]

#: The smallest run memory limit accepted: a worker maps about 0.75 GiB before any run and
#: numba's compiler can abort under about 0.9 GiB (see the notes above).
MIN_MEMORY_LIMIT = 2**30
#: The largest: 1 EiB, far above any machine and within what ``RLIMIT_AS`` holds.
MAX_MEMORY_LIMIT = 2**60

_UNITS = {
    "": 1,
    "b": 1,
    "k": 2**10,
    "kib": 2**10,
    "kb": 10**3,
    "m": 2**20,
    "mib": 2**20,
    "mb": 10**6,
    "g": 2**30,
    "gib": 2**30,
    "gb": 10**9,
    "t": 2**40,
    "tib": 2**40,
    "tb": 10**12,
}
_SIZE = re.compile(r"^\s*(\d+(?:\.\d*)?|\.\d+)\s*([a-zA-Z]*)\s*$")


def parse_memory_size(value: Any) -> int | None:
    """Return a memory size in bytes: ``4GiB``, ``512 MiB``, ``2G``, ``4GB`` or a byte count.

    ``None`` stays ``None`` (no limit).

    Raises
    ------
    InvalidParameterError
        For anything else, naming the value.

    Examples
    --------
    >>> parse_memory_size("4GiB"), parse_memory_size("1.5 G"), parse_memory_size(1024)
    (4294967296, 1610612736, 1024)
    >>> parse_memory_size("2GB")
    2000000000
    """
    if value is None:
        return None
    match = _SIZE.match(value) if isinstance(value, str) else None
    if match is not None and match.group(2).lower() in _UNITS:
        size = int(float(match.group(1)) * _UNITS[match.group(2).lower()])
    elif isinstance(value, int) and not isinstance(value, bool):
        size = value
    else:
        size = 0
    if size < 1:
        raise InvalidParameterError(
            f"a memory size must be positive, a number of bytes or a number with a unit "
            f"(KiB, MiB, GiB, TiB; kB, MB, GB, TB), e.g. 4GiB; got {value!r}"
        )
    return size


def parse_memory_limit(value: Any) -> int | None:
    """Return a run's memory limit in bytes (`parse_memory_size`), refused outside [1 GiB, 1 EiB].

    Examples
    --------
    >>> parse_memory_limit("2GiB")
    2147483648
    >>> parse_memory_limit("64MiB")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    conjure.core.errors.InvalidParameterError: a run's memory limit must be at least 1 GiB ...
    """
    size = parse_memory_size(value)
    if size is not None and size < MIN_MEMORY_LIMIT:
        raise InvalidParameterError(
            f"a run's memory limit must be at least 1 GiB (a worker maps about 0.75 GiB before "
            f"any run); got {value!r} = {format_memory_size(size)}"
        )
    if size is not None and size > MAX_MEMORY_LIMIT:
        raise InvalidParameterError(
            f"a run's memory limit must be at most 1 EiB (2^60 bytes); got {str(value)[:40]!r}"
        )
    return size


def format_memory_size(num_bytes: int) -> str:
    """Return ``num_bytes`` in the largest binary unit that keeps it >= 1, e.g. ``1.5 GiB``.

    Examples
    --------
    >>> format_memory_size(3 * 2**29), format_memory_size(300 * 2**20), format_memory_size(512)
    ('1.5 GiB', '300 MiB', '512 B')
    """
    for unit, size in (("TiB", 2**40), ("GiB", 2**30), ("MiB", 2**20), ("KiB", 2**10)):
        if num_bytes >= size:
            return f"{num_bytes / size:.4g} {unit}"
    return f"{num_bytes} B"


def check_memory_limit(max_bytes: int) -> None:
    """Check that `limit_memory` can set ``max_bytes`` here (before starting workers).

    Raises
    ------
    InvalidParameterError
        On a system without ``RLIMIT_AS`` (Windows), or above the hard limit.
    """
    try:
        import resource
    except ImportError:
        raise InvalidParameterError(
            "max_memory needs RLIMIT_AS (Linux, macOS, BSD); this system has none."
        ) from None
    _, hard = resource.getrlimit(resource.RLIMIT_AS)
    if hard != resource.RLIM_INFINITY and max_bytes > hard:
        raise InvalidParameterError(
            f"max_memory = {format_memory_size(max_bytes)} exceeds this system's hard limit "
            f"on address space, {format_memory_size(hard)}."
        )


def limit_memory(max_bytes: int) -> None:
    """Cap this process's address space at ``max_bytes`` (``RLIMIT_AS``; for worker processes).

    Raises
    ------
    InvalidParameterError
        As `check_memory_limit`.
    """
    import resource

    check_memory_limit(max_bytes)
    _, hard = resource.getrlimit(resource.RLIMIT_AS)
    resource.setrlimit(resource.RLIMIT_AS, (max_bytes, hard))


def memory_limit() -> int | None:
    """Return this process's address-space limit in bytes (``RLIMIT_AS``), or ``None``."""
    try:
        import resource
    except ImportError:
        return None
    soft, _ = resource.getrlimit(resource.RLIMIT_AS)
    return None if soft == resource.RLIM_INFINITY else soft


def explain_memory_error(message: str) -> str:
    """Prefix a `MemoryError`'s message with the memory limit in force here, if any.

    Examples
    --------
    >>> explain_memory_error("MemoryError: Unable to allocate 2.00 GiB")  # no limit here
    'MemoryError: Unable to allocate 2.00 GiB'
    """
    limit = memory_limit()
    if limit is None:
        return message
    return (
        f"the run exceeded its memory limit, max_memory = {format_memory_size(limit)} "
        f"(the worker's address space, RLIMIT_AS): {message}"
    )
