"""Cooperative Learning-1 (iCCA with Actor-Critic), Geramifard (2012), Algorithm 23."""

from __future__ import annotations

import numpy as np

from conjure.agents import ActorCritic
from conjure.core.cooperative import CooperativePlanner, RiskAnalyzer
from conjure.core.interfaces import Representation, check_is_set_up
from conjure.core.params import InstanceOf, Interval
from conjure.models.approximate_model import ApproximateModel
from conjure.policies import greedy_action
from conjure.safety._box_rules import fading_bias, is_unvisited, visit_bias
from conjure.safety.compiled_cooperative import CompiledBox, icca_kernel
from conjure.safety.cooperative_agent import CooperativeAgent

__all__ = ["CooperativeActorCritic"]


class CooperativeActorCritic(CooperativeAgent):
    """An Actor-Critic biased toward π^p whose unsafe actions are replaced and penalised.

    Geramifard (2012), Algorithm 23 and Sections 5.3.2-5.3.4 ("iCCA"). The actor's
    preferences ρ(s, a) start biased toward the planner: ρ(s, π^p(s)) += λ (Section 5.3.2).
    Each step the actor proposes a^l ~ π^l(s) (Gibbs over ρ); if the risk analyser finds it
    unsafe, the planner's action is executed instead and ρ(s, a^l) −= λ, "to reduce the
    probability of the learner suggesting the same action". Actor-Critic then learns from the
    executed action (Algorithm 12, lines 7-10)::

        a^p ← π^p(s);  a^l ~ π^l(s);  a ← a^l           # lines 1-3
        if not safe(s, a): a ← a^p; ρ(s, a^l) −= λ      # lines 4-6
        ActorCritic.learn(s, r, a)                      # line 7

    Parameters
    ----------
    learner : ActorCritic
        The actor-critic (Algorithm 12); the thesis's is tabular with a Gibbs actor, τ = 1.
    planner : CooperativePlanner
        π^p (GridWorld-1: ``ModelPlanner()`` on the noise-free model; UAVs: CBBA).
    risk : RiskAnalyzer
        The ``safe`` test (GridWorld-1: `NominalRiskAnalyzer`; UAVs: `FuelRiskAnalyzer`).
    model : ApproximateModel
        T̂, a model of the learning domain's map or graph.
    index : Representation or None, default None
        Gives each state its row in the first-visit table; ``None`` means ``Tabular()``, or
        ``HashedTabular()`` on state spaces of more than a million cells (UAV missions).
    bias : float, default 30.0
        λ ≥ 0, the planner bias and the unsafe-action penalty (Section 5.3.5: 100).
    bias_half_life : float or None, default 2.0
        N_b > 0: the planner bias fades with the state's visits n(s) as
        b(n) = λ·N_b/(N_b + n), halving after N_b visits, so that the actor can leave π^p
        where it has learned; ``None``: the bias stays λ (Algorithm 23 as printed).
        The defaults, λ = 30 and N_b = 2 (the bias is below 1 after about 60 visits), are
        the setting Fig. 5-5's search selected on GridWorld-1 (seeds 0-4, by the area under
        the return curve, among λ ∈ {3, 10, 30} × N_b ∈ {2, 5, 20} × the thesis's step
        sizes; docs/reproduction/fig_5_5.md). Algorithm 23 as printed is ``bias=100.0,
        bias_half_life=None`` with an ``ActorCritic(critic="q")``.

    Attributes
    ----------
    visits_ : ndarray of int64, shape (index features,)
        n(s): how often the actor acted in the state while learning (0: never biased).
    learner_, planner_, risk_, model_, index_
        The set-up parts.

    Notes
    -----
    ======  ===========  ===============================================
    Symbol  Name         Meaning
    ======  ===========  ===============================================
    ρ(s,a)  preferences  the actor's preferences, ωᵀψ(s, a)
    λ       bias         planner bias and penalty for unsafe proposals
    N_b     bias_half_   visits after which the bias is halved
            life
    π^p     planner      the cooperative planner's policy
    ======  ===========  ===============================================

    - Choice (spec 5): the bias is applied lazily, on the first visit of a state (the thesis
      biases "state-action pairs sampled from π^p"); greedy acting treats unvisited states as
      biased, without recording the visit.
    - Choice: the penalty falls on the learner's unsafe action a^l (the text of Section 5.3.4;
      Algorithm 23's line 6 writes ρ(s, a) after a was replaced).
    - Choice: ρ(s, a) ± λ changes the actor's weights by ±λψ(s)/‖ψ(s)‖²
      (`ActorCritic.shift_preference`): exactly ρ(s, a) with the thesis's tabular actor.
    - Choice: greedy acting (policy checks) takes argmax ρ and replaces an unsafe action by
      π^p(s): "For iCCA, unsafe moves again were replaced by the cooperative planner's
      solution" (Section 5.3.5).
    - As printed (``bias_half_life=None``) with the thesis's Q critic (`ActorCritic`
      ``critic="q"``), a tabular actor stays the critic plus the bias, ρ(s, a) = Q(s, a) +
      λ·𝟙[a = π^p(s)]: with λ = 100 ≫ |Q| the actor never leaves π^p and iCCA *is* the
      planner (docs/reproduction/index.md, chapter 5). What makes the actor learn past its planner,
      as the thesis's Figures 5-5 to 5-7 show, is a fading bias (``bias_half_life``) and a
      learner that judges actions by their advantage: ``ActorCritic(critic="v",
      actor_update="log_policy")`` with eligibility traces (``trace_decay``) and an actor step
      size at or below the critic's (two time scales, as in Bhatnagar et al.). On GridWorld-1
      the fading bias with Algorithm 12's own actor step already beats the planner; on the
      UAV missions, where a mission is worth about 1,000, only the log-policy step (unmoved by
      a constant error in the critic, such as V = 0 in unseen states) leaves CBBA; the
      searches picked λ = 1 traces on UAV 7-2 (a new action judged by the episode's return)
      and λ = 0 on 10-2 (docs/reproduction/fig_5_6.md, fig_5_7.md). Both variants are kept;
      which runs is named by these parameters and the learner's.
    - Choice: the fading bias is stored in ρ like the printed one. On the visit of s that
      finds n(s) = n earlier visits, ρ(s, π^p(s)) is moved to hold b(n) before the actor
      acts: the first visit adds b(0) = λ, a later one b(n) − b(n − 1) < 0. Greedy acting
      (argmax ρ) therefore needs no other table; unvisited states count as biased by λ.

    Complexity
    ----------
    Actor-Critic's Θ(n|A| + m|A|) per step, plus the planner's action and one risk analysis.

    Examples
    --------
    >>> from conjure.domains import GridWorld
    >>> from conjure.experiments import run
    >>> from conjure.planners import ModelPlanner
    >>> from conjure.representations import Tabular
    >>> from conjure.safety import NominalRiskAnalyzer
    >>> icca = CooperativeActorCritic(
    ...     learner=ActorCritic(representation=Tabular(), critic="v"), planner=ModelPlanner(),
    ...     risk=NominalRiskAnalyzer(), model=ApproximateModel(domain=GridWorld(noise=0.0)))
    >>> result = run(domain=GridWorld(), agent=icca, budget_steps=2000, seed=0)
    >>> visits = int(icca.visits_[icca.state_row(np.array([0.0, 0.0]), store=False)])
    >>> visits > 60, icca.planner_bias(0), icca.planner_bias(visits) < 1.0  # λ·N_b/(N_b + n)
    (True, 30.0, True)
    """

    parameter_constraints = {
        **CooperativeAgent.parameter_constraints,
        "learner": InstanceOf(ActorCritic, "an ActorCritic (Algorithm 12)"),
        "bias": Interval(float, 0.0, None),
        "bias_half_life": Interval(float, 0.0, None, closed="neither") | InstanceOf(type(None)),
    }

    def __init__(
        self,
        *,
        learner: ActorCritic,
        planner: CooperativePlanner,
        risk: RiskAnalyzer,
        model: ApproximateModel,
        index: Representation | None = None,
        bias: float = 30.0,
        bias_half_life: float | None = 2.0,
    ):
        super().__init__(learner=learner, planner=planner, risk=risk, model=model, index=index)
        self.bias = bias
        self.bias_half_life = bias_half_life

    def _build_tables(self, num_states: int, num_actions: int) -> None:
        self.visits_ = np.zeros(num_states, dtype=np.int64)

    def _table_arrays(self) -> dict[str, np.ndarray]:
        return {"visits": self.visits_}

    def planner_bias(self, visits: int) -> float:
        """b(n): the bias ρ(s, π^p(s)) holds after n visits (λ, or λ·N_b/(N_b + n))."""
        if self.bias_half_life is None:
            return self.bias
        return fading_bias(self.bias, self.bias_half_life, visits)

    compiled_methods = ("act", "learn", "begin_episode", "planner_bias")
    compiled_variant = (
        "a planner with a table (ModelPlanner, ShortestPathPlanner) or CBBA (CBBAPlanner), a "
        "deterministic risk analyser (NominalRiskAnalyzer with a table, FuelRiskAnalyzer) or "
        "Monte-Carlo rollouts, a static model and a one-row-per-state index, around a "
        "compiled learner on fixed features"
    )

    def compiled_form(self) -> CompiledBox | None:
        """Algorithm 23's box for the compiled loop (`icca_kernel`), or None."""
        check_is_set_up(self, "compiled_form")
        return self._kept_box(icca_kernel)

    def act(
        self, state: np.ndarray, greedy: bool = False, legal_actions: np.ndarray | None = None
    ) -> int:
        """Algorithm 23, lines 1-6: the actor's action unless unsafe, then the planner's.

        The rules are the compiled box's (`conjure.safety._box_rules`: `visit_bias`,
        `is_unvisited`); π^p(s), the actor's proposal and safe(s, a) are the parts' own methods.
        """
        check_is_set_up(self, "act")
        learner = self.learner_
        planner_action = self.planner_.action(state)  # line 1
        row = self.state_row(state, store=not greedy)
        if greedy:
            preferences = learner.preferences(state)
            if is_unvisited(self.visits_, row):  # biased by λ
                preferences[planner_action] += self.bias
            learner_action = int(greedy_action(preferences, self._actions(legal_actions)))
            if self.risk_.is_safe(
                state, learner_action, self.eval_rng_, planner_action=planner_action
            ):
                return learner_action
            return planner_action
        half_life = self.bias_half_life
        is_shifted, shift = visit_bias(
            self.visits_, row, self.bias, 0.0 if half_life is None else half_life,
            half_life is not None,
        )  # fmt: skip
        if is_shifted:  # Section 5.3.2: ρ(s, π^p(s)) holds b(n)
            learner.shift_preference(state, planner_action, shift)
        learner_action = learner.act(state, False, legal_actions)  # line 2
        if self.risk_.is_safe(state, learner_action, planner_action=planner_action):  # line 4
            return learner_action  # line 3
        learner.shift_preference(state, learner_action, -self.bias)  # line 6
        return planner_action  # line 5
