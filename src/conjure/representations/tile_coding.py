"""Tile coding (CMAC): several offset uniform tilings, optionally over subsets of dimensions."""

from __future__ import annotations

from typing import Any

import numpy as np

from conjure.core.errors import InvalidParameterError
from conjure.core.interfaces import DomainSpec, Representation, SparseFeatures, check_is_set_up
from conjure.core.params import InstanceOf, Interval, Predicate
from conjure.core.seeding import as_seed_sequence
from conjure.representations._kernels import (
    EMPTY_SLOT,
    MAX_FEATURES,
    BucketTable,
    dimension_table,
    hashed_tile_features,
    per_dimension,
    positive_ints,
    tile_features,
)
from conjure.representations.compiled_representation import (
    HASHED_TILES,
    TILES,
    RepresentationKernel,
    representation_kernel,
)

__all__ = ["TileCoding"]


def _is_groups(value: Any) -> bool:
    index = Interval(int, 0, None)
    return (
        isinstance(value, (list, tuple))
        and len(value) > 0
        and all(
            isinstance(group, (list, tuple))
            and len(group) > 0
            and all(index.is_satisfied_by(i) for i in group)
            for group in value
        )
    )


class TileCoding(BucketTable, Representation):
    """Tile coding φ(s): one active tile in each of ``num_tilings`` offset uniform grids.

    Geramifard (2012), Section 3.1.4 (tile coding, Albus's CMAC; Fig. 3-3) with tilings over
    chosen subsets of the dimensions (Fig. 3-5: a tile ignoring dimension i covers it fully,
    G_i(f) = 1, Eq. 3.5-3.7); φ(s, a) follows Eq. 2.11. Offsets and hashing follow Sutton &
    Barto (2018, Section 9.5.4) and Sutton's ``tiles3``.

    Parameters
    ----------
    num_tilings : int, default 8
        Tilings per dimension group, k in [1, inf) (Section 3.1.4's "number of tilings").
    tiles_per_dim : int or list of int, default 10
        Tiles across ``[low, high]`` per continuous dimension, in [1, inf); a list gives one
        entry per state dimension. The tile width is (high − low) / tiles_per_dim. Discrete
        dimensions get one tile per integer value ``low .. high`` and ignore their entry.
    dimension_groups : list of list of int or None, default None
        Subsets of dimension indices in [0, d); each group gets its own ``num_tilings``
        tilings over only its dimensions (Fig. 3-5). ``None`` means one group of all
        dimensions.
    memory_size : int or None, default None
        If set, in [1, inf): tiles are hashed into this many features with a tiles3 index hash
        table; ``None`` gives every tile its own feature.

    Attributes
    ----------
    spec_ : DomainSpec
        The spec given to `setup`.
    num_features_ : int
        Number of tiles over all tilings and groups, or ``memory_size`` when hashing.
    num_tiles_ : int
        Number of tiles before hashing.
    num_active_ : int
        ``num_tilings × len(groups)``, the active count (fewer only after hash collisions).
    num_collisions_ : int
        Hashing only: lookups of an unseen tile after the table filled up, each answered by
        ``hash % memory_size`` (tiles3's ``overfullCount``); 0 without hashing.
    num_stored_ : int
        Hashing only: tiles that own an index (at most ``memory_size``); 0 without hashing.
    is_set_up_ : bool
        Whether `setup` has run.

    Notes
    -----
    - Symbols: φ(s) ``active_features``; k ``num_tilings``; n ``num_features_``;
      sparsity(φ) = k / n per group (Section 3.1.2).
    - Offsets (tiles3, Sutton & Barto's asymmetric displacement): tiling t of a group shifts
      its j-th continuous dimension by ((t · (2j + 1)) mod k) / k tile widths, the first odd
      integers 1, 3, 5, ... times width / k. Each continuous dimension has
      ``tiles_per_dim + 1`` tiles per tiling so that shifted grids still cover
      ``[low, high]``.
    - Indices: group by group, tiling by tiling, the tile's row-major position inside its
      tiling; the unhashed φ(s) is therefore already sorted.
    - Choice: discrete dimensions are not displaced (every tiling agrees on them).
    - Choice: values outside ``[low, high]`` are clipped into the edge tiles; NaN falls in
      the first. A continuous dimension with ``low == high`` has a single tile.
    - Choice (hashing, tiles3 conventions): the key of a tile is (group, tiling,
      coordinates), encoded as its unhashed index; a flat open-addressing table hands out
      indices 0, 1, 2, ... in order of first appearance, then falls back to a splitmix64
      hash of the key modulo ``memory_size``. Two active tiles may then share an index:
      `active_features` returns the sorted unique indices, so fewer than ``num_active_``.
      The indices depend on the order states were learned from (greedy acting reads φ(s)
      by `peek`, which stores no tile); `state_arrays` saves the table.
    - Choice: the unhashed tile count must fit in an int64 (< 2**62), also when hashing;
      use ``dimension_groups`` to tile large state spaces.
    - The seed is accepted for interface uniformity; tile coding uses no randomness.

    Complexity
    ----------
    Θ(k · Σ_groups |group| + d) per call to `active_features` (plus an expected O(1) probe
    per tile when hashing).

    Examples
    --------
    >>> from conjure.core import DomainSpec
    >>> spec = DomainSpec(name="line", low=[0.0], high=[1.0], is_discrete=[False],
    ...                   num_actions=2, discount=0.9, max_episode_steps=10)
    >>> rep = TileCoding(num_tilings=2, tiles_per_dim=2).setup(spec, seed=0)
    >>> rep.num_features_
    6
    >>> rep.active_features([0.3]).tolist()
    [0, 4]
    """

    parameter_constraints = {
        "num_tilings": Interval(int, 1, None),
        "tiles_per_dim": positive_ints(),
        "dimension_groups": InstanceOf(type(None))
        | Predicate(
            _is_groups, "a non-empty list of non-empty lists of dimension indices (ints >= 0)"
        ),
        "memory_size": InstanceOf(type(None)) | Interval(int, 1, None),
    }

    def __init__(
        self,
        *,
        num_tilings: int = 8,
        tiles_per_dim: int | list[int] = 10,
        dimension_groups: list[list[int]] | None = None,
        memory_size: int | None = None,
    ):
        self.num_tilings = num_tilings
        self.tiles_per_dim = tiles_per_dim
        self.dimension_groups = dimension_groups
        self.memory_size = memory_size

    # -----------------------------------------------------------------------------------------
    # setup

    def _groups(self, spec: DomainSpec) -> list[list[int]]:
        if self.dimension_groups is None:
            return [list(range(spec.num_dims))]
        groups = [[int(i) for i in group] for group in self.dimension_groups]
        for group in groups:
            for i in group:
                if i >= spec.num_dims:
                    raise InvalidParameterError(
                        f"`TileCoding.dimension_groups` refers to dimension {i}, but "
                        f"{spec.name!r} has {spec.num_dims} dimensions (0 .. "
                        f"{spec.num_dims - 1}); got {self.dimension_groups!r}."
                    )
            if len(set(group)) != len(group):
                raise InvalidParameterError(
                    f"`TileCoding.dimension_groups` must not repeat a dimension within a "
                    f"group; got {self.dimension_groups!r}."
                )
        return groups

    def setup(self, spec: DomainSpec, seed: int | np.random.SeedSequence) -> TileCoding:
        """Validate the parameters against ``spec``, lay out the tilings and return ``self``."""
        self.validate_params()
        as_seed_sequence(seed)  # no randomness; the seed is checked for uniformity
        num_tilings = int(self.num_tilings)
        tiles = per_dimension(self, "tiles_per_dim", spec)
        groups = self._groups(spec)
        dims, sizes = dimension_table(spec, tiles, quantum=num_tilings, extend=True)
        is_displaced = ~spec.is_discrete & (spec.high > spec.low)

        layout_rows: list[tuple[int, int, int]] = []
        group_rows: list[tuple[int, int, int, int]] = []
        base = 0
        for group in groups:
            first = len(layout_rows)
            per_tiling = 1
            strides = []
            for i in reversed(group):  # row-major: the group's last dimension varies fastest
                strides.append(per_tiling)
                per_tiling *= int(sizes[i])
            strides.reverse()
            j = 0
            for i, stride in zip(group, strides, strict=True):
                odd = 2 * j + 1 if is_displaced[i] else 0
                j += int(is_displaced[i])
                layout_rows.append((i, stride, odd))
            group_rows.append((first, len(layout_rows), base, per_tiling))
            base += num_tilings * per_tiling
            if base > MAX_FEATURES:
                raise InvalidParameterError(
                    f"`TileCoding.tiles_per_dim` = {self.tiles_per_dim!r} over "
                    f"{spec.num_dims} dimensions gives more tiles than an int64 index allows; "
                    f"tile subsets of the dimensions with `dimension_groups` or use fewer "
                    f"tiles."
                )

        self._dims = dims
        self._layout = np.array(layout_rows, dtype=np.int64).reshape(-1, 3)
        self._group_table = np.array(group_rows, dtype=np.int64).reshape(-1, 4)
        self._num_tilings = num_tilings
        self._is_hashed = self.memory_size is not None
        if self._is_hashed:
            held = min(int(self.memory_size), base)
            capacity = 1 << max(1, (2 * held - 1).bit_length())
            self._hash_table = np.full((capacity, 2), EMPTY_SLOT, dtype=np.int64)
            self._hash_counts = np.array([0, 0, int(self.memory_size)], dtype=np.int64)
        self.spec_ = spec
        self.num_tiles_ = int(base)
        self.num_active_ = num_tilings * len(groups)
        self.num_features_ = int(self.memory_size) if self._is_hashed else int(base)
        self.is_set_up_ = True
        return self

    # -----------------------------------------------------------------------------------------
    # φ(s)

    compiled_methods = ("active_features", "encode")

    def compiled_form(self) -> RepresentationKernel:
        """The tile layout for the compiled loop (with the hash table when hashed)."""
        check_is_set_up(self, "compiled_form")
        tables = {"dims": self._dims, "layout": self._layout, "groups": self._group_table}
        if self._is_hashed:
            tables.update(hash_table=self._hash_table, hash_counts=self._hash_counts)
        kind = HASHED_TILES if self._is_hashed else TILES
        return representation_kernel(
            kind, self.num_active_, num_tilings=self._num_tilings, **tables
        )

    def active_features(self, state: np.ndarray) -> np.ndarray:
        """Return φ(s): the sorted, unique int64 indices of the active tiles."""
        dims, state = self._dims_and_state(state)
        if self._is_hashed:
            return hashed_tile_features(
                state,
                dims,
                self._layout,
                self._group_table,
                self._num_tilings,
                self._hash_table,
                self._hash_counts,
            )
        return tile_features(state, dims, self._layout, self._group_table, self._num_tilings)

    def peek(self, state: np.ndarray) -> SparseFeatures:
        """φ(s) without storing new tiles in the hash table (greedy acting); else `encode`."""
        if not self._is_hashed:
            return self.encode(state)
        dims, state = self._dims_and_state(state)
        tables = (self._layout, self._group_table, self._num_tilings)
        counted = (self._hash_table, self._hash_counts)
        return self._binary(hashed_tile_features(state, dims, *tables, *counted, False))

    @property
    def num_collisions_(self) -> int:
        """Hash fallbacks after the table filled up (tiles3's overfullCount); 0 if none."""
        counts = getattr(self, "_hash_counts", None) if getattr(self, "_is_hashed", False) else None
        return 0 if counts is None else int(counts[1])

    @property
    def num_stored_(self) -> int:
        """Tiles that own a hashed index (0 without hashing or before setup)."""
        counts = getattr(self, "_hash_counts", None) if getattr(self, "_is_hashed", False) else None
        return 0 if counts is None else int(counts[0])

    # -----------------------------------------------------------------------------------------
    # save / restore

    def state_arrays(self) -> dict[str, np.ndarray]:
        """Return the hash table and its counters (empty without hashing: offsets are fixed)."""
        check_is_set_up(self, "state_arrays")
        if not self._is_hashed:
            return {}
        return {"hash_table": self._hash_table.copy(), "hash_counts": self._hash_counts.copy()}

    def load_state_arrays(self, arrays: dict[str, np.ndarray]) -> None:
        """Restore `state_arrays`' output into a representation set up with the same spec."""
        check_is_set_up(self, "load_state_arrays")
        if not self._is_hashed:
            return
        table = np.asarray(arrays.get("hash_table"))
        counts = np.asarray(arrays.get("hash_counts"))
        if (
            table.shape != self._hash_table.shape
            or counts.shape != self._hash_counts.shape
            or counts[2] != self._hash_counts[2]
            or not 0 <= counts[0] <= counts[2]
        ):
            raise InvalidParameterError(
                f"TileCoding.load_state_arrays: expected 'hash_table' of shape "
                f"{self._hash_table.shape} and 'hash_counts' [stored, collisions, "
                f"{self.memory_size}]; got {table.shape} and {counts.tolist()}. Were they saved "
                f"with another memory_size or spec?"
            )
        self._hash_table = table.astype(np.int64, copy=True)
        self._hash_counts = counts.astype(np.int64, copy=True)
