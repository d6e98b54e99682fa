"""Sparse distributed memory (SDM): overlapping prototype boxes, allocated where states are seen."""

from __future__ import annotations

from typing import Any

import numpy as np

from conjure.core.errors import InvalidParameterError
from conjure.core.interfaces import DomainSpec, Expansion, Representation, check_is_set_up
from conjure.core.params import Interval, Predicate
from conjure.core.seeding import as_seed_sequence
from conjure.representations._adaptive_kernels import sdm_active, sdm_cell
from conjure.representations._max_features import MAX_FEATURES, check_max_features
from conjure.representations.weights import append_rows

__all__ = ["SparseDistributedMemory"]

_MAX_CELLS = 1 << 16  # grid cells of the neighbour search
_MAX_GRID_DIMS = 6
_RADIUS = Interval(float, 0, 1, closed="right")


def _radius_per_dimension(owner: Any, spec: DomainSpec) -> np.ndarray:
    value = owner.activation_radius
    if isinstance(value, (list, tuple)):
        if len(value) != spec.num_dims:
            raise InvalidParameterError(
                f"`SparseDistributedMemory.activation_radius` must have one entry per state "
                f"dimension ({spec.num_dims} for {spec.name!r}); got {value!r} (length "
                f"{len(value)}). Pass a single float to use it for every dimension."
            )
        return np.array([float(v) for v in value], dtype=np.float64)
    return np.full(spec.num_dims, float(value), dtype=np.float64)


