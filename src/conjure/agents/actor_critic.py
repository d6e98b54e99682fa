"""Actor-Critic, Geramifard (2012), Algorithm 12 (after Bhatnagar et al. 2007).

Choice: ``learn`` stays a Python composition of the update kernels rather than a call of
the compiled loop's `conjure.agents.compiled_agent.td_learn` (with its
`_learn_with_row_traces`): the compiled kernel serves only an actor that shares the critic's
features (one φ), while this class also runs an actor on its own features (ψ ≠ φ), and a
policy or schedule without a compiled form (`conjure.agents.linear_td`'s Notes). The
arithmetic is shared: without traces δ and θ's step are `_kernels.td_step` and ω's step
`_kernels.add` or `add_log_policy_gradient` on both paths; with traces both paths step and
apply them through `RowTraces`' kernels (`step_row_traces`, `apply_row_traces`). The
differential tests (``tests/compiled``) hold both to the same θ and ω bit for bit.
"""

from __future__ import annotations

import numpy as np

from conjure.agents import _kernels, persistence
from conjure.agents import compiled_agent as forms
from conjure.agents.linear_td import STEP_SIZE, LinearTDAgent, make_schedule, state_key
from conjure.agents.row_traces import MIN_TRACE, RowTraces
from conjure.core.errors import IncompatibleComponentsError
from conjure.core.interfaces import (
    DomainSpec,
    Expansion,
    Policy,
    Representation,
    SparseFeatures,
    Transition,
    check_is_set_up,
)
from conjure.core.params import InstanceOf, Interval, Options
from conjure.core.schedules import StepSizeSchedule
from conjure.policies import Gibbs, greedy_action
from conjure.representations.weights import initial_weights, with_room

__all__ = ["ActorCritic"]


