"""The exact tabular model (P, R, γ) of a finite MDP, stored sparsely (Geramifard 2012, Eq. 2.7)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
import scipy.sparse as sp

from conjure.core.errors import InvalidParameterError
from conjure.core.interfaces import DomainSpec

__all__ = ["TabularModel"]


@dataclass(eq=False)
class TabularModel:
    """A finite MDP ⟨S, A, P, R, γ⟩ with one sparse |S| × |S| transition matrix per action.

    Geramifard (2012), Section 2.1 and Eq. 2.7: P^a_{ss'} and the expected rewards
    R(s, a) = Σ_{s'} P^a_{ss'} R^a_{ss'} are what Algorithms 1-9 take as input.

    Parameters
    ----------
    transitions : sequence of scipy.sparse matrices, each (|S|, |S|)
        P^a for every action a (CSR; rows sum to 1).
    rewards : ndarray of float, shape (|S|, |A|)
        Expected one-step rewards R(s, a).
    is_terminal : ndarray of bool, shape (|S|,)
        Terminal states; they absorb (self-loop) with reward 0, and V(terminal) = 0.
    discount : float
        γ in [0, 1].
    states : ndarray of float, shape (|S|, d)
        The observation of each state (what the domain's ``reset`` and ``step`` return).
    start_distribution : ndarray of float, shape (|S|,)
        Probability of starting in each state.
    name : str, default "model"
        For messages.
    spec : DomainSpec or None, default None
        The domain's spec (derived from ``states`` when absent).

    Notes
    -----
    Conventions of every tabular result (`q_values`, and `conjure.planners.Plan`'s ``values``,
    ``q_values`` and ``policy``; documented here only):

    - Q is state-major, shape (|S|, |A|): ``q[s, a]`` is Q(s, a), as users index it.
    - V(terminal) = 0 and Q(terminal, ·) = 0.
    - π(terminal) = 0: every action is equivalent in a terminal state, and every planner
      returns the first one there (value iteration's argmax of an all-zero row; the policy
      iterations start with π₀(terminal) = 0 and keep the current action on ties).

    - Choice: terminal states are kept in the model as absorbing states with zero reward, so
      every row of every P^a sums to 1; planners treat V(terminal) as 0 (episodic tasks with
      γ = 1 stay well posed).
    - Choice: the stacked matrices (action-major rows ``a * |S| + s`` and state-major rows
      ``s * |A| + a``) are built once and cached: one sparse product gives Q for every pair.

    Complexity
    ----------
    Memory Θ(nnz(P)); no dense |S| × |S| object.

    Examples
    --------
    >>> import scipy.sparse as sp
    >>> p = sp.csr_matrix(np.array([[0.0, 1.0], [0.0, 1.0]]))
    >>> model = TabularModel(transitions=[p], rewards=np.array([[1.0], [0.0]]),
    ...                      is_terminal=np.array([False, True]), discount=0.9,
    ...                      states=np.array([[0.0], [1.0]]),
    ...                      start_distribution=np.array([1.0, 0.0]))
    >>> model.q_values(np.zeros(2)).tolist()
    [[1.0], [0.0]]
    """

    transitions: list[sp.csr_matrix]
    rewards: np.ndarray
    is_terminal: np.ndarray
    discount: float
    states: np.ndarray
    start_distribution: np.ndarray
    name: str = "model"
    spec: DomainSpec | None = None
    _cache: dict[str, Any] = field(default_factory=dict, repr=False)

    def __post_init__(self) -> None:
        self.transitions = [sp.csr_matrix(p, dtype=np.float64) for p in self.transitions]
        self.rewards = np.asarray(self.rewards, dtype=np.float64)
        self.is_terminal = np.asarray(self.is_terminal, dtype=bool).reshape(-1)
        self.states = np.asarray(self.states, dtype=np.float64)
        if self.states.ndim == 1:
            self.states = self.states.reshape(-1, 1)
        self.start_distribution = np.asarray(self.start_distribution, dtype=np.float64)
        n = self.states.shape[0]
        num_actions = len(self.transitions)
        if num_actions == 0 or any(p.shape != (n, n) for p in self.transitions):
            raise InvalidParameterError(
                f"TabularModel {self.name!r}: needs one ({n}, {n}) transition matrix per "
                f"action; got shapes {[p.shape for p in self.transitions]}."
            )
        if self.rewards.shape != (n, num_actions):
            raise InvalidParameterError(
                f"TabularModel {self.name!r}: rewards must have shape ({n}, {num_actions}); "
                f"got {self.rewards.shape}."
            )
        if self.is_terminal.shape != (n,) or self.start_distribution.shape != (n,):
            raise InvalidParameterError(
                f"TabularModel {self.name!r}: is_terminal and start_distribution need one "
                f"entry per state ({n})."
            )
        if not 0.0 <= float(self.discount) <= 1.0:
            raise InvalidParameterError(
                f"TabularModel {self.name!r}: discount must be in [0, 1]; got {self.discount!r}."
            )
        self.discount = float(self.discount)

    # ------------------------------------------------------------------ sizes and lookups

    @property
    def num_states(self) -> int:
        """|S|."""
        return int(self.states.shape[0])

    @property
    def num_actions(self) -> int:
        """|A|."""
        return len(self.transitions)

    @property
    def domain_spec(self) -> DomainSpec:
        """The domain's spec, or one derived from the state observations."""
        if self.spec is not None:
            return self.spec
        if "spec" not in self._cache:
            low, high = self.states.min(axis=0), self.states.max(axis=0)
            is_discrete = np.all(self.states == np.round(self.states), axis=0)
            self._cache["spec"] = DomainSpec(
                name=self.name,
                low=low,
                high=high,
                is_discrete=is_discrete,
                num_actions=self.num_actions,
                discount=self.discount,
                max_episode_steps=1000,
            )
        return self._cache["spec"]

    def state_index(self, state: Any) -> int:
        """Return the index of the state whose observation is ``state`` (built lazily, Θ(1))."""
        lookup = self._cache.get("lookup")
        if lookup is None:
            lookup = {row.tobytes(): i for i, row in enumerate(self.states)}
            self._cache["lookup"] = lookup
        key = np.asarray(state, dtype=np.float64).reshape(-1).tobytes()
        try:
            return lookup[key]
        except KeyError:
            raise InvalidParameterError(
                f"TabularModel {self.name!r} has no state {np.asarray(state).tolist()}; was the "
                f"plan made for another domain?"
            ) from None

    # ------------------------------------------------------------------ Bellman backups

    @property
    def stacked_transitions(self) -> sp.csr_matrix:
        """P stacked action-major: (|A||S| × |S|), row ``a * |S| + s`` is P^a_{s·}."""
        stacked = self._cache.get("stacked")
        if stacked is None:
            stacked = sp.vstack(self.transitions, format="csr")
            self._cache["stacked"] = stacked
        return stacked

    @property
    def state_major_transitions(self) -> sp.csr_matrix:
        """P stacked state-major: (|S||A| × |S|), row ``s * |A| + a`` is P^a_{s·}."""
        cached = self._cache.get("state_major")
        if cached is None:
            n, num_actions = self.num_states, self.num_actions
            order = (np.arange(num_actions)[None, :] * n + np.arange(n)[:, None]).ravel()
            cached = self.stacked_transitions[order]
            self._cache["state_major"] = cached
        return cached

    @property
    def rewards_by_action(self) -> np.ndarray:
        """R as a contiguous (|A|, |S|) array: the layout of `stacked_transitions`, not a Q."""
        cached = self._cache.get("rewards_t")
        if cached is None:
            cached = np.ascontiguousarray(self.rewards.T)
            self._cache["rewards_t"] = cached
        return cached

    def q_values(self, values: np.ndarray) -> np.ndarray:
        """Return the Bellman backup Q(s, a) = R(s, a) + γ Σ_s' P^a_{ss'} V(s') (Eq. 2.10).

        State-major, shape (|S|, |A|), with V(terminal) = 0 (see the Notes' conventions).
        """
        masked = np.where(self.is_terminal, 0.0, values)
        expected = self.state_major_transitions @ masked
        return self.rewards + self.discount * expected.reshape(self.num_states, self.num_actions)

    def policy_matrix(self, policy: np.ndarray) -> sp.csr_matrix:
        """Return P^π (|S| × |S|): row s is P^{π(s)}_{s·}."""
        rows = np.asarray(policy, dtype=np.int64) * self.num_states + np.arange(self.num_states)
        return self.stacked_transitions[rows]

    def policy_rewards(self, policy: np.ndarray) -> np.ndarray:
        """Return R^π (|S|,): R(s, π(s))."""
        return self.rewards[np.arange(self.num_states), np.asarray(policy, dtype=np.int64)]

    def restart_matrix(self, matrix: sp.csr_matrix) -> sp.csr_matrix:
        """Replace terminal rows of a policy's chain by the start distribution (episodes repeat)."""
        if not np.any(self.is_terminal):
            return matrix
        keep = sp.diags((~self.is_terminal).astype(np.float64))
        restart = sp.csr_matrix(self.is_terminal.astype(np.float64).reshape(-1, 1)) @ sp.csr_matrix(
            self.start_distribution.reshape(1, -1)
        )
        return sp.csr_matrix(keep @ matrix + restart)

    def check(self, atol: float = 1e-9) -> None:
        """Raise `InvalidParameterError` unless rows sum to 1, R is finite and terminals absorb."""
        for a, p in enumerate(self.transitions):
            sums = np.asarray(p.sum(axis=1)).reshape(-1)
            bad = np.flatnonzero(np.abs(sums - 1.0) > atol)
            if bad.size:
                raise InvalidParameterError(
                    f"TabularModel {self.name!r}: row {int(bad[0])} of P^{a} sums to "
                    f"{sums[bad[0]]:.6g}, not 1."
                )
            if p.nnz and np.any(p.data < -atol):
                raise InvalidParameterError(f"TabularModel {self.name!r}: P^{a} is negative.")
            terminal = np.flatnonzero(self.is_terminal)
            if terminal.size and not np.allclose(np.asarray(p[terminal, terminal]).ravel(), 1.0):
                raise InvalidParameterError(
                    f"TabularModel {self.name!r}: terminal states must absorb under P^{a}."
                )
        if not np.all(np.isfinite(self.rewards)):
            raise InvalidParameterError(f"TabularModel {self.name!r}: R must be finite.")
        if not np.isclose(self.start_distribution.sum(), 1.0):
            raise InvalidParameterError(
                f"TabularModel {self.name!r}: the start distribution must sum to 1."
            )
