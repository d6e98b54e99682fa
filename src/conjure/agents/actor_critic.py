"""Actor-Critic, Geramifard (2012), Algorithm 12 (after Bhatnagar et al. 2007).

``learn`` is one call of the kernel the compiled loop's update runs
(`conjure.agents.compiled_agent.learn_transition` → `td_update`), with the actor on its own
features ψ when it has them; θ, ω and the traces are the learner's compiled form, its state
(`conjure.agents.linear_td`'s Notes).
"""

from __future__ import annotations

import numpy as np

from conjure.agents import _kernels, persistence
from conjure.agents import compiled_agent as forms
from conjure.agents.constraints import CostConstraint
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
from conjure.representations.weights import initial_weights

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
    constraint : CostConstraint or None, default None
        A cost limit per episode and its multiplier rule (`Lagrangian`, `PIDLagrangian`;
        `conjure.agents.constraints`): a cost critic θ_C (V_C with critic "v") and λ; the actor
        steps on δ − λδ_C.

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

    kernel_kind = forms.ACTOR_CRITIC

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
        constraint: CostConstraint | None = None,
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
        self.constraint = constraint

    def _set_up_learner(self, spec: DomainSpec) -> None:
        """The critic (V or Q), the actor's features, schedule and step, and the traces."""
        self._is_state_value = self.critic == "v"
        self._is_shared = self.actor_representation is None
        if self._is_shared:
            self.actor_representation_ = self.representation_
        else:
            self.actor_representation_ = self.actor_representation.clone().setup(
                spec, self.seeds_["actor"]
            )
        self._encode_actor = self.actor_representation_.encode
        if self.actor_step_size is not None:
            self.actor_schedule_ = make_schedule(self.actor_step_size)
        self._is_log_policy = self.actor_update == "log_policy"
        if self._is_log_policy and not (
            isinstance(self.policy_, Gibbs) and self.policy_.temperature > 0
        ):
            raise IncompatibleComponentsError(
                f"ActorCritic(actor_update='log_policy') needs a Gibbs policy with temperature "
                f"> 0 (its log-probability gradient); got {self.policy_!r}."
            )
        self._has_traces = self.trace_decay > 0
        self._trace_factor = self.discount_ * self.trace_decay

    def _make_kernel(self) -> forms.AgentKernel:
        """Algorithm 12's `AgentKernel`: either critic, either actor step, λ ≥ 0."""
        traces = (forms.ROW_TRACES, self._trace_factor, MIN_TRACE) if self._has_traces else ()
        return self._kernel(
            forms.ACTOR_CRITIC,
            *traces,
            is_state_value=self._is_state_value,
            is_log_policy=self._is_log_policy,
        )

    def _initial_arrays(self, spec: DomainSpec) -> forms.LearnerArrays:
        """θ (one column for V) and ω, both at ``initial_weight``; the traces' rows if λ > 0."""
        arrays = super()._initial_arrays(spec)
        if self._is_state_value:
            arrays = arrays._replace(weights=arrays.weights[:, :1].copy())
        actor = initial_weights(
            (self.actor_representation_.num_features_, spec.num_actions), self.initial_weight
        )
        if self._has_traces:
            weights = arrays.weights
            self.critic_traces_ = RowTraces(weights.shape[0], weights.shape[1])
            self.actor_traces_ = RowTraces(actor.shape[0], spec.num_actions)
            self.row_traces_ = self._row_trace_pair()
        return arrays._replace(actor_weights=actor)

    def _row_trace_pair(self) -> forms.RowTracePair:
        """z^θ and z^ω, the traces' own arrays (`RowTraces.compiled_form`)."""
        critic, actor = self.critic_traces_.compiled_form(), self.actor_traces_.compiled_form()
        return forms.row_trace_pair(critic, actor)

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
        form = super().compiled_form()
        if not self._is_shared:
            return None
        if (self._is_log_policy or self._has_traces) and self.representation_.is_adaptive:
            return None
        return form

    @property
    def actor_weights_(self) -> np.ndarray:
        """ω: the rows of ``arrays_.actor_weights`` in use, a view."""
        check_is_set_up(self, "actor_weights_")
        return self._omega[: self.actor_representation_.num_features_]

    def grow_trace_capacity(self) -> None:
        """Double the live rows of both traces (the compiled loop asks before it overflows)."""
        self.critic_traces_.grow_rows()
        self.actor_traces_.grow_rows()
        self._set_arrays(self.arrays_, self._row_trace_pair())

    def act(
        self, state: np.ndarray, greedy: bool = False, legal_actions: np.ndarray | None = None
    ) -> int:
        """Return a ~ π^actor(s), or argmax_a ρ(s, a) when ``greedy``."""
        check_is_set_up(self, "act")
        legal = self._all_actions if legal_actions is None else legal_actions
        if greedy:  # stores nothing (`preferences`)
            return int(greedy_action(self.preferences(state), legal))
        psi = self._encode_actor(state)
        preferences = _kernels.q_values(self._omega, psi[0], psi[1])
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
        return _kernels.q_values(self._omega, *self.actor_representation_.peek(state))

    def shift_preference(self, state: np.ndarray, action: int, amount: float) -> None:
        """ρ(s, a) += ``amount``: the bias and penalty λ of iCCA (Section 5.3.2; Algorithm 23).

        ω_a += amount · ψ(s) / ‖ψ(s)‖², which changes ρ(s, a) by exactly ``amount``; with a
        tabular actor (the thesis's) nothing else changes.
        """
        check_is_set_up(self, "shift_preference")
        indices, values = self._encode_actor(state)
        forms.shift_preference_into(self._omega, indices, values, int(action), float(amount))

    def learn(self, transition: Transition) -> float:
        """Critic and actor updates of Algorithm 12, lines 6-9; returns δ.

        One `learn_transition` call with the critic's θᵀφ(s') for Q⁺(s, a) and the actor on
        ψ(s) (φ(s) itself when shared).
        """
        check_is_set_up(self, "learn")
        psi = self._actor_features(transition.state)
        phi = psi if self._is_shared else self._encode(transition.state)
        drawn = self._policy_of(transition) if self._is_log_policy else None
        if transition.terminated:
            q_next = self._no_values
        else:  # line 6: the critic's Q(s', a') or V(s')
            state = transition.next_state
            next_phi = self._critic_features(state)
            q_next = _kernels.q_values(self._theta, next_phi[0], next_phi[1])
        return self._learn_from(
            transition, phi, psi, q_next, transition.next_action, self._all_actions, drawn
        )

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

    def _actor_features(self, state: np.ndarray) -> SparseFeatures:
        """ψ(s), from the act cache when possible."""
        return self._features(state, self._encode_actor)

    def _critic_features(self, state: np.ndarray) -> SparseFeatures:
        """φ(s): ψ(s) when shared (the act cache holds ψ), else the critic's own encoding."""
        return self._actor_features(state) if self._is_shared else self._encode(state)

    def _grown_arrays(self) -> tuple[bool, bool]:
        return self._is_shared, False  # ω grows when the actor shares the critic's features

    def _grow(self, expansion: Expansion) -> None:
        """Grow θ, and ω too when the actor shares the critic's (adaptive) features."""
        super()._grow(expansion)
        if self._has_traces:
            self.critic_traces_.grow(expansion)
            if self._is_shared:
                self.actor_traces_.grow(expansion)
            self._set_arrays(self.arrays_, self._row_trace_pair())

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
        actor = saved.array("actor_weights", shape)
        row_traces = None
        if self._has_traces:
            self.critic_traces_ = self._loaded_traces(saved, "critic_trace_", self.weights_)
            self.actor_traces_ = self._loaded_traces(saved, "actor_trace_", actor)
            row_traces = self._row_trace_pair()
        self._set_arrays(self.arrays_._replace(actor_weights=actor), row_traces)

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
