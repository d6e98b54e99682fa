"""Online iFDD as the compiled learning loop reads it (`conjure.core.compiled_form`).

`IFDDKernel` is a representation the loop can grow: the base's `RepresentationKernel` (φ⁰)
with `OnlineIFDD`'s own tables, or the base alone (``is_ifdd`` False, empty tables of the same
types, so that one compilation of the loop serves both). The kernels here are the
representation's ``active_features`` after φ⁰ (Algorithm 19) and ``discover`` (Algorithms
20/21, or the fixed rate of Eq. 4.6) over those tables; they call `activate` and `discover` of
`conjure.representations._ifdd_kernels`, as `OnlineIFDD`'s Python methods do.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

from conjure.representations._ifdd_kernels import (
    IFDDTables,
    activate,
    discover_fitting,
    discover_room,
    empty_tables,
    fits_discoveries,
)
from conjure.representations.compiled_representation import RepresentationKernel

__all__ = ["IFDDKernel", "discover_from", "fixed", "has_room_for", "room_for", "sparsify"]


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
    """

    base: RepresentationKernel
    is_ifdd: bool
    tables: IFDDTables


def fixed(base: RepresentationKernel) -> IFDDKernel:
    """A fixed representation's kernel in the loop's growing-representation slot."""
    return IFDDKernel(base=base, is_ifdd=False, tables=empty_tables())


@njit(cache=True)
def sparsify(rep: IFDDKernel, initial: np.ndarray) -> np.ndarray:
    """φ̇(s) from φ⁰(s)'s indices (Algorithm 19, `OnlineIFDD.active_features`).

    The loop encodes φ⁰ with the base's `encode_into` and calls this when ``rep.is_ifdd``.
    """
    return activate(initial, rep.tables)


@njit(cache=True, inline="always")
def room_for(rep: IFDDKernel, phi: np.ndarray) -> int:
    """`discover_room` of φ(s): what a discovery from it needs, or −1 when it does not fit."""
    return discover_room(phi, rep.tables)


@njit(cache=True, inline="always")
def has_room_for(rep: IFDDKernel, count: int) -> bool:
    """Whether ``count`` discoveries from any φ̇(s) fit (`fits_discoveries`; sparsified φ̇)."""
    return fits_discoveries(max(rep.base.max_active, 1), count, rep.tables)


@njit(cache=True, inline="always")
def discover_from(
    rep: IFDDKernel, phi: np.ndarray, delta: float, room: int
) -> tuple[int, int, np.ndarray]:
    """Algorithm 20/21 on φ(s) with δ: (first new feature id, number added, parents table).

    ``room``: `room_for`'s answer for this φ(s), so that the room is counted once.
    """
    tables = rep.tables
    before = tables.num_features[0]
    added = discover_fitting(phi, delta, room, tables)
    return before, added, tables.feat_parents
