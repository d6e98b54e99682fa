"""Shared machinery of the linear online TD learners (Algorithms 10-12).

`LinearTDAgent` holds θ (n_features × |A|), the representation, the policy, the step-size
schedule, the episode counter and the generator; subclasses say how the bootstrap target
Q⁺(s, a) is formed. φ(s) is the representation's `encode` (`SparseFeatures`: indices with their
values), so binary and real-valued features take one code path. ``act`` caches φ and Q of the
states it saw so ``learn`` does not encode a state twice: per step the learners pay one feature
activation, one Q evaluation and one update.

Notes
-----
- Choice: the cache is keyed on the bytes of the state (`state_key`, an owned copy compared
  by value), never on the array object: a wrapper that reuses one observation
  buffer, or a cooperative learner that calls ``act`` on some states and ``learn`` on others,
  can never make ``learn`` use the features of another state. A miss just encodes again.
- Choice: an imagined transition (`Transition.is_imagined`, e.g. a cooperative learner's
  vetoed proposal) is learned as a one-step episode of its own: θ ← θ + αδφ(s, a) with the
  episode's α, whatever the learner's traces (a fresh episode's trace is φ(s, a), cleared at
  its end); it counts no learning step. ``learn`` marks the weights changed, so the Q(s', ·)
  cached by ``act`` is recomputed for the next real update.
- Choice: ``learn`` composes the update kernels itself instead of calling the compiled
  loop's `conjure.agents.compiled_agent.td_learn` and `bootstrap`. Those read an
  `AgentKernel`, which exists only when the policy and every schedule have a compiled form,
  so a learner with a user's Python schedule or policy would need this path anyway; and a
  call would box θ, the traces and the kernels' named tuples for a single update, on the
  path whose per-step cost `run_episode` reports. What the two share is the arithmetic: θ's
  update is `_kernels.td_step` / `td_step_traces` on both paths, α_t comes from
  `conjure.core.schedules`' rate functions on both (``value`` here, the schedule's compiled
  form there), and new features' rows from `compiled_agent.grow_learner_rows`. Only the
  orchestration (which φ, which target, when to grow) is written twice; the differential
  tests (``tests/compiled``) hold both to the same θ bit for bit.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any, ClassVar

import numpy as np

from conjure.agents import _kernels, persistence
from conjure.agents import compiled_agent as forms
from conjure.core.compiled_form import compiled_form
from conjure.core.errors import DivergenceError, IncompatibleComponentsError
from conjure.core.interfaces import (
    Agent,
    DomainSpec,
    Expansion,
    Policy,
    Representation,
    SparseFeatures,
    Transition,
    check_is_set_up,
)
from conjure.core.params import InstanceOf, Interval
from conjure.core.schedules import ALPHA_0, ConstantStepSize, StepSizeSchedule
from conjure.core.seeding import make_rng, rng_from_state, rng_state, split_seed
from conjure.policies import EpsilonGreedy, greedy_action
from conjure.representations.weights import expansion_parents, initial_weights, with_room

__all__ = ["STEP_SIZE", "LinearTDAgent", "state_key"]

STEP_SIZE = ALPHA_0 | InstanceOf(StepSizeSchedule, "a StepSizeSchedule")
_FLOAT64 = np.dtype(np.float64)
_NDARRAY = np.ndarray
_q_values = _kernels.q_values
#: The trace arrays of `compiled_arrays` for a learner without traces.
_NO_TRACES = {
    "trace_slots": np.zeros((0, 0), dtype=np.int64),
    "trace_features": np.zeros(0, dtype=np.int64),
    "trace_actions": np.zeros(0, dtype=np.int64),
    "trace_values": np.zeros(0),
    "trace_count": np.zeros(1, dtype=np.int64),
}
_l1_norm = _kernels.l1_norm


def state_key(state: np.ndarray) -> bytes:
    """Return the bytes of ``state`` as float64: equal keys exactly when the states are equal.

    Examples
    --------
    >>> state_key(np.array([1.0])) == state_key([1])
    True
    """
    if type(state) is _NDARRAY and state.dtype is _FLOAT64:
        return state.tobytes()
    return np.asarray(state, dtype=np.float64).tobytes()


class LinearTDAgent(Agent):
    """Base of the online learners with Q(s, a) = θᵀφ(s, a) (Eq. 2.11); not used directly."""

    parameter_constraints = {
        "representation": InstanceOf(Representation, "a Representation"),
        "policy": InstanceOf((Policy, type(None)), "a Policy or None"),
        "step_size": STEP_SIZE,
        "initial_weight": Interval(float, None, None),
    }
    default_policy: ClassVar[type[Policy]] = EpsilonGreedy
    #: The methods a compiled form stands in for (`conjure.core.compiled_form`).
    compiled_methods: ClassVar[tuple[str, ...]] = (
        "act", "learn", "begin_episode", "_bootstrap", "_update", "_after_update",
    )  # fmt: skip
    #: θ's initial value is folded into θ at ``setup``; the compiled form need not carry it.
    compiled_irrelevant_params: ClassVar[frozenset[str]] = frozenset({"initial_weight"})
    #: What the compiled loop covers of the learner (said when a run falls back to Python).
    compiled_variant: ClassVar[str] = ""

    # ------------------------------------------------------------------ lifecycle

    def setup(self, spec: DomainSpec, seed: int | np.random.SeedSequence) -> LinearTDAgent:
        """Validate parameters, set up the representation and build θ for ``spec``."""
        self.validate_params()
        seeds = split_seed(seed, ("representation", "policy", "actor"))
        self.seeds_ = seeds
        self.spec_ = spec
        self.discount_ = float(spec.discount)
        self.representation_ = self.representation.clone().setup(spec, seeds["representation"])
        self.policy_ = (self.default_policy() if self.policy is None else self.policy).clone()
        self.policy_.validate_params()
        self.schedule_ = make_schedule(self.step_size)
        self.rng_ = make_rng(seeds["policy"])
        check_weight_size(self.representation_, spec)
        self.weights_ = initial_weights(
            (self.representation_.num_features_, spec.num_actions), self.initial_weight
        )
        self.episode_ = 0
        self.num_learning_steps_ = 0
        self._all_actions = np.arange(spec.num_actions, dtype=np.int64)
        self._encode = self.representation_.encode
        self.forget_cache()
        self.is_set_up_ = True
        return self

    def begin_episode(self) -> None:
        """Count a new episode (the schedules' ``Episode #``)."""
        check_is_set_up(self, "begin_episode")
        self.episode_ += 1

    def _kernel(
        self,
        kind: int,
        traces: int = forms.NO_TRACES,
        trace_decay: float = 0.0,
        min_trace: float = 0.0,
        actor_schedule: StepSizeSchedule | None = None,
        is_state_value: bool = False,
        is_log_policy: bool = False,
    ) -> forms.AgentKernel | None:
        """The `AgentKernel` of a set-up learner, or None if its policy or a schedule has none."""
        check_is_set_up(self, "compiled_form")
        parts = (self.policy_, self.schedule_, actor_schedule or self.schedule_)
        policy, schedule, actor = (compiled_form(part) for part in parts)
        if policy is None or schedule is None or actor is None:
            return None
        return forms.AgentKernel(
            kind=kind,
            traces=traces,
            trace_decay=trace_decay,
            min_trace=min_trace,
            discount=self.discount_,
            schedule=schedule,
            actor_schedule=actor,
            policy=policy,
            is_state_value=is_state_value,
            is_log_policy=is_log_policy,
        )

    def compiled_arrays(self, rows: int = 0) -> forms.LearnerArrays:
        """θ, ω and the traces for the compiled loop, with room for ``rows`` features.

        The arrays are the learner's own (or buffers they lead, `with_room`), updated in
        place; `load_compiled_arrays` takes them back.
        """
        check_is_set_up(self, "compiled_arrays")
        weights = with_room(self.weights_, rows)
        return forms.LearnerArrays(weights=weights, actor_weights=weights, **_NO_TRACES)

    def compiled_row_traces(self) -> forms.RowTracePair:
        """Actor-Critic's traces for the compiled loop; `NO_ROW_TRACE_PAIR` for the others."""
        return forms.NO_ROW_TRACE_PAIR

    def load_compiled_arrays(
        self, arrays: forms.LearnerArrays, num_features: int | None = None
    ) -> None:
        """Take θ back from the compiled loop and drop the cache.

        The first ``num_features`` rows (default: as many as now) stay in use.
        """
        rows = self.weights_.shape[0] if num_features is None else num_features
        self.weights_ = arrays.weights[:rows]
        self.forget_cache()

    @property
    def num_features(self) -> int:
        """Number of features of the representation in use now (`num_features_in_use_`)."""
        check_is_set_up(self, "num_features")
        return self.representation_.num_features_in_use_

    # ------------------------------------------------------------------ acting

    def act(
        self, state: np.ndarray, greedy: bool = False, legal_actions: np.ndarray | None = None
    ) -> int:
        """Return π^ε(s), or the greedy action for policy checks, which changes nothing.

        Greedy acting draws no random number and reads φ(s) by `Representation.peek`, which
        stores no new feature.
        """
        try:
            encode = self._encode
        except AttributeError:
            check_is_set_up(self, "act")
        legal = self._all_actions if legal_actions is None else legal_actions
        if greedy:
            return int(greedy_action(self.q_values(state), legal))
        phi = encode(state)
        q = _q_values(self.weights_, phi[0], phi[1])
        self._remember(state, phi, q)
        return int(self.policy_.select(q, self.rng_, legal))

    def q_values(self, state: np.ndarray) -> np.ndarray:
        """Return Q(s, ·) under the current weights; stores nothing (`Representation.peek`)."""
        check_is_set_up(self, "q_values")
        indices, values = self.representation_.peek(state)
        return _q_values(self.weights_, indices, values)

    # ------------------------------------------------------------------ learning

    def learn(self, transition: Transition) -> float:
        """One TD update from ``transition``; returns δ (Algorithm 10/11, lines 4-7)."""
        check_is_set_up(self, "learn")
        phi = self._features(transition.state)
        target = transition.reward
        if not transition.terminated:
            target += self.discount_ * self._bootstrap(transition)  # line 5: Q⁺(s, a)
        step_size = self._step_size(self.schedule_, phi)
        if transition.is_imagined:  # a one-step episode of its own: e = φ(s, a), no live trace
            delta = _kernels.td_step(
                self.weights_, phi[0], phi[1], transition.action, target, step_size
            )
        else:
            delta = self._update(phi, transition.action, target, step_size)  # lines 6-7
        self._after_update(transition, phi, delta)
        return delta

    def _bootstrap(self, transition: Transition) -> float:
        """Return the estimate of the next state's value used in Q⁺(s, a)."""
        raise NotImplementedError

    def _update(self, phi: SparseFeatures, action: int, target: float, step_size: float) -> float:
        return _kernels.td_step(self.weights_, phi[0], phi[1], action, target, step_size)

    def _after_update(self, transition: Transition, phi: SparseFeatures, delta: float) -> None:
        if not transition.is_imagined:
            self.num_learning_steps_ += 1
        self._weights_version += 1
        if not math.isfinite(delta):
            raise DivergenceError(
                f"{type(self).__name__}: the TD error became {delta} at learning step "
                f"{self.num_learning_steps_}; the weights diverged. Lower the step size "
                f"(now {self.step_size!r}) or use a feature-normalised schedule."
            )
        if self.representation_.is_adaptive:
            expansion = self.representation_.discover(phi[0], delta, transition.state)
            if expansion is not None and expansion.num_new:
                self._grow(expansion)

    def _grow(self, expansion: Expansion) -> None:
        """Add rows for new features, θ_f = θ_g + θ_h (Section 4.1.1), and drop stale caches.

        Through the arrays the compiled loop uses and its growth kernel
        (`conjure.agents.compiled_agent.grow_learner_rows`), so the rule exists once.
        """
        first = self.weights_.shape[0]
        parents = expansion_parents(expansion, first)
        rows = first + parents.shape[0]
        arrays = self.compiled_arrays(rows)
        forms.grow_learner_rows(arrays, first, parents, *self._grown_arrays())
        self.load_compiled_arrays(arrays, rows)

    def _grown_arrays(self) -> tuple[bool, bool]:
        """Whether a new feature also gets the actor's ω row and SARSA(λ)'s trace slots."""
        return False, False

    def _step_size(self, schedule: StepSizeSchedule, phi: SparseFeatures) -> float:
        """α_t of ``schedule`` for this episode and φ(s) (k_t = |φ(s)|₁ only if it is used)."""
        num_active = _l1_norm(phi[1]) if schedule.uses_num_active else 1.0
        return schedule.value(max(self.episode_, 1), num_active)

    # ------------------------------------------------------------------ the act/learn cache

    def forget_cache(self) -> None:
        """Drop the features and Q-values ``act`` cached: θ or φ changed outside ``learn``.

        The compiled loop (`conjure.compiled`) calls it after it updated θ in place.
        """
        self._weights_version = 0
        self._last = (None, None, None, -1)
        self._before_last = (None, None, None, -1)

    # The hot paths below inline `state_key`'s fast case (a function call costs as much).

    def _remember(self, state: np.ndarray, phi: SparseFeatures, q: np.ndarray | None) -> None:
        self._before_last = self._last
        if type(state) is _NDARRAY and state.dtype is _FLOAT64:
            self._last = (state.tobytes(), phi, q, self._weights_version)
        else:
            self._last = (state_key(state), phi, q, self._weights_version)

    def _features(self, state: np.ndarray, encode: Any = None) -> SparseFeatures:
        """φ(s) (or ``encode(s)``), from the cache when ``act`` saw a state of the same value.

        In the run loop s is the state ``act`` saw before last, so that entry is tried first.
        """
        if type(state) is _NDARRAY and state.dtype is _FLOAT64:
            key = state.tobytes()
        else:
            key = state_key(state)
        if key == self._before_last[0]:
            return self._before_last[1]
        if key == self._last[0]:
            return self._last[1]
        return (encode or self._encode)(state)

    def _next_q_values(self, state: np.ndarray) -> np.ndarray:
        """Q(s', ·) under the current weights, from the cache when still valid."""
        key, phi, q, version = self._last
        if type(state) is _NDARRAY and state.dtype is _FLOAT64:
            same = state.tobytes() == key
        else:
            same = state_key(state) == key
        if same:
            if version == self._weights_version:
                return q
        else:
            phi = self._features(state)
        return _q_values(self.weights_, phi[0], phi[1])

    # ------------------------------------------------------------------ persistence

    def save(self, path: str | Path) -> Path:
        """Write the agent to directory ``path``; see `conjure.agents.persistence`."""
        check_is_set_up(self, "save")
        return persistence.save_agent(self, path)

    @classmethod
    def restore(cls, path: str | Path) -> LinearTDAgent:
        """Load an agent written by `save`; it continues exactly as if never saved.

        Raises `InvalidParameterError` naming the file for a damaged save (see
        `conjure.agents.persistence`).
        """
        return persistence.restore_agent(cls, path)

    def state_metadata(self) -> dict[str, Any]:
        """The agent's scalar state for `save` (episode and step counters, RNG state)."""
        return {
            "episode": self.episode_,
            "num_learning_steps": self.num_learning_steps_,
            "rng": rng_state(self.rng_),
        }

    def state_arrays(self) -> dict[str, np.ndarray]:
        """The agent's own arrays for `save` (the representation saves its own)."""
        return {"weights": self.weights_}

    def load_state(self, saved: persistence.SavedAgent) -> None:
        """Restore what `state_metadata` and `state_arrays` saved, checking each array."""
        state = saved.state
        self.episode_ = int(state["episode"])
        self.num_learning_steps_ = int(state["num_learning_steps"])
        self.rng_ = rng_from_state(state["rng"])
        self._encode = self.representation_.encode
        self.weights_ = saved.array(
            "weights", (self.representation_.num_features_, self.weights_.shape[1])
        )
        self.forget_cache()


#: The largest weight table a learner allocates (θ is n_features x |A| float64 numbers).
MAX_WEIGHT_BYTES = 8 * 2**30


def check_weight_size(representation: Representation, spec: DomainSpec) -> None:
    """Raise a clear error instead of a numpy MemoryError when θ cannot fit in memory."""
    num_bytes = 8 * representation.num_features_ * spec.num_actions
    if num_bytes > MAX_WEIGHT_BYTES:
        raise IncompatibleComponentsError(
            f"{type(representation).__name__} gives {representation.num_features_:,} features "
            f"on {spec.name!r}: θ would take {num_bytes / 2**30:,.0f} GiB for "
            f"{spec.num_actions} actions (limit {MAX_WEIGHT_BYTES // 2**30} GiB). Use a "
            f"representation that generalises (OnlineIFDD, TileCoding with memory_size) or "
            f"fewer buckets."
        )


def make_schedule(step_size: float | StepSizeSchedule) -> StepSizeSchedule:
    """Return a validated schedule: a float α becomes `ConstantStepSize` (α)."""
    schedule = (
        step_size.clone()
        if isinstance(step_size, StepSizeSchedule)
        else ConstantStepSize(alpha_0=float(step_size))
    )
    schedule.validate_params()
    return schedule
