"""Cooperative Learning-2: any online learner guided by a planner (Geramifard 2012, Alg. 24)."""

from __future__ import annotations

import math
import numbers
from typing import Any

import numpy as np

from conjure.core.cooperative import CooperativePlanner, RiskAnalyzer
from conjure.core.interfaces import Agent, Representation, Transition, check_is_set_up
from conjure.core.params import InstanceOf, Interval, Predicate
from conjure.models.approximate_model import ApproximateModel
from conjure.safety._box_rules import (
    NEVER_TRUSTED,
    consult_planner,
    is_trusted,
    mentor_greedy_action,
)
from conjure.safety.compiled_cooperative import CompiledBox, cooperative_learner_kernel
from conjure.safety.cooperative_agent import CooperativeAgent

__all__ = ["CooperativeLearner"]


def _is_reward_or_none(value: Any) -> bool:
    return value is None or (
        isinstance(value, numbers.Real) and not isinstance(value, bool) and math.isfinite(value)
    )


class CooperativeLearner(CooperativeAgent):
    """Follow π^p until a state-action is known, then let the learner act if its action is safe.

    Geramifard (2012), Algorithm 24 and Section 5.4 (with SARSA: "CSARSA"). Motivated by
    R_max's known states and the mentor/protégé analogy: the planner (mentor) acts until the
    pair ⟨s, π^p(s)⟩ has been seen often enough; then, with probability equal to its
    knownness, the learner (protégé) proposes an action, which is executed if the risk
    analyser finds it safe. Any online learner fits (SARSA, QLearning, ActorCritic, with any
    representation, OnlineIFDD included): only its ``act`` and ``learn`` are used. A vetoed
    proposal is learned as a step into a failure (``veto_reward``, the veto rule of the Notes;
    not in the printed algorithm, which ``veto_reward=None`` keeps).

    Per step (``act``; ``learn`` is line 9)::

        a ← π^p(s)                                      # line 1
        knownness ← min{1, count(s, a) / 𝒦}             # line 2
        if rand() < knownness:                          # line 3
            a′ ← π^l(s)                                  # line 4
            if safe(s, a′): a ← a′                       # lines 5-6
            else: learner.update(s, a′ → failure)       # the veto rule (veto_reward)
        else: count(s, a) ← count(s, a) + 1             # line 8
        learner.update(s, r, a)                         # line 9

    Parameters
    ----------
    learner : Agent
        The online learner π^l (e.g. ``SARSA(representation=Tabular())``).
    planner : CooperativePlanner
        π^p (e.g. ``ModelPlanner()``: value iteration on T̂).
    risk : RiskAnalyzer
        The ``safe`` test (e.g. `NominalRiskAnalyzer`, `MonteCarloRiskAnalyzer`).
    model : ApproximateModel
        T̂, a model of the learning domain's map or graph; static here (see
        `AdaptiveCooperativeLearner` for Algorithm 26).
    index : Representation or None, default None
        Gives each state its row in the count table: one active feature per state. ``None``
        means ``Tabular()``, or ``HashedTabular()`` (lazily indexed, capacity 100,000) on state
        spaces of more than a million cells such as UAV missions.
    num_known_visits : int, default 10
        𝒦 ≥ 1, the knownness parameter: ⟨s, a⟩ is fully known after 𝒦 planner visits
        (Section 5.4.1 picks 𝒦 from {10, 20, 50}).
    veto_reward : float or None, default -1.0
        The reward of the failure a vetoed proposal ⟨s, a′⟩ is learned as (the veto rule,
        Notes), any finite float: −1 is the grid worlds' pit reward; give a domain's own
        failure reward elsewhere (a UAV crash costs −Σ rewards, −1750 on UAV 7-2). ``None``:
        Algorithm 24 as printed, a vetoed proposal changes nothing.
    trusted_knownness : float or None, default None
        Section 5.5.3's extension: from this knownness in [0, 1] on, the learner's action is
        executed without a safety check (line 5 skipped), so that a wrong model cannot filter
        the learner forever; also in greedy acting. ``None``: always check (as printed).
        Knownness moves in steps of 1/𝒦 and the learner is consulted from 1/𝒦 on, so a value
        ≤ 1/𝒦 never checks a consulted learner. Section 5.5.3 adds it to AM-iCCA
        (`AdaptiveCooperativeLearner`); it is a parameter here so that Algorithm 24 can use it
        too.

    Attributes
    ----------
    counts_ : ndarray of int32, shape (index features, |A|)
        count(s, a): how often the planner acted in s with a unconsulted.
    learner_, planner_, risk_, model_, index_
        The set-up parts.

    Notes
    -----
    ======  =================  ==============================================
    Symbol  Name               Meaning
    ======  =================  ==============================================
    π^p     planner            the cooperative planner's policy
    π^l     learner            the learner's (exploratory) policy
    𝒦       num_known_visits   visits after which a pair is known
    ======  =================  ==============================================

    - Choice (spec 5): the count grows only when the planner's action is executed without
      consulting the learner (line 8), not when the learner was consulted but unsafe.
    - Choice: the knownness draw is skipped when knownness is 0 (never consult) or 1
      (always consult); it is drawn from the agent's own generator otherwise.
    - Choice: greedy acting (policy checks) consults the learner only in fully known pairs
      (knownness = 1, R_max's "known"), takes its greedy action, and still replaces an unsafe
      one by π^p(s) as Section 5.3.5 evaluates iCCA. Before learning the greedy policy is
      therefore the planner's, and the learner takes over state by state as it learns there.
    - Choice: the learner's greedy action breaks ties in favour of π^p(s): π^p(s) is kept
      unless the learner's Q-values rank another action strictly higher. A learner whose
      Q(s, ·) are still equal (untrained, or trained only on step costs) then follows the
      mentor instead of the first action of highest value (which walks a grid agent into a
      wall until the episode cap). Learners without ``q_values`` use their own greedy action.
    - Choice: a learner action equal to π^p(s) is safe without analysis (`RiskAnalyzer`).
    - Choice (``trusted_knownness``): the trust test compares the knownness of the pair
      ⟨s, π^p(s)⟩, the value line 2 computes, where Section 5.5.3 speaks of the knownness
      of the state. The two are the same number here: the count grows only on ⟨s, π^p(s)⟩
      (line 8), π^p is fixed in Algorithm 24, and Algorithm 26 resets every count when π^p
      changes (line 15), so count(s, π^p(s)) counts every unconsulted visit to s under the
      current π^p, and no other action of s has a count. Keying on the pair keeps one count
      table and one knownness per step instead of a second, per-state count.
    - Choice (the veto rule, ``veto_reward``): Algorithm 24 gives a vetoed proposal no
      consequence (Algorithm 23 lowers the actor's ρ(s, a′) by λ), so a learner whose values
      favour a move the analyser keeps blocking proposes it again and again while the planner
      pulls the agent back; on GridWorld-2 with the static 40% model (Fig. 5-12's "iCCA")
      learner and planner then drag the agent back and forth and the greedy policy cycles
      until the episode cap. Here the vetoed pair is a failure: the learner's own ``learn``
      receives ⟨s, a′, veto_reward, s' = s, a′, terminated⟩ marked `Transition.is_imagined`
      (a one-step episode of its own: SARSA(λ)'s traces are untouched and no learning step
      is counted), so Q(s, a′) (SARSA, Q-learning), or the critic's Q and the actor's
      ρ(s, a′) (Actor-Critic), move toward the failure's value by the learner's own step
      size. Unlike a λ-style penalty on ρ it needs no explicit actor, so it fits any learner
      (batch learners store the imagined sample with the real ones). With Algorithm 25's
      random verdicts Q(s, a′) mixes the vetoes with the real outcomes of approved
      proposals. It applies only while learning (greedy acting learns nothing). The default
      reward is the failure's own (−1 on the grid worlds). Its effect on GridWorld-2 is on
      Fig. 5-12's page (docs/reproduction/fig_5_12.md).

    Complexity
    ----------
    Θ(1) plus the planner's action, the learner's act/learn and, when the learner is
    consulted, one risk analysis (Θ(𝓜𝓗) for Algorithm 25).

    Examples
    --------
    >>> from conjure.agents import SARSA
    >>> from conjure.domains import GridWorld
    >>> from conjure.experiments import run
    >>> from conjure.planners import ModelPlanner
    >>> from conjure.representations import Tabular
    >>> from conjure.safety import NominalRiskAnalyzer
    >>> csarsa = CooperativeLearner(
    ...     learner=SARSA(representation=Tabular()), planner=ModelPlanner(),
    ...     risk=NominalRiskAnalyzer(), model=ApproximateModel(domain=GridWorld(noise=0.0)))
    >>> result = run(domain=GridWorld(), agent=csarsa, budget_steps=500, seed=0)
    >>> int(csarsa.counts_.sum()) > 0  # the planner acted unconsulted
    True
    """

    parameter_constraints = {
        **CooperativeAgent.parameter_constraints,
        "num_known_visits": Interval(int, 1, None),
        "veto_reward": Predicate(_is_reward_or_none, "a finite float or None"),
        "trusted_knownness": Interval(float, 0.0, 1.0) | InstanceOf(type(None)),
    }

    def __init__(
        self,
        *,
        learner: Agent,
        planner: CooperativePlanner,
        risk: RiskAnalyzer,
        model: ApproximateModel,
        index: Representation | None = None,
        num_known_visits: int = 10,
        veto_reward: float | None = -1.0,
        trusted_knownness: float | None = None,
    ):
        super().__init__(learner=learner, planner=planner, risk=risk, model=model, index=index)
        self.num_known_visits = num_known_visits
        self.veto_reward = veto_reward
        self.trusted_knownness = trusted_knownness

    def _build_tables(self, num_states: int, num_actions: int) -> None:
        self.counts_ = np.zeros((num_states, num_actions), dtype=np.int32)

    def _table_arrays(self) -> dict[str, np.ndarray]:
        return {"counts": self.counts_}

    def knownness(self, state: np.ndarray, action: int) -> float:
        """min{1, count(s, a)/𝒦} (Algorithm 24, line 2); inspecting records nothing.

        A state a lazily indexed ``index`` never stored has count 0 and gets no row.
        """
        check_is_set_up(self, "knownness")
        row = self.state_row(state, store=False)
        return consult_planner(self.counts_, self.num_known_visits, row, action, self.rng_, True)[0]

    compiled_methods = ("act", "learn", "begin_episode", "_is_trusted", "_learn_vetoed")
    compiled_variant = (
        "a planner with a table (ModelPlanner, ShortestPathPlanner) or CBBA (CBBAPlanner), a "
        "deterministic risk analyser (NominalRiskAnalyzer with a table, FuelRiskAnalyzer) or "
        "Monte-Carlo rollouts, a static model and a one-row-per-state index, around a "
        "compiled SARSA or Q-Learning on fixed features or online iFDD with sparsified "
        "activation"
    )

    def compiled_form(self) -> CompiledBox | None:
        """Algorithm 24's box for the compiled loop (`cooperative_learner_kernel`), or None."""
        check_is_set_up(self, "compiled_form")
        return self._kept_box(cooperative_learner_kernel)

    def act(
        self, state: np.ndarray, greedy: bool = False, legal_actions: np.ndarray | None = None
    ) -> int:
        """Algorithm 24, lines 1-8: the planner's action, or the learner's if known and safe.

        The rules are the compiled box's (`conjure.safety._box_rules`: `consult_planner`,
        `is_trusted`, `mentor_greedy_action`); π^p(s), the learner's proposal and safe(s, a)
        are the parts' own methods.
        """
        check_is_set_up(self, "act")
        planner_action = self.planner_.action(state)  # line 1
        row = self.state_row(state, store=not greedy)
        knownness, is_consulted = consult_planner(  # lines 2-3 and 8
            self.counts_, self.num_known_visits, row, planner_action, self.rng_, greedy
        )
        if not is_consulted:
            return planner_action
        if greedy:
            learner_action = self._greedy_learner_action(state, planner_action, legal_actions)
        else:
            learner_action = self.learner_.act(state, False, legal_actions)  # line 4
        if self._is_trusted(knownness) or self.risk_.is_safe(  # the pair's knownness (Notes)
            state, learner_action, self.eval_rng_ if greedy else None, planner_action=planner_action
        ):  # line 5
            return learner_action  # line 6
        if not greedy and self.veto_reward is not None:
            self._learn_vetoed(state, learner_action)
        return planner_action

    def _learn_vetoed(self, state: np.ndarray, action: int) -> None:
        """Teach the learner ⟨s, a′⟩ → failure: a terminal step earning ``veto_reward``.

        s' = s is a placeholder (the step terminates, so no learner reads it).
        """
        self.learner_.learn(
            Transition(
                state=state,
                action=action,
                reward=float(self.veto_reward),
                next_state=state,
                next_action=action,
                terminated=True,
                is_imagined=True,
            )
        )

    def _greedy_learner_action(
        self, state: np.ndarray, planner_action: int, legal_actions: np.ndarray | None
    ) -> int:
        """The learner's greedy action, π^p(s) among the maximisers (policy checks).

        Greedy by what the learner acts on: an actor's preferences, else its Q-values; a
        learner with neither takes its own greedy action.
        """
        learner = self.learner_
        values_of = getattr(learner, "preferences", None) or getattr(learner, "q_values", None)
        if values_of is None:
            return int(learner.act(state, True, legal_actions))
        return int(
            mentor_greedy_action(values_of(state), self._actions(legal_actions), planner_action)
        )

    def _is_trusted(self, knownness: float) -> bool:
        """Whether the learner's action may skip the safety check (Section 5.5.3)."""
        trusted = self.trusted_knownness
        return is_trusted(knownness, NEVER_TRUSTED if trusted is None else trusted)
