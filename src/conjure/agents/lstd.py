"""LSTD policy evaluation from samples (Geramifard 2012, Eqs. 2.37-2.39), also as an agent."""

from __future__ import annotations

import time
from collections.abc import Sequence

import numpy as np
import scipy.sparse as sp

from conjure.agents import persistence
from conjure.agents.batch import BATCH_PARAMETERS, BatchAgent
from conjure.core.errors import InvalidParameterError
from conjure.core.interfaces import (
    DomainSpec,
    Policy,
    Representation,
    Transition,
    check_is_set_up,
)
from conjure.core.linalg import lstd_system, solve_regularized

__all__ = ["LSTD"]


class LSTD(BatchAgent):
    """Evaluate the policy that generated the samples: θ = Ã⁻¹b̃ (Eqs. 2.37-2.39).

    Ã = Φ̃ᵀ(Φ̃ − γP̃Φ̃)/L and b̃ = Φ̃ᵀR̃/L from L transitions ⟨s_i, r_i, s'_i⟩ (Bradtke and Barto
    1996; Geramifard 2012, Section 2.6.4), assembled sparsely from the active features.

    As an agent in a run, LSTD is Algorithm 13's cycle (trajectory sampling Q-API): it
    gathers samples with π^ε, and each fit evaluates V^π (`fit`, Eqs. 2.37-2.39) and Q^π of
    the sampling policy (LSTD-Q: Eqs. 2.34-2.36 with the sampled a'_i), then acts greedily on
    Q^π: one policy-improvement step per fit.

    Parameters
    ----------
    representation : Representation
        φ(s), read through its `encode` (binary or real-valued features).
    regularization : float, default 1e-6
        λ ≥ 0 added to Ã's diagonal where the inverse does not exist.
    policy : Policy or None, default None
        Behaviour policy π^ε of ``act`` (``None``: ε-greedy, ε = 0.1).
    fit_every : int or None, default None
        In a run: fit before every policy check (``None``) or after every N new samples, N in
        [1, inf) (see `BatchAgent`).

    Attributes
    ----------
    representation_ : Representation
        The set-up representation.
    weights_ : ndarray, shape (n,)
        θ, so that V(s) = φ(s)ᵀθ.
    q_weights_ : ndarray, shape (n, |A|)
        θ̄ of Q^π of the last sampling policy (zero before the first fit in a run).
    a_, b_ : sparse matrix (n, n), ndarray (n,)
        Ã and b̃ of the last fit.
    wall_time_s_ : float
        Seconds the last fit took.
    iterations_ : int
        Always 1 (one solve).

    Notes
    -----
    - Choice: a terminal transition contributes φ(s') = 0 (V(terminal) = 0).
    - Choice: λ defaults to 10⁻⁶; Figure 2-5's numbers use λ = 10⁻⁴.
    - Choice (in a run): Q^π, not V^π, drives the improvement step, since a greedy step on V
      would need the model; each fit uses only the samples gathered since the previous fit
      (one policy's samples) and then drops them, as Algorithm 13 does. `fit` alone (the
      batch API) evaluates V only.

    Complexity
    ----------
    Θ(Lk²) to assemble with k active features, plus a sparse solve (Θ(n³) dense); in a run,
    also one LSTD-Q solve of n|A| unknowns per fit.

    Examples
    --------
    >>> from conjure.representations import Tabular
    >>> spec = DomainSpec(name="two", low=[0.0], high=[1.0], is_discrete=[True], num_actions=1,
    ...                   discount=0.9, max_episode_steps=10)
    >>> t = [Transition(np.array([0.0]), 0, 1.0, np.array([1.0]), 0, False),
    ...      Transition(np.array([1.0]), 0, 0.0, np.array([0.0]), 0, False)]
    >>> LSTD(representation=Tabular(), regularization=0.0).setup(spec, 0).fit(t).weights_.round(3)
    array([5.263, 4.737])
    """

    parameter_constraints = {**BATCH_PARAMETERS}

    def __init__(
        self,
        *,
        representation: Representation,
        regularization: float = 1e-6,
        policy: Policy | None = None,
        fit_every: int | None = None,
    ):
        self.representation = representation
        self.regularization = regularization
        self.policy = policy
        self.fit_every = fit_every

    def setup(self, spec: DomainSpec, seed: int | np.random.SeedSequence = 0) -> LSTD:
        """Validate parameters and set up the representation for ``spec``; θ = 0."""
        super().setup(spec, seed)
        n = self.representation_.num_features_
        self.weights_ = np.zeros(n)
        self.q_weights_ = np.zeros((n, spec.num_actions))
        return self

    def fit(self, transitions: Sequence[Transition] | None = None) -> LSTD:
        """Estimate θ of V from ``transitions`` (Eqs. 2.37-2.39) and return ``self``.

        ``None`` uses the samples stored by ``learn``.
        """
        check_is_set_up(self, "fit")
        started = time.perf_counter()
        transitions = self._batch(transitions)
        if not transitions:
            raise InvalidParameterError("LSTD.fit needs at least one transition; got none.")
        phi = self._feature_matrix([t.state for t in transitions])
        live = np.array([not t.terminated for t in transitions], dtype=np.float64)
        phi_next = sp.diags(live) @ self._feature_matrix([t.next_state for t in transitions])
        rewards = np.array([t.reward for t in transitions], dtype=np.float64)
        self.a_, self.b_ = lstd_system(phi, sp.csr_matrix(phi_next), rewards, self.spec_.discount)
        self.weights_ = solve_regularized(self.a_, self.b_, float(self.regularization))
        self.iterations_ = 1
        self.wall_time_s_ = time.perf_counter() - started
        return self

    def value(self, state: np.ndarray) -> float:
        """V(s) = φ(s)ᵀθ."""
        check_is_set_up(self, "value")
        return float(self.values([state])[0])

    def values(self, states: Sequence[np.ndarray]) -> np.ndarray:
        """V of every state in ``states``."""
        check_is_set_up(self, "values")
        return np.asarray(self._feature_matrix(states) @ self.weights_).reshape(-1)

    # ------------------------------------------------------------------ persistence

    def state_arrays(self) -> dict[str, np.ndarray]:
        return {**super().state_arrays(), "weights": self.weights_, "q_weights": self.q_weights_}

    def load_state(self, saved: persistence.SavedAgent) -> None:
        super().load_state(saved)
        n, num_actions = self.representation_.num_features_, self.spec_.num_actions
        self.weights_ = saved.array("weights", (n,))
        self.q_weights_ = saved.array("q_weights", (n, num_actions))
