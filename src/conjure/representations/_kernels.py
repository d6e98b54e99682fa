"""Numba kernels of the representations (φ(s), Eq. 2.11) and the tables they read.

Every kernel takes a few packed arrays that ``setup`` precomputes, so one call from Python
costs about a microsecond (see ``/work/shared/specs/performance-and-infra.md``). Validation
happens in ``setup`` and ``check_state``, never here.

Packed per-dimension table (``dimension_table``), one row per state dimension:
``[low, scale, shift, top]``; the bucket of value x is ``floor((x - low) * scale + shift)``
clipped into ``[0, top]`` (NaN goes to bucket 0).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numba import njit

from conjure.core.errors import InvalidParameterError
from conjure.core.interfaces import DomainSpec, check_is_set_up
from conjure.core.params import Constraint, Interval, Predicate

__all__ = [
    "EMPTY_SLOT",
    "MAX_FEATURES",
    "BucketTable",
    "dimension_table",
    "hashed_tile_features",
    "independent_features",
    "per_dimension",
    "positive_ints",
    "rbf_values",
    "tabular_feature",
    "tile_features",
    "tile_indices_into",
]

EMPTY_SLOT = -1
MAX_FEATURES = 2**62  # indices must fit in int64 with room for arithmetic

_POSITIVE_INT = Interval(int, 1, None)


# ---------------------------------------------------------------------------------------------
# Setup helpers (pure Python)


def positive_ints() -> Constraint:
    """Return the constraint 'an int in [1, inf) or a non-empty list of such ints'."""
    return _POSITIVE_INT | Predicate(
        lambda v: (
            isinstance(v, (list, tuple))
            and len(v) > 0
            and all(_POSITIVE_INT.is_satisfied_by(x) for x in v)
        ),
        "a non-empty list of ints in [1, inf)",
    )


class BucketTable:
    """Mixin of the representations whose setup builds a bucket table ``_dims``.

    `Tabular`, `IndependentDiscretization`, `HashedTabular` and `TileCoding` open
    ``active_features`` with `_dims_and_state`.
    """

    _dims: np.ndarray

    def _dims_and_state(self, state: Any) -> tuple[np.ndarray, np.ndarray]:
        """(the bucket table, the checked ``state``); `NotSetUpError` before setup."""
        try:
            dims = self._dims
        except AttributeError:
            check_is_set_up(self, "active_features")
            raise
        return dims, self.check_state(state)  # type: ignore[attr-defined]


def per_dimension(owner: Any, name: str, spec: DomainSpec) -> np.ndarray:
    """Return parameter ``name`` of ``owner`` (an int or a per-dimension list) as d ints.

    Raises `InvalidParameterError` naming the parameter, its value and the expected length
    when a list does not have one entry per state dimension of ``spec``.
    """
    value = getattr(owner, name)
    if isinstance(value, (list, tuple)):
        if len(value) != spec.num_dims:
            raise InvalidParameterError(
                f"`{type(owner).__name__}.{name}` must have one entry per state dimension "
                f"({spec.num_dims} for {spec.name!r}); got {value!r} (length {len(value)}). "
                f"Pass a single int to use it for every dimension."
            )
        return np.array([int(v) for v in value], dtype=np.int64)
    return np.full(spec.num_dims, int(value), dtype=np.int64)


def dimension_table(
    spec: DomainSpec, num_buckets: np.ndarray, quantum: int = 1, extend: bool = False
) -> tuple[np.ndarray, np.ndarray]:
    """Return the packed ``[low, scale, shift, top]`` table and the buckets per dimension.

    A discrete dimension gets one bucket per integer value ``low .. high`` (its
    ``num_buckets`` entry is ignored); a continuous one ``num_buckets[d]`` equal buckets over
    ``[low, high]``, and a continuous one with ``low == high`` a single bucket. With
    ``quantum = q`` every bucket is cut into q sub-buckets (the tile-coding resolution
    ``num_tilings``); with ``extend`` the top bucket of a continuous dimension may be one past
    the grid (the extra tile that offset tilings need).
    """
    d = spec.num_dims
    table = np.zeros((d, 4), dtype=np.float64)
    sizes = np.zeros(d, dtype=np.int64)
    for i in range(d):
        low, high = float(spec.low[i]), float(spec.high[i])
        if spec.is_discrete[i]:
            n = round(high - low) + 1
            table[i] = (low, quantum, 0.5 * quantum, n * quantum - 1)
            sizes[i] = n
        elif high > low:
            n = int(num_buckets[i])
            top = n * quantum if extend else n * quantum - 1
            table[i] = (low, n * quantum / (high - low), 0.0, top)
            sizes[i] = n + 1 if extend else n
        else:
            table[i] = (low, 0.0, 0.0, 0.0)
            sizes[i] = 1
    return table, sizes


# ---------------------------------------------------------------------------------------------
# Shared inner kernels


@njit(cache=True, inline="always")
def _bucket(x: float, low: float, scale: float, shift: float, top: float) -> int:
    v = (x - low) * scale + shift
    if v >= top:  # also +inf
        return int(top)
    if v >= 1.0:
        return int(v)  # floor, as v > 0
    return 0  # below the grid, -inf and NaN


@njit(cache=True)
def _sort_unique(values: np.ndarray) -> np.ndarray:
    """Insertion-sort a short array in place and return its unique prefix."""
    n = values.shape[0]
    for i in range(1, n):
        v = values[i]
        j = i - 1
        while j >= 0 and values[j] > v:
            values[j + 1] = values[j]
            j -= 1
        values[j + 1] = v
    m = 0
    for i in range(n):
        if i == 0 or values[i] != values[m - 1]:
            values[m] = values[i]
            m += 1
    if m == n:
        return values
    return values[:m].copy()


# ---------------------------------------------------------------------------------------------
# Tabular and independent discretization (Section 4.1.4's tabular and initial features)


@njit(cache=True)
def tabular_feature(state: np.ndarray, dims: np.ndarray, strides: np.ndarray) -> np.ndarray:
    """Return the one active cell of the product grid: Σ_d bucket_d · stride_d."""
    index = 0
    for i in range(state.shape[0]):
        index += _bucket(state[i], dims[i, 0], dims[i, 1], dims[i, 2], dims[i, 3]) * strides[i]
    out = np.empty(1, dtype=np.int64)
    out[0] = index
    return out


@njit(cache=True)
def independent_features(state: np.ndarray, dims: np.ndarray, offsets: np.ndarray) -> np.ndarray:
    """Return one feature per dimension, offset_d + bucket_d (sorted as offsets increase)."""
    d = state.shape[0]
    out = np.empty(d, dtype=np.int64)
    for i in range(d):
        out[i] = offsets[i] + _bucket(state[i], dims[i, 0], dims[i, 1], dims[i, 2], dims[i, 3])
    return out


# ---------------------------------------------------------------------------------------------
# Tile coding (Section 3.1.4, Fig. 3-3 and 3-5)
#
# layout (E, 3) int64, one row per (group, dimension) entry: [dim, stride, odd]; odd = 2j + 1
#   for the j-th dimension of its group (continuous), 0 for a discrete one (no displacement).
# groups (G, 4) int64: [first entry, end entry, base index, tiles per tiling].
# A tiling t of a group shifts dimension j by ((t · odd) mod T) / T tile widths (tiles3).


@njit(cache=True, inline="always")
def tile_indices_into(
    state: np.ndarray,
    dims: np.ndarray,
    layout: np.ndarray,
    groups: np.ndarray,
    num_tilings: int,
    quanta: np.ndarray,
    out: np.ndarray,
) -> None:
    """Write one tile per tiling per group into ``out``, using ``quanta`` (d ints) as scratch.

    Tiling t adds ((q + (t · odd) mod T) // T) · stride per dimension, q its position in 1/T
    tiles; with q = b T + r this is (b + [r + shift ≥ T]) · stride, and the shift is stepped
    by odd mod T from one tiling to the next, so a call divides once per dimension, not per
    tile (the same integers, about 5 times faster).
    """
    for i in range(state.shape[0]):  # position in units of 1/T tile
        quanta[i] = _bucket(state[i], dims[i, 0], dims[i, 1], dims[i, 2], dims[i, 3])
    k = 0
    for g in range(groups.shape[0]):
        first, end, base, per_tiling = groups[g, 0], groups[g, 1], groups[g, 2], groups[g, 3]
        for t in range(num_tilings):
            out[k + t] = base + t * per_tiling
        for m in range(first, end):
            position, stride = quanta[layout[m, 0]], layout[m, 1]
            tile, rest = position // num_tilings, position % num_tilings
            step = layout[m, 2] % num_tilings
            shift = 0
            for t in range(num_tilings):
                if rest + shift >= num_tilings:
                    out[k + t] += (tile + 1) * stride
                else:
                    out[k + t] += tile * stride
                shift += step
                if shift >= num_tilings:
                    shift -= num_tilings
        k += num_tilings


@njit(cache=True, inline="always")
def _tile_indices(
    state: np.ndarray, dims: np.ndarray, layout: np.ndarray, groups: np.ndarray, num_tilings: int
) -> np.ndarray:
    quanta = np.empty(state.shape[0], dtype=np.int64)
    out = np.empty(groups.shape[0] * num_tilings, dtype=np.int64)
    tile_indices_into(state, dims, layout, groups, num_tilings, quanta, out)
    return out


@njit(cache=True)
def tile_features(
    state: np.ndarray, dims: np.ndarray, layout: np.ndarray, groups: np.ndarray, num_tilings: int
) -> np.ndarray:
    """Return one tile per tiling per group; already sorted (bases increase)."""
    return _tile_indices(state, dims, layout, groups, num_tilings)


@njit(cache=True, inline="always")
def _mix(key: int) -> np.uint64:
    """Splitmix64 finaliser: a well-spread 64-bit hash of an int64 key."""
    x = np.uint64(key)
    x ^= x >> np.uint64(30)
    x *= np.uint64(0xBF58476D1CE4E5B9)
    x ^= x >> np.uint64(27)
    x *= np.uint64(0x94D049BB133111EB)
    x ^= x >> np.uint64(31)
    return x


@njit(cache=True, inline="always")
def _hash_index(key: int, table: np.ndarray, counts: np.ndarray) -> int:
    """tiles3's IHT.getindex: index of first appearance, or hash % size once full.

    ``table`` (capacity, 2) holds [key, index] per slot (capacity a power of two, at least
    twice the most entries it will hold); ``counts`` = [entries, collisions, memory_size].
    """
    mask = table.shape[0] - 1
    h = _mix(key)
    slot = np.int64(h & np.uint64(mask))
    while True:
        stored = table[slot, 0]
        if stored == key:
            return table[slot, 1]
        if stored == EMPTY_SLOT:
            if counts[0] < counts[2]:
                index = counts[0]
                table[slot, 0] = key
                table[slot, 1] = index
                counts[0] = index + 1
                return index
            counts[1] += 1  # tiles3's overfullCount
            return np.int64(h % np.uint64(counts[2]))
        slot = (slot + 1) & mask


@njit(cache=True)
def _peek_index(key: int, table: np.ndarray, counts: np.ndarray, num_new: int) -> tuple[int, bool]:
    """`_hash_index`'s answer for ``key`` after ``num_new`` new keys, storing nothing.

    (index, whether it would be stored): a stored key's index; else the index storing would
    give, ``counts[0] + num_new`` while below the memory size, then ``hash % memory_size``.
    """
    mask = table.shape[0] - 1
    h = _mix(key)
    slot = np.int64(h & np.uint64(mask))
    while table[slot, 0] != key and table[slot, 0] != EMPTY_SLOT:
        slot = (slot + 1) & mask
    if table[slot, 0] == key:
        return table[slot, 1], False
    if counts[0] + num_new < counts[2]:
        return counts[0] + num_new, True
    return np.int64(h % np.uint64(counts[2])), False


@njit(cache=True)
def hashed_tile_features(
    state: np.ndarray,
    dims: np.ndarray,
    layout: np.ndarray,
    groups: np.ndarray,
    num_tilings: int,
    table: np.ndarray,
    counts: np.ndarray,
    is_storing: bool = True,
) -> np.ndarray:
    """Return the hashed tiles: each tile's unhashed index is the key (group, tiling, coords).

    With ``is_storing`` false (greedy acting) nothing is stored: each new key gets the index
    storing it would give (`_peek_index`; the keys of one state are distinct), so the result
    is the same and the table unchanged.
    """
    out = _tile_indices(state, dims, layout, groups, num_tilings)
    num_new = 0
    for k in range(out.shape[0]):
        if is_storing:
            out[k] = _hash_index(out[k], table, counts)
        else:
            index, is_new = _peek_index(out[k], table, counts, num_new)
            out[k] = index
            num_new += is_new
    return _sort_unique(out)


# ---------------------------------------------------------------------------------------------
# Gaussian radial basis functions


@njit(cache=True)
def rbf_values(
    state: np.ndarray, affine: np.ndarray, centers: np.ndarray, num_features: int
) -> np.ndarray:
    """Return φ_i(s) = exp(−Σ_d ((s_d − c_id) / σ_d)² / 2), then 1.0 for a bias if room.

    ``affine`` (2, d) maps s to u = s · affine[0] + affine[1] in σ units; ``centers`` (K, d)
    are in the same units; ``num_features`` is K or K + 1 (bias last).
    """
    d = state.shape[0]
    num_centers = centers.shape[0]
    u = np.empty(d, dtype=np.float64)
    for i in range(d):
        u[i] = state[i] * affine[0, i] + affine[1, i]
    out = np.empty(num_features, dtype=np.float64)
    for k in range(num_centers):
        total = 0.0
        for i in range(d):
            diff = u[i] - centers[k, i]
            total += diff * diff
        out[k] = np.exp(-0.5 * total)
    if num_features > num_centers:
        out[num_centers] = 1.0
    return out
