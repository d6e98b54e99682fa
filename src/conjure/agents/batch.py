"""The batch learners' protocol in the run loop: gather samples, fit, act on Q (Algorithms 13-16).

Geramifard (2012), Algorithms 13-16 "create L₁ samples ⟨s_i, a_i, r_i, s'_i, a'_i⟩ following
policy π^ε" and then solve a least-squares system on them. `BatchAgent` turns that into an
`Agent` the run loop drives like any other: ``learn`` stores each transition, the fit runs in
`Agent.before_policy_check` (or after every ``fit_every`` new samples), and ``act`` is π^ε
(or greedy, for policy checks) on the Q of the last fit (θ = 0 before the first one).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any, ClassVar

import numpy as np
import scipy.sparse as sp

from conjure.agents import persistence
from conjure.core.interfaces import (
    Agent,
    DomainSpec,
    Policy,
    Representation,
    SparseFeatures,
    Transition,
    check_is_set_up,
)
from conjure.core.linalg import feature_matrix, lstd_system, row_matrix, solve_regularized
from conjure.core.params import InstanceOf, Interval
from conjure.core.seeding import make_rng, rng_from_state, rng_state, split_seed
from conjure.policies import EpsilonGreedy, greedy_action

__all__ = ["BATCH_PARAMETERS", "BatchAgent", "action_rows", "q_system"]

#: The constraints of the parameters every batch learner has.
BATCH_PARAMETERS = {
    "representation": InstanceOf(Representation, "a Representation"),
    "policy": InstanceOf((Policy, type(None)), "a Policy or None"),
    "regularization": Interval(float, 0.0, None),
    "fit_every": Interval(int, 1, None) | InstanceOf(type(None)),
}


def action_rows(phi: sp.csr_matrix, actions: np.ndarray, num_actions: int) -> sp.csr_matrix:
    """Φ̄ rows φ(s_i, a_i): φ(s_i) in action a_i's slot, columns a·n + f (Eq. 2.11)."""
    phi = sp.csr_matrix(phi)
    n = phi.shape[1]
    offsets = np.asarray(actions, dtype=np.int64) * n
    return row_matrix(phi.indices, phi.indptr, n * num_actions, phi.data, offsets)


def q_system(
    phi: sp.csr_matrix,
    phi_next: sp.csr_matrix,
    actions: np.ndarray,
    next_actions: np.ndarray,
    rewards: np.ndarray,
    live: np.ndarray,
    num_actions: int,
    discount: float,
) -> tuple[sp.csr_matrix, np.ndarray]:
    """Ã and b̃ of LSTD-Q (Eqs. 2.34-2.36): rows φ(s_i, a_i) and φ(s'_i, a'_i) (0 if terminal).

    Examples
    --------
    >>> phi = sp.csr_matrix(np.array([[1.0, 0.0], [0.0, 1.0]]))
    >>> a, b = q_system(phi, phi[::-1], np.array([0, 0]), np.array([0, 0]),
    ...                 np.array([1.0, 0.0]), np.ones(2), 1, 0.9)
    >>> a.toarray().tolist(), b.tolist()
    ([[0.5, -0.45], [-0.45, 0.5]], [0.5, 0.0])
    """
    phi_bar = action_rows(phi, actions, num_actions)
    phi_next_bar = sp.diags(live) @ action_rows(phi_next, next_actions, num_actions)
    return lstd_system(phi_bar, sp.csr_matrix(phi_next_bar), rewards, discount)


