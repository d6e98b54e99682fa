"""Actor-Critic, Geramifard (2012), Algorithm 12 (after Bhatnagar et al. 2007)."""

from __future__ import annotations

import numpy as np

from conjure.agents import _kernels, persistence
from conjure.agents.linear_td import STEP_SIZE, LinearTDAgent, make_schedule
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
from conjure.core.params import InstanceOf, Options
from conjure.core.schedules import StepSizeSchedule
from conjure.policies import Gibbs, greedy_action
from conjure.representations.weights import grow_weights

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
        estimates the advantage of the action taken. The actor's update, ω += αδψ(s, a)
        (line 9), is the same for both.

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
    ):
        self.representation = representation
        self.actor_representation = actor_representation
        self.policy = policy
        self.step_size = step_size
        self.actor_step_size = actor_step_size
        self.initial_weight = initial_weight
        self.critic = critic

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
        self.actor_weights_ = np.full((actor.num_features_, spec.num_actions), self.initial_weight)
        return self

    def act(
        self, state: np.ndarray, greedy: bool = False, legal_actions: np.ndarray | None = None
    ) -> int:
        """Return a ~ π^actor(s), or argmax_a ρ(s, a) when ``greedy``."""
        check_is_set_up(self, "act")
        psi = self._encode_actor(state)
        preferences = _kernels.q_values(self.actor_weights_, psi[0], psi[1])
        legal = self._all_actions if legal_actions is None else legal_actions
        if greedy:
            return int(greedy_action(preferences, legal))
        self._remember(state, psi, None)
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
        """Return ρ(s, ·) = ωᵀψ(s, ·) (Eq. 2.33)."""
        check_is_set_up(self, "preferences")
        return _kernels.q_values(self.actor_weights_, *self._encode_actor(state))

    def shift_preference(self, state: np.ndarray, action: int, amount: float) -> None:
        """ρ(s, a) += ``amount``: the bias and penalty λ of iCCA (Section 5.3.2; Algorithm 23).

        ω_a += amount · ψ(s) / ‖ψ(s)‖², which changes ρ(s, a) by exactly ``amount``; with a
        tabular actor (the thesis's) nothing else changes.
        """
        check_is_set_up(self, "shift_preference")
        indices, values = self._encode_actor(state)
        norm = _kernels.squared_norm(values)
        if norm > 0.0:
            _kernels.add(self.actor_weights_, indices, values, int(action), float(amount) / norm)

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
        delta = self._update(phi, column, target, step_size)  # lines 7-8
        if np.isfinite(delta):
            actor_step = self._step_size(self.actor_schedule_, psi)
            _kernels.add(self.actor_weights_, psi[0], psi[1], transition.action, actor_step * delta)
        self._after_update(transition, phi, delta)  # line 9 done above
        return delta

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

    def _grow(self, expansion: Expansion) -> None:
        """Grow θ, and ω too when the actor shares the critic's (adaptive) features."""
        super()._grow(expansion)
        if self._is_shared:
            self.actor_weights_ = grow_weights(self.actor_weights_, expansion)

    def _state_arrays(self) -> dict[str, np.ndarray]:
        arrays = super()._state_arrays()
        arrays["actor_weights"] = self.actor_weights_
        if not self._is_shared:
            arrays.update(
                persistence.prefixed(
                    "actor_representation.", self.actor_representation_.state_arrays()
                )
            )
        return arrays

    def _load_state(self, saved: persistence.SavedAgent) -> None:
        super()._load_state(saved)
        if not self._is_shared:
            self.actor_representation_.load_state_arrays(saved.with_prefix("actor_representation."))
        shape = (self.actor_representation_.num_features_, self.spec_.num_actions)
        self.actor_weights_ = saved.array("actor_weights", shape)
