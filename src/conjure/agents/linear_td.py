"""Shared machinery of the linear online TD learners (Algorithms 10-12).

`LinearTDAgent` holds θ (n_features × |A|), the representation, the policy, the step-size
schedule, the episode counter and the generator; subclasses give their kind (which target
Q⁺(s, a) the shared kernel `conjure.agents.compiled_agent.bootstrap` forms) and traces. φ(s)
is the representation's `encode` (`SparseFeatures`: indices with their values), so binary
and real-valued features take one code path. ``act`` caches φ and Q of the states it saw so
``learn`` does not encode a state twice: per step the learners pay one feature activation,
one Q evaluation and one update.

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
- The learner's compiled form is its state: ``setup`` builds its `AgentKernel` (``kernel_``),
  θ, ω and SARSA(λ)'s traces (``arrays_``, a `LearnerArrays`), Actor-Critic's traces
  (``row_traces_``) and the `LearnerState` holding the three (``state_``). ``weights_`` is
  the leading rows of ``arrays_.weights`` in use (the representation's ``num_features_``),
  never a copy. ``learn`` is one call of `conjure.agents.compiled_agent.learn_transition`,
  which runs `learn_step` (Q⁺(s, a) by `bootstrap`, α_t by the schedule's form, the update
  by `td_update`), the kernel the compiled loop's learn slot runs too; new features' rows
  come from `grow_learner_rows` on both paths. The compiled loop updates the same arrays in place,
  so nothing is taken back after it ran (only ``act``'s cache is dropped, `forget_cache`).
- Choice: a step-size schedule or policy with no compiled form (a user's Python part) is
  marked `PYTHON_PART` in ``kernel_``: ``learn`` then passes α_t from the schedule's
  ``value`` (the same rate functions, `conjure.core.schedules`), and the learner has no
  compiled form for the loop (`compiled_form` is None).
- A cost constraint (``constraint``, `conjure.agents.constraints`) adds θ_C (``arrays_``'s
  ``cost_weights``, the rows of ``cost_weights_``) and λ (``multiplier_``) to the form, read
  and updated by the same kernels on both paths; SARSA and Q-Learning then act on
  Q − λQ_C (`penalized_values`).
- A `Saute` constraint (`conjure.agents.constraints`) makes θ (and ω) B + 1 blocks, one
  per budget bin; ``act`` reads the block of the budget the run loop last told
  (``observe_episode_cost``: learning and greedy apart), ``learn``'s kernel the blocks of s
  and s' and Sauté's reward, and ``weights_`` is every block's rows.
- Choice: when θ (or the traces) must grow past their capacity (`reserve_rows`,
  ``grow_trace_capacity``) the arrays are reallocated (doubling) and a new ``arrays_`` and
  ``state_`` replace the old ones.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any, ClassVar

import numpy as np

from conjure.agents import _kernels, persistence
from conjure.agents import compiled_agent as forms
from conjure.agents.constraints import CostConstraint
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
from conjure.core.schedules import ALPHA_0, ConstantStepSize, ScheduleKernel, StepSizeSchedule
from conjure.core.seeding import make_rng, rng_from_state, rng_state, split_seed
from conjure.policies import EpsilonGreedy, greedy_action
from conjure.policies.compiled_policy import PolicyKernel
from conjure.representations.weights import expansion_parents, initial_weights, with_room

__all__ = ["STEP_SIZE", "LinearTDAgent", "state_key"]

STEP_SIZE = ALPHA_0 | InstanceOf(StepSizeSchedule, "a StepSizeSchedule")
_FLOAT64 = np.dtype(np.float64)
_NDARRAY = np.ndarray
_q_values = _kernels.q_values
_l1_norm = _kernels.l1_norm
_learn_transition = forms.learn_transition
#: The schedule part of an `AgentKernel` for a schedule with no compiled form.
_PYTHON_SCHEDULE = ScheduleKernel(kind=forms.PYTHON_PART, alpha_0=math.nan, n_0=math.nan)


def _no_traces() -> dict[str, np.ndarray]:
    """SARSA(λ)'s trace arrays and θ_C of `LearnerArrays`, empty (a learner without them)."""
    return {
        "trace_slots": np.zeros((0, 0), dtype=np.int64),
        "trace_features": np.zeros(0, dtype=np.int64),
        "trace_actions": np.zeros(0, dtype=np.int64),
        "trace_values": np.zeros(0),
        "trace_count": np.zeros(1, dtype=np.int64),
        "cost_weights": np.zeros((0, 0)),
        "constraint_state": np.zeros(4),
    }


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
        "constraint": InstanceOf((CostConstraint, type(None)), "a CostConstraint or None"),
    }
    default_policy: ClassVar[type[Policy]] = EpsilonGreedy
    #: The methods a compiled form stands in for (`conjure.core.compiled_form`).
    compiled_methods: ClassVar[tuple[str, ...]] = (
        "act", "learn", "begin_episode", "_learn_from", "_after_update", "_next_q_values",
    )  # fmt: skip
    #: θ's initial value is folded into θ at ``setup``; the compiled form need not carry it.
    compiled_irrelevant_params: ClassVar[frozenset[str]] = frozenset({"initial_weight"})
    #: What the compiled loop covers of the learner (said when a run falls back to Python).
    compiled_variant: ClassVar[str] = ""
    #: The learner's kind in its `AgentKernel` (`conjure.agents.compiled_agent`).
    kernel_kind: ClassVar[int] = -1
    _has_traces = False

    # ------------------------------------------------------------------ lifecycle

    def setup(self, spec: DomainSpec, seed: int | np.random.SeedSequence) -> LinearTDAgent:
        """Validate parameters, set up the representation and build the compiled form.

        θ, the traces and the `AgentKernel` are the learner's state from here on (Notes).
        """
        self.validate_params()
        seeds = split_seed(seed, ("representation", "policy", "actor"))
        self.seeds_ = seeds
        self.spec_ = spec
        self.discount_ = float(spec.discount)
        self.representation_ = self.representation.clone().setup(spec, seeds["representation"])
        self.policy_ = (self.default_policy() if self.policy is None else self.policy).clone()
        self.policy_.validate_params()
        self.schedule_ = make_schedule(self.step_size)
        self.constraint_ = None if self.constraint is None else self.constraint.clone()
        if self.constraint_ is not None:
            self.constraint_.validate_params()
        self.actor_schedule_ = self.schedule_
        self.rng_ = make_rng(seeds["policy"])
        check_weight_size(self.representation_, spec)
        self.episode_ = 0
        self.num_learning_steps_ = 0
        self._all_actions = np.arange(spec.num_actions, dtype=np.int64)
        self._encode = self.representation_.encode
        self._set_up_learner(spec)
        self.kernel_ = self._make_kernel()
        self._set_up_constraint()
        self._has_python_parts = forms.PYTHON_PART in (
            self.kernel_.schedule.kind,
            self.kernel_.actor_schedule.kind,
            self.kernel_.policy.kind,
        )
        self._has_python_schedule = forms.PYTHON_PART in (
            self.kernel_.schedule.kind,
            self.kernel_.actor_schedule.kind,
        )
        self._no_values = np.zeros(spec.num_actions)  # Q(s', ·) of a terminal s': unread
        self._alphas = np.full(2, math.nan)  # α_t, α'_t of Python schedules (`LearnerState`)
        self._drawn = np.zeros(spec.num_actions)  # π(s, ·) for the log-policy actor
        self._tracing = int(self._has_traces)
        self.row_traces_ = forms.NO_ROW_TRACE_PAIR
        self._set_arrays(self._with_constraint(self._initial_arrays(spec)))
        self.forget_cache()
        self.is_set_up_ = True
        return self

    def _set_up_learner(self, spec: DomainSpec) -> None:
        """Set the learner's own parameters before its form is built (subclasses)."""

    def _make_kernel(self) -> forms.AgentKernel:
        """The learner's `AgentKernel` (subclasses, through `_kernel`)."""
        return self._kernel(self.kernel_kind)

    def _initial_arrays(self, spec: DomainSpec) -> forms.LearnerArrays:
        """θ at ``initial_weight`` (ω is θ itself) and no traces."""
        weights = initial_weights(
            (self.representation_.num_features_, spec.num_actions), self.initial_weight
        )
        return forms.LearnerArrays(weights=weights, actor_weights=weights, **_no_traces())

    def _set_up_constraint(self) -> None:
        """Which constraint the form holds; refuse what Sauté's blocks cannot serve."""
        constraint = self.kernel_.constraint
        self._has_cost_critic = constraint.kind in (forms.LAGRANGIAN, forms.PID_LAGRANGIAN)
        self._is_saute = constraint.kind == forms.SAUTE
        self._num_blocks = constraint.num_budget_bins + 1 if self._is_saute else 1
        if not self._is_saute:
            return
        check_weight_size(self.representation_, self.spec_, self._num_blocks)
        if self.representation_.is_adaptive or getattr(
            getattr(self, "actor_representation_", None), "is_adaptive", False
        ):
            raise IncompatibleComponentsError(
                f"Saute cannot augment an adaptive representation "
                f"({type(self.representation_).__name__}): θ's budget blocks would each have "
                f"to grow with it; use a fixed one (Tabular, TileCoding, RBF)."
            )
        if self._has_traces:
            raise IncompatibleComponentsError(
                f"Saute cannot combine with eligibility traces (trace_decay="
                f"{self.trace_decay!r}): a trace would have to carry its budget block; use "
                f"trace_decay=0."
            )

    def _with_constraint(self, arrays: forms.LearnerArrays) -> forms.LearnerArrays:
        """θ_C at 0, shaped as θ, for a cost critic (λ starts at 0); Sauté's blocks of θ, ω.

        Sauté: B + 1 copies of θ (and of Actor-Critic's own ω), block b the rows of bin b
        (`conjure.agents.compiled_agent.weight_block`), and the spent budgets' slots.
        """
        if self._has_cost_critic:
            return arrays._replace(cost_weights=np.zeros_like(arrays.weights))
        if not self._is_saute:
            return arrays
        blocks = (self._num_blocks, 1)
        weights = np.tile(arrays.weights, blocks)
        actor = arrays.actor_weights
        actor = weights if actor is arrays.weights else np.tile(actor, blocks)
        return arrays._replace(
            weights=weights, actor_weights=actor, constraint_state=np.zeros(forms.GREEDY_SPENT + 1)
        )

    def _set_arrays(
        self, arrays: forms.LearnerArrays, row_traces: forms.RowTracePair | None = None
    ) -> None:
        """Make ``arrays`` (and ``row_traces``) the learner's state: a new `LearnerState`."""
        if row_traces is not None:
            self.row_traces_ = row_traces
        self.arrays_ = arrays
        self.state_ = forms.learner_state(
            self.kernel_, arrays, self.row_traces_, self._alphas, self._drawn
        )
        self._theta = arrays.weights
        self._omega = arrays.actor_weights
        self._cost_theta = arrays.cost_weights
        self._use_budget()

    @property
    def observes_budget(self) -> bool:
        """Whether the learner acts on the episode's cost so far (a `Saute` constraint)."""
        return getattr(self, "_is_saute", False)

    def observe_episode_cost(self, spent: float, greedy: bool = False) -> None:
        """Take the episode's cost before the state the next ``act`` sees (Sauté's z).

        A learning ``act``'s becomes the last learning state's and that state's the one
        before (the pair ``learn`` reads, `learn_transition`); a greedy one is kept apart.
        Nothing without `Saute`.
        """
        if not self._is_saute:
            return
        state = self.arrays_.constraint_state
        if greedy:
            state[forms.GREEDY_SPENT] = spent
        else:
            state[forms.PREVIOUS_SPENT] = state[forms.ACTED_SPENT]
            state[forms.ACTED_SPENT] = spent
        self._use_budget()

    def _use_budget(self) -> None:
        """θ and ω's rows for learning and greedy ``act`` (Sauté's blocks of the spent budgets)."""
        theta, omega = self._theta, self._omega
        if not self._is_saute:
            self._acting_theta = self._greedy_theta = theta
            self._acting_omega = self._greedy_omega = omega
            return
        state, constraint = self.arrays_.constraint_state, self.kernel_.constraint
        limit, bins, blocks = constraint.cost_limit, constraint.num_budget_bins, self._num_blocks
        acting = forms.budget_bin(state[forms.ACTED_SPENT], limit, bins)
        greedy = forms.budget_bin(state[forms.GREEDY_SPENT], limit, bins)
        self._acting_theta = forms.weight_block(theta, acting, blocks)
        self._greedy_theta = forms.weight_block(theta, greedy, blocks)
        self._acting_omega = forms.weight_block(omega, acting, blocks)
        self._greedy_omega = forms.weight_block(omega, greedy, blocks)

    def begin_episode(self) -> None:
        """Count a new episode (the schedules' ``Episode #``) and clear the traces, if any."""
        check_is_set_up(self, "begin_episode")
        self.episode_ += 1
        if self._has_traces or self._has_cost_critic:
            forms.begin_learner_episode(self.state_, self.episode_ - 1)

    def _kernel(
        self,
        kind: int,
        traces: int = forms.NO_TRACES,
        trace_decay: float = 0.0,
        min_trace: float = 0.0,
        is_state_value: bool = False,
        is_log_policy: bool = False,
    ) -> forms.AgentKernel:
        """The learner's `AgentKernel`; a part with no compiled form is a `PYTHON_PART`."""
        schedule, actor = compiled_form(self.schedule_), compiled_form(self.actor_schedule_)
        policy = compiled_form(self.policy_)
        if policy is None:  # τ, read by the log-policy actor only
            temperature = float(getattr(self.policy_, "temperature", math.nan))
            policy = PolicyKernel(kind=forms.PYTHON_PART, parameter=temperature)
        return forms.AgentKernel(
            kind=kind,
            traces=traces,
            trace_decay=trace_decay,
            min_trace=min_trace,
            discount=self.discount_,
            schedule=_PYTHON_SCHEDULE if schedule is None else schedule,
            actor_schedule=_PYTHON_SCHEDULE if actor is None else actor,
            policy=policy,
            is_state_value=is_state_value,
            is_log_policy=is_log_policy,
            constraint=forms.NO_CONSTRAINT_KERNEL
            if self.constraint_ is None
            else self.constraint_.compiled_form(),
        )

    def compiled_form(self) -> forms.AgentKernel | None:
        """The learner's `AgentKernel` (``kernel_``) for the compiled loop, or None.

        None when the policy or a schedule has no compiled form (Notes).
        """
        check_is_set_up(self, "compiled_form")
        return None if self._has_python_parts else self.kernel_

    def reserve_rows(self, rows: int) -> None:
        """Give θ (and ω, SARSA(λ)'s trace slots, when they grow with it) ``rows`` rows.

        Reallocates (doubling, `with_room`) only when they have fewer; the leading rows are
        kept and a new ``arrays_`` / ``state_`` replaces the old. The compiled loop asks for
        as many rows as an adaptive representation's tables hold features.
        """
        check_is_set_up(self, "reserve_rows")
        arrays = self.arrays_
        if arrays.weights.shape[0] >= rows:
            return
        is_actor_growing, has_trace_slots = self._grown_arrays()
        weights = with_room(arrays.weights, rows)
        actor = arrays.actor_weights
        if actor is arrays.weights:
            actor = weights
        elif is_actor_growing:
            actor = with_room(actor, rows)
        slots = with_room(arrays.trace_slots, rows) if has_trace_slots else arrays.trace_slots
        costs = (
            with_room(arrays.cost_weights, rows) if self._has_cost_critic else arrays.cost_weights
        )
        self._set_arrays(
            arrays._replace(
                weights=weights, actor_weights=actor, trace_slots=slots, cost_weights=costs
            )
        )

    @property
    def weights_(self) -> np.ndarray:
        """θ: the rows of ``arrays_.weights`` in use (the representation's features), a view.

        With `Saute` every budget block's rows: B + 1 blocks of n rows.
        """
        check_is_set_up(self, "weights_")
        return self._theta[: self.representation_.num_features_ * self._num_blocks]

    @property
    def cost_weights_(self) -> np.ndarray:
        """θ_C of a constrained learner (rows in use, a view; no rows without a constraint)."""
        check_is_set_up(self, "cost_weights_")
        return self._cost_theta[: self.representation_.num_features_]

    @property
    def multiplier_(self) -> float:
        """λ, the Lagrange multiplier of a constrained learner (0 without a constraint)."""
        check_is_set_up(self, "multiplier_")
        return float(self.arrays_.constraint_state[forms.MULTIPLIER])

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
            if self._has_cost_critic:
                phi = self.representation_.peek(state)
                q = self._penalized(phi, _q_values(self._theta, phi[0], phi[1]))
                return int(greedy_action(q, legal))
            return int(greedy_action(self.q_values(state), legal))
        phi = encode(state)
        q = _q_values(self._acting_theta, phi[0], phi[1])
        self._remember(state, phi, q)
        if self._has_cost_critic:
            q = self._penalized(phi, q)
        return int(self.policy_.select(q, self.rng_, legal))

    def _penalized(self, phi: SparseFeatures, q: np.ndarray) -> np.ndarray:
        """Q(s, ·) − λ Q_C(s, ·), the values a constrained learner acts on (a new array)."""
        values = q.copy()
        forms.penalized_values(self.arrays_, phi[0], phi[1], values, self.multiplier_)
        return values

    def q_values(self, state: np.ndarray) -> np.ndarray:
        """Return Q(s, ·) under the current weights; stores nothing (`Representation.peek`).

        With `Saute`, Q(s, z, ·) at the greedy ``act``'s budget z (``observe_episode_cost``).
        """
        check_is_set_up(self, "q_values")
        indices, values = self.representation_.peek(state)
        return _q_values(self._greedy_theta, indices, values)

    # ------------------------------------------------------------------ learning

    def learn(self, transition: Transition) -> float:
        """One TD update from ``transition``; returns δ (Algorithm 10/11, lines 4-7)."""
        try:
            phi = self._features(transition.state)
        except AttributeError:
            check_is_set_up(self, "learn")
            raise
        if transition.terminated:
            return self._learn_from(transition, phi, phi, self._no_values, 0, self._all_actions)
        legal, next_action = transition.next_legal_actions, transition.next_action
        return self._learn_from(
            transition,
            phi,
            phi,
            self._next_q_values(transition.next_state),  # Q(s', ·) for Q⁺(s, a), line 5
            0 if next_action is None else next_action,  # Q-Learning may be given none
            self._all_actions if legal is None else legal,
        )

    def _learn_from(
        self,
        transition: Transition,
        phi: SparseFeatures,
        psi: SparseFeatures,
        q_next: np.ndarray,
        next_action: int,
        next_legal: np.ndarray,
        drawn: np.ndarray | None = None,
    ) -> float:
        """Lines 5-9 in one `learn_transition` call (traces grown first if they might not fit).

        An imagined transition updates without the traces (module Notes).
        """
        is_tracing = 0 if transition.is_imagined else self._tracing
        is_terminal = 1 if transition.terminated else 0
        cost_next = self._no_values
        if self._has_cost_critic and not transition.terminated:  # θ_Cᵀφ(s')
            next_phi = self._critic_features(transition.next_state)
            cost_next = _q_values(self._cost_theta, next_phi[0], next_phi[1])
        if self._has_python_schedule:  # else from the schedules' forms
            self._alphas[0] = self._step_size(self.schedule_, phi)
            self._alphas[1] = self._step_size(self.actor_schedule_, psi)
        if drawn is not None:
            self._drawn[:] = drawn
        while True:
            if psi is phi:
                fits, delta = _learn_transition(
                    self.state_, phi[0], phi[1], transition.action, transition.reward,
                    is_terminal, q_next, next_action, next_legal, self.episode_, is_tracing,
                    transition.cost, cost_next,
                )  # fmt: skip
            else:
                fits, delta = forms.learn_transition_with_actor_features(
                    self.state_, phi[0], phi[1], psi[0], psi[1], transition.action,
                    transition.reward, is_terminal, q_next, next_action, next_legal,
                    self.episode_, is_tracing, transition.cost, cost_next,
                )  # fmt: skip
            if fits:
                break
            self.grow_trace_capacity()
        self._after_update(transition, phi, delta)
        return delta

    def _critic_features(self, state: np.ndarray) -> SparseFeatures:
        """φ(s) of the critic's features (from the act cache when possible)."""
        return self._features(state)

    def grow_trace_capacity(self) -> None:
        """Make room for more live traces (learners with traces; the compiled loop asks)."""

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

        Through the compiled loop's growth kernel
        (`conjure.agents.compiled_agent.grow_learner_rows`), so the rule exists once. The
        representation already counts the new features.
        """
        first = self.representation_.num_features_ - expansion.num_new
        parents = expansion_parents(expansion, first)
        self.reserve_rows(first + parents.shape[0])
        forms.grow_learner_rows(self.arrays_, first, parents, *self._grown_arrays())
        self.forget_cache()

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
        return _q_values(self._acting_theta, phi[0], phi[1])

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
        if self._has_cost_critic:
            return {
                "weights": self.weights_,
                "cost_weights": self.cost_weights_,
                "constraint_state": self.arrays_.constraint_state,
            }
        if self._is_saute:
            return {"weights": self.weights_, "constraint_state": self.arrays_.constraint_state}
        return {"weights": self.weights_}

    def load_state(self, saved: persistence.SavedAgent) -> None:
        """Restore what `state_metadata` and `state_arrays` saved, checking each array."""
        state = saved.state
        self.episode_ = int(state["episode"])
        self.num_learning_steps_ = int(state["num_learning_steps"])
        self.rng_ = rng_from_state(state["rng"])
        self._encode = self.representation_.encode
        arrays = self.arrays_
        rows = self.representation_.num_features_ * self._num_blocks
        weights = saved.array("weights", (rows, self._theta.shape[1]))
        actor = weights if arrays.actor_weights is arrays.weights else arrays.actor_weights
        arrays = arrays._replace(weights=weights, actor_weights=actor)
        if self._has_cost_critic:
            arrays = arrays._replace(cost_weights=saved.array("cost_weights", weights.shape))
        if self._has_cost_critic or self._is_saute:
            shape = arrays.constraint_state.shape
            arrays = arrays._replace(constraint_state=saved.array("constraint_state", shape))
        self._set_arrays(arrays)
        self.forget_cache()


#: The largest weight table a learner allocates (θ is n_features x |A| float64 numbers).
MAX_WEIGHT_BYTES = 8 * 2**30


def check_weight_size(
    representation: Representation, spec: DomainSpec, num_blocks: int = 1
) -> None:
    """Raise a clear error instead of a numpy MemoryError when θ cannot fit in memory.

    ``num_blocks``: copies of θ's rows (Sauté's budget blocks).
    """
    num_bytes = 8 * representation.num_features_ * spec.num_actions * num_blocks
    if num_bytes > MAX_WEIGHT_BYTES:
        blocks = f" in {num_blocks} budget blocks" if num_blocks > 1 else ""
        raise IncompatibleComponentsError(
            f"{type(representation).__name__} gives {representation.num_features_:,} features "
            f"on {spec.name!r}: θ would take {num_bytes / 2**30:,.0f} GiB for "
            f"{spec.num_actions} actions{blocks} (limit {MAX_WEIGHT_BYTES // 2**30} GiB). Use a "
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