class BatchAgent(Agent):
    """Base of the batch learners (LSTD, FDLSTD, LSPI, LSPI-BRM); not used directly.

    Geramifard (2012), Algorithms 13-16 as agents: samples follow π^ε (the ``policy``) on the
    current Q; each fit solves on them; the greedy policy w.r.t. the new Q is what policy checks
    evaluate and what π^ε explores around.

    Parameters (of every subclass)
    ------------------------------
    representation : Representation
        φ(s).
    policy : Policy or None
        The behaviour policy π^ε of ``act`` (``None``: ε-greedy, ε = 0.1, Section 4.1.4).
    regularization : float
        λ ≥ 0 added to Ã's diagonal.
    fit_every : int or None
        ``None``: fit before every policy check (`Agent.before_policy_check`) on the samples
        gathered since the last fit, if any; an int N in [1, inf): fit after every N new
        samples instead (and not at policy checks), so learning does not depend on when the
        run checks the policy.

    Attributes
    ----------
    samples_ : list of Transition
        The stored samples: all of them (``reuses_samples``, LSPI) or those since the last fit.
    num_new_samples_ : int
        Samples stored since the last fit.

    Notes
    -----
    - Choice: a learner that evaluates the sampling policy (``reuses_samples = False``: LSTD,
      FDLSTD) fits only on the samples gathered since its last fit, which all follow one
      policy, and then forgets them (Algorithm 13: "samples ... are thrown away after each
      cycle"); LSPI (``reuses_samples = True``) re-greedifies a'_i, so it keeps every sample.
    - Choice: ``learn`` stores owned float64 copies of s and s' and returns 0 (no TD error).
    """

    #: Whether each fit uses every sample so far (off-policy) or only those since the last fit.
    reuses_samples: ClassVar[bool] = False

    # ------------------------------------------------------------------ lifecycle

    def setup(self, spec: DomainSpec, seed: int | np.random.SeedSequence = 0) -> BatchAgent:
        """Validate parameters, set up φ and the behaviour policy, and start with θ = 0."""
        self.validate_params()
        seeds = split_seed(seed, ("representation", "policy"))
        self.spec_ = spec
        self.representation_ = self.representation.clone().setup(spec, seeds["representation"])
        self.policy_ = (EpsilonGreedy() if self.policy is None else self.policy).clone()
        self.policy_.validate_params()
        self.rng_ = make_rng(seeds["policy"])
        self.samples_: list[Transition] = []
        self.num_new_samples_ = 0
        self.iterations_ = 0
        self.wall_time_s_ = 0.0
        self._all_actions = np.arange(spec.num_actions, dtype=np.int64)
        self.is_set_up_ = True
        return self

    def begin_episode(self) -> None:
        """Nothing to do (no traces, no schedule)."""
        check_is_set_up(self, "begin_episode")

    @property
    def num_features(self) -> int:
        """n, the number of features of φ(s) in use (`num_features_in_use_`)."""
        check_is_set_up(self, "num_features")
        return self.representation_.num_features_in_use_

    # ------------------------------------------------------------------ acting

    def q_values(self, state: np.ndarray) -> np.ndarray:
        """Q(s, ·) = θᵀφ(s) of the last fit."""
        check_is_set_up(self, "q_values")
        return self._state_features(state).dot(self._q_weights())

    def act(
        self, state: np.ndarray, greedy: bool = False, legal_actions: np.ndarray | None = None
    ) -> int:
        """Greedy π(s) = argmax_a Q(s, a), or the behaviour policy π^ε's choice."""
        check_is_set_up(self, "act")
        q = self.q_values(state)
        legal = self._all_actions if legal_actions is None else legal_actions
        if greedy:
            return int(greedy_action(q, legal))
        return int(self.policy_.select(q, self.rng_, legal))

    def _state_features(self, state: np.ndarray) -> SparseFeatures:
        """φ(s) of the features Q is defined over, storing nothing (`Representation.peek`).

        Acting learns nothing (``fit`` encodes the samples), so it indexes no new feature.
        """
        return self.representation_.peek(state)

    def _q_weights(self) -> np.ndarray:
        """θ̄ of the Q that ``act`` uses, shape (n, |A|)."""
        return self.q_weights_

    # ------------------------------------------------------------------ the batch protocol

    def learn(self, transition: Transition) -> float:
        """Store ``transition`` (fitting when ``fit_every`` new samples are in); returns 0."""
        check_is_set_up(self, "learn")
        self.samples_.append(
            transition._replace(
                state=np.array(transition.state, dtype=np.float64),
                next_state=np.array(transition.next_state, dtype=np.float64),
            )
        )
        self.num_new_samples_ += 1
        if self.fit_every is not None and self.num_new_samples_ >= self.fit_every:
            self._fit_collected()
        return 0.0

    def before_policy_check(self) -> None:
        """Fit on the samples gathered since the last fit (only when ``fit_every`` is None)."""
        check_is_set_up(self, "before_policy_check")
        if self.fit_every is None and self.num_new_samples_ > 0:
            self._fit_collected()

    def _fit_collected(self) -> None:
        self._fit_samples(self.samples_)
        self.num_new_samples_ = 0
        if not self.reuses_samples:
            self.samples_ = []

    def _fit_samples(self, batch: list[Transition]) -> None:
        """The protocol's fit on ``batch``: `fit` (policy evaluation), then Q^π by LSTD-Q."""
        self.fit(batch)
        self.q_weights_ = self._evaluate_q(batch)

    def fit(self, transitions: Sequence[Transition] | None = None) -> BatchAgent:
        """Fit on ``transitions`` (default: the samples stored by ``learn``)."""
        raise NotImplementedError

    def _batch(self, transitions: Sequence[Transition] | None) -> list[Transition]:
        return self.samples_ if transitions is None else list(transitions)

    def _feature_matrix(self, states: Sequence[np.ndarray]) -> sp.csr_matrix:
        """Φ̃ whose row i is φ(s_i)ᵀ."""
        return feature_matrix(self.representation_, states)

    def _evaluate_q(self, batch: Sequence[Transition]) -> np.ndarray:
        """θ of Q^π for the policy that drew ``batch`` (LSTD-Q with the sampled a'_i), (n, |A|)."""
        num_actions = self.spec_.num_actions
        phi = self._feature_matrix([t.state for t in batch])
        a, b = q_system(
            phi,
            self._feature_matrix([t.next_state for t in batch]),
            np.array([t.action for t in batch], dtype=np.int64),
            np.array([t.next_action for t in batch], dtype=np.int64),
            np.array([t.reward for t in batch], dtype=np.float64),
            np.array([not t.terminated for t in batch], dtype=np.float64),
            num_actions,
            self.spec_.discount,
        )
        theta = solve_regularized(a, b, float(self.regularization))
        return theta.reshape(num_actions, phi.shape[1]).T.copy()

    # ------------------------------------------------------------------ persistence

    def save(self, path: str | Path) -> Path:
        """Write θ, φ's arrays, the stored samples and the generator (see `persistence`)."""
        check_is_set_up(self, "save")
        return persistence.save_agent(self, path)

    @classmethod
    def restore(cls, path: str | Path) -> BatchAgent:
        """Load an agent written by `save`; it continues exactly as if never saved."""
        return persistence.restore_agent(cls, path)

    def state_metadata(self) -> dict[str, Any]:
        """The agent's scalar state for `save` (RNG state, new-sample and iteration counts)."""
        return {
            "rng": rng_state(self.rng_),
            "num_new_samples": self.num_new_samples_,
            "iterations": self.iterations_,
        }

    def state_arrays(self) -> dict[str, np.ndarray]:
        """The agent's own arrays for `save` (the representation saves its own)."""
        return _pack_samples(self.samples_, self.spec_)

    def load_state(self, saved: persistence.SavedAgent) -> None:
        """Restore what `state_metadata` and `state_arrays` saved, checking each array."""
        state = saved.state
        self.rng_ = rng_from_state(state["rng"])
        self.iterations_ = int(state["iterations"])
        self.samples_ = _unpack_samples(saved, self.spec_)
        self.num_new_samples_ = int(state["num_new_samples"])
        if not 0 <= self.num_new_samples_ <= len(self.samples_):
            raise saved.damaged("agent.json", "'num_new_samples' exceeds the stored samples")


