"""A fixed representation as the compiled learning loop reads it (`conjure.core.compiled_form`).

`RepresentationKernel` holds an encoder's kind and tables; `encode_into` and `values_of` give
φ(s) by the representations' own kernels (`tile_indices_into`, `hashed_tile_features`,
`tabular_feature`, `find_cell`, `independent_features`, `rbf_values`, ARiFDD's
`basic_features`), as their ``active_features`` and ``encode`` do.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

from conjure.representations._arifdd_kernels import basic_features
from conjure.representations._hashed_tabular_kernels import (
    EMPTY,
    FULL,
    find_cell,
    lookup_cell,
    peek_cell,
)
from conjure.representations._kernels import (
    hashed_tile_features,
    independent_features,
    rbf_values,
    tabular_feature,
    tile_indices_into,
)

__all__ = [
    "BASIC_TILES",
    "FULL",
    "HASHED_TABULAR",
    "HASHED_TILES",
    "INDEPENDENT",
    "INDICATORS",
    "RBF",
    "TABULAR",
    "TILES",
    "RepresentationKernel",
    "clear_index",
    "encode_into",
    "index_row",
    "lookup_row",
    "peek_into",
    "representation_kernel",
    "rows_in_use",
    "values_of",
]


#: Representation kinds of `RepresentationKernel`.
TILES, HASHED_TILES, TABULAR, INDEPENDENT, INDICATORS, RBF, HASHED_TABULAR, BASIC_TILES = range(8)
_NO_INTS = np.zeros(0, dtype=np.int64)
_NO_INT_TABLE = np.zeros((0, 0), dtype=np.int64)
_NO_FLOAT_TABLE = np.zeros((0, 0))


class RepresentationKernel(NamedTuple):
    """A fixed representation φ (Eq. 2.11) as the compiled loop reads it; unused tables empty.

    Parameters
    ----------
    kind : int
        Which encoder (`TILES` ... `BASIC_TILES`).
    num_tilings : int
        Tile coding's tilings.
    max_active : int
        The most features φ(s) lists.
    dims, layout, groups : ndarray
        The tables of `tile_indices_into` / `hashed_tile_features` (``dims`` also the
        buckets of `tabular_feature`, `find_cell` and `independent_features`, or ARiFDD's
        tile edges, ``layout`` its tiles' features).
    vector : ndarray of int64
        `tabular_feature`'s strides, `independent_features`' offsets, `find_cell`'s hash
        slots, RBF's 0 .. n − 1, or ARiFDD's tiles per dimension.
    hash_table, hash_counts : ndarray of int64
        Hashed tile coding's table, or `HashedTabular`'s stored cells and their count: the
        representation's own, updated in place.
    rbf : tuple of ndarray or None
        None for binary φ, else `RBF`'s (affine, scaled centers) (Section 3.1.2): φ(s) lists
        every feature with its Gaussian value. numba compiles binary and real-valued φ apart,
        so binary φ never reads a value.
    """

    kind: int
    num_tilings: int
    max_active: int
    dims: np.ndarray
    layout: np.ndarray
    groups: np.ndarray
    vector: np.ndarray
    hash_table: np.ndarray
    hash_counts: np.ndarray
    rbf: tuple[np.ndarray, np.ndarray] | None


def representation_kernel(
    kind: int,
    max_active: int,
    *,
    num_tilings: int = 0,
    dims: np.ndarray = _NO_FLOAT_TABLE,
    layout: np.ndarray = _NO_INT_TABLE,
    groups: np.ndarray = _NO_INT_TABLE,
    vector: np.ndarray = _NO_INTS,
    hash_table: np.ndarray = _NO_INT_TABLE,
    hash_counts: np.ndarray = _NO_INTS,
    rbf: tuple[np.ndarray, np.ndarray] | None = None,
) -> RepresentationKernel:
    """A `RepresentationKernel` with the tables ``kind`` needs (C-contiguous), the rest empty."""
    return RepresentationKernel(
        kind=kind,
        num_tilings=num_tilings,
        max_active=max_active,
        dims=np.ascontiguousarray(dims),
        layout=np.ascontiguousarray(layout),
        groups=np.ascontiguousarray(groups),
        vector=np.ascontiguousarray(vector),
        hash_table=hash_table,
        hash_counts=hash_counts,
        rbf=rbf,
    )


@njit(cache=True, inline="always")
def encode_into(
    rep: RepresentationKernel, state: np.ndarray, quanta: np.ndarray, out: np.ndarray
) -> np.ndarray:
    """φ(s)'s indices by the representation's kernel (its ``active_features``).

    Unhashed tiles are written into ``out`` (``quanta`` is their scratch) and returned; the
    other encoders return a new array (RBF its constant list of every feature).
    """
    if rep.kind == TILES:
        tile_indices_into(state, rep.dims, rep.layout, rep.groups, rep.num_tilings, quanta, out)
        return out
    if rep.kind == HASHED_TILES:
        return hashed_tile_features(
            state, rep.dims, rep.layout, rep.groups, rep.num_tilings, rep.hash_table,
            rep.hash_counts,
        )  # fmt: skip
    if rep.kind == TABULAR:
        return tabular_feature(state, rep.dims, rep.vector)
    if rep.kind == HASHED_TABULAR:  # [`FULL`] when a new cell does not fit
        return find_cell(state, rep.dims, rep.vector, rep.hash_table, rep.hash_counts)
    if rep.kind == INDEPENDENT:
        return independent_features(state, rep.dims, rep.vector)
    if rep.kind == RBF:
        return rep.vector
    if rep.kind == BASIC_TILES:  # ARiFDD's φ⁰, over tables its splits update in place
        return basic_features(state, rep.dims, rep.vector, rep.layout)
    return np.flatnonzero(state)


@njit(cache=True)
def peek_into(
    rep: RepresentationKernel, state: np.ndarray, quanta: np.ndarray, out: np.ndarray
) -> np.ndarray:
    """`encode_into` storing nothing (greedy acting; `Representation.peek`).

    A hashed table's new cell or tile gets the index storing it would give (`peek_cell`,
    `hashed_tile_features` not storing); the other encoders store nothing anyway.
    """
    if rep.kind == HASHED_TABULAR:
        return peek_cell(state, rep.dims, rep.vector, rep.hash_table, rep.hash_counts)
    if rep.kind == HASHED_TILES:
        return hashed_tile_features(
            state, rep.dims, rep.layout, rep.groups, rep.num_tilings, rep.hash_table,
            rep.hash_counts, False,
        )  # fmt: skip
    return encode_into(rep, state, quanta, out)


@njit(cache=True, inline="always")
def index_row(rep: RepresentationKernel, state: np.ndarray) -> int:
    """A `HASHED_TABULAR` index's row of s, stored first if new; `FULL` if it does not fit."""
    return find_cell(state, rep.dims, rep.vector, rep.hash_table, rep.hash_counts)[0]


