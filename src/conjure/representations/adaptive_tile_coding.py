"""Adaptive tile coding (ATC): one tiling whose tiles split in two when learning in them stalls."""

from __future__ import annotations

import numpy as np

from conjure.core.errors import InvalidParameterError
from conjure.core.interfaces import DomainSpec, Expansion, Representation, check_is_set_up
from conjure.core.params import Interval
from conjure.core.seeding import as_seed_sequence
from conjure.representations._adaptive_kernels import atc_leaf, atc_record
from conjure.representations._kernels import per_dimension, positive_ints
from conjure.representations._max_features import MAX_FEATURES, check_max_features
from conjure.representations.weights import append_rows

__all__ = ["AdaptiveTileCoding"]


class AdaptiveTileCoding(Representation):
    """Adaptive tile coding φ(s): one active tile; a tile whose learning stalls splits in two.

    The ATC baseline of Geramifard (2012), Section 4.1.4 (Fig. 4-4 feature counts, Fig. 4-5
    learning curves; Section 4.3 places it among tree partitionings: "cuts the space into
    finer regions through time"), after Whiteson, Taylor & Stone (2007), "Adaptive tile coding
    for value function approximation" (UT Austin AI-TR-07-339). It starts from a coarse single
    tiling (one tile per dimension by default); every TD update of a tile t records |δ|, and
    once t's lowest |δ| has not improved for ``patience`` updates, t is split at the midpoint
    of the dimension that the value criterion picks. Tile t keeps the lower half; the upper
    half becomes a new feature whose `Expansion` parents are (t, −1), so learners copy θ_t
    into it (Section 4.1.1's θ_f = θ_g + θ_h with no second parent) and no value changes.

    Parameters
    ----------
    initial_tiles_per_dim : int or list of int, default 1
        Equal tiles across ``[low, high]`` per dimension before any split, in [1, inf); a
        list gives one entry per state dimension. A discrete dimension gets at most one tile
        per integer value.
    patience : int, default 50
        Whiteson et al.'s p, in [1, inf): updates of a tile without a new lowest |δ| after
        which it is split.
    max_features : int, default 10000
        Cap on the number of tiles, initial plus those added by splits, in [1, inf); no tile
        splits once it is reached. Must be at least the number of initial tiles.
    min_tile_width : float, default 0.01
        Smallest tile width along a continuous dimension, as a fraction of ``high − low``, in
        (0, 1]: a tile splits along a dimension only if both halves are at least this wide.

    Attributes
    ----------
    spec_ : DomainSpec
        The spec given to `setup`.
    num_features_ : int
        Number of tiles so far (initial tiles plus one per split).
    num_initial_features_ : int
        Number of tiles before any split.
    tile_low_, tile_high_ : ndarray of float64, shape (num_features_, d)
        The box ``[low, high)`` of each tile; discrete dimensions are stored as
        ``[a − 1/2, b + 1/2)`` for the integer values a .. b.
    is_set_up_ : bool
        Whether `setup` has run.

    Notes
    -----
    - Symbols: φ(s) ``active_features``; δ ``td_error``; p ``patience``; n ``num_features_``.
    - The tiles are the leaves of a kd-tree held in flat arrays (split dimension, threshold,
      left child, tile) and descended by a numba kernel; the initial grid is itself a
      balanced kd-tree, its tiles numbered row-major (the last dimension varies fastest).
    - Choice (when to split): the stall test is per tile, as in the issue's reading of
      Whiteson et al.: tile t counts its updates since |δ| last hit a new minimum for t and is
      split when the count reaches p. The count restarts after every attempt, also when no
      dimension qualifies.
    - Choice (where to split): the value criterion, not the policy criterion (which needs the
      per-action weights a representation never owns). Whiteson et al. learn the values of
      the two prospective sub-tiles of every dimension and split where they differ most; a
      sub-tile's value differs from its tile's by the TD errors that fall in it, so here each
      prospective half keeps the running mean of the δ observed in it since the tile was made,
      and the tile splits along the dimension with the largest gap between its halves' means
      (the lowest such dimension on ties). A dimension qualifies only if both halves have seen
      a δ and are wide enough (``min_tile_width``; a discrete tile needs two values).
    - Choice: the statistics pool the TD errors of all actions: tiles are shared by the
      actions (θ has one column per action), and `discover` receives δ without the action.
    - `discover` needs the updated state s (the learners pass it as ``state``) to place it in
      the prospective halves; ``state=None`` raises `InvalidParameterError`.
    - Choice: split tiles start afresh (lowest |δ| = ∞, no half statistics), and features
      are never removed: the parent id keeps the lower half.
    - Choice: states outside ``[low, high]`` fall in the edge tiles; NaN goes to the lower
      side of every split.
    - The seed is accepted for interface uniformity; ATC uses no randomness.

    Complexity
    ----------
    Θ(depth) per call to `active_features`, the kd-tree depth (Θ(log n) for balanced splits,
    at most n); Θ(d) per call to `discover`, plus an amortised Θ(d) when a tile splits.

    Examples
    --------
    >>> from conjure.core import DomainSpec
    >>> spec = DomainSpec(name="line", low=[0.0], high=[1.0], is_discrete=[False],
    ...                   num_actions=2, discount=0.9, max_episode_steps=10)
    >>> rep = AdaptiveTileCoding(patience=2).setup(spec, seed=0)
    >>> rep.num_features_
    1
    >>> for x, delta in [(0.2, 1.0), (0.8, -1.0), (0.3, 1.0)]:
    ...     expansion = rep.discover(rep.active_features([x]), delta, state=[x])
    >>> expansion.first_new, expansion.parents.tolist()
    (1, [[0, -1]])
    >>> rep.active_features([0.3]).tolist(), rep.active_features([0.7]).tolist()
    ([0], [1])
    """

    is_adaptive = True

    parameter_constraints = {
        "initial_tiles_per_dim": positive_ints(),
        "patience": Interval(int, 1, None),
        "max_features": MAX_FEATURES,
        "min_tile_width": Interval(float, 0, 1, closed="right"),
    }

    def __init__(
        self,
        *,
        initial_tiles_per_dim: int | list[int] = 1,
        patience: int = 50,
        max_features: int = 10_000,
        min_tile_width: float = 0.01,
    ):
        self.initial_tiles_per_dim = initial_tiles_per_dim
        self.patience = patience
        self.max_features = max_features
        self.min_tile_width = min_tile_width

    # -----------------------------------------------------------------------------------------
    # setup

    def setup(self, spec: DomainSpec, seed: int | np.random.SeedSequence) -> AdaptiveTileCoding:
        """Validate the parameters against ``spec``, build the initial tiling, return ``self``."""
        self.validate_params()
        as_seed_sequence(seed)  # no randomness; the seed is checked for uniformity
        tiles = per_dimension(self, "initial_tiles_per_dim", spec)
        d = spec.num_dims
        is_discrete = np.array(spec.is_discrete, dtype=bool)
        low = np.where(is_discrete, spec.low - 0.5, spec.low)
        high = np.where(is_discrete, spec.high + 0.5, spec.high)

        boundaries = []
        num_initial = 1
        for i in range(d):
            if is_discrete[i]:
                num_values = round(high[i] - low[i])
                n = min(int(tiles[i]), num_values)
                cuts = [low[i] + round(k * num_values / n) for k in range(1, n)]
            elif high[i] > low[i]:
                n = int(tiles[i])
                cuts = [low[i] + k * (high[i] - low[i]) / n for k in range(1, n)]
            else:
                cuts = []
            boundaries.append(cuts)
            num_initial *= len(cuts) + 1
        where = f"tiles of initial_tiles_per_dim={self.initial_tiles_per_dim!r} on {spec.name!r}"
        check_max_features(type(self).__name__, self.max_features, num_initial, where)

        # the initial grid as a balanced kd-tree: split every leaf along dimension 0, then 1, ...
        node_dim, node_threshold, node_left = [-1], [0.0], [-1]
        leaves = [(0, low.copy(), high.copy())]
        for i in range(d):
            grown = []
            for node, leaf_low, leaf_high in leaves:
                grown.extend(
                    _split_evenly(
                        node,
                        i,
                        boundaries[i],
                        leaf_low,
                        leaf_high,
                        node_dim,
                        node_threshold,
                        node_left,
                    )
                )
            leaves = grown
        node_feature = [-1] * len(node_dim)
        for feature, (node, _, _) in enumerate(leaves):
            node_feature[node] = feature

        self._node_dim = np.array(node_dim, dtype=np.int64)
        self._node_threshold = np.array(node_threshold, dtype=np.float64)
        self._node_left = np.array(node_left, dtype=np.int64)
        self._node_feature = np.array(node_feature, dtype=np.int64)
        self._leaf_node = np.array([node for node, _, _ in leaves], dtype=np.int64)
        self._tile_low = np.array([lo for _, lo, _ in leaves], dtype=np.float64).reshape(-1, d)
        self._tile_high = np.array([hi for _, _, hi in leaves], dtype=np.float64).reshape(-1, d)
        self._lowest_error = np.full(num_initial, np.inf)
        self._num_since_lowest = np.zeros(num_initial, dtype=np.int64)
        self._half_sums = np.zeros((num_initial, d, 2), dtype=np.float64)
        self._half_counts = np.zeros((num_initial, d, 2), dtype=np.int64)
        self._is_discrete = is_discrete
        self._min_half_width = np.where(
            is_discrete, 0.0, float(self.min_tile_width) * (spec.high - spec.low)
        )
        self._patience = int(self.patience)
        self._max_features = int(self.max_features)
        self.spec_ = spec
        self.num_features_ = num_initial
        self.num_initial_features_ = num_initial
        self.is_set_up_ = True
        return self

    @property
    def tile_low_(self) -> np.ndarray:
        """Lower corner of every tile, shape (num_features_, d)."""
        check_is_set_up(self, "tile_low_")
        return self._tile_low[: self.num_features_].copy()

    @property
    def tile_high_(self) -> np.ndarray:
        """Upper corner (exclusive) of every tile, shape (num_features_, d)."""
        check_is_set_up(self, "tile_high_")
        return self._tile_high[: self.num_features_].copy()

    # -----------------------------------------------------------------------------------------
    # φ(s)

    def active_features(self, state: np.ndarray) -> np.ndarray:
        """Return φ(s): the one tile holding ``state`` (a length-1 int64 array)."""
        try:
            node_dim = self._node_dim
        except AttributeError:
            check_is_set_up(self, "active_features")
            raise
        state = self.check_state(state)
        return atc_leaf(state, node_dim, self._node_threshold, self._node_left, self._node_feature)

    # -----------------------------------------------------------------------------------------
    # discovery

    def discover(
        self, active: np.ndarray, td_error: float, state: np.ndarray | None = None
    ) -> Expansion | None:
        """Record δ at s for the active tile; split it if its learning stalled (Whiteson et al.).

        ``state`` is the s whose φ(s) = ``active`` the learner just updated; it is required.
        """
        check_is_set_up(self, "discover")
        if state is None:
            raise InvalidParameterError(
                f"{type(self).__name__}.discover needs the updated state s to place it in its "
                f"tile's halves; got state=None. Pass discover(active, td_error, state=s)."
            )
        state = self.check_state(state)
        tile = int(active[0])
        split_dim = atc_record(
            tile,
            state,
            float(td_error),
            self._patience,
            self.num_features_ < self._max_features,
            self._tile_low,
            self._tile_high,
            self._is_discrete,
            self._min_half_width,
            self._lowest_error,
            self._num_since_lowest,
            self._half_sums,
            self._half_counts,
        )
        if split_dim < 0:
            return None
        return self._split(tile, int(split_dim))

    def _split(self, tile: int, dim: int) -> Expansion:
        """Split ``tile`` at the midpoint of ``dim``: it keeps the lower half (line: split)."""
        low, high = self._tile_low[tile, dim], self._tile_high[tile, dim]
        if self._is_discrete[dim]:
            threshold = low + np.floor(np.round(high - low) / 2.0)
        else:
            threshold = 0.5 * (low + high)
        new = self.num_features_
        parent = int(self._leaf_node[tile])
        left = self._node_dim.shape[0]
        self._node_dim = append_rows(self._node_dim, 2, fill=-1)
        self._node_threshold = append_rows(self._node_threshold, 2, fill=0.0)
        self._node_left = append_rows(self._node_left, 2, fill=-1)
        self._node_feature = append_rows(self._node_feature, 2, fill=-1)
        self._node_dim[parent] = dim
        self._node_threshold[parent] = threshold
        self._node_left[parent] = left
        self._node_feature[parent] = -1
        self._node_feature[left] = tile
        self._node_feature[left + 1] = new

        self._leaf_node = append_rows(self._leaf_node, 1, fill=left + 1)
        self._leaf_node[tile] = left
        self._tile_low = append_rows(self._tile_low, 1)
        self._tile_high = append_rows(self._tile_high, 1)
        self._tile_low[new] = self._tile_low[tile]
        self._tile_high[new] = self._tile_high[tile]
        self._tile_high[tile, dim] = threshold
        self._tile_low[new, dim] = threshold
        self._lowest_error = append_rows(self._lowest_error, 1, fill=np.inf)
        self._num_since_lowest = append_rows(self._num_since_lowest, 1, fill=0)
        self._half_sums = append_rows(self._half_sums, 1, fill=0.0)
        self._half_counts = append_rows(self._half_counts, 1, fill=0)
        self._lowest_error[tile] = np.inf
        self._num_since_lowest[tile] = 0
        self._half_sums[tile] = 0.0
        self._half_counts[tile] = 0
        self.num_features_ = new + 1
        return Expansion(first_new=new, parents=np.array([[tile, -1]], dtype=np.int64))

    # -----------------------------------------------------------------------------------------
    # save / restore

    _ARRAYS = (
        "node_dim",
        "node_threshold",
        "node_left",
        "node_feature",
        "leaf_node",
        "tile_low",
        "tile_high",
        "lowest_error",
        "num_since_lowest",
        "half_sums",
        "half_counts",
    )

    def state_arrays(self) -> dict[str, np.ndarray]:
        """Return the kd-tree, the tiles' boxes and their split statistics (copies)."""
        check_is_set_up(self, "state_arrays")
        return {name: getattr(self, f"_{name}").copy() for name in self._ARRAYS}

    def load_state_arrays(self, arrays: dict[str, np.ndarray]) -> None:
        """Restore `state_arrays`' output into a representation set up with the same spec."""
        check_is_set_up(self, "load_state_arrays")
        missing = [name for name in self._ARRAYS if name not in arrays]
        d = self.spec_.num_dims
        loaded = {name: np.asarray(arrays[name]) for name in self._ARRAYS if name in arrays}
        num_nodes = loaded.get("node_dim", np.empty(0)).shape[0]
        num_tiles = loaded.get("leaf_node", np.empty(0)).shape[0]
        shapes_ok = not missing and (
            all(loaded[n].shape == (num_nodes,) for n in self._ARRAYS[:4])
            and all(loaded[n].shape == (num_tiles,) for n in self._ARRAYS[4:5] + self._ARRAYS[7:9])
            and all(loaded[n].shape == (num_tiles, d) for n in self._ARRAYS[5:7])
            and all(loaded[n].shape == (num_tiles, d, 2) for n in self._ARRAYS[9:])
            and num_nodes == 2 * num_tiles - 1  # every split adds two nodes to a binary tree
        )
        if not shapes_ok or num_tiles < self.num_initial_features_:
            raise InvalidParameterError(
                f"AdaptiveTileCoding.load_state_arrays: expected the arrays {list(self._ARRAYS)} "
                f"of a tree set up for {self.spec_.name!r} with these parameters; got "
                f"{ {n: loaded[n].shape for n in loaded} } (missing {missing}). Were they saved "
                f"with another spec or initial_tiles_per_dim?"
            )
        for name in self._ARRAYS:
            dtype = getattr(self, f"_{name}").dtype
            setattr(self, f"_{name}", loaded[name].astype(dtype, copy=True))
        self.num_features_ = int(num_tiles)


def _split_evenly(
    node: int,
    dim: int,
    cuts: list[float],
    low: np.ndarray,
    high: np.ndarray,
    node_dim: list[int],
    node_threshold: list[float],
    node_left: list[int],
) -> list[tuple[int, np.ndarray, np.ndarray]]:
    """Split leaf ``node`` at ``cuts`` along ``dim`` as a balanced subtree; return its leaves."""
    if not cuts:
        return [(node, low, high)]
    middle = len(cuts) // 2
    threshold = cuts[middle]
    left = len(node_dim)
    node_dim[node], node_threshold[node], node_left[node] = dim, threshold, left
    node_dim.extend([-1, -1])
    node_threshold.extend([0.0, 0.0])
    node_left.extend([-1, -1])
    left_high, right_low = high.copy(), low.copy()
    left_high[dim] = threshold
    right_low[dim] = threshold
    return _split_evenly(
        left, dim, cuts[:middle], low, left_high, node_dim, node_threshold, node_left
    ) + _split_evenly(
        left + 1, dim, cuts[middle + 1 :], right_low, high, node_dim, node_threshold, node_left
    )
