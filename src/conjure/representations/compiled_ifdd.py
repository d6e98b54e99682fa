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

from conjure.representations._ifdd_kernels import I_NUM_FEATURES, activate, discover, discover_room
from conjure.representations.compiled_representation import RepresentationKernel

__all__ = ["IFDDKernel", "discover_from", "fixed", "has_room", "num_features", "sparsify"]

_I1 = np.zeros(0, dtype=np.int64)
_I2 = np.zeros((0, 0), dtype=np.int64)
_F1 = np.zeros(0)
_F2 = np.zeros((0, 0))
#: Stand-ins of `activate`'s and `discover`'s tables (same types) for a base alone.
_NO_ACTIVATION = (_I1, _I1, _I1, _I1, _I2, _I2, _I2, _I2, _I1, _I2, _I1)
_NO_DISCOVERY = (_I1, _I1, _I1, _I1, _I2, _I1, _I1, _I1, _I1, _I2, _F2, _I1, _I1, _I1, _I1, _F1)


class IFDDKernel(NamedTuple):
    """φ⁰'s kernel and, when ``is_ifdd``, online iFDD's tables (Algorithms 19-21).

    Parameters
    ----------
    base : RepresentationKernel
        φ⁰, the initial features.
    is_ifdd : bool
        Whether iFDD sits on ``base`` (else the tables are empty stand-ins).
    activation, discovery : tuple of ndarray
        `activate`'s and `discover`'s tables after their first arguments (`OnlineIFDD`'s
        own arrays, updated in place).
    """

    base: RepresentationKernel
    is_ifdd: bool
    activation: tuple
    discovery: tuple


def fixed(base: RepresentationKernel) -> IFDDKernel:
    """A fixed representation's kernel in the loop's growing-representation slot."""
    return IFDDKernel(base, False, _NO_ACTIVATION, _NO_DISCOVERY)


@njit(cache=True, inline="always")
def sparsify(rep: IFDDKernel, initial: np.ndarray) -> np.ndarray:
    """φ̇(s) from φ⁰(s)'s indices (Algorithm 19, `OnlineIFDD.active_features`).

    The loop encodes φ⁰ with the base's `encode_into` and calls this when ``rep.is_ifdd``.
    """
    return activate(initial, *rep.activation)


@njit(cache=True, inline="always")
def has_room(rep: IFDDKernel, phi: np.ndarray) -> bool:
    """Whether a discovery from φ(s) fits in the tables (else the representation grows)."""
    d = rep.discovery
    return discover_room(phi, d[3], d[1], d[5], d[12], d[14]) >= 0


@njit(cache=True, inline="always")
def discover_from(rep: IFDDKernel, phi: np.ndarray, delta: float) -> tuple[int, int, np.ndarray]:
    """Algorithm 20/21 on φ(s) with δ: (first new feature id, number added, parents table)."""
    d = rep.discovery
    before = d[14][I_NUM_FEATURES]
    added = discover(phi, delta, *d)
    return before, added, d[4]


@njit(cache=True, inline="always")
def num_features(rep: IFDDKernel) -> int:
    """n_t, the features the tables hold now."""
    return rep.discovery[14][I_NUM_FEATURES]
