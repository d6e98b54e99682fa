"""Least-Squares Policy Iteration (Lagoudakis and Parr 2003; Geramifard 2012, Algorithm 14)."""

from __future__ import annotations

import time
from collections.abc import Sequence
from typing import Any

import numpy as np
import scipy.sparse as sp

from conjure.agents import persistence
from conjure.agents.batch import BATCH_PARAMETERS, BatchAgent, q_system
from conjure.core.errors import IncompatibleComponentsError
from conjure.core.interfaces import DomainSpec, Policy, Representation, Transition, check_is_set_up
from conjure.core.linalg import solve_regularized
from conjure.core.params import Interval

__all__ = ["LSPI"]


class LSPI(BatchAgent):
    """Reuse one batch of samples: solve LSTD-Q (Eqs. 2.34-2.36), then re-greedify every a'.

    Geramifard (2012), Algorithm 14: Ã = Φ̃ᵀ(Φ̃ − γP̃Φ̃)/L, b̃ = Φ̃ᵀR̃/L with P̃Φ̃ rows
    φ(s'_i, a'_i); then a'_i ← argmax_a Q(s'_i, a).

    Parameters
    ----------
    representation : Representation
        φ(s), read through its `encode` and assembled sparsely (binary or real-valued).
    policy : Policy or None, default None
        Behaviour policy π^ε of ``act`` (``None``: ε-greedy, ε = 0.1); `fit` ignores it.
    regularization : float, default 1e-6
        λ ≥ 0 added to Ã's diagonal where the inverse does not exist.
    max_iterations : int, default 20
        Cap on policy iterations ("while time left"), in [1, inf).
    tolerance : float, default 1e-6
        Also stop when max |θ_{k+1} − θ_k| < tolerance, in [0, inf).
    fit_every : int or None, default None
        In a run: ``None`` fits before every policy check, an int N in [1, inf) after every N
        new samples (see `BatchAgent`).

    Attributes
    ----------
    weights_ : ndarray, shape (n, |A|)
        θ̄ with one column per action (Q(s, a) = φ(s)ᵀθ_a).
    samples_ : list of Transition
        Every sample ``learn`` stored (all of them are reused by every fit).
    iterations_ : int
        Iterations of the last `fit`.
    wall_time_s_ : float
        Seconds of the last `fit`.
    history_ : list of int
        Number of a'_i that changed at each iteration.

    Notes
    -----
    - Choice: the loop also stops when no a'_i changes (the policy on the samples is stable).
    - Choice: terminal transitions have φ(s', a') = 0.
    - Choice (in a run, `BatchAgent`): ``learn`` stores the transitions of π^ε on the current
      Q and every fit runs Algorithm 14 on all samples stored so far, warm-started from the
      last θ: the "initial set of samples" of line 2 grows as the run goes on, and LSPI's
      re-greedification of a'_i makes the older samples (of older policies) valid.
    - Choice: every action is considered legal in a'_i ← argmax unless the transition lists
      ``next_legal_actions``.

    Complexity
    ----------
    Θ(Lk²|A|⁰ + L k|A|) to assemble with k active features, plus one sparse solve of n|A|
    unknowns (Θ(n³|A|³) dense) per iteration.

    Examples
    --------
    >>> from conjure.representations import Tabular
    >>> spec = DomainSpec(name="two", low=[0.0], high=[1.0], is_discrete=[True], num_actions=2,
    ...                   discount=0.9, max_episode_steps=10)
    >>> s0, s1 = np.array([0.0]), np.array([1.0])
    >>> batch = [Transition(s0, 0, 1.0, s1, 0, False), Transition(s1, 0, 0.0, s0, 0, False),
    ...          Transition(s0, 1, 0.0, s0, 0, False), Transition(s1, 1, 0.0, s1, 0, False)]
    >>> agent = LSPI(representation=Tabular()).setup(spec, seed=0).fit(batch)
    >>> [agent.act(s, greedy=True) for s in (s0, s1)]
    [0, 0]

    In a run, LSPI fits at each policy check on the samples of its ε-greedy behaviour:

    >>> from conjure.domains import ChainMDP
    >>> from conjure.experiments import run
    >>> costly = ChainMDP(num_states=4, num_actions=2, step_reward=-1.0)  # best: stay put
    >>> result = run(domain=costly, agent=LSPI(representation=Tabular()), budget_steps=200,
    ...              num_policy_checks=2, seed=0)
    >>> result.curve["return"].tolist()
    [-3.0, 0.0, 0.0]
    """

    parameter_constraints = {
        **BATCH_PARAMETERS,
        "max_iterations": Interval(int, 1, None),
        "tolerance": Interval(float, 0.0, None),
    }
    reuses_samples = True

    def __init__(
        self,
        *,
        representation: Representation,
        policy: Policy | None = None,
        regularization: float = 1e-6,
        max_iterations: int = 20,
        tolerance: float = 1e-6,
        fit_every: int | None = None,
    ):
        self.representation = representation
        self.policy = policy
        self.regularization = regularization
        self.max_iterations = max_iterations
        self.tolerance = tolerance
        self.fit_every = fit_every

    def setup(self, spec: DomainSpec, seed: int | np.random.SeedSequence = 0) -> LSPI:
        """Validate parameters, set up φ, π^ε and θ = 0 for ``spec``."""
        super().setup(spec, seed)
        self.weights_ = np.zeros((self.representation_.num_features_, spec.num_actions))
        self.history_: list[int] = []
        return self

    def _q_weights(self) -> np.ndarray:
        return self.weights_

    # ------------------------------------------------------------------ batch learning

    def _encode(self, transitions: Sequence[Transition]) -> dict[str, Any]:
        return {
            "phi": self._feature_matrix([t.state for t in transitions]),
            "phi_next": self._feature_matrix([t.next_state for t in transitions]),
            "actions": np.array([t.action for t in transitions], dtype=np.int64),
            "next_actions": np.array([t.next_action for t in transitions], dtype=np.int64),
            "rewards": np.array([t.reward for t in transitions], dtype=np.float64),
            "live": np.array([not t.terminated for t in transitions], dtype=np.float64),
            "legal": [t.next_legal_actions for t in transitions],
        }

    def _greedy_next(self, phi_next: sp.csr_matrix, legal: list[Any]) -> np.ndarray:
        """a'_i ← argmax_a Q(s'_i, a) for every sample (Algorithm 14, line 7)."""
        q = np.asarray(phi_next @ self.weights_)
        if any(item is not None for item in legal):
            for i, item in enumerate(legal):
                if item is not None:
                    mask = np.full(q.shape[1], -np.inf)
                    mask[np.asarray(item, dtype=np.int64)] = 0.0
                    q[i] += mask
        return q.argmax(axis=1).astype(np.int64)

    def _system(self, data: dict[str, Any], next_actions: Any) -> tuple[sp.csr_matrix, np.ndarray]:
        return q_system(
            data["phi"],
            data["phi_next"],
            data["actions"],
            next_actions,
            data["rewards"],
            data["live"],
            self.spec_.num_actions,
            self.spec_.discount,
        )

    def fit(self, transitions: Sequence[Transition] | None = None) -> LSPI:
        """Run Algorithm 14 on ``transitions`` (default: those stored by ``learn``)."""
        check_is_set_up(self, "fit")
        started = time.perf_counter()
        batch = self._batch(transitions)
        if not batch:
            raise IncompatibleComponentsError(
                f"{type(self).__name__}.fit needs at least one transition; got none."
            )
        data = self._prepare(batch)
        next_actions = data["next_actions"]  # line 2: a'_i from the sampling policy
        self.history_ = []
        n, num_actions = self.weights_.shape
        iterations = 0
        for iteration in range(1, self.max_iterations + 1):
            iterations = iteration
            a, b = self._system(data, next_actions)  # line 4
            theta = solve_regularized(  # line 5
                a, b, float(self.regularization), initial=self.weights_.T.reshape(-1)
            )
            new_weights = theta.reshape(num_actions, n).T.copy()
            change = float(np.abs(new_weights - self.weights_).max(initial=0.0))
            self.weights_ = new_weights
            greedy = self._next_actions(data)  # line 7
            num_changed = int(np.count_nonzero(greedy != next_actions))
            self.history_.append(num_changed)
            next_actions = greedy
            if num_changed == 0 or change < self.tolerance:
                break
        self.iterations_ = iterations
        self.wall_time_s_ = time.perf_counter() - started
        return self

    def _fit_samples(self, batch: list[Transition]) -> None:
        self.fit(batch)

    def _prepare(self, batch: list[Transition]) -> dict[str, Any]:
        return self._encode(batch)

    def _next_actions(self, data: dict[str, Any]) -> Any:
        return self._greedy_next(data["phi_next"], data["legal"])

    # ------------------------------------------------------------------ persistence

    def state_arrays(self) -> dict[str, np.ndarray]:
        return {**super().state_arrays(), "weights": self.weights_}

    def load_state(self, saved: persistence.SavedAgent) -> None:
        super().load_state(saved)
        shape = (self.representation_.num_features_, self.spec_.num_actions)
        self.weights_ = saved.array("weights", shape)
