"""The lazily indexed tabular representation: one feature per visited grid cell."""

from __future__ import annotations

import math

import numpy as np

from conjure.core.errors import InvalidParameterError
from conjure.core.interfaces import DomainSpec, Representation, SparseFeatures, check_is_set_up
from conjure.core.params import Interval
from conjure.core.seeding import as_seed_sequence
from conjure.representations import _hashed_tabular_kernels as _hk
from conjure.representations._kernels import (
    BucketTable,
    dimension_table,
    per_dimension,
    positive_ints,
)
from conjure.representations.compiled_representation import (
    HASHED_TABULAR,
    RepresentationKernel,
    representation_kernel,
)

__all__ = ["HashedTabular"]

#: The largest index (hash slots plus stored cells) `setup` allocates.
MAX_INDEX_BYTES = 8 * 2**30


class HashedTabular(BucketTable, Representation):
    """Tabular φ(s) over the states actually seen: a cell gets its feature when first visited.

    Geramifard (2012), Section 4.1.4: the tabular baseline of Fig. 4-5 "potentially demands"
    one feature per state-action pair (368,316 on BlocksWorld, whose 36 binary dimensions span
    2^36 grid cells that `Tabular` would allocate), i.e. it indexes only the reachable states.
    As in `Tabular` (Section 3.1.3, Eq. 2.1; φ(s, a) by Eq. 2.11) exactly one feature is active,
    the cell of s, but cells are numbered 0, 1, 2, ... in the order they are first seen, through
    an open-addressing hash table on the cell's integer vector. Learners size θ by
    ``num_features_`` as for any representation, so they need no change.

    Parameters
    ----------
    capacity : int, default 100_000
        The number of distinct cells (states of a discrete domain) it can index, in [1, inf);
        θ has this many rows, so it reserves capacity × |A| × 8 bytes (28.8 MB for
        BlocksWorld's 36 actions at the default), of which a zero-initialised θ occupies
        memory only for the rows a run reaches (rows are numbered by first visit); the index
        takes capacity × d × 8 bytes for the cells (likewise) plus 8 bytes for each of its 2-4
        hash slots per capacity. A new cell beyond the capacity
        raises `InvalidParameterError` naming it and suggesting a larger one.
    num_buckets : int or list of int, default 20
        As in `Tabular`: equal buckets per continuous dimension over ``[low, high]``, in
        [1, inf); a list gives one entry per dimension. Discrete dimensions get one bucket per
        integer value and ignore their entry.

    Attributes
    ----------
    spec_ : DomainSpec
        The spec given to `setup`.
    num_features_ : int
        The capacity in effect, θ's rows: ``capacity``, or the number of grid cells if that is
        smaller. The features in use, which a run's ``num_features`` column reports, are
        `num_features_in_use_` (= ``num_stored_``).
    num_buckets_ : ndarray of int64, shape (d,)
        Buckets per dimension (as `Tabular`'s).
    num_stored_ : int
        Cells indexed so far; their indices are ``0 .. num_stored_ - 1``.
    cells_ : ndarray of int64, shape (num_stored_, d)
        Row i is the cell of index i (its bucket per dimension; ``value − low`` for a
        discrete dimension).
    is_set_up_ : bool
        Whether `setup` has run.

    Notes
    -----
    - Symbols: φ(s) ``active_features``; |S| the cells seen, ``num_stored_``.
    - Choice: cells are those of `Tabular` with the same ``num_buckets`` (same clipping of
      values outside ``[low, high]``), so the two give the same partition of the state space;
      only the numbering differs.
    - Choice: indices follow the order in which `active_features` first sees a cell, so they
      depend on the states learned from, not on the seed; every probe compares the whole
      stored cell, so cells whose hashes collide are never merged.
      `state_arrays` saves the cells in index order and `load_state_arrays` rebuilds the hash
      slots from them.
    - Choice: greedy acting reads φ(s) by `peek`, which stores nothing: a new cell gets the
      index it would be given, ``num_stored_``, whose θ row no update has touched, so the
      action is the one storing it would give and a policy check leaves the index as it was.
    - Choice: a full table raises rather than sharing indices (tiles3's fallback), which would
      silently merge states; `index_of` looks a state up without storing it.
    - The seed is accepted for interface uniformity; nothing is random.

    Complexity
    ----------
    Θ(d) per call to `active_features` (bucket and hash the cell; expected O(1) probes of Θ(d)
    comparisons at load factor ≤ 1/2); k = 1 active feature.

    Examples
    --------
    >>> from conjure.testing import box_spec
    >>> spec = box_spec([0.0, 0.0], [1.0, 1.0], is_discrete=[True, True])
    >>> rep = HashedTabular(capacity=10).setup(spec, seed=0)
    >>> [rep.active_features(s).tolist() for s in ([1, 1], [0, 1], [1, 1])]
    [[0], [1], [0]]
    >>> rep.num_features_, rep.num_features_in_use_, rep.index_of([0, 0])  # capacity, in use
    (4, 2, -1)
    """

    parameter_constraints = {"capacity": Interval(int, 1, None), "num_buckets": positive_ints()}

    def __init__(self, *, capacity: int = 100_000, num_buckets: int | list[int] = 20):
        self.capacity = capacity
        self.num_buckets = num_buckets

    def setup(self, spec: DomainSpec, seed: int | np.random.SeedSequence) -> HashedTabular:
        """Validate the parameters against ``spec``, allocate the empty index, return ``self``."""
        self.validate_params()
        as_seed_sequence(seed)  # no randomness; the seed is checked for uniformity
        dims, sizes = dimension_table(spec, per_dimension(self, "num_buckets", spec))
        capacity = min(int(self.capacity), math.prod(sizes.tolist()))
        num_slots = 1 << (2 * capacity - 1).bit_length()
        num_bytes = 8 * (num_slots + capacity * spec.num_dims)
        if num_bytes > MAX_INDEX_BYTES:
            raise InvalidParameterError(
                f"`HashedTabular.capacity` = {self.capacity!r} would take "
                f"{num_bytes / 2**30:,.1f} GiB of index for {spec.name!r} "
                f"({spec.num_dims} dimensions; limit {MAX_INDEX_BYTES // 2**30} GiB); use a "
                f"smaller capacity."
            )
        self._dims = dims
        self._slots = np.full(num_slots, _hk.EMPTY, dtype=np.int64)
        self._cells = np.zeros((capacity, spec.num_dims), dtype=np.int64)
        self._counts = np.zeros(1, dtype=np.int64)
        self.spec_ = spec
        self.num_buckets_ = sizes
        self.num_features_ = capacity
        self.is_set_up_ = True
        return self

    compiled_methods = ("active_features", "encode")
    #: The capacity reaches the loop only as the cell array's length, which is the number of
    #: grid cells when that is smaller (then no capacity changes the form).
    compiled_irrelevant_params = frozenset({"capacity"})

    def compiled_form(self) -> RepresentationKernel:
        """The bucket table and the index itself for the compiled loop (`find_cell`).

        The loop stores new cells in this representation's own arrays; a full table stops it,
        and `active_features` raises the error.
        """
        check_is_set_up(self, "compiled_form")
        return representation_kernel(
            HASHED_TABULAR, 1, dims=self._dims, vector=self._slots, hash_table=self._cells,
            hash_counts=self._counts,
        )  # fmt: skip

    def active_features(self, state: np.ndarray) -> np.ndarray:
        """Return φ(s) = [index of s's cell], indexing the cell first if it is new."""
        dims, state = self._dims_and_state(state)
        phi = _hk.find_cell(state, dims, self._slots, self._cells, self._counts)
        if phi[0] == _hk.FULL:
            self._raise_full(state)
        return phi

    def peek(self, state: np.ndarray) -> SparseFeatures:
        """φ(s) without storing s's cell (greedy acting): the index it has or would get."""
        dims, state = self._dims_and_state(state)
        return self._binary(_hk.peek_cell(state, dims, self._slots, self._cells, self._counts))

    def index_of(self, state: np.ndarray) -> int:
        """Return the index of s's cell, or −1 if it was never seen (stores nothing)."""
        check_is_set_up(self, "index_of")
        state = self.check_state(state)
        return int(_hk.lookup_cell(state, self._dims, self._slots, self._cells))

    def _raise_full(self, state: np.ndarray) -> None:
        capacity = self.num_features_
        suggested = 2 * capacity
        raise InvalidParameterError(
            f"HashedTabular is full: all capacity = {capacity:,} indices hold distinct states "
            f"of {self.spec_.name!r}, and state {state.tolist()} is new. Set "
            f"`HashedTabular.capacity` to at least {suggested:,} (θ then takes "
            f"{suggested * self.spec_.num_actions * 8 / 2**20:,.1f} MiB for "
            f"{self.spec_.num_actions} actions)."
        )

    @property
    def num_features_in_use_(self) -> int:
        """The cells indexed so far (``num_stored_``), not the capacity ``num_features_``."""
        return self.num_stored_

    @property
    def num_stored_(self) -> int:
        """Cells indexed so far."""
        check_is_set_up(self, "num_stored_")
        return int(self._counts[0])

    @property
    def cells_(self) -> np.ndarray:
        """(num_stored_, d) cells in index order (a copy)."""
        return self._cells[: self.num_stored_].copy()

    # ------------------------------------------------------------------ save / restore

    def state_arrays(self) -> dict[str, np.ndarray]:
        """Return the indexed cells in index order (the hash slots are rebuilt from them)."""
        return {"cells": self.cells_}

    def load_state_arrays(self, arrays: dict[str, np.ndarray]) -> None:
        """Restore `state_arrays`' output into a representation set up with the same spec."""
        check_is_set_up(self, "load_state_arrays")
        cells = np.asarray(arrays.get("cells", np.zeros((0, 0))))
        d = self.spec_.num_dims
        if (
            cells.ndim != 2
            or cells.shape[1] != d
            or cells.shape[0] > self.num_features_
            or np.any(cells < 0)
            or np.any(cells >= self.num_buckets_)
            or np.unique(cells, axis=0).shape[0] != cells.shape[0]
        ):
            raise InvalidParameterError(
                f"HashedTabular.load_state_arrays: expected 'cells' of shape (at most "
                f"{self.num_features_:,}, {d}) of distinct cells below the buckets "
                f"{self.num_buckets_.tolist()}; got shape {cells.shape}. Were they saved with "
                f"another capacity, num_buckets or spec?"
            )
        num_stored = cells.shape[0]
        self._slots.fill(_hk.EMPTY)
        self._cells[:num_stored] = cells
        self._cells[num_stored:] = 0
        self._counts[0] = num_stored
        _hk.rebuild_slots(self._slots, self._cells, num_stored)
