"""Cooperative Learning-3 (AM-iCCA): iCCA with an adaptive model (Geramifard 2012, Alg. 26)."""

from __future__ import annotations

from conjure.core.cooperative import CooperativePlanner, RiskAnalyzer
from conjure.core.interfaces import (
    Agent,
    Representation,
    Transition,
    check_is_set_up,
)
from conjure.core.params import Interval
from conjure.models.approximate_model import ApproximateModel
from conjure.safety._box_rules import needs_replan
from conjure.safety.compiled_cooperative import CompiledBox, cooperative_learner_kernel
from conjure.safety.cooperative_learner import CooperativeLearner

__all__ = ["AdaptiveCooperativeLearner"]


class AdaptiveCooperativeLearner(CooperativeLearner):
    """Algorithm 24 plus model adaptation: re-estimate T̂, replan, restart the knownness counts.

    Geramifard (2012), Algorithm 26 and Section 5.5 ("AM-iCCA"). Lines 1-9 are
    `CooperativeLearner`'s; after the learner's update, T̂ learns from the observed move
    (line 10), and once T̂ drifted more than ΔT from the model the planner last planned with,
    the planner replans (lines 11-13); if π^p changed, every count restarts at zero "so that
    the learner start watching the new policy (mentor) from the scratch" (lines 14-15). The
    risk analyser always uses the current T̂. With a `SwitchingPlanner` this is GridWorld-2's
    and UAV 7-2's conservative → aggressive switch once η̂ < 25% (Section 5.5.2).

    Per transition (``learn``)::

        learner.update(s, r, a)                         # line 9
        model.update(s, r, a)                           # line 10: T̂
        if ‖T̂^p − T̂‖ > ΔT:                              # line 11
            T̂^p ← T̂; planner.update()                   # lines 12-13
            if π^p changed: reset all counts to zero    # lines 14-15
        if T̂ changed: risk.update(π^p changed?)         # the analyser judges with T̂ and π^p

    Parameters
    ----------
    learner, planner, risk, index, num_known_visits, veto_reward, trusted_knownness
        As in `CooperativeLearner` (a vetoed proposal is learned as a failure by default).
    model : ApproximateModel
        T̂; give it ``is_adaptive=True`` (Section 5.5.2: ``initial_noise=0.4``,
        ``prior_weight=100``), otherwise nothing adapts.
    replan_threshold : float, default 0.0
        ΔT ≥ 0: replan when |η̂^p − η̂| > ΔT; 0 replans whenever η̂ changed.

    Attributes
    ----------
    planned_noise_ : float
        η̂^p, the noise estimate of the model π^p was last planned with (T̂^p).
    num_policy_changes_ : int
        How often π^p changed (and the counts were reset).
    replan_state_ : ReplanState
        Both as the arrays the compiled form shares (`box_learn` updates them in place).

    Notes
    -----
    - Choice: ‖T̂^p − T̂‖ = |η̂^p − η̂|: the model's only parameter is the noise η̂ (spec 5).
    - Choice: ΔT defaults to 0, so a `SwitchingPlanner` switches on the very step η̂ crosses
      its threshold (spec 5: "recompute when the estimate crosses 25%"). The planner is
      asked to replan only on a step that moved η̂ (a static model, or a step whose move the
      model does not count, plans nothing). A `ModelPlanner`'s policy depends on η̂ itself,
      and every counted move moves η̂, so at ΔT = 0 it runs value iteration once per move:
      raise ΔT (e.g. 0.01) there. (A `SwitchingPlanner` of fixed policies, as in the shipped
      configs, only compares η̂ with its threshold.) Cost: one ``planner.update`` per step
      that moved η̂ (Θ(1) for the shipped switch, one value-iteration solve for a
      `ModelPlanner`). The default stays 0: it is the threshold the shipped AM-iCCA configs
      and their stored results ran with, and a positive default would delay the switch.
    - Choice: the risk analyser is told of every change of T̂ (`RiskAnalyzer.update`, with
      whether π^p changed too), not only of a new π^p; the Monte-Carlo analyser reads η̂ at
      each rollout and re-tabulates π^p only when it changed.
    - Section 5.5.3's extension (``trusted_knownness``, `CooperativeLearner`): a threshold
      ≤ 1/𝒦 never runs the analyser on a consulted learner, so AM-iCCA then learns as SARSA
      bootstrapped by π^p, without Algorithm 25. Its GridWorld-3 results, with the selection
      rule fixed before the runs, are in docs/reproduction/chapter5/fig_5_14_selection.md.

    Complexity
    ----------
    `CooperativeLearner`'s plus Θ(1) for T̂, and a planning run on each replan.

    Examples
    --------
    >>> from conjure.agents import SARSA
    >>> from conjure.domains import GridWorld
    >>> from conjure.experiments import run
    >>> from conjure.planners import ShortestPathPlanner, SwitchingPlanner
    >>> from conjure.representations import Tabular
    >>> from conjure.safety import MonteCarloRiskAnalyzer
    >>> am_icca = AdaptiveCooperativeLearner(
    ...     learner=SARSA(representation=Tabular()),
    ...     planner=SwitchingPlanner(conservative=ShortestPathPlanner.conservative(),
    ...                              aggressive=ShortestPathPlanner.aggressive()),
    ...     risk=MonteCarloRiskAnalyzer(),
    ...     model=ApproximateModel(domain=GridWorld.gridworld_2(), initial_noise=0.4,
    ...                            is_adaptive=True))
    >>> result = run(domain=GridWorld.gridworld_2(), agent=am_icca, budget_steps=300, seed=0)
    >>> am_icca.planner_.is_aggressive_  # the wind (20%) was found calmer than 25%
    True
    """

    parameter_constraints = {
        **CooperativeLearner.parameter_constraints,
        "replan_threshold": Interval(float, 0.0, None),
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
        replan_threshold: float = 0.0,
        trusted_knownness: float | None = None,
    ):
        super().__init__(
            learner=learner,
            planner=planner,
            risk=risk,
            model=model,
            index=index,
            num_known_visits=num_known_visits,
            veto_reward=veto_reward,
            trusted_knownness=trusted_knownness,
        )
        self.replan_threshold = replan_threshold

    adapts_model = True

    @property
    def num_policy_changes_(self) -> int:
        """How often π^p changed (``replan_state_``); none after `setup`."""
        return int(self.replan_state_.policy_changes[0])

    @num_policy_changes_.setter
    def num_policy_changes_(self, count: int) -> None:
        self.replan_state_.policy_changes[0] = count

    compiled_variant = (
        "a planner that never replans (CBBA, or a SwitchingPlanner of CBBA or ShortestPath "
        "planners), the fuel rule or Monte-Carlo rollouts, a one-row-per-state index (Tabular "
        "on grid worlds), around a compiled SARSA or Q-Learning on fixed features or online "
        "iFDD with sparsified activation"
    )

    def compiled_form(self) -> CompiledBox | None:
        """Algorithm 26's box for the compiled loop, or None; built once, kept as its state.

        Algorithm 24's box (`cooperative_learner_kernel`) whose `box_learn` counts T̂'s moves
        and switches π^p in the arrays ``learn`` updates too. Defined here, not inherited,
        because the kernel stands for this class's own ``learn`` (`conjure.core.compiled_form`).
        """
        check_is_set_up(self, "compiled_form")
        return self._kept_box(cooperative_learner_kernel)

    def _extra_state(self) -> dict[str, int]:
        return {"num_policy_changes": self.num_policy_changes_}

    def learn(self, transition: Transition) -> float:
        """Algorithm 26, lines 9-15: update the learner and T̂; replan; reset counts if π^p moved.

        The replan test is the compiled box's (`conjure.safety._box_rules.needs_replan`); T̂'s
        update, the replan and the analyser's update are the parts' own methods.
        """
        check_is_set_up(self, "learn")
        delta = self.learner_.learn(transition)  # line 9
        model = self.model_
        noise = model.noise_
        model.update(transition.state, transition.action, transition.next_state)  # line 10
        if model.noise_ == noise:  # T̂ unchanged: nothing π^p or the analyser use moved
            return delta
        is_policy_changed = False
        if needs_replan(model.noise_, self.planned_noise_, self.replan_threshold):  # line 11
            self.planned_noise_ = float(model.noise_)  # line 12: T̂^p ← T̂
            is_policy_changed = self.planner_.update(model)  # line 13
            if is_policy_changed:  # line 14
                self.counts_[: self.index_.num_features_in_use_] = 0  # line 15: rows in use
                self.num_policy_changes_ += 1
        self.risk_.update(is_policy_changed=is_policy_changed)  # T̂ (and maybe π^p) changed
        return delta
