"""Online incremental Feature Dependency Discovery (Geramifard 2012, Section 4.1)."""

from __future__ import annotations

import numpy as np

from conjure.core.compiled_form import compiled_form
from conjure.core.errors import InvalidParameterError
from conjure.core.interfaces import (
    DomainSpec,
    Expansion,
    Representation,
    check_binary_features,
    check_is_set_up,
)
from conjure.core.params import InstanceOf, Interval, Options
from conjure.core.seeding import make_rng, split_seed
from conjure.representations import _ifdd_kernels as _k
from conjure.representations._max_features import OPTIONAL_MAX_FEATURES, check_max_features
from conjure.representations.compiled_ifdd import NO_TILES, IFDDKernel

__all__ = ["OnlineIFDD"]

_RELEVANCES = {
    "ifdd": _k.RELEVANCE_IFDD,
    "ifdd_plus": _k.RELEVANCE_IFDD_PLUS,
    "ifdd_plus_signed": _k.RELEVANCE_IFDD_PLUS_SIGNED,
}
# arrays that grow with the number of nodes (potential + discovered conjunctions), by row
_NODE_ARRAYS = ("node_key", "node_start", "node_len", "node_feature", "node_parents",
                "node_stats", "node_slot", "heap")  # fmt: skip
_FEATURE_ARRAYS = ("feat_start", "feat_len", "feat_parents")
_MINUS_ONE = ("node_feature", "node_parents", "node_slot", "feat_parents")
_STATE_ARRAYS = ("words", "pool", *_FEATURE_ARRAYS, *_NODE_ARRAYS, "table", "ints", "floats")
_CACHE_ROWS = 1 << 13
_CACHE_CELLS = 1 << 17