@njit(cache=True, inline="always")
def lookup_row(rep: RepresentationKernel, state: np.ndarray) -> int:
    """A one-row-per-state index's row of s, storing nothing (greedy acting's lookup).

    −1 when a `HASHED_TABULAR` index never saw s (`HashedTabular.index_of`).
    """
    if rep.kind == HASHED_TABULAR:
        return lookup_cell(state, rep.dims, rep.vector, rep.hash_table)
    return tabular_feature(state, rep.dims, rep.vector)[0]


@njit(cache=True, inline="always")
def rows_in_use(rep: RepresentationKernel, num_rows: int) -> int:
    """The rows of a one-row-per-state index's tables in use: the cells stored, or all."""
    return rep.hash_counts[0] if rep.kind == HASHED_TABULAR else num_rows


@njit(cache=True)
def clear_index(rep: RepresentationKernel) -> None:
    """Forget every cell of a `HASHED_TABULAR` index (its rows are numbered from 0 again)."""
    rep.vector.fill(EMPTY)
    rep.hash_counts[0] = 0


@njit(cache=True, inline="always")
def values_of(rep: RepresentationKernel, state: np.ndarray) -> np.ndarray | None:
    """φ(s)'s values: None for binary φ, else `RBF.encode`'s Gaussians."""
    return _gaussians(rep.rbf, rep.vector.shape[0], state)


@njit(cache=True)
def _gaussians(
    rbf: tuple[np.ndarray, np.ndarray] | None, num_features: int, state: np.ndarray
) -> np.ndarray | None:
    """`rbf_values` for ``rbf`` = (affine, scaled centers), None for None.

    numba prunes the None branch only on an argument, so ``rbf`` comes apart from its tuple.
    """
    if rbf is None:
        return None
    affine, centers = rbf
    return rbf_values(state, affine, centers, num_features)