class SparseDistributedMemory(Representation):
    """Sparse distributed memory φ(s): every prototype whose box around it holds s is active.

    The SDM baseline of Geramifard (2012), Section 4.1.4 (Fig. 4-4 feature counts, Fig. 4-5
    learning curves: on the inverted pendulum it found good policies quickly; Section 4.3:
    "the main insight of SDM is to maintain at least N neighbors for a given sampled point"),
    after Ratitch & Precup (2004), "Sparse distributed memories for on-line value-based
    reinforcement learning" (ECML, LNCS 3201). Prototypes (memory locations) c_k live in the
    state space scaled to [0, 1]^d; prototype k is active for s when |u_i − c_ki| <= r_i in
    every dimension i, u the scaled s and r ``activation_radius``. When a state that a learner
    updates activates fewer than ``min_active`` prototypes, Ratitch & Precup's dynamic
    allocation adds the missing ones: one centred on the state, the rest drawn uniformly
    within its activation box, so that the state activates them all. New prototypes have
    `Expansion` parents (−1, −1): their weights start at 0, so no value changes.

    Parameters
    ----------
    activation_radius : float or list of float, default 0.1
        r_i, the half-width of a prototype's box per dimension as a fraction of
        ``high − low``, in (0, 1]; a list gives one entry per state dimension.
    min_active : int, default 3
        Ratitch & Precup's N_min, in [1, inf): the fewest prototypes an updated state should
        activate before new ones are allocated around it.
    max_features : int, default 10000
        Cap on the number of prototypes, initial plus allocated, in [1, inf); none are added
        once it is reached. Must be at least the number of initial prototypes (see Notes).

    Attributes
    ----------
    spec_ : DomainSpec
        The spec given to `setup`.
    num_features_ : int
        Number of prototypes so far.
    num_initial_features_ : int
        Number of prototypes of the initial covering grid.
    centers_ : ndarray of float64, shape (num_features_, d)
        The prototypes' centres in the scaled space [0, 1]^d.
    num_allocations_ : int
        Number of allocations (states that received new prototypes).
    is_set_up_ : bool
        Whether `setup` has run.

    Notes
    -----
    - Symbols: φ(s) ``active_features``; c_k ``centers_``; r ``activation_radius``; N_min
      ``min_active``; n ``num_features_``.
    - Choice (activation): binary, as the thesis plots SDM among the binary representations:
      φ_k(s) = 1 on the support of Ratitch & Precup's triangular similarity (|u_i − c_ki| <=
      r_i for all i) instead of their graded similarity and normalised weighted average.
    - Choice (initial memory): Ratitch & Precup start empty; here every state must activate at
      least one feature, so the memory starts with the coarsest grid that covers [0, 1]^d:
      ceil(1 / (2 r_i)) evenly spaced centres per dimension (one in a dimension with
      ``low == high``).
    - Choice (new weights): their new location takes the current prediction at its centre,
      which leaves a normalised average unchanged; with the conjure sum θᵀφ(s) the same holds
      for θ = 0, so parents are (−1, −1).
    - Choice (full memory): Ratitch & Precup then move existing locations to the new state;
      features here are never removed or moved (a learned weight would change meaning), so
      allocation simply stops at ``max_features``.
    - Choice: the one new prototype centred on the state is skipped if a prototype already
      sits exactly there; the others' offsets come from a generator seeded by the setup seed
      and the allocation count, so runs are deterministic and restores continue exactly.
    - `discover` needs the updated state s (the learners pass it as ``state``) to allocate
      around it; ``state=None`` raises `InvalidParameterError`. The count is re-checked
      against the current memory before allocating.
    - Choice: states outside ``[low, high]`` are clipped into it (NaN to ``low``); discrete
      dimensions are scaled like continuous ones.
    - Neighbour search: prototypes sit in linked lists per cell of a uniform grid (cells at
      least 2 r_i wide over up to 6 dimensions, at most 2**16 cells); a query visits only the
      cells its box overlaps (numba).

    Complexity
    ----------
    Θ(2^g · m · d) per call to `active_features`, g <= 6 grid dimensions and m the
    prototypes per cell (independent of n for a bounded density); `discover` is Θ(1) unless
    the state is under-covered, then Θ(N_min · d) plus one search.

    Examples
    --------
    >>> from conjure.core import DomainSpec
    >>> spec = DomainSpec(name="line", low=[0.0], high=[1.0], is_discrete=[False],
    ...                   num_actions=2, discount=0.9, max_episode_steps=10)
    >>> rep = SparseDistributedMemory(activation_radius=0.25, min_active=2).setup(spec, 0)
    >>> rep.centers_.ravel().tolist()
    [0.25, 0.75]
    >>> phi = rep.active_features([0.1])
    >>> phi.tolist()
    [0]
    >>> expansion = rep.discover(phi, td_error=1.0, state=[0.1])
    >>> expansion.first_new, expansion.parents.tolist()
    (2, [[-1, -1]])
    >>> rep.centers_[2].tolist(), rep.active_features([0.1]).tolist()
    ([0.1], [0, 2])
    """

    is_adaptive = True

    parameter_constraints = {
        "activation_radius": _RADIUS
        | Predicate(
            lambda v: (
                isinstance(v, (list, tuple))
                and len(v) > 0
                and all(_RADIUS.is_satisfied_by(x) for x in v)
            ),
            "a non-empty list of floats in (0, 1]",
        ),
        "min_active": Interval(int, 1, None),
        "max_features": MAX_FEATURES,
    }

    def __init__(
        self,
        *,
        activation_radius: float | list[float] = 0.1,
        min_active: int = 3,
        max_features: int = 10_000,
    ):
        self.activation_radius = activation_radius
        self.min_active = min_active
        self.max_features = max_features

    # -----------------------------------------------------------------------------------------
    # setup

    def setup(
        self, spec: DomainSpec, seed: int | np.random.SeedSequence
    ) -> SparseDistributedMemory:
        """Validate the parameters against ``spec``, lay out the initial grid, return ``self``."""
        self.validate_params()
        seed_key = as_seed_sequence(seed).generate_state(4, dtype=np.uint32)
        raw_radius = _radius_per_dimension(self, spec)
        d = spec.num_dims
        span = spec.high - spec.low
        is_flat = ~(span > 0)
        inverse_range = np.where(is_flat, 0.0, 1.0 / np.where(is_flat, 1.0, span))
        # a hair of slack so that rounding never leaves a gap between grid centres
        radius = raw_radius * (1.0 + 1e-9)

        axes = []
        for i in range(d):
            if is_flat[i]:
                axes.append(np.zeros(1))
                continue
            n = int(np.ceil(1.0 / (2.0 * raw_radius[i]) - 1e-9))
            axes.append((np.arange(n) + 0.5) / n)
        num_initial = int(np.prod([float(axis.shape[0]) for axis in axes]))
        where = (
            f"prototypes of the initial covering grid, activation_radius="
            f"{self.activation_radius!r} on {spec.name!r}; a larger activation_radius needs fewer"
        )
        check_max_features(type(self).__name__, self.max_features, num_initial, where)
        grid_points = np.zeros((1, 0))
        for axis in axes:  # the row-major Cartesian product (no 32-dimension limit)
            grid_points = np.hstack(
                [
                    np.repeat(grid_points, axis.shape[0], axis=0),
                    np.tile(axis, grid_points.shape[0])[:, None],
                ]
            )

        self._low = np.asarray(spec.low, dtype=np.float64).copy()
        self._inverse_range = inverse_range.astype(np.float64)
        self._radius = radius
        self._grid = _grid_layout(radius, is_flat)
        self._num_cells = int(np.prod(self._grid[:, 1])) if self._grid.shape[0] else 1
        self._seed_key = seed_key
        self._min_active = int(self.min_active)
        self._max_features = int(self.max_features)
        self._set_centers(grid_points, num_allocations=0)
        self.spec_ = spec
        self.num_initial_features_ = num_initial
        self.is_set_up_ = True
        return self

    def _set_centers(self, centers: np.ndarray, num_allocations: int) -> None:
        """Install ``centers`` and rebuild the grid's linked lists in index order."""
        num = centers.shape[0]
        self._centers = np.array(centers, dtype=np.float64).reshape(num, -1)
        self._next_in_cell = np.full(num, -1, dtype=np.int64)
        self._cell_head = np.full(self._num_cells, -1, dtype=np.int64)
        for k in range(num):
            self._link(k)
        self.num_features_ = num
        self.num_allocations_ = int(num_allocations)

    def _link(self, k: int) -> None:
        cell = sdm_cell(self._centers[k], self._grid)
        self._next_in_cell[k] = self._cell_head[cell]
        self._cell_head[cell] = k

    @property
    def centers_(self) -> np.ndarray:
        """Prototype centres in [0, 1]^d, shape (num_features_, d)."""
        check_is_set_up(self, "centers_")
        return self._centers[: self.num_features_].copy()

    # -----------------------------------------------------------------------------------------
    # φ(s)

    def active_features(self, state: np.ndarray) -> np.ndarray:
        """Return φ(s): the sorted int64 indices of the prototypes whose box holds ``state``."""
        try:
            low = self._low
        except AttributeError:
            check_is_set_up(self, "active_features")
            raise
        state = self.check_state(state)
        return sdm_active(
            state,
            low,
            self._inverse_range,
            self._radius,
            self._centers,
            self._grid,
            self._cell_head,
            self._next_in_cell,
        )

    # -----------------------------------------------------------------------------------------
    # discovery (Ratitch & Precup's dynamic allocation)

    def discover(
        self, active: np.ndarray, td_error: float, state: np.ndarray | None = None
    ) -> Expansion | None:
        """Allocate prototypes around the updated state if it activates fewer than N_min.

        ``state`` is the s whose φ(s) = ``active`` the learner just updated; it is required.
        """
        check_is_set_up(self, "discover")
        if state is None:
            raise InvalidParameterError(
                f"{type(self).__name__}.discover needs the updated state s to allocate "
                f"prototypes around it; got state=None. Pass discover(active, td_error, state=s)."
            )
        if active.shape[0] >= self._min_active or self.num_features_ >= self._max_features:
            return None
        state = self.check_state(state)
        current = self.active_features(state)  # the memory may have grown since φ was made
        missing = min(self._min_active - current.shape[0], self._max_features - self.num_features_)
        if missing <= 0:
            return None
        u = np.clip(np.nan_to_num((state - self._low) * self._inverse_range, nan=0.0), 0.0, 1.0)
        u[self._inverse_range == 0.0] = 0.0
        new_centers = []
        if not np.any(np.all(self._centers[current] == u, axis=1)):
            new_centers.append(u)
        if len(new_centers) < missing:
            rng = np.random.default_rng(
                np.random.SeedSequence(
                    entropy=[int(x) for x in self._seed_key], spawn_key=(self.num_allocations_,)
                )
            )
            lo = np.maximum(u - self._radius, 0.0)
            hi = np.minimum(u + self._radius, 1.0)
            lo[self._inverse_range == 0.0] = hi[self._inverse_range == 0.0] = 0.0
            for _ in range(missing - len(new_centers)):
                new_centers.append(np.clip(rng.uniform(lo, hi), lo, hi))
        first_new = self.num_features_
        num_new = len(new_centers)
        self._centers = append_rows(self._centers, num_new)
        self._centers[first_new:] = np.array(new_centers)
        self._next_in_cell = append_rows(self._next_in_cell, num_new, fill=-1)
        for k in range(first_new, first_new + num_new):
            self._link(k)
        self.num_features_ = first_new + num_new
        self.num_allocations_ += 1
        return Expansion(first_new=first_new, parents=np.full((num_new, 2), -1, dtype=np.int64))

    # -----------------------------------------------------------------------------------------
    # save / restore

    def state_arrays(self) -> dict[str, np.ndarray]:
        """Return the centres, the allocation count and the seed key (copies)."""
        check_is_set_up(self, "state_arrays")
        return {
            "centers": self._centers[: self.num_features_].copy(),
            "num_allocations": np.array([self.num_allocations_], dtype=np.int64),
            "seed_key": self._seed_key.copy(),
        }

    def load_state_arrays(self, arrays: dict[str, np.ndarray]) -> None:
        """Restore `state_arrays`' output into a representation set up with the same spec."""
        check_is_set_up(self, "load_state_arrays")
        centers = np.asarray(arrays.get("centers"))
        count = np.asarray(arrays.get("num_allocations"))
        key = np.asarray(arrays.get("seed_key"))
        d = self.spec_.num_dims
        if (
            centers.ndim != 2
            or centers.shape[1] != d
            or not self.num_initial_features_ <= centers.shape[0]
            or count.shape != (1,)
            or key.shape != self._seed_key.shape
            or not np.all(np.isfinite(centers))
        ):
            raise InvalidParameterError(
                f"SparseDistributedMemory.load_state_arrays: expected 'centers' of shape "
                f"(n >= {self.num_initial_features_}, {d}), 'num_allocations' of shape (1,) and "
                f"'seed_key' of shape {self._seed_key.shape}; got {centers.shape}, "
                f"{count.shape} and {key.shape}. Were they saved with another spec?"
            )
        self._seed_key = key.astype(np.uint32, copy=True)
        self._set_centers(centers, num_allocations=int(count[0]))


def _grid_layout(radius: np.ndarray, is_flat: np.ndarray) -> np.ndarray:
    """Return the neighbour-search grid rows [dim, cells, stride] (cells >= 2 r wide)."""
    cells = np.where(is_flat, 1, np.floor(1.0 / (2.0 * radius)).astype(np.int64))
    order = sorted(range(radius.shape[0]), key=lambda i: (-int(cells[i]), i))
    rows: list[list[int]] = []
    total = 1
    for i in order[:_MAX_GRID_DIMS]:
        n = int(cells[i])
        if n < 2:
            break
        n = min(n, _MAX_CELLS // total)
        if n < 2:
            break
        rows.append([i, n, 0])
        total *= n
    stride = 1
    for row in reversed(rows):
        row[2] = stride
        stride *= row[1]
    return np.array(rows, dtype=np.int64).reshape(-1, 3)