class OnlineIFDD(Representation):
    """Online iFDD: sparse conjunctions of binary features, discovered from the TD error.

    Geramifard (2012), Section 4.1: φ̇(s) is Algorithm 19 (the greedy, sparsifying cover of the
    active initial features by the largest discovered conjunctions, the ℧ operator of
    Algorithm 18 and Section 3.4); `discover` is Algorithm 20 (relevance ψ_f = Σ|δ| of Eq. 4.2)
    or Algorithm 21 (iFDD⁺, ψ_f = Δ_f / √ν_f of Eq. 4.3) with the discovery threshold ξ, or
    the fixed discovery rate n_t = n₀ + √(C t) of Eq. 4.6 (Section 4.1.4). A new feature
    f = g ∪ h lists its parents (g, h) so learners set θ_f = θ_g + θ_h (Section 4.1.1,
    Theorem 3.4.4).

    Parameters
    ----------
    base : Representation
        The initial binary features φ⁰ (``IndependentDiscretization``, ``TileCoding``,
        ``Tabular``, a domain's indicator features); a clone is set up, and its n₀ features
        keep their ids ``0 .. n₀ - 1``.
    discovery_threshold : float, default 1.0
        ξ in [0, inf): a potential feature is discovered when its relevance exceeds ξ
        (Alg 20 line 5, Alg 21 line 7). Ignored when ``discovery_rate`` is set.
    relevance : {"ifdd", "ifdd_plus", "ifdd_plus_signed"}, default "ifdd"
        ψ_f: "ifdd" is Eq. 4.2 (Σ|δ|, Alg 20); "ifdd_plus" is Eq. 4.3 with the magnitude
        |Δ_f| / √ν_f; "ifdd_plus_signed" is Alg 21 as printed, Δ_f / √ν_f.
    sparsify : bool, default True
        Whether φ̇ is sparsified (Alg 19); ``False`` activates every feature whose initial set
        lies within the active initial features (φ of Section 3.3, for comparison).
    max_features : int or None, default None
        Cap on the total number of features, the n₀ initial ones of ``base`` plus the
        discovered ones, in [n₀, inf) (a smaller cap raises at setup); ``None``: no cap. For up
        to k discovered features, pass n₀ + k.
    discovery_rate : float or None, default None
        C in (0, inf) of Eq. 4.6: if set, the threshold is ignored and after the t-th call of
        `discover` potential features are added (chosen by ``expansion``) while fewer than
        n₀ + ⌊√(C t)⌋ features exist.
    expansion : {"relevance", "random"}, default "relevance"
        Which potential feature the fixed rate adds: "relevance" the most relevant (Section
        4.1.4's online iFDD at a fixed rate), "random" one drawn uniformly (the Random
        Expansion baseline of Section 4.1.4, Fig. 4-7; `RandomExpansion` names it). "random"
        needs ``discovery_rate``.

    Attributes
    ----------
    base_ : Representation
        The set-up clone of ``base``.
    num_features_ : int
        n_t, the current number of features.
    num_initial_features_ : int
        n₀.
    num_discovered_ : int
        n_t − n₀.
    parents_ : ndarray of int64, shape (num_features_, 2)
        Row f holds the parents (g, h) of feature f; (−1, −1) for initial features.
    relevances_ : ndarray of float64
        ψ of each potential (not yet discovered) feature, in order of first co-activation;
        `potential_features` gives their sets too.
    num_discover_calls_ : int
        t, the number of `discover` calls (the time of Eq. 4.6).

    Notes
    -----
    Symbols: φ⁰ ``base``, φ̇(s) ``active_features``, ξ ``discovery_threshold``, ψ relevances,
    δ ``td_error``, Δ_f and ν_f the sum of δ and the count of Eq. 4.3, C ``discovery_rate``.

    - Choice: a conjunction is its SET of initial features, so pairs (g, h) with the same
      union share one relevance. Its parents are the pair that last updated it (with the
      threshold rule, the pair co-active when it is discovered).
    - Choice (tie rule of Alg 19): among conjunctions of equal size the latest discovered is
      activated first, as Algorithm 18 (℧) applies columns from n down; a feature is only
      activated if all its initial features are still uncovered, so φ̇ is a disjoint cover
      (as ℧ gives; RLPy's fix of the ICML 2011 algorithm). With this rule Theorem 3.4.4 holds.
    - Choice: pairs are visited as (φ̇[i], φ̇[j]) for i < j in increasing feature id, and a
      feature is discovered as soon as its relevance passes ξ, so one step may add several.
    - Choice (iFDD⁺): "ifdd_plus" uses |Δ_f| / √ν_f, as RLPy (the thesis author's library)
      does: the new weight may take either sign, so the sign of the correlation does not
      matter (Theorem 3.2.6 lets ξ be any real). Alg 21 as printed (no |·|, which the thesis
      says yields smaller relevances) is "ifdd_plus_signed".
    - Choice (Eq. 4.6): n_t = n₀ + ⌊√(C t)⌋ with t the number of `discover` calls; the most
      relevant potential feature goes first (ties to the first seen). Relevances keep being
      tracked after ``max_features`` is reached.
    - Choice (``expansion="random"``): the potential features are kept in a list with
      swap-removal, and the i-th draw picks index ⌊u_i · P⌋ with
      u_i = splitmix64(word + i · 0xD1B54A32D192ED03) / 2⁶⁴ (top 53 bits), ``word`` drawn
      from the setup seed: counter-based randomness, so saving and restoring needs only the
      draw count, and the draws never touch numpy's global RNG. Relevances are still
      tracked, for inspection only.
    - Choice: keys are XORs of per-initial-feature random 64-bit words drawn from the setup
      seed; every hash hit is checked against the stored index list, so a key collision never
      merges two conjunctions.

    Complexity
    ----------
    `discover`: Θ(k_t² k₀) per call for k_t active features (Section 4.1.3: Θ(k_t²) pairs);
    Θ(k_t² (k₀ + log P)) with the fixed rate's heap over P potential features.
    `active_features`: a miss finds the m features within the active initial set from a
    parent index (each feature is found from its later-found parent, by walking that parent's
    children or by looking up its pairs with the features found before it, whichever is
    cheaper: at most Θ(m²), m ≤ 2^k₀ as in Algorithm 19's Θ(k₀ 2^k₀)), then covers greedily
    with bit sets, Θ(m log m). The m found per miss grows with n_t toward that bound (on
    Persistent Surveillance, a median of 42 at 100 discovered features and 205 at 200,000).
    Covers are cached per initial set in a direct-mapped table over a ring of cells (a miss
    overwrites one row; the oldest cells expire first, never the whole cache); a hit is
    re-checked against the features discovered since, Θ(k₀) each. Neither bound depends on
    n_t.

    Examples
    --------
    >>> from conjure.core import DomainSpec
    >>> from conjure.representations import IndependentDiscretization
    >>> spec = DomainSpec(name="box", low=[0.0, 0.0], high=[1.0, 1.0], is_discrete=[False, False],
    ...                   num_actions=2, discount=0.9, max_episode_steps=10)
    >>> rep = OnlineIFDD(base=IndependentDiscretization(num_buckets=2)).setup(spec, seed=0)
    >>> phi = rep.active_features([0.9, 0.9])
    >>> phi.tolist()
    [1, 3]
    >>> expansion = rep.discover(phi, td_error=2.0)  # ψ = |δ| = 2 > ξ = 1
    >>> expansion.first_new, expansion.parents.tolist()
    (4, [[1, 3]])
    >>> rep.active_features([0.9, 0.9]).tolist(), rep.active_features([0.9, 0.1]).tolist()
    ([4], [1, 2])
    """

    parameter_constraints = {
        "base": InstanceOf(Representation, "a binary Representation"),
        "discovery_threshold": Interval(float, 0, None),
        "relevance": Options(tuple(_RELEVANCES)),
        "sparsify": InstanceOf(bool, "a bool"),
        "max_features": OPTIONAL_MAX_FEATURES,
        "discovery_rate": Interval(float, 0, None, closed="neither") | InstanceOf(type(None)),
        "expansion": Options(("relevance", "random")),
    }

    is_adaptive = True

    def __init__(
        self,
        *,
        base: Representation,
        discovery_threshold: float = 1.0,
        relevance: str = "ifdd",
        sparsify: bool = True,
        max_features: int | None = None,
        discovery_rate: float | None = None,
        expansion: str = "relevance",
    ):
        self.base = base
        self.discovery_threshold = discovery_threshold
        self.relevance = relevance
        self.sparsify = sparsify
        self.max_features = max_features
        self.discovery_rate = discovery_rate
        self.expansion = expansion

    # ------------------------------------------------------------------ settings

    def _selection(self) -> tuple[int, float]:
        """Return the kernels' selection rule and C (0 for the threshold rule)."""
        if self.discovery_rate is None:
            if self.expansion == "random":
                raise InvalidParameterError(
                    f"{type(self).__name__}: expansion='random' adds features at the fixed "
                    f"rate of Eq. 4.6; set discovery_rate (C > 0)."
                )
            return _k.SELECT_THRESHOLD, 0.0
        if self.expansion == "random":
            return _k.SELECT_RATE_RANDOM, float(self.discovery_rate)
        return _k.SELECT_RATE_RELEVANCE, float(self.discovery_rate)

    # ------------------------------------------------------------------ lifecycle

    def setup(self, spec: DomainSpec, seed: int | np.random.SeedSequence) -> OnlineIFDD:
        """Validate the parameters, set up a clone of ``base`` and start from its n₀ features."""
        self.validate_params()
        selection, rate = self._selection()
        seeds = split_seed(seed, ("base", "conjunctions"))
        base = self.base.clone().setup(spec, seeds["base"])
        check_binary_features(base, f"{type(self).__name__}.base: iFDD")
        n0 = int(base.num_features_)
        where = f"{type(base).__name__} on {spec.name!r}"
        check_max_features(type(self).__name__, self.max_features, n0, where)
        rng = make_rng(seeds["conjunctions"])
        ints = np.zeros(_k.NUM_INTS, dtype=np.int64)
        counts = dict(zip(_k.COUNTERS, ints[:, None], strict=True))  # named one-cell views
        counts["num_features"][0] = n0
        counts["num_initial"][0] = n0
        counts["pool_used"][0] = n0
        counts["relevance"][0] = _RELEVANCES[self.relevance]
        counts["selection"][0] = selection
        counts["max_features"][0] = (
            np.iinfo(np.int64).max if self.max_features is None else (self.max_features)
        )
        counts["random_word"][0] = rng.integers(0, 2**63 - 1, dtype=np.int64)
        counts["sparsify"][0] = int(self.sparsify)
        floats = np.array([self.discovery_threshold, rate], dtype=np.float64)  # _k.SETTINGS
        node_capacity = 1024
        arrays: dict[str, np.ndarray] = {
            "words": rng.integers(-(2**63), 2**63 - 1, size=n0, dtype=np.int64, endpoint=True),
            "pool": np.zeros(n0 + 8 * node_capacity, dtype=np.int64),
            "feat_start": np.zeros(n0 + node_capacity, dtype=np.int64),
            "feat_len": np.zeros(n0 + node_capacity, dtype=np.int64),
            "feat_parents": np.full((n0 + node_capacity, 2), -1, dtype=np.int64),
            "node_key": np.zeros(node_capacity, dtype=np.int64),
            "node_start": np.zeros(node_capacity, dtype=np.int64),
            "node_len": np.zeros(node_capacity, dtype=np.int64),
            "node_feature": np.full(node_capacity, -1, dtype=np.int64),
            "node_parents": np.full((node_capacity, 2), -1, dtype=np.int64),
            "node_stats": np.zeros((node_capacity, 3), dtype=np.float64),
            "node_slot": np.full(node_capacity, -1, dtype=np.int64),
            "heap": np.zeros(node_capacity, dtype=np.int64),
            "table": np.full(4 * node_capacity, -1, dtype=np.int64),
            "ints": ints,
            "floats": floats,
        }
        arrays["pool"][:n0] = np.arange(n0)
        arrays["feat_start"][:n0] = np.arange(n0)
        arrays["feat_len"][:n0] = 1
        self.spec_ = spec
        self.base_ = base
        self.num_initial_features_ = n0
        self._install(arrays)
        self.is_set_up_ = True
        return self

    def _install(
        self, arrays: dict[str, np.ndarray], cache: tuple[np.ndarray, ...] | None = None
    ) -> None:
        """Bind the state arrays, the activation cache (fresh if none) and the kernel tables."""
        self._arrays = arrays
        # named one-cell views of the counters (the kernels' own, `_k.COUNTERS`)
        self._counts = dict(zip(_k.COUNTERS, arrays["ints"][:, None], strict=True))
        if cache is None:
            cache = (
                np.zeros((_CACHE_ROWS, _k.NUM_C), dtype=np.int64),
                np.zeros(_CACHE_CELLS, dtype=np.int64),
            )
            self._counts["cache_written"][0] = 0
        self._centry, self._cpool = cache
        capacity = arrays["feat_start"].shape[0]
        # the parent index, derived from feat_parents (filled lazily by the kernel)
        index = {
            "links": np.zeros((capacity, _k.NUM_L), dtype=np.int64),
            "children": np.zeros((4 * capacity + 8, 2), dtype=np.int64),  # used: children_used
            "pair_table": np.full((1 << int(2 * capacity - 1).bit_length(), 3), -1, dtype=np.int64),
        }
        for name in ("linked", "children_used", "search_capacity"):  # for the new index
            self._counts[name][0] = 0
        self._tables = _k.new_tables(
            {**arrays, **index, "centry": self._centry, "cpool": self._cpool},
            arrays["ints"],
            arrays["floats"],
        )
        self._encode_base = self.base_.active_features

    compiled_methods = ("active_features", "encode", "discover", "activate_initial")

    def compiled_form(self) -> IFDDKernel | None:
        """The base's kernel with iFDD's own tables (`kernel_tables`, updated in place).

        None when the base has no compiled kernel or real-valued φ (iFDD needs binary φ⁰).
        """
        check_is_set_up(self, "compiled_form")
        base = compiled_form(self.base_)
        if base is None or base.rbf is not None:
            return None
        return IFDDKernel(
            base=base, is_ifdd=True, tables=self.kernel_tables(), splits=False, tiles=NO_TILES
        )

    def grow_tables(self) -> None:
        """Double the node, feature and pool capacities and rebuild the hash table.

        `discover` calls it when a discovery would not fit; the compiled loop calls it when
        `discover_room` says so. The features, relevances and cached covers are unchanged.
        """
        a = dict(self._arrays)
        n0 = self.num_initial_features_
        node_capacity = 2 * a["node_key"].shape[0]
        sizes = {name: node_capacity for name in _NODE_ARRAYS}
        sizes.update({name: n0 + node_capacity for name in _FEATURE_ARRAYS})
        sizes["pool"] = 2 * a["pool"].shape[0]
        for name, size in sizes.items():
            old = a[name]
            grown = np.full((size, *old.shape[1:]), -1 if name in _MINUS_ONE else 0, old.dtype)
            grown[: old.shape[0]] = old
            a[name] = grown
        a["table"] = np.full(4 * node_capacity, -1, dtype=np.int64)
        _k.rebuild_table(a["table"], a["node_key"], int(self._counts["num_nodes"][0]))
        cache = (self._centry, self._cpool)
        self._install(a, cache)  # cached covers stay valid: no feature was added

    # ------------------------------------------------------------------ Algorithm 19

    def active_features(self, state: np.ndarray) -> np.ndarray:
        """Return φ̇(s): the sorted int64 ids of the sparsified active features (Alg 19)."""
        try:
            encode = self._encode_base
        except AttributeError:
            check_is_set_up(self, "active_features")
            raise
        return _k.activate(encode(state), self._tables)

    def activate_initial(self, initial: np.ndarray) -> np.ndarray:
        """Return φ̇ for a sorted set of active initial feature ids (Alg 19 without φ⁰)."""
        check_is_set_up(self, "activate_initial")
        initial = np.unique(np.asarray(initial, dtype=np.int64))
        n0 = self.num_initial_features_
        if initial.size and (initial[0] < 0 or initial[-1] >= n0):
            raise InvalidParameterError(
                f"{type(self).__name__}.activate_initial: initial feature ids must lie in "
                f"[0, {n0}); got {initial.tolist()}."
            )
        return _k.activate(initial, self._tables)

    # ------------------------------------------------------------------ Algorithms 20 and 21

    def discover(
        self, active: np.ndarray, td_error: float, state: np.ndarray | None = None
    ) -> Expansion | None:
        """Update the relevances of the co-active pairs of φ̇(s) with δ; add features (Alg 20/21).

        ``active`` must be the φ̇(s) used in the TD update. Returns the new features with their
        parents (θ_f = θ_g + θ_h, Section 4.1.1), or ``None`` if none was added.
        """
        check_is_set_up(self, "discover")
        before = self.num_features_
        while True:
            added = _k.discover(active, float(td_error), self._tables)
            if added >= 0:
                break
            self.grow_tables()
        if added == 0:
            return None
        parents = self._arrays["feat_parents"][before : before + added].copy()
        return Expansion(first_new=before, parents=parents)

    # ------------------------------------------------------------------ the compiled form

    def kernel_tables(self) -> _k.IFDDTables:
        """Return the tables the kernels read and update in place, as one named value.

        `conjure.representations._ifdd_kernels.IFDDTables` (a numba structref) holds every
        table of the module's docstring and the counters and settings by name; the compiled
        loop passes it to the same `activate`, `discover_room` and `discover_fitting` that
        `active_features` and `discover` call. It is replaced (not resized) when the tables
        grow: ask again after `grow_tables`.
        """
        check_is_set_up(self, "kernel_tables")
        return self._tables

    @property
    def feature_capacity_(self) -> int:
        """The number of features the current tables hold (θ needs as many rows)."""
        check_is_set_up(self, "feature_capacity_")
        return int(self._arrays["feat_start"].shape[0])

    # ------------------------------------------------------------------ inspection

    @property
    def num_features_(self) -> int:
        """n_t, the current number of features (the kernels' counter)."""
        try:
            counts = self._counts
        except AttributeError:
            check_is_set_up(self, "num_features_")
            raise
        return int(counts["num_features"][0])

    @property
    def num_discovered_(self) -> int:
        """n_t − n₀, the number of discovered conjunctions."""
        check_is_set_up(self, "num_discovered_")
        return self.num_features_ - self.num_initial_features_

    @property
    def num_discover_calls_(self) -> int:
        """t, the number of `discover` calls so far."""
        check_is_set_up(self, "num_discover_calls_")
        return int(self._counts["num_calls"][0])

    @property
    def parents_(self) -> np.ndarray:
        """(num_features_, 2) parents of each feature; (−1, −1) for initial features."""
        check_is_set_up(self, "parents_")
        return self._arrays["feat_parents"][: self.num_features_].copy()

    def initial_set(self, feature: int) -> np.ndarray:
        """Return the sorted initial feature ids whose conjunction is ``feature``."""
        check_is_set_up(self, "initial_set")
        if not 0 <= feature < self.num_features_:
            raise InvalidParameterError(
                f"{type(self).__name__}.initial_set: feature must be in "
                f"[0, {self.num_features_}); got {feature!r}."
            )
        a = self._arrays
        start = a["feat_start"][feature]
        return a["pool"][start : start + a["feat_len"][feature]].copy()

    @property
    def initial_sets_(self) -> list[np.ndarray]:
        """The initial set of every feature, in feature order."""
        return [self.initial_set(f) for f in range(self.num_features_)]

    def potential_features(self) -> tuple[list[np.ndarray], np.ndarray, np.ndarray]:
        """Return the potential features: (initial sets, last parents (P, 2), relevances ψ)."""
        check_is_set_up(self, "potential_features")
        a = self._arrays
        num_nodes = int(self._counts["num_nodes"][0])
        nodes = np.flatnonzero(a["node_feature"][:num_nodes] < 0)
        sets = [
            a["pool"][a["node_start"][v] : a["node_start"][v] + a["node_len"][v]].copy()
            for v in nodes
        ]
        kind = int(self._counts["relevance"][0])
        relevances = np.array(
            [_k.relevance_of(a["node_stats"][v], kind) for v in nodes], dtype=np.float64
        )
        return sets, a["node_parents"][nodes].copy(), relevances

    @property
    def relevances_(self) -> np.ndarray:
        """ψ of each potential feature, in order of first co-activation."""
        return self.potential_features()[2]

    # ------------------------------------------------------------------ persistence

    def state_arrays(self) -> dict[str, np.ndarray]:
        """Return copies of every table, the counters and the base's arrays (``base.*``).

        Features, potential features, relevances, the hash table and the random stream's
        position are all included, so a restored representation continues exactly.
        """
        check_is_set_up(self, "state_arrays")
        arrays = {name: self._arrays[name].copy() for name in _STATE_ARRAYS}
        for name in _k.TRANSIENT_COUNTERS:  # rebuilt on load
            arrays["ints"][_k.COUNTERS.index(name)] = 0
        arrays.update({f"base.{k}": v for k, v in self.base_.state_arrays().items()})
        return arrays

    def load_state_arrays(self, arrays: dict[str, np.ndarray]) -> None:
        """Restore `state_arrays`' output into a representation set up with the same spec."""
        check_is_set_up(self, "load_state_arrays")
        missing = [name for name in _STATE_ARRAYS if name not in arrays]
        if missing:
            raise InvalidParameterError(
                f"{type(self).__name__}.load_state_arrays: missing {missing}; were the arrays "
                f"saved from another representation?"
            )
        loaded = {name: np.array(arrays[name]) for name in _STATE_ARRAYS}
        if loaded["words"].shape != (self.num_initial_features_,):
            raise InvalidParameterError(
                f"{type(self).__name__}.load_state_arrays: saved with "
                f"{loaded['words'].shape[0]} initial features, but the base has "
                f"{self.num_initial_features_}; was it saved with another spec or base?"
            )
        self.base_.load_state_arrays(
            {k[len("base.") :]: v for k, v in arrays.items() if k.startswith("base.")}
        )
        self._install(loaded)