class ActorCritic(LinearTDAgent):
    """A Gibbs actor over preferences ρ = ωᵀψ(s, a) with a TD critic (Algorithm 12).

    Parameters
    ----------
    representation : Representation
        The critic's features φ, read through `encode` (binary or real-valued).
    actor_representation : Representation or None, default None
        The actor's features ψ (Eq. 2.33); ``None`` means the same features as the critic.
    policy : Policy or None, default None
        π^actor over the preferences; ``None`` means ``Gibbs(temperature=1.0)`` (Eq. 2.32;
        τ = 1 as in Section 5.3.5).
    step_size : float or StepSizeSchedule, default 0.1
        The critic's α (line 8).
    actor_step_size : float, StepSizeSchedule or None, default None
        The actor's α (line 9); ``None`` means the same schedule as the critic.
    initial_weight : float, default 0.0
        The initial value of both θ and ω.
    critic : {"q", "v"}, default "q"
        What the critic estimates. ``"q"``: Q(s, a) = θᵀφ(s, a) with Algorithm 12's on-policy
        TD error δ = r + γQ(s', a') − Q(s, a) (lines 6-7). ``"v"``: V(s) = θᵀφ(s) with
        δ = r + γV(s') − V(s), the actor-critic of Sutton & Barto (1998, Section 6.6), whose δ
        estimates the advantage of the action taken.
    actor_update : {"features", "log_policy"}, default "features"
        The actor's update (line 9). ``"features"``: ω += αδψ(s, a), as printed.
        ``"log_policy"``: ω += αδ∇_ω log π(s, a) = αδ(ψ(s, a) − Σ_b π(s, b)ψ(s, b))/τ, the
        policy-gradient step of the actor-critic template the thesis follows (Bhatnagar et
        al. 2007, 2009, whose ψ are the compatible features ∇ log π); needs a `Gibbs` policy
        with τ > 0.
    trace_decay : float, default 0.0
        λ in [0, 1]; 0 is Algorithm 12 as written, > 0 gives both the critic and the actor
        eligibility traces (the actor-critic with traces of Sutton & Barto 2018, §13.5):
        z^θ ← γλz^θ + ∇_θ critic(s), z^ω ← γλz^ω + (the actor's step direction above),
        θ += αδz^θ, ω += α'δz^ω. With λ = 1 on an episodic task δ's sum along the episode is
        the return minus the critic's value (a Monte-Carlo advantage).

    Attributes
    ----------
    weights_ : ndarray of shape (n_features, n_actions), or (n_features, 1) for critic "v"
        The critic's θ.
    actor_weights_ : ndarray of shape (m_features, n_actions)
        The actor's ω.

    Notes
    -----
    Symbols: θ ``weights_``, ω ``actor_weights_``, φ the critic's features, ψ the actor's,
    ρ(s, a) = ωᵀψ(s, a) the preferences, τ the Gibbs temperature, δ the critic's TD error.

    - Lines 7-9: a' ~ π^actor(s'); δ = r + γQ(s', a') − Q(s, a); θ += αδφ(s, a);
      ω += αδψ(s, a).
    - Choice: θ and ω start at ``initial_weight`` (zero) where Algorithm 12 writes Random().
    - Choice: the greedy action for policy checks maximises the actor's preferences, as the
      thesis evaluated actor-critic learners (Section 5.3.5).
    - Choice: with an adaptive critic representation only the critic discovers features.
    - With ``critic="q"``, a tabular actor sharing the critic's features and step size stays
      equal to the critic plus its initial preferences (both get αδ on the same (s, a)), so
      the actor is a softmax over Q. With ``critic="v"`` the actor accumulates the TD errors
      of each action against V(s), so an action's preference grows only if it did better than
      the state's average: what lets a biased actor leave a suboptimal prior policy
      (`conjure.safety.CooperativeActorCritic`).
    - ``actor_update="features"`` adds αδ to the action taken only, so while the critic is
      still below its values (δ > 0 on average, e.g. V starting at 0 on a mission worth
      1,000) the action taken most gains a preference as large as the critic's own growth and
      the Gibbs actor stops exploring. The log-policy step's expected change under π is zero
      for any constant error in δ (Σ_a π(a)(𝟙[b = a] − π(b)) = 0), so only advantages move it.
    - Choice: ``"log_policy"`` uses π(s, ·) as the ``act`` that chose a drew it (over the
      legal actions it was given), cached with ψ(s): the act before last, or the last one
      after a terminal step (the run loop's order); if ``learn`` meets a state ``act`` did not
      see, π(s, ·) is recomputed over all actions.
    - With ``trace_decay`` > 0 the critic's δ no longer judges an action by the value of the
      next state alone: a state first reached by a new action has V = 0 (far below a mission
      worth 1,000), which with λ = 0 makes every new action look bad, while with λ = 1 the
      episode's actual return reaches the action. Choice: the traces accumulate, are cleared
      at each episode's start, drop rows below `conjure.agents.row_traces.MIN_TRACE`, and
      omit Sutton & Barto's γ^t factor (γ = 1 on the thesis's episodic domains); an imagined
      transition (`Transition.is_imagined`) updates without them.

    Complexity
    ----------
    Θ(n|A| + m|A|) per step (Algorithm 12), k and k' active features when binary.

    Examples
    --------
    >>> from conjure.domains import ChainMDP
    >>> from conjure.experiments import run
    >>> from conjure.representations import Tabular
    >>> result = run(domain=ChainMDP(), agent=ActorCritic(representation=Tabular()),
    ...              budget_steps=300, seed=2)
    >>> int(result.curve["learning_steps"].iloc[-1])
    300
    """

    parameter_constraints = {
        **LinearTDAgent.parameter_constraints,
        "actor_representation": InstanceOf(
            (Representation, type(None)), "a Representation or None"
        ),
        "actor_step_size": STEP_SIZE | InstanceOf(type(None)),
        "critic": Options(("q", "v")),
        "actor_update": Options(("features", "log_policy")),
        "trace_decay": Interval(float, 0, 1),
    }
    default_policy = Gibbs
    expected_check_failures = {
        "check_converges_on_chain": "the critic evaluates the stochastic Gibbs actor "
        "(Algorithm 12), not Q*; tests/agents/test_actor_critic.py checks the actor instead",
    }

    def __init__(
        self,
        *,
        representation: Representation,
        actor_representation: Representation | None = None,
        policy: Policy | None = None,
        step_size: float | StepSizeSchedule = 0.1,
        actor_step_size: float | StepSizeSchedule | None = None,
        initial_weight: float = 0.0,
        critic: str = "q",
        actor_update: str = "features",
        trace_decay: float = 0.0,
    ):
        self.representation = representation
        self.actor_representation = actor_representation
        self.policy = policy
        self.step_size = step_size
        self.actor_step_size = actor_step_size
        self.initial_weight = initial_weight
        self.critic = critic
        self.actor_update = actor_update
        self.trace_decay = trace_decay

    def setup(self, spec: DomainSpec, seed: int | np.random.SeedSequence) -> ActorCritic:
        """Set up the critic as `LinearTDAgent.setup` (one column for V), then the actor's ω."""
        super().setup(spec, seed)
        self._is_state_value = self.critic == "v"
        if self._is_state_value:
            self.weights_ = self.weights_[:, :1].copy()
        self._is_shared = self.actor_representation is None
        if self._is_shared:
            self.actor_representation_ = self.representation_
        else:
            self.actor_representation_ = self.actor_representation.clone().setup(
                spec, self.seeds_["actor"]
            )
        actor = self.actor_representation_
        self._encode_actor = actor.encode
        self.actor_schedule_ = (
            self.schedule_ if self.actor_step_size is None else make_schedule(self.actor_step_size)
        )
        self.actor_weights_ = initial_weights(
            (actor.num_features_, spec.num_actions), self.initial_weight
        )
        self._is_log_policy = self.actor_update == "log_policy"
        if self._is_log_policy and not (
            isinstance(self.policy_, Gibbs) and self.policy_.temperature > 0
        ):
            raise IncompatibleComponentsError(
                f"ActorCritic(actor_update='log_policy') needs a Gibbs policy with temperature "
                f"> 0 (its log-probability gradient); got {self.policy_!r}."
            )
        self._has_traces = self.trace_decay > 0
        if self._has_traces:
            self._trace_factor = self.discount_ * self.trace_decay
            self.critic_traces_ = RowTraces(self.weights_.shape[0], self.weights_.shape[1])
            self.actor_traces_ = RowTraces(actor.num_features_, spec.num_actions)
            self._critic_units = np.eye(self.weights_.shape[1])  # e_column, no per-step array
            self._actor_units = np.eye(spec.num_actions)
        return self

    compiled_variant = (
        "the actor sharing the critic's features, and the log-policy actor or traces only "
        "over fixed features"
    )

    def compiled_form(self) -> forms.AgentKernel | None:
        """Algorithm 12 (either critic, either actor step, λ ≥ 0) for the compiled loop, or None.

        See `compiled_variant`. Choice: the log-policy actor and the traces over an adaptive
        representation stay in Python, where a discovery drops the cached π(s, ·) and grows
        the traces' rows.
        """
        check_is_set_up(self, "compiled_form")
        if not self._is_shared:
            return None
        if (self._is_log_policy or self._has_traces) and self.representation_.is_adaptive:
            return None
        traces = (forms.ROW_TRACES, self._trace_factor, MIN_TRACE) if self._has_traces else ()
        return self._kernel(
            forms.ACTOR_CRITIC,
            *traces,
            actor_schedule=self.actor_schedule_,
            is_state_value=self._is_state_value,
            is_log_policy=self._is_log_policy,
        )

    def compiled_arrays(self, rows: int = 0) -> forms.LearnerArrays:
        """θ and the actor's ω, each with room for ``rows`` features (ω if it shares them)."""
        arrays = super().compiled_arrays(rows)
        if not self._is_shared:  # ω has the actor's own features: rows are θ's
            return arrays._replace(actor_weights=self.actor_weights_)
        return arrays._replace(actor_weights=with_room(self.actor_weights_, rows))

    def compiled_row_traces(self) -> forms.RowTracePair:
        """z^θ and z^ω, the traces' own arrays (`RowTraces.compiled_form`), with λ > 0."""
        if not self._has_traces:
            return forms.NO_ROW_TRACE_PAIR
        critic, actor = self.critic_traces_.compiled_form(), self.actor_traces_.compiled_form()
        return forms.row_trace_pair(critic, actor)

    def grow_trace_capacity(self) -> None:
        """Double the live rows of both traces (the compiled loop asks before it overflows)."""
        self.critic_traces_.grow_rows()
        self.actor_traces_.grow_rows()

    def load_compiled_arrays(
        self, arrays: forms.LearnerArrays, num_features: int | None = None
    ) -> None:
        rows = self.weights_.shape[0] if num_features is None else num_features
        super().load_compiled_arrays(arrays, rows)
        if self._is_shared:  # else ω, never grown, is the learner's own
            self.actor_weights_ = arrays.actor_weights[:rows]

    def begin_episode(self) -> None:
        """Count a new episode and clear the eligibility traces."""
        super().begin_episode()
        if self._has_traces:
            self.critic_traces_.clear()
            self.actor_traces_.clear()

    def act(
        self, state: np.ndarray, greedy: bool = False, legal_actions: np.ndarray | None = None
    ) -> int:
        """Return a ~ π^actor(s), or argmax_a ρ(s, a) when ``greedy``."""
        check_is_set_up(self, "act")
        legal = self._all_actions if legal_actions is None else legal_actions
        if greedy:  # stores nothing (`preferences`)
            return int(greedy_action(self.preferences(state), legal))
        psi = self._encode_actor(state)
        preferences = _kernels.q_values(self.actor_weights_, psi[0], psi[1])
        policy = self.policy_.probabilities(preferences, legal) if self._is_log_policy else None
        self._remember(state, psi, policy)
        return int(self.policy_.select(preferences, self.rng_, legal))

    def q_values(self, state: np.ndarray) -> np.ndarray:
        """Return the critic's Q(s, ·); critic "v" has none (its V(s) is ``weights_`` · φ(s))."""
        check_is_set_up(self, "q_values")
        if self._is_state_value:
            raise IncompatibleComponentsError(
                "ActorCritic(critic='v') learns V(s), not Q(s, ·); its actor's values are "
                "preferences(s)."
            )
        return super().q_values(state)

    def preferences(self, state: np.ndarray) -> np.ndarray:
        """Return ρ(s, ·) = ωᵀψ(s, ·) (Eq. 2.33); stores nothing (`Representation.peek`)."""
        check_is_set_up(self, "preferences")
        return _kernels.q_values(self.actor_weights_, *self.actor_representation_.peek(state))

    def shift_preference(self, state: np.ndarray, action: int, amount: float) -> None:
        """ρ(s, a) += ``amount``: the bias and penalty λ of iCCA (Section 5.3.2; Algorithm 23).

        ω_a += amount · ψ(s) / ‖ψ(s)‖², which changes ρ(s, a) by exactly ``amount``; with a
        tabular actor (the thesis's) nothing else changes.
        """
        check_is_set_up(self, "shift_preference")
        indices, values = self._encode_actor(state)
        forms.shift_preference_into(
            self.actor_weights_, indices, values, int(action), float(amount)
        )

    def learn(self, transition: Transition) -> float:
        """Critic and actor updates of Algorithm 12, lines 6-9; returns δ."""
        check_is_set_up(self, "learn")
        psi = self._actor_features(transition.state)
        phi = psi if self._is_shared else self._encode(transition.state)
        target = transition.reward
        if not transition.terminated:
            target += self.discount_ * self._bootstrap(transition)  # line 6: Q⁺(s, a)
        step_size = self._step_size(self.schedule_, phi)
        column = 0 if self._is_state_value else transition.action
        actor_step = self._step_size(self.actor_schedule_, psi)
        if self._has_traces and not transition.is_imagined:
            delta = self._learn_with_traces(transition, phi, psi, column, target)
            self.critic_traces_.apply(self.weights_, step_size * delta)
            self.actor_traces_.apply(self.actor_weights_, actor_step * delta)
        else:
            delta = self._update(phi, column, target, step_size)  # lines 7-8
            if np.isfinite(delta):
                self._actor_step(psi, transition, actor_step * delta)  # line 9
        self._after_update(transition, phi, delta)
        return delta

    def _actor_step(self, psi: SparseFeatures, transition: Transition, amount: float) -> None:
        """ω += amount · (ψ(s, a), or ∇_ω log π(s, a) for ``actor_update="log_policy"``)."""
        action = transition.action
        if self._is_log_policy:
            policy = self._policy_of(transition)
            _kernels.add_log_policy_gradient(
                self.actor_weights_,
                psi[0],
                psi[1],
                action,
                policy,
                amount / self.policy_.temperature,
            )
        else:
            _kernels.add(self.actor_weights_, psi[0], psi[1], action, amount)

    def _learn_with_traces(
        self,
        transition: Transition,
        phi: SparseFeatures,
        psi: SparseFeatures,
        column: int,
        target: float,
    ) -> float:
        """δ, after z^θ ← γλz^θ + φ(s) ⊗ e_column and z^ω ← γλz^ω + ψ(s) ⊗ the actor's direction."""
        delta = target - float(_kernels.q_values(self.weights_, phi[0], phi[1])[column])
        self.critic_traces_.step(self._trace_factor, phi, self._critic_units[column])
        actor = self._actor_units[transition.action]
        if self._is_log_policy:
            actor = (actor - self._policy_of(transition)) / self.policy_.temperature
        self.actor_traces_.step(self._trace_factor, psi, actor)
        return delta

    def _policy_of(self, transition: Transition) -> np.ndarray:
        """π(s, ·) as the ``act`` that chose a drew it (cached with ψ(s)), else over all now.

        The run loop calls ``act(s')`` before ``learn`` unless s' is terminal, so that act is
        the one before last, or the last one after a terminal step (s and s' may be equal).
        """
        key = state_key(transition.state)
        entries = (
            (self._last, self._before_last)
            if transition.terminated
            else (self._before_last, self._last)
        )
        for cached_key, _, policy, _ in entries:
            if key == cached_key and policy is not None:
                return policy
        return self.policy_.probabilities(self.preferences(transition.state), self._all_actions)

    def _bootstrap(self, transition: Transition) -> float:
        next_phi = (
            self._actor_features(transition.next_state)
            if self._is_shared
            else self._encode(transition.next_state)
        )
        q_next = _kernels.q_values(self.weights_, next_phi[0], next_phi[1])
        return float(q_next[0 if self._is_state_value else transition.next_action])

    def _actor_features(self, state: np.ndarray) -> SparseFeatures:
        """ψ(s), from the act cache when possible."""
        return self._features(state, self._encode_actor)

    def _grown_arrays(self) -> tuple[bool, bool]:
        return self._is_shared, False  # ω grows when the actor shares the critic's features

    def _grow(self, expansion: Expansion) -> None:
        """Grow θ, and ω too when the actor shares the critic's (adaptive) features."""
        super()._grow(expansion)
        if self._has_traces:
            self.critic_traces_.grow(expansion)
            if self._is_shared:
                self.actor_traces_.grow(expansion)

    def state_arrays(self) -> dict[str, np.ndarray]:
        arrays = super().state_arrays()
        arrays["actor_weights"] = self.actor_weights_
        if self._has_traces:
            arrays.update(self.critic_traces_.state_arrays("critic_trace_"))
            arrays.update(self.actor_traces_.state_arrays("actor_trace_"))
        if not self._is_shared:
            arrays.update(
                persistence.prefixed(
                    "actor_representation.", self.actor_representation_.state_arrays()
                )
            )
        return arrays

    def load_state(self, saved: persistence.SavedAgent) -> None:
        super().load_state(saved)
        if not self._is_shared:
            self.actor_representation_.load_state_arrays(saved.with_prefix("actor_representation."))
        shape = (self.actor_representation_.num_features_, self.spec_.num_actions)
        self.actor_weights_ = saved.array("actor_weights", shape)
        if self._has_traces:
            self.critic_traces_ = self._loaded_traces(saved, "critic_trace_", self.weights_)
            self.actor_traces_ = self._loaded_traces(saved, "actor_trace_", self.actor_weights_)

    @staticmethod
    def _loaded_traces(
        saved: persistence.SavedAgent, prefix: str, weights: np.ndarray
    ) -> RowTraces:
        """The live trace rows saved under ``prefix``, checked against ``weights``."""
        n, width = weights.shape
        rows = saved.indices(f"{prefix}rows", (None,), n)
        values = saved.array(f"{prefix}values", (rows.shape[0], width))
        if np.unique(rows).shape[0] != rows.shape[0]:
            raise saved.damaged(persistence.ARRAYS_FILE, f"two {prefix}rows are the same feature")
        traces = RowTraces(n, width)
        traces.load(rows, values)
        return traces
