"""Adaptive Resolution iFDD: online iFDD over basic tiles that split (Geramifard 2012, §4.2)."""

from __future__ import annotations

import math

import numpy as np

from conjure.core.errors import InvalidParameterError
from conjure.core.interfaces import DomainSpec, Expansion, Representation, check_is_set_up
from conjure.core.params import Interval, Options
from conjure.core.seeding import as_seed_sequence
from conjure.representations import _arifdd_kernels as _ak
from conjure.representations import _ifdd_kernels as _k
from conjure.representations._kernels import per_dimension, positive_ints
from conjure.representations._max_features import OPTIONAL_MAX_FEATURES
from conjure.representations.compiled_ifdd import IFDDKernel
from conjure.representations.compiled_representation import BASIC_TILES, representation_kernel
from conjure.representations.online_ifdd import _RELEVANCES, _STATE_ARRAYS, OnlineIFDD

__all__ = ["ARiFDD"]

_STATS = ("error_sum", "mean", "variance")


class ARiFDD(OnlineIFDD):
    """ARiFDD: online iFDD whose one-dimensional basic tiles split where the error persists.

    Geramifard (2012), Section 4.2, Algorithm 22 (Fig. 4-10), with the coverage floor of
    Section 4.2.1 (Fig. 4-11). Each state dimension starts with ``initial_tiles_per_dim``
    equal basic tiles (intervals); φ⁰(s) is the d tiles holding s and φ̇(s) the sparsified
    cover of Algorithm 19 by discovered conjunctions. `discover` is Algorithm 22: if φ̇(s)
    has more than one active feature, online iFDD can still conjoin there and Algorithm 20
    (or 21) runs (line 20); otherwise the error-weighted statistics Ξ, μ, σ² of s's basic
    tiles are updated (lines 3-8) and, among those with Ξ > ς, the tile of least variance is
    split at its weighted mean μ (lines 12-15). The split tile and every conjunction built on
    it are retired (lines 16-18); the two new tiles are later conjoined by iFDD.

    Parameters
    ----------
    initial_tiles_per_dim : int or list of int, default 1
        Equal basic tiles per dimension before any split (Fig. 4-11's "number of uniform
        cuts"; Section 4.2.1: "ARiFDD can start with one feature per dimension"), in
        [1, inf); a list gives one entry per state dimension. A discrete dimension gets at
        most one tile per integer value.
    discovery_threshold : float, default 1.0
        ξ of Algorithm 20/21 in [0, inf): a conjunction is discovered when its relevance
        exceeds ξ.
    relevance : {"ifdd", "ifdd_plus", "ifdd_plus_signed"}, default "ifdd"
        ψ_f as in `OnlineIFDD`: Eq. 4.2 (Alg 20, used for Fig. 4-11), Eq. 4.3 as |Δ|/√ν, or
        Alg 21 as printed.
    split_threshold : float, default 1.0
        ς in [0, inf] (Alg 22 line 9; Section 4.2.1 used ς = 1): a basic tile may be split
        once its Ξ, the sum of |δ| observed in it, exceeds ς. ``inf`` recovers online iFDD.
    min_tile_fraction : float, default 0.05
        The coverage floor in (0, 1] (Section 4.2.1: 1/20): a split is rejected if either
        new tile would cover less than this fraction of its dimension's range.
    max_features : int or None, default None
        Cap on the total number of features, initial plus discovered (the initial tiles, split
        tiles, retired ones included, and conjunctions), in [number of initial tiles, inf) (a
        smaller cap raises at setup): no conjunction is added and no tile split beyond it.

    Attributes
    ----------
    num_features_ : int
        n_t, every feature ever made (retired tiles and their conjunctions included).
    num_initial_features_ : int
        n₀, the initial basic tiles (ids ``0 .. n₀ - 1``, dimension by dimension).
    parents_ : ndarray of int64, shape (num_features_, 2)
        (g, h) of a conjunction, (t, −1) of a tile split from tile t, (−1, −1) initially.
    basic_tiles_ : dict of ndarray
        The current (live) basic tiles: ``feature``, ``dim``, ``low``, ``high`` and their
        statistics ``error_sum`` (Ξ), ``mean`` (μ) and ``variance`` (σ²), in state units.
    retired_tiles_ : ndarray of int64
        The split tiles, in split order.
    num_splits_, num_rejected_splits_ : int
        Splits done, and steps at which the coverage floor blocked every candidate tile.

    Notes
    -----
    Symbols: φ⁰ the basic tiles, φ̇(s) ``active_features``, δ ``td_error``, ξ
    ``discovery_threshold``, ς ``split_threshold``, Ξ the sum of |δ|, μ and σ² the
    |δ|-weighted mean and variance (Finch 2009) of the states seen in a tile.

    - Choice (line 1): "φ̇(s) has one active feature" is read literally on the sparsified
      φ̇(s) the learner updated: exactly then no pair is co-active and iFDD cannot expand
      at s. Otherwise only Algorithm 20/21 runs (line 20) and no statistics change.
    - Choice (lines 5-6): the weights are |δ| (the text: "the weights are the absolute TD
      error"; Ξ sums |δ|), so δ_t in lines 5-6 is read as |δ_t|; with a signed δ the
      "mean" could leave the tile. σ² is the population (weighted) variance of Finch's
      incremental formula; an update with Ξ⁺ = 0 (δ = 0 on a fresh tile) changes nothing.
    - Choice (line 9): the printed ξ of line 9 is the split threshold ς of the text and of
      the inputs; the test is strict (Ξ > ς). Ξ is never reset, so once a tile passes ς
      every later single-feature step at it suggests a split.
    - Choice (line 12): the candidates are ranked by σ² itself, as printed; ties go to the
      lower dimension. The normalised rank σ² / (high − low)² was compared with it on
      Fig. 4-11 and found no better (docs/reproduction/fig_4_11.md), so it is not an option.
    - Choice (Section 4.2.1): line 12 ranks only the candidates whose split the coverage
      floor allows (a tile it blocks is skipped, rather than re-picked after a rejection);
      if it blocks every candidate nothing splits that step, as "all suggested splits were
      rejected" with 10 cuts. A split exactly at the midpoint of a 1/10 tile (halves of
      exactly 1/20) is accepted (footnote 7), up to a 1e-9 relative tolerance.
    - Choice (lines 13-15): the split tile t is retired and BOTH halves are new features
      (ids n_t and n_t + 1, lower half first), each with parents (t, −1), so θ_t is copied
      into both and values are unchanged wherever no conjunction on t was active. Their
      statistics start at zero. Retiring t retires the conjunctions on t (lines 16-18) at
      no cost: t is never in φ⁰(s) again, so no conjunction containing it is activated
      (features are never removed, Expansion semantics). Their potential features keep
      their relevances but are never updated again.
    - Choice: the split point is μ for a continuous dimension; a discrete dimension's tiles
      span [a − 1/2, b + 1/2) for the integers a .. b and split at ⌊μ⌋ + 1/2, between values.
      Statistics clip s into [low, high] (NaN to low); s at a boundary goes to the upper tile.
    - Choice: the statistics pool the TD errors of all actions (tiles are shared by the
      actions, and `discover` receives δ without the action), as the thesis's φ(s) is.
    - Choice: φ̇ is always sparsified (Alg 22 tests φ̇), and the threshold rule of Alg 20/21
      is used (not the fixed rate of Eq. 4.6). A new tile's hash word is splitmix64 of the
      setup's random word and its id, so nothing random is drawn after setup.
    - `discover` needs s (the learners pass ``state``); ``state=None`` raises
      `InvalidParameterError`.

    Complexity
    ----------
    `active_features`: Θ(d log m) to find φ⁰(s) (m tiles per dimension) plus Algorithm 19
    as in `OnlineIFDD`. `discover`: Θ(d) on a single-feature step (lines 2-13); a split adds
    Θ(m + d) and retires the conjunctions on t in Θ(1) (line 16-18's Θ(2^k₀) in the thesis);
    otherwise Algorithm 20/21's Θ(k_t² k₀). None depends on n_t, as Section 4.2 states.

    Examples
    --------
    >>> from conjure.core import DomainSpec
    >>> spec = DomainSpec(name="line", low=[0.0], high=[1.0], is_discrete=[False],
    ...                   num_actions=2, discount=0.9, max_episode_steps=10)
    >>> rep = ARiFDD(split_threshold=1.0).setup(spec, seed=0)
    >>> rep.discover(rep.active_features([0.25]), td_error=1.0, state=[0.25]) is None  # Ξ = 1
    True
    >>> expansion = rep.discover(rep.active_features([0.75]), td_error=-1.0, state=[0.75])
    >>> expansion.first_new, expansion.parents.tolist()  # Ξ = 2 > ς: split at μ = 0.5
    (1, [[0, -1], [0, -1]])
    >>> rep.active_features([0.49]).tolist(), rep.active_features([0.5]).tolist()
    ([1], [2])
    """

    parameter_constraints = {
        "initial_tiles_per_dim": positive_ints(),
        "discovery_threshold": Interval(float, 0, None),
        "relevance": Options(tuple(_RELEVANCES)),
        "split_threshold": Interval(float, 0, math.inf),
        "min_tile_fraction": Interval(float, 0, 1, closed="right"),
        "max_features": OPTIONAL_MAX_FEATURES,
    }

    is_adaptive = True
    # fixed settings of the OnlineIFDD machinery (not parameters of ARiFDD)
    sparsify = True
    discovery_rate = None
    expansion = "relevance"

    def __init__(
        self,
        *,
        initial_tiles_per_dim: int | list[int] = 1,
        discovery_threshold: float = 1.0,
        relevance: str = "ifdd",
        split_threshold: float = 1.0,
        min_tile_fraction: float = 0.05,
        max_features: int | None = None,
    ):
        self.initial_tiles_per_dim = initial_tiles_per_dim
        self.discovery_threshold = discovery_threshold
        self.relevance = relevance
        self.split_threshold = split_threshold
        self.min_tile_fraction = min_tile_fraction
        self.max_features = max_features

    @property
    def base(self) -> Representation:
        """The splittable basic tiles φ⁰ that the OnlineIFDD machinery conjoins (derived)."""
        return _BasicTiles(
            initial_tiles_per_dim=self.initial_tiles_per_dim,
            min_tile_fraction=self.min_tile_fraction,
            split_threshold=self.split_threshold,
        )

    # ------------------------------------------------------------------ lifecycle

    def setup(self, spec: DomainSpec, seed: int | np.random.SeedSequence) -> ARiFDD:
        """Validate the parameters, build the initial basic tiles and return ``self``."""
        self.validate_params()
        per_dimension(self, "initial_tiles_per_dim", spec)  # a clear error naming ARiFDD
        super().setup(spec, seed)
        return self

    def _install(
        self, arrays: dict[str, np.ndarray], cache: tuple[np.ndarray, ...] | None = None
    ) -> None:
        """Bind the arrays as `OnlineIFDD` does; hash words exist for every feature slot."""
        capacity = arrays["feat_start"].shape[0]
        words = arrays["words"]
        if words.shape[0] < capacity:  # split tiles are initial sets too: one word per id
            grown = np.zeros(capacity, dtype=np.int64)
            grown[: words.shape[0]] = words
            arrays = {**arrays, "words": grown}
        super()._install(arrays, cache)

    def _reserve(self, num_splits: int, num_features: int) -> None:
        """Grow the tables until ``num_splits`` splits and ``num_features`` new features fit."""
        while not _ak.fits_splits(self.base_.tiles_, num_splits, num_features, self._tables):
            self.grow_tables()

    def grow_tables(self) -> None:
        """Double the basic tiles' slots per dimension and iFDD's capacities (`OnlineIFDD`)."""
        self.base_.grow()
        super().grow_tables()

    def compiled_form(self) -> IFDDKernel:
        """The basic tiles under iFDD's tables, both updated in place (Algorithms 19-22)."""
        check_is_set_up(self, "compiled_form")
        tiles = self.base_.tiles_
        base = representation_kernel(
            BASIC_TILES,
            self.spec_.num_dims,
            dims=tiles.edges,
            layout=tiles.tile_feature,
            vector=tiles.num_tiles,
        )
        return IFDDKernel(
            base=base, is_ifdd=True, tables=self.kernel_tables(), splits=True, tiles=tiles
        )

    # ------------------------------------------------------------------ Algorithm 22

    def discover(
        self, active: np.ndarray, td_error: float, state: np.ndarray | None = None
    ) -> Expansion | None:
        """Algorithm 22: split a basic tile at a single-feature state s, else Algorithm 20/21.

        ``active`` is the φ̇(s) the learner updated with δ = ``td_error``; ``state`` is s and
        is required. Returns the new features with their parents, or ``None``.
        """
        check_is_set_up(self, "discover")
        if state is None:
            raise InvalidParameterError(
                f"{type(self).__name__}.discover needs the updated state s to place it in its "
                f"basic tiles; got state=None. Pass discover(active, td_error, state=s)."
            )
        k = active.shape[0]
        if k != 1:  # line 20: iFDD can still expand at s
            self._reserve(1, k * (k - 1) // 2)
            return super().discover(active, td_error)
        state = self.check_state(state)
        self._reserve(1, 2)
        first = self.num_features_
        if _ak.split_at(self.base_.tiles_, state, float(td_error), self._tables) == 0:
            return None  # lines 2-13 found no tile to split
        parents = self._arrays["feat_parents"][first : first + 2].copy()
        return Expansion(first_new=first, parents=parents)  # lines 14-18: `split_at`

    # ------------------------------------------------------------------ inspection

    @property
    def basic_tiles_(self) -> dict[str, np.ndarray]:
        """The live basic tiles: feature, dim, low, high, error_sum Ξ, mean μ, variance σ²."""
        check_is_set_up(self, "basic_tiles_")
        return self.base_.describe()

    @property
    def retired_tiles_(self) -> np.ndarray:
        """The split (retired) tiles, in split order: the parent t of each pair of halves."""
        check_is_set_up(self, "retired_tiles_")
        parents = self._arrays["feat_parents"][self.num_initial_features_ : self.num_features_]
        return parents[parents[:, 1] == -1][::2, 0].copy()

    @property
    def num_splits_(self) -> int:
        """Number of tiles split so far."""
        check_is_set_up(self, "num_splits_")
        return int(self.base_.tiles_.num_tiles.sum()) - self.num_initial_features_

    @property
    def num_rejected_splits_(self) -> int:
        """Number of steps at which the coverage floor blocked every candidate tile."""
        check_is_set_up(self, "num_rejected_splits_")
        return int(self.base_.tiles_.counters[1])

    # ------------------------------------------------------------------ persistence

    def load_state_arrays(self, arrays: dict[str, np.ndarray]) -> None:
        """Restore `state_arrays`' output into an ARiFDD set up with the same spec."""
        check_is_set_up(self, "load_state_arrays")
        missing = [name for name in _STATE_ARRAYS if name not in arrays]
        if missing:
            raise InvalidParameterError(
                f"{type(self).__name__}.load_state_arrays: missing {missing}; were the arrays "
                f"saved from another representation?"
            )
        loaded = {name: np.array(arrays[name]) for name in _STATE_ARRAYS}
        saved = dict(zip(_k.COUNTERS, loaded["ints"].tolist(), strict=True))
        num_features = saved["num_features"]
        if (
            saved["num_initial"] != self.num_initial_features_
            or loaded["words"].shape[0] < num_features
            or loaded["feat_start"].shape[0] < num_features
        ):
            raise InvalidParameterError(
                f"{type(self).__name__}.load_state_arrays: saved with "
                f"{saved['num_initial']} initial tiles and {num_features} "
                f"features, but set up with {self.num_initial_features_} initial tiles; was it "
                f"saved with another spec or initial_tiles_per_dim?"
            )
        self.base_.load_state_arrays(
            {k[len("base.") :]: v for k, v in arrays.items() if k.startswith("base.")}
        )
        self._install(loaded)


class _BasicTiles(Representation):
    """ARiFDD's φ⁰: per-dimension interval tiles that split (Section 4.2, Fig. 4-10 a-e).

    Initial tiles are numbered dimension by dimension; the ids of split halves come from
    `ARiFDD`. Its state is ``tiles_``, the `BasicTiles` its kernels and the compiled loop
    read and update in place (`conjure.representations._arifdd_kernels`); `grow` replaces it.
    """

    parameter_constraints = {
        "initial_tiles_per_dim": positive_ints(),
        "min_tile_fraction": Interval(float, 0, 1, closed="right"),
        "split_threshold": Interval(float, 0, math.inf),
    }
    _ARRAYS = ("edges", "num_tiles", "tile_feature", "stats", "counters")

    def __init__(
        self,
        *,
        initial_tiles_per_dim: int | list[int] = 1,
        min_tile_fraction: float = 0.05,
        split_threshold: float = 1.0,
    ):
        self.initial_tiles_per_dim = initial_tiles_per_dim
        self.min_tile_fraction = min_tile_fraction
        self.split_threshold = split_threshold

    def setup(self, spec: DomainSpec, seed: int | np.random.SeedSequence) -> _BasicTiles:
        """Lay out the initial equal tiles of every dimension and return ``self``."""
        self.validate_params()
        as_seed_sequence(seed)  # no randomness
        requested = per_dimension(self, "initial_tiles_per_dim", spec)
        d = spec.num_dims
        is_discrete = np.array(spec.is_discrete, dtype=bool)
        low = np.where(is_discrete, spec.low - 0.5, spec.low).astype(np.float64)
        high = np.where(is_discrete, spec.high + 0.5, spec.high).astype(np.float64)
        boundaries = []
        for i in range(d):
            if is_discrete[i]:
                num_values = round(high[i] - low[i])
                n = min(int(requested[i]), num_values)
                cuts = [low[i] + round(k * num_values / n) for k in range(1, n)]
            elif high[i] > low[i]:
                n = int(requested[i])
                cuts = [low[i] + k * (high[i] - low[i]) / n for k in range(1, n)]
            else:
                cuts = []
            boundaries.append([low[i], *cuts, high[i]])
        num_tiles = np.array([len(b) - 1 for b in boundaries], dtype=np.int64)
        capacity = int(num_tiles.max()) + 8
        edges = np.full((d, capacity + 1), np.inf)
        tile_feature = np.full((d, capacity), -1, dtype=np.int64)
        offset = 0
        for i, b in enumerate(boundaries):
            edges[i, : len(b)] = b
            tile_feature[i, : num_tiles[i]] = offset + np.arange(num_tiles[i])
            offset += int(num_tiles[i])
        self.tiles_ = _ak.BasicTiles(
            edges=edges,
            num_tiles=num_tiles,
            tile_feature=tile_feature,
            stats=np.zeros((d, capacity, 3), dtype=np.float64),
            low=np.asarray(spec.low, dtype=np.float64).copy(),
            high=np.asarray(spec.high, dtype=np.float64).copy(),
            min_width=float(self.min_tile_fraction) * (high - low),
            is_discrete=is_discrete,
            counters=np.zeros(2, dtype=np.int64),
            split_threshold=float(self.split_threshold),
        )
        self.spec_ = spec
        self.num_features_ = offset
        self.is_set_up_ = True
        return self

    def active_features(self, state: np.ndarray) -> np.ndarray:
        """Return φ⁰(s) (ids in ARiFDD's numbering)."""
        check_is_set_up(self, "active_features")
        state = self.check_state(state)
        tiles = self.tiles_
        return _ak.basic_features(state, tiles.edges, tiles.num_tiles, tiles.tile_feature)

    def grow(self) -> None:
        """Double the tile slots of every dimension (the tiles and statistics are kept)."""
        tiles = self.tiles_
        d, capacity = tiles.tile_feature.shape
        edges = np.full((d, 2 * capacity + 1), np.inf)
        edges[:, : capacity + 1] = tiles.edges
        feature = np.full((d, 2 * capacity), -1, dtype=np.int64)
        feature[:, :capacity] = tiles.tile_feature
        stats = np.zeros((d, 2 * capacity, 3), dtype=np.float64)
        stats[:, :capacity] = tiles.stats
        self.tiles_ = tiles._replace(edges=edges, tile_feature=feature, stats=stats)

    def describe(self) -> dict[str, np.ndarray]:
        """The live tiles and their statistics, dimension by dimension (state units)."""
        columns: dict[str, list] = {name: [] for name in ("feature", "dim", "low", "high", *_STATS)}
        tiles = self.tiles_
        for i, m in enumerate(tiles.num_tiles):
            for j in range(int(m)):
                columns["feature"].append(int(tiles.tile_feature[i, j]))
                columns["dim"].append(i)
                columns["low"].append(float(tiles.edges[i, j]))
                columns["high"].append(float(tiles.edges[i, j + 1]))
                for k, name in enumerate(_STATS):
                    columns[name].append(float(tiles.stats[i, j, k]))
        return {
            name: np.array(values, dtype=np.int64 if name in ("feature", "dim") else np.float64)
            for name, values in columns.items()
        }

    def state_arrays(self) -> dict[str, np.ndarray]:
        """Return the tiles, their statistics and the counters (copies)."""
        return {name: getattr(self.tiles_, name).copy() for name in self._ARRAYS}

    def load_state_arrays(self, arrays: dict[str, np.ndarray]) -> None:
        """Restore `state_arrays`' output (shapes checked against the spec)."""
        missing = [name for name in self._ARRAYS if name not in arrays]
        d = self.spec_.num_dims
        loaded = {name: np.array(arrays[name]) for name in self._ARRAYS if name in arrays}
        capacity = loaded["tile_feature"].shape[-1] if "tile_feature" in loaded else -1
        if (
            missing
            or loaded["edges"].shape != (d, capacity + 1)
            or loaded["tile_feature"].shape != (d, capacity)
            or loaded["stats"].shape != (d, capacity, 3)
            or loaded["num_tiles"].shape != (d,)
            or loaded["counters"].shape != (2,)
        ):
            raise InvalidParameterError(
                f"ARiFDD.load_state_arrays: the basic tiles (base.*) do not fit a "
                f"{d}-D spec (missing {missing}); were they saved with another spec?"
            )
        self.tiles_ = self.tiles_._replace(
            **{
                name: np.ascontiguousarray(loaded[name], dtype=getattr(self.tiles_, name).dtype)
                for name in self._ARRAYS
            }
        )
