"""Least-Squares Policy Iteration (Lagoudakis and Parr 2003; Geramifard 2012, Algorithm 14)."""

from __future__ import annotations

import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import scipy.sparse as sp

from conjure.agents import persistence
from conjure.core.errors import IncompatibleComponentsError
from conjure.core.interfaces import (
    Agent,
    DomainSpec,
    Policy,
    Representation,
    Transition,
    check_is_set_up,
)
from conjure.core.linalg import feature_matrix, lstd_system, row_matrix, solve_regularized
from conjure.core.params import InstanceOf, Interval
from conjure.core.seeding import make_rng, rng_from_state, rng_state, split_seed
from conjure.policies import EpsilonGreedy, greedy_action

__all__ = ["LSPI"]


def action_rows(phi: sp.csr_matrix, actions: np.ndarray, num_actions: int) -> sp.csr_matrix:
    """Φ̄ rows φ(s_i, a_i): φ(s_i) in action a_i's slot, columns a·n + f (Eq. 2.11)."""
    n = phi.shape[1]
    offsets = np.asarray(actions, dtype=np.int64) * n
    return row_matrix(phi.indices, phi.indptr, n * num_actions, phi.data, offsets)


class LSPI(Agent):
    """Reuse one batch of samples: solve LSTD-Q (Eqs. 2.34-2.36), then re-greedify every a'.

    Geramifard (2012), Algorithm 14: Ã = Φ̃ᵀ(Φ̃ − γP̃Φ̃)/L, b̃ = Φ̃ᵀR̃/L with P̃Φ̃ rows
    φ(s'_i, a'_i); then a'_i ← argmax_a Q(s'_i, a).

    Parameters
    ----------
    representation : Representation
        φ(s) (binary features are assembled sparsely; dense ones work too).
    policy : Policy or None, default None
        Exploration policy of ``act`` (``None``: ε-greedy, ε = 0.1); `fit` ignores it.
    regularization : float, default 1e-6
        λ ≥ 0 added to Ã's diagonal where the inverse does not exist.
    max_iterations : int, default 20
        Cap on policy iterations ("while time left"), in [1, inf).
    tolerance : float, default 1e-6
        Also stop when max |θ_{k+1} − θ_k| < tolerance, in [0, inf).

    Attributes
    ----------
    weights_ : ndarray, shape (n, |A|)
        θ̄ with one column per action (Q(s, a) = φ(s)ᵀθ_a).
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
    - Choice: ``learn`` only stores transitions; ``fit()`` without arguments uses them, so the
      run loop can collect samples for a later fit.
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
    """

    parameter_constraints = {
        "representation": InstanceOf(Representation, "a Representation"),
        "policy": InstanceOf((Policy, type(None)), "a Policy or None"),
        "regularization": Interval(float, 0.0, None),
        "max_iterations": Interval(int, 1, None),
        "tolerance": Interval(float, 0.0, None),
    }
    expected_check_failures = {
        "check_converges_on_chain": "a batch learner: it learns in fit(), not learn()",
    }

    def __init__(
        self,
        *,
        representation: Representation,
        policy: Policy | None = None,
        regularization: float = 1e-6,
        max_iterations: int = 20,
        tolerance: float = 1e-6,
    ):
        self.representation = representation
        self.policy = policy
        self.regularization = regularization
        self.max_iterations = max_iterations
        self.tolerance = tolerance

    # ------------------------------------------------------------------ lifecycle

    def setup(self, spec: DomainSpec, seed: int | np.random.SeedSequence) -> LSPI:
        """Validate parameters, set up φ and θ = 0 for ``spec``."""
        self.validate_params()
        seeds = split_seed(seed, ("representation", "policy"))
        self.spec_ = spec
        self.representation_ = self.representation.clone().setup(spec, seeds["representation"])
        self.policy_ = (EpsilonGreedy() if self.policy is None else self.policy).clone()
        self.policy_.validate_params()
        self.rng_ = make_rng(seeds["policy"])
        self.weights_ = np.zeros((self.representation_.num_features_, spec.num_actions))
        self.samples_: list[Transition] = []
        self.iterations_ = 0
        self.wall_time_s_ = 0.0
        self.history_: list[int] = []
        self._all_actions = np.arange(spec.num_actions, dtype=np.int64)
        self.is_set_up_ = True
        return self

    def begin_episode(self) -> None:
        """Nothing to do (no traces, no schedule)."""
        check_is_set_up(self, "begin_episode")

    @property
    def num_features(self) -> int:
        """n, the number of features of φ(s)."""
        check_is_set_up(self, "num_features")
        return int(self.representation_.num_features_)

    # ------------------------------------------------------------------ acting

    def q_values(self, state: np.ndarray) -> np.ndarray:
        """Q(s, ·) = θᵀφ(s)."""
        check_is_set_up(self, "q_values")
        rep = self.representation_
        if rep.is_binary:
            return self.weights_[rep.active_features(state)].sum(axis=0)
        return rep.feature_values(state) @ self.weights_

    def act(
        self, state: np.ndarray, greedy: bool = False, legal_actions: np.ndarray | None = None
    ) -> int:
        """Greedy π(s) = argmax_a Q(s, a), or the exploration policy's choice."""
        check_is_set_up(self, "act")
        q = self.q_values(state)
        legal = self._all_actions if legal_actions is None else legal_actions
        if greedy:
            return int(greedy_action(q, legal))
        return int(self.policy_.select(q, self.rng_, legal))

    def learn(self, transition: Transition) -> float:
        """Store ``transition`` for the next ``fit()``; returns 0 (no update happens here)."""
        check_is_set_up(self, "learn")
        self.samples_.append(transition)
        return 0.0

    # ------------------------------------------------------------------ batch learning

    def _encode(self, transitions: Sequence[Transition]) -> dict[str, Any]:
        rep = self.representation_
        return {
            "phi": feature_matrix(rep, [t.state for t in transitions]),
            "phi_next": feature_matrix(rep, [t.next_state for t in transitions]),
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
        num_actions = self.spec_.num_actions
        phi_bar = action_rows(data["phi"], data["actions"], num_actions)
        phi_next = sp.diags(data["live"]) @ action_rows(data["phi_next"], next_actions, num_actions)
        return lstd_system(phi_bar, sp.csr_matrix(phi_next), data["rewards"], self.spec_.discount)

    def fit(self, transitions: Sequence[Transition] | None = None) -> LSPI:
        """Run Algorithm 14 on ``transitions`` (default: those stored by ``learn``)."""
        check_is_set_up(self, "fit")
        started = time.perf_counter()
        batch = self.samples_ if transitions is None else list(transitions)
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

    def _prepare(self, batch: list[Transition]) -> dict[str, Any]:
        return self._encode(batch)

    def _next_actions(self, data: dict[str, Any]) -> Any:
        return self._greedy_next(data["phi_next"], data["legal"])

    # ------------------------------------------------------------------ persistence

    def save(self, path: str | Path) -> Path:
        """Write θ, φ's arrays and the generator (`conjure.agents.persistence`)."""
        check_is_set_up(self, "save")
        arrays = persistence.prefixed("representation.", self.representation_.state_arrays())
        arrays["weights"] = self.weights_
        state = {"rng": rng_state(self.rng_), "iterations": self.iterations_}
        return persistence.write_agent(path, self, state, arrays)

    @classmethod
    def restore(cls, path: str | Path) -> LSPI:
        """Load an agent written by `save` (stored samples are not saved)."""
        agent, state, arrays = persistence.read_agent(path, cls)
        agent.representation_.load_state_arrays(persistence.unprefixed("representation.", arrays))
        agent.weights_ = np.array(arrays["weights"], dtype=np.float64)
        agent.rng_ = rng_from_state(state["rng"])
        agent.iterations_ = int(state["iterations"])
        return agent
