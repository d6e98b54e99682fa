"""Feature Discovery LSTD, batch iFDD for policy evaluation (Geramifard 2012, Algorithm 16)."""

from __future__ import annotations

import time
from collections.abc import Sequence
from typing import Any

import numpy as np
import scipy.sparse as sp

from conjure.agents import persistence
from conjure.agents.batch import BATCH_PARAMETERS, BatchAgent
from conjure.agents.lstd import LSTD
from conjure.core.errors import InvalidParameterError
from conjure.core.interfaces import (
    DomainSpec,
    Policy,
    Representation,
    SparseFeatures,
    Transition,
    check_binary_features,
    check_is_set_up,
)
from conjure.core.linalg import feature_matrix, lstd_system, solve_regularized
from conjure.core.params import InstanceOf, Interval, Options
from conjure.core.seeding import make_rng

__all__ = ["FDLSTD"]


def _columns(matrix: sp.csr_matrix) -> list[np.ndarray]:
    """The sorted sample rows where each column is active."""
    csc = sp.csc_matrix(matrix)
    return [csc.indices[csc.indptr[j] : csc.indptr[j + 1]].copy() for j in range(csc.shape[1])]


def _matrix(columns: list[np.ndarray], num_rows: int) -> sp.csr_matrix:
    """The binary (num_rows × len(columns)) matrix whose column j is active on ``columns[j]``."""
    lengths = np.fromiter((c.size for c in columns), dtype=np.int64, count=len(columns))
    indptr = np.concatenate([[0], np.cumsum(lengths)])
    indices = np.concatenate(columns) if columns else np.zeros(0, dtype=np.int64)
    data = np.ones(indices.size)
    return sp.csr_matrix(sp.csc_matrix((data, indices, indptr), shape=(num_rows, len(columns))))