def _pack_samples(samples: list[Transition], spec: DomainSpec) -> dict[str, np.ndarray]:
    """The stored samples as arrays (``next_legal_actions`` as a mask with a has-mask flag)."""
    num, d, num_actions = len(samples), spec.num_dims, spec.num_actions
    legal = np.ones((num, num_actions), dtype=bool)
    has_legal = np.zeros(num, dtype=bool)
    for i, t in enumerate(samples):
        if t.next_legal_actions is not None:
            has_legal[i] = True
            legal[i] = False
            legal[i, np.asarray(t.next_legal_actions, dtype=np.int64)] = True
    return {
        "samples.states": np.array([t.state for t in samples], dtype=np.float64).reshape(num, d),
        "samples.actions": np.array([t.action for t in samples], dtype=np.int64),
        "samples.rewards": np.array([t.reward for t in samples], dtype=np.float64),
        "samples.next_states": np.array([t.next_state for t in samples], dtype=np.float64).reshape(
            num, d
        ),
        "samples.next_actions": np.array([t.next_action for t in samples], dtype=np.int64),
        "samples.terminated": np.array([t.terminated for t in samples], dtype=bool),
        "samples.legal": legal,
        "samples.has_legal": has_legal,
    }


def _unpack_samples(saved: persistence.SavedAgent, spec: DomainSpec) -> list[Transition]:
    d, num_actions = spec.num_dims, spec.num_actions
    states = saved.array("samples.states", (None, d))
    num = states.shape[0]
    actions = saved.indices("samples.actions", (num,), num_actions)
    rewards = saved.array("samples.rewards", (num,))
    next_states = saved.array("samples.next_states", (num, d))
    next_actions = saved.indices("samples.next_actions", (num,), num_actions)
    terminated = saved.array("samples.terminated", (num,), bool)
    legal = saved.array("samples.legal", (num, num_actions), bool)
    has_legal = saved.array("samples.has_legal", (num,), bool)
    return [
        Transition(
            states[i],
            int(actions[i]),
            float(rewards[i]),
            next_states[i],
            int(next_actions[i]),
            bool(terminated[i]),
            np.flatnonzero(legal[i]).astype(np.int64) if has_legal[i] else None,
        )
        for i in range(num)
    ]
