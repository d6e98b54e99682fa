"""Online iFDD as the compiled learning loop reads it (`conjure.core.compiled_form`).

`IFDDKernel` is a representation the loop can grow: the base's `RepresentationKernel` (φ⁰)
with `OnlineIFDD`'s own tables, or the base alone (``is_ifdd`` False, empty tables of the same
types, so that one compilation of the loop serves both). ARiFDD adds its basic tiles
(``splits``; the base then encodes those tiles, `BASIC_TILES`). The kernels here are the
representation's ``active_features`` after φ⁰ (Algorithm 19) and ``discover`` (Algorithms
20/21, or the fixed rate of Eq. 4.6, and ARiFDD's Algorithm 22) over those tables; they call
`activate` and `discover` of `conjure.representations._ifdd_kernels` and `split_at` of
`conjure.representations._arifdd_kernels`, as `OnlineIFDD`'s and `ARiFDD`'s Python methods do.
The loop grows whatever representation this is through these kernels: it never asks which.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

from conjure.representations._arifdd_kernels import BasicTiles, fits_splits, split_at
from conjure.representations._ifdd_kernels import (
    IFDDTables,
    activate,
    discover_fitting,
    discover_room,
    empty_tables,
    fits_discoveries,
)
from conjure.representations.compiled_representation import RepresentationKernel

__all__ = [
    "NO_TILES",
    "IFDDKernel",
    "discover_from",
    "fixed",
    "has_room_for",
    "room_for",
    "sparsify",
]

#: The stand-in basic tiles of a representation whose φ⁰ does not split.
NO_TILES = BasicTiles(
    edges=np.zeros((0, 0)),
    num_tiles=np.zeros(0, dtype=np.int64),
    tile_feature=np.zeros((0, 0), dtype=np.int64),
    stats=np.zeros((0, 0, 3)),
    low=np.zeros(0),
    high=np.zeros(0),
    min_width=np.zeros(0),
    is_discrete=np.zeros(0, dtype=np.bool_),
    counters=np.zeros(2, dtype=np.int64),
    split_threshold=0.0,
)


class IFDDKernel(NamedTuple):
    """φ⁰'s kernel and, when ``is_ifdd``, online iFDD's tables (Algorithms 19-21).

    Parameters
    ----------
    base : RepresentationKernel
        φ⁰, the initial features.
    is_ifdd : bool
        Whether iFDD sits on ``base`` (else ``tables`` is the empty stand-in).
    tables : IFDDTables
        `OnlineIFDD.kernel_tables`: its own tables, updated in place (one reference, a
        numba structref).
    splits : bool
        Whether φ⁰ is ARiFDD's basic tiles, which split (Algorithm 22).
    tiles : BasicTiles
        Those tiles, updated in place (`NO_TILES` when ``splits`` is False).
    """

    base: RepresentationKernel
    is_ifdd: bool
    tables: IFDDTables
    splits: bool
    tiles: BasicTiles


def fixed(base: RepresentationKernel) -> IFDDKernel:
    """A fixed representation's kernel in the loop's growing-representation slot."""
    return IFDDKernel(base=base, is_ifdd=False, tables=empty_tables(), splits=False, tiles=NO_TILES)


@njit(cache=True)
def sparsify(rep: IFDDKernel, initial: np.ndarray) -> np.ndarray:
    """φ̇(s) from φ⁰(s)'s indices (Algorithm 19, `OnlineIFDD.active_features`).

    The loop encodes φ⁰ with the base's `encode_into` and calls this when ``rep.is_ifdd``.
    """
    return activate(initial, rep.tables)


@njit(cache=True, inline="always")
def room_for(rep: IFDDKernel, phi: np.ndarray) -> int:
    """`discover_room` of φ(s): what a discovery from it needs, or −1 when it does not fit.

    With basic tiles that split, also −1 unless a split (one feature in φ(s)) or the
    conjunctions of φ(s)'s pairs fit (`fits_splits`; splits add features without nodes).
    """
    room = discover_room(phi, rep.tables)
    if rep.splits:
        k = phi.shape[0]
        if not fits_splits(rep.tiles, 1, 2 if k == 1 else k * (k - 1) // 2, rep.tables):
            return -1
    return room


@njit(cache=True, inline="always")
def has_room_for(rep: IFDDKernel, count: int) -> bool:
    """Whether ``count`` discoveries from any φ̇(s) fit (`fits_discoveries`; sparsified φ̇)."""
    k = max(rep.base.max_active, 1)
    fits = fits_discoveries(k, count, rep.tables)
    if rep.splits:
        return fits and fits_splits(rep.tiles, count, count * max(2, k * (k - 1) // 2), rep.tables)
    return fits


@njit(cache=True, inline="always")
def discover_from(
    rep: IFDDKernel, phi: np.ndarray, delta: float, room: int, state: np.ndarray
) -> tuple[int, int, np.ndarray]:
    """Discovery on φ(s) at s with δ: (first new feature id, number added, parents table).

    Algorithm 20/21, or with basic tiles that split Algorithm 22 (`split_at` when φ(s) is
    one feature, else Algorithm 20/21, line 20). ``room``: `room_for`'s answer for this
    φ(s), so that the room is counted once.
    """
    tables = rep.tables
    before = tables.num_features[0]
    if rep.splits and phi.shape[0] == 1:
        added = split_at(rep.tiles, state, delta, tables)
    else:
        added = discover_fitting(phi, delta, room, tables)
    return before, added, tables.feat_parents