class FDLSTD(BatchAgent):
    """Evaluate a fixed policy by LSTD while adding one feature conjunction per iteration.

    Geramifard (2012), Algorithm 16 (Section 3.3): from L₁ samples ⟨s_i, r_i, s'_i⟩ of the
    policy, solve LSTD (Eqs. 2.37-2.39, lines 2-3); then repeatedly pick the pair f = g ∧ h of
    existing features by Eq. 3.19 (iFDD) or Eq. 3.18 (iFDD⁺) (line 5), add it (line 6) and
    solve again (lines 7-8). The "random" and "best" expansions are the baselines of Section
    3.3.1 and Figure 3-15.

    Parameters
    ----------
    representation : Representation
        The initial binary features χ (e.g. `IndependentDiscretization`, 20 buckets per
        dimension on the pendulum, as in Section 3.3.1).
    expansion : str, default "ifdd_plus_signed"
        Line 5's rule: "ifdd" is Eq. 3.19 (Σ|δ| over the samples where f is active);
        "ifdd_plus_signed" Eq. 3.18 as printed, Σδ / √count (FDLSTD⁺); "ifdd_plus" Eq. 3.18
        with the magnitude |Σδ| / √count (RLPy's batch iFDD⁺); "random" uniform over the
        pairs active on some sample; "best" the pair whose addition minimises the sample
        RMSE to a reference value function.
    num_expansions : int, default 20
        Iterations of the repeat loop (features added), in [0, inf).
    regularization : float, default 1e-6
        λ ≥ 0 added to Ã's diagonal where the inverse does not exist.
    reference_representation : Representation or None, default None
        For ``"best"`` when `fit` receives no reference: the tabular representation of the
        reference LSTD (``None``: `Tabular` with 20 buckets per dimension).
    seed : int, default 0
        Seed of the random expansion, in [0, inf).
    policy : Policy or None, default None
        Behaviour policy π^ε of ``act`` in a run (``None``: ε-greedy, ε = 0.1).
    fit_every : int or None, default None
        In a run: fit before every policy check (``None``) or after every N new samples, N in
        [1, inf) (see `BatchAgent`).

    Attributes
    ----------
    representation_ : Representation
        The set-up initial representation.
    features_ : list of tuple of int
        Every feature as the initial features it conjoins (initial ones are singletons).
    parents_ : ndarray of int64, shape (num_expansions_, 2)
        The pair (g, h) each added feature conjoins.
    scores_ : ndarray of float64, shape (num_expansions_,)
        The chosen pair's relevance (iFDD, iFDD⁺), sample RMSE (best) or NaN (random).
    weights_ : ndarray, shape (num_features_,)
        θ, so that V(s) = φ(s)ᵀθ.
    q_weights_ : ndarray, shape (n, |A|)
        θ̄ of Q^π over the χ of the last fit in a run (zero before it).
    num_features_ : int
        n after the expansions.
    reference_ : ndarray or None
        The reference V at the sample states (``"best"`` only).
    iterations_ : int
        Expansions made (fewer than ``num_expansions`` when no pair is left).
    wall_time_s_ : float
        Seconds the last `fit` took.

    Notes
    -----
    ======  ======================  ====================================
    Symbol  Name                    Meaning
    ======  ======================  ====================================
    χ       features_               the current features
    θ       weights_                LSTD weights
    δ_i     (TD errors)             r_i + [γφ(s'_i) − φ(s_i)]ᵀθ
    ψ_f     scores_                 relevance of the chosen pair
    ======  ======================  ====================================

    - Choice: φ_f(s) = 1 iff every initial feature of f is active; features are not
      sparsified (Section 3.4's ℧ is the online version's), and a pair whose union already
      is a feature is not a candidate.
    - Choice (Eq. 3.18): the default is the equation as printed, argmax Σδ / √count
      ("ifdd_plus_signed", the thesis's FDLSTD⁺), as the thesis is the specification.
      "ifdd_plus" is RLPy's |Σδ| / √count (the names match `OnlineIFDD`'s relevances): the
      new weight of Theorem 3.2.6 may take either sign, so a conjunction where V is
      over-estimated can help as much as one where it is under-estimated, and the signed
      argmax passes it over. Fig. 3-15's page compares the two
      (docs/reproduction/fig_3_15.md).
    - Choice: ties go to the pair (g, h) with the smallest g, then h.
    - Choice ("best"): the reference V is a given array (V at each sample's state), an object
      with ``values(states)``, or, by default, LSTD with a tabular representation on the
      samples given to `fit`; the thesis used 100,000 samples, so pass a reference built on
      many samples when the batch is small.
    - Choice: a terminal transition contributes φ(s') = 0.
    - Choice (as an agent in a run, as `LSTD`): each fit runs Algorithm 16 from the initial
      features on the samples of π^ε gathered since the previous fit, then evaluates Q^π
      over the discovered χ by LSTD-Q (Eqs. 2.34-2.36 with the sampled a'_i) and acts
      greedily on it: one policy-improvement step per fit, the features rediscovered for
      each policy. `fit` alone (the batch API) evaluates V only.

    Complexity
    ----------
    Θ(L₁k² + n³) per iteration with k active features per sample: the pair statistics are
    the sparse products Φ̃ᵀ diag(δ) Φ̃ (the thesis's Θ(n³L₁) without sparsity); "best" adds
    one (n+1)-dimensional solve per candidate pair.

    Examples
    --------
    >>> from conjure.representations import Tabular
    >>> spec = DomainSpec(name="two", low=[0.0], high=[1.0], is_discrete=[True], num_actions=1,
    ...                   discount=0.9, max_episode_steps=10)
    >>> t = [Transition(np.array([0.0]), 0, 1.0, np.array([1.0]), 0, False),
    ...      Transition(np.array([1.0]), 0, 0.0, np.array([0.0]), 0, False)]
    >>> agent = FDLSTD(representation=Tabular(), num_expansions=1, regularization=0.0)
    >>> agent.setup(spec, 0).fit(t).weights_.round(3).tolist()  # no co-active pair to add
    [5.263, 4.737]
    """

    parameter_constraints = {
        **BATCH_PARAMETERS,
        "expansion": Options(("ifdd", "ifdd_plus_signed", "ifdd_plus", "random", "best")),
        "num_expansions": Interval(int, 0, None),
        "reference_representation": InstanceOf(
            (Representation, type(None)), "a Representation or None"
        ),
        "seed": Interval(int, 0, None),
    }

    def __init__(
        self,
        *,
        representation: Representation,
        expansion: str = "ifdd_plus_signed",
        num_expansions: int = 20,
        regularization: float = 1e-6,
        reference_representation: Representation | None = None,
        seed: int = 0,
        policy: Policy | None = None,
        fit_every: int | None = None,
    ):
        self.representation = representation
        self.expansion = expansion
        self.num_expansions = num_expansions
        self.regularization = regularization
        self.reference_representation = reference_representation
        self.seed = seed
        self.policy = policy
        self.fit_every = fit_every

    def setup(self, spec: DomainSpec, seed: int | np.random.SeedSequence = 0) -> FDLSTD:
        """Validate parameters and set up the initial representation χ for ``spec``."""
        super().setup(spec, seed)
        rep = self.representation_
        check_binary_features(rep, "FDLSTD")
        self.features_ = [(f,) for f in range(rep.num_features_)]
        self.parents_ = np.zeros((0, 2), dtype=np.int64)
        self.scores_ = np.zeros(0)
        self.weights_ = np.zeros(rep.num_features_)
        self.num_features_ = rep.num_features_
        self.reference_ = None
        self._use_for_q([])
        self.q_weights_ = np.zeros((rep.num_features_, spec.num_actions))
        return self

    # ------------------------------------------------------------------ fitting

    def _reference(self, transitions: Sequence[Transition], reference: Any) -> np.ndarray:
        """V at each sample's state for "best" (given, or tabular LSTD on the samples)."""
        states = [t.state for t in transitions]
        if reference is None:
            tabular = self.reference_representation
            if tabular is None:
                from conjure.representations import Tabular

                tabular = Tabular(num_buckets=20)
            lstd = LSTD(representation=tabular, regularization=float(self.regularization))
            reference = lstd.setup(self.spec_, 0).fit(transitions)
        if hasattr(reference, "values"):
            return np.asarray(reference.values(states), dtype=np.float64)
        values = np.asarray(reference, dtype=np.float64).reshape(-1)
        if values.shape[0] != len(transitions):
            raise InvalidParameterError(
                f"FDLSTD.fit: `reference` must hold V at each of the {len(transitions)} sample "
                f"states; got shape {np.shape(reference)}."
            )
        return values

    def fit(self, transitions: Sequence[Transition] | None = None, reference: Any = None) -> FDLSTD:
        """Run Algorithm 16 on ``transitions`` of the evaluated policy and return ``self``.

        ``transitions`` defaults to the samples stored by ``learn``. ``reference``
        (``"best"`` only) is V at each transition's state, or an object with
        ``values(states)``; ``None`` builds it by tabular LSTD on ``transitions``.
        """
        check_is_set_up(self, "fit")
        started = time.perf_counter()
        transitions = self._batch(transitions)
        if not transitions:
            raise InvalidParameterError("FDLSTD.fit needs at least one transition; got none.")
        rep, discount = self.representation_, self.spec_.discount
        num_samples = len(transitions)
        rng = make_rng(self.seed)
        live = np.array([not t.terminated for t in transitions], dtype=np.float64)
        rewards = np.array([t.reward for t in transitions], dtype=np.float64)
        phi0 = feature_matrix(rep, [t.state for t in transitions])
        phi0_next = sp.csr_matrix(
            sp.diags(live) @ feature_matrix(rep, [t.next_state for t in transitions])
        )
        phi0_next.eliminate_zeros()
        self.features_ = [(f,) for f in range(rep.num_features_)]
        rows, rows_next = _columns(phi0), _columns(phi0_next)  # where each feature is active
        known = {frozenset(f) for f in self.features_}
        self.reference_ = (
            self._reference(transitions, reference) if self.expansion == "best" else None
        )
        parents, scores = [], []

        def solve() -> tuple[sp.csr_matrix, sp.csr_matrix, np.ndarray]:
            phi, phi_next = _matrix(rows, num_samples), _matrix(rows_next, num_samples)
            a, b = lstd_system(phi, phi_next, rewards, discount)  # Eqs. 2.37-2.39
            return phi, phi_next, solve_regularized(a, b, float(self.regularization))

        phi, phi_next, weights = solve()  # lines 2-3
        for _ in range(self.num_expansions):  # line 4: repeat
            candidates = self._candidates(phi, known)
            if not candidates:
                break
            pick, score = self._choose(  # line 5
                candidates, phi, phi_next, weights, rewards, discount, rows, rows_next, rng
            )
            g, h = candidates[pick]
            union = tuple(sorted(set(self.features_[g]) | set(self.features_[h])))
            self.features_.append(union)  # line 6: χ ← χ ∪ {f*}
            known.add(frozenset(union))
            rows.append(np.intersect1d(rows[g], rows[h], assume_unique=True))
            rows_next.append(np.intersect1d(rows_next[g], rows_next[h], assume_unique=True))
            parents.append((g, h))
            scores.append(score)
            phi, phi_next, weights = solve()  # lines 7-8
        self.parents_ = np.array(parents, dtype=np.int64).reshape(-1, 2)
        self.scores_ = np.array(scores, dtype=np.float64)
        self.weights_ = weights
        self.num_features_ = len(self.features_)
        self.iterations_ = len(parents)
        self.wall_time_s_ = time.perf_counter() - started
        return self

    def _candidates(self, phi: sp.csr_matrix, known: set[frozenset]) -> list[tuple[int, int]]:
        """pair(χ) active on some sample, minus pairs whose union is already a feature."""
        coactive = sp.triu(sp.csr_matrix(phi.T) @ phi, k=1).tocoo()  # counts of g ∧ h
        order = np.lexsort((coactive.col, coactive.row))
        pairs, seen = [], set()
        for g, h in zip(coactive.row[order].tolist(), coactive.col[order].tolist(), strict=True):
            union = frozenset(self.features_[g]) | frozenset(self.features_[h])
            if union in known or union in seen:
                continue
            seen.add(union)
            pairs.append((g, h))
        return pairs

    def _choose(
        self,
        candidates: list[tuple[int, int]],
        phi: sp.csr_matrix,
        phi_next: sp.csr_matrix,
        weights: np.ndarray,
        rewards: np.ndarray,
        discount: float,
        rows: list[np.ndarray],
        rows_next: list[np.ndarray],
        rng: np.random.Generator,
    ) -> tuple[int, float]:
        """Line 5: the index of f* among ``candidates`` and its score."""
        if self.expansion == "random":
            return int(rng.integers(len(candidates))), float("nan")
        g = np.array([c[0] for c in candidates])
        h = np.array([c[1] for c in candidates])
        if self.expansion in ("ifdd", "ifdd_plus", "ifdd_plus_signed"):
            td = rewards + discount * (phi_next @ weights) - phi @ weights  # δ_i
            phi_t = sp.csr_matrix(phi.T)
            count = np.asarray((phi_t @ phi)[g, h]).reshape(-1)
            if self.expansion == "ifdd":  # Eq. 3.19
                score = np.asarray((phi_t @ sp.diags(np.abs(td)) @ phi)[g, h]).reshape(-1)
            else:  # Eq. 3.18: Σδ / √count as printed, or its magnitude
                total = np.asarray((phi_t @ sp.diags(td) @ phi)[g, h]).reshape(-1)
                signed = self.expansion == "ifdd_plus_signed"
                score = (total if signed else np.abs(total)) / np.sqrt(count)
            pick = int(np.argmax(score))
            return pick, float(score[pick])
        return self._best(candidates, phi, phi_next, rewards, discount, rows, rows_next)

    def _best(
        self,
        candidates: list[tuple[int, int]],
        phi: sp.csr_matrix,
        phi_next: sp.csr_matrix,
        rewards: np.ndarray,
        discount: float,
        rows: list[np.ndarray],
        rows_next: list[np.ndarray],
    ) -> tuple[int, float]:
        """argmin_f RMSE over the samples of V − Ṽ_{χ ∪ {f}} (Section 3.3.1's "Best")."""
        num_samples, n = phi.shape
        new = [np.intersect1d(rows[g], rows[h], assume_unique=True) for g, h in candidates]
        new_next = [
            np.intersect1d(rows_next[g], rows_next[h], assume_unique=True) for g, h in candidates
        ]
        f_mat, f_next = _matrix(new, num_samples), _matrix(new_next, num_samples)
        a, b = lstd_system(phi, phi_next, rewards, discount)
        a = a.toarray()
        phi_t, f_t = sp.csr_matrix(phi.T), sp.csr_matrix(f_mat.T)
        right = (phi_t @ (f_mat - discount * f_next)).toarray() / num_samples  # Ã's new column
        below = (f_t @ (phi - discount * phi_next)).toarray() / num_samples  # Ã's new row
        corner = np.asarray((f_t @ (f_mat - discount * f_next)).diagonal()) / num_samples
        b_new = (f_t @ rewards) / num_samples
        reference = self.reference_
        extended = np.zeros((n + 1, n + 1))
        extended[:n, :n] = a
        errors = np.empty(len(candidates))
        for j in range(len(candidates)):
            extended[:n, n], extended[n, :n], extended[n, n] = right[:, j], below[j], corner[j]
            theta = solve_regularized(extended, np.append(b, b_new[j]), float(self.regularization))
            values = phi @ theta[:n]
            values[new[j]] += theta[n]
            errors[j] = np.sqrt(np.mean((reference - values) ** 2))
        pick = int(np.argmin(errors))
        return pick, float(errors[pick])

    # ------------------------------------------------------------------ values

    def encode(self, states: Sequence[np.ndarray]) -> sp.csr_matrix:
        """Φ over the current features χ (initial features and conjunctions) for ``states``."""
        check_is_set_up(self, "encode")
        phi0 = feature_matrix(self.representation_, states)
        columns = _columns(phi0)
        for members in self.features_[phi0.shape[1] :]:
            active = columns[members[0]]
            for m in members[1:]:
                active = np.intersect1d(active, columns[m], assume_unique=True)
            columns.append(active)
        return _matrix(columns, phi0.shape[0])

    def values(self, states: Sequence[np.ndarray]) -> np.ndarray:
        """Ṽ^π = Φ_χθ for every state in ``states`` (line 9)."""
        check_is_set_up(self, "values")
        return np.asarray(self.encode(states) @ self.weights_).reshape(-1)

    def value(self, state: np.ndarray) -> float:
        """Ṽ^π(s) = φ_χ(s)ᵀθ."""
        return float(self.values([state])[0])

    # ------------------------------------------------------------------ as an agent

    @property
    def num_features(self) -> int:
        """n, the number of features of χ (initial features and conjunctions)."""
        check_is_set_up(self, "num_features")
        return int(self.num_features_)

    def _fit_samples(self, batch: list[Transition]) -> None:
        super()._fit_samples(batch)  # Algorithm 16, then Q^π over the new χ
        self._use_for_q(self.features_[self.representation_.num_features_ :])

    def _feature_matrix(self, states: Sequence[np.ndarray]) -> sp.csr_matrix:
        return self.encode(states)

    def _use_for_q(self, conjunctions: list[tuple[int, ...]]) -> None:
        """Index the conjunctions Q is defined over, for a fast single-state φ_χ(s) in ``act``.

        Row j of ``_q_members`` lists conjunction j's initial features, padded with the index
        n₀ of an always-true slot of the indicator.
        """
        n0 = self.representation_.num_features_
        self._q_members = _padded(conjunctions, n0)
        self._indicator = np.zeros(n0 + 1, dtype=bool)

    def _state_features(self, state: np.ndarray) -> SparseFeatures:
        """φ_χ(s) of the χ that Q is defined over: active initial features, then conjunctions."""
        active = self.representation_.active_features(state)
        if self._q_members.shape[0]:
            indicator = self._indicator
            indicator[:] = False
            indicator[active] = True
            indicator[-1] = True
            conjunctions = np.flatnonzero(indicator[self._q_members].all(axis=1))
            active = np.concatenate([active, conjunctions + indicator.shape[0] - 1])
        return SparseFeatures(active, np.ones(active.shape[0]))

    def state_arrays(self) -> dict[str, np.ndarray]:
        n0 = self.representation_.num_features_
        return {
            **super().state_arrays(),
            "weights": self.weights_,
            "q_weights": self.q_weights_,
            "parents": self.parents_,
            "scores": self.scores_,
            "conjunctions": _padded(self.features_[n0:], n0),
            "q_conjunctions": _padded([tuple(m[m < n0]) for m in self._q_members], n0),
        }

    def load_state(self, saved: persistence.SavedAgent) -> None:
        super().load_state(saved)
        n0, num_actions = self.representation_.num_features_, self.spec_.num_actions
        conjunctions = _unpadded(saved, "conjunctions", n0)
        q_conjunctions = _unpadded(saved, "q_conjunctions", n0)
        n, n_q = n0 + len(conjunctions), n0 + len(q_conjunctions)
        self.features_ = [(f,) for f in range(n0)] + conjunctions
        self.num_features_ = n
        self.parents_ = saved.indices("parents", (None, 2), n)
        self.scores_ = saved.array("scores", (self.parents_.shape[0],), is_finite=False)
        self.weights_ = saved.array("weights", (n,))
        self.q_weights_ = saved.array("q_weights", (n_q, num_actions))
        self._use_for_q(q_conjunctions)


def _padded(conjunctions: list[tuple[int, ...]], n0: int) -> np.ndarray:
    """Conjunctions of initial features as rows padded with n0 (for saving)."""
    width = max((len(c) for c in conjunctions), default=2)
    rows = np.full((len(conjunctions), width), n0, dtype=np.int64)
    for j, conjunction in enumerate(conjunctions):
        rows[j, : len(conjunction)] = conjunction
    return rows


def _unpadded(saved: persistence.SavedAgent, name: str, n0: int) -> list[tuple[int, ...]]:
    """Read `_padded` rows back, checking that each conjoins at least two initial features."""
    rows = saved.indices(name, (None, None), n0 + 1)
    conjunctions = [tuple(int(f) for f in row[row < n0]) for row in rows]
    if any(len(c) < 2 or list(c) != sorted(set(c)) for c in conjunctions):
        raise saved.damaged("arrays.npz", f"array {name!r} holds a malformed conjunction")
    return conjunctions
