"""LSTD policy evaluation from samples (Geramifard 2012, Eqs. 2.37-2.39)."""

from __future__ import annotations

import time
from collections.abc import Sequence

import numpy as np
import scipy.sparse as sp

from conjure.core.interfaces import DomainSpec, Representation, Transition, check_is_set_up
from conjure.core.linalg import feature_matrix, lstd_system, solve_regularized
from conjure.core.params import Configurable, InstanceOf, Interval

__all__ = ["LSTD"]


class LSTD(Configurable):
    """Evaluate the policy that generated the samples: θ = Ã⁻¹b̃ (Eqs. 2.37-2.39).

    Ã = Φ̃ᵀ(Φ̃ − γP̃Φ̃)/L and b̃ = Φ̃ᵀR̃/L from L transitions ⟨s_i, r_i, s'_i⟩ (Bradtke and Barto
    1996; Geramifard 2012, Section 2.6.4), assembled sparsely from the active features.

    Parameters
    ----------
    representation : Representation
        φ(s) (binary or dense).
    regularization : float, default 1e-6
        λ ≥ 0 added to Ã's diagonal where the inverse does not exist.

    Attributes
    ----------
    representation_ : Representation
        The set-up representation.
    weights_ : ndarray, shape (n,)
        θ, so that V(s) = φ(s)ᵀθ.
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

    Complexity
    ----------
    Θ(Lk²) to assemble with k active features, plus a sparse solve (Θ(n³) dense).

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

    parameter_constraints = {
        "representation": InstanceOf(Representation, "a Representation"),
        "regularization": Interval(float, 0.0, None),
    }

    def __init__(self, *, representation: Representation, regularization: float = 1e-6):
        self.representation = representation
        self.regularization = regularization

    def setup(self, spec: DomainSpec, seed: int | np.random.SeedSequence = 0) -> LSTD:
        """Validate parameters and set up the representation for ``spec``."""
        self.validate_params()
        self.spec_ = spec
        self.representation_ = self.representation.clone().setup(spec, seed)
        self.weights_ = np.zeros(self.representation_.num_features_)
        self.is_set_up_ = True
        return self

    def fit(self, transitions: Sequence[Transition]) -> LSTD:
        """Estimate θ from ``transitions`` (Eqs. 2.37-2.39) and return ``self``."""
        check_is_set_up(self, "fit")
        started = time.perf_counter()
        rep = self.representation_
        phi = feature_matrix(rep, [t.state for t in transitions])
        live = np.array([not t.terminated for t in transitions], dtype=np.float64)
        phi_next = sp.diags(live) @ feature_matrix(rep, [t.next_state for t in transitions])
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
        return np.asarray(feature_matrix(self.representation_, states) @ self.weights_).reshape(-1)
