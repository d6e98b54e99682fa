"""A learner behind a preemptive shield: iCCA's risk analyser without the planner's guidance."""

from __future__ import annotations

from typing import Any

import numpy as np

from conjure.core.interfaces import check_is_set_up
from conjure.safety.cooperative_agent import CooperativeAgent

__all__ = ["ShieldedLearner"]


class ShieldedLearner(CooperativeAgent):
    """Let the learner choose, but only among the actions the risk analyser finds safe.

    The preemptive shield of Alshiekh et al. (2018, "Safe reinforcement learning via
    shielding", AAAI) built from iCCA's parts (Geramifard 2012, Sections 5.2 and 5.3.3): the
    same risk analyser and model T̂ as `CooperativeLearner` (Algorithm 24), but no mentor, no
    knownness and no fallback to π^p. It is the baseline that isolates what iCCA's planner
    adds to its risk analyser. Per step::

        S ← {a legal in s : risk(s, a) < ε}               # ε: the analyser's risk_tolerance
        if S = ∅: S ← {argmin_a risk(s, a)}              # the least risky legal action
        a ← π^l(s) over S                                # the learner's own policy
        learner.update(s, r, a)

    Parameters
    ----------
    learner : Agent
        π^l: an online `Agent` whose ``act`` takes ``legal_actions`` (SARSA, QLearning,
        ActorCritic).
    planner : CooperativePlanner
        Only the risk analyser's: the policy Algorithm 25's rollouts follow after the judged
        action. The shield itself never consults it.
    risk : RiskAnalyzer
        risk(s, a) and ε (e.g. `NominalRiskAnalyzer`, `FuelRiskAnalyzer`,
        `MonteCarloRiskAnalyzer`).
    model : ApproximateModel
        T̂, a static model of the learning domain's map or graph.
    index : Representation or None, default None
        Unused by the shield (it keeps no per-state table); accepted as for every box.

    Attributes
    ----------
    num_shielded_steps_ : int
        Learning steps in which the shield removed at least one legal action.
    learner_, planner_, risk_, model_
        The set-up parts.

    Notes
    -----
    - Choice (preemptive, not post-posed): the learner's policy draws from S, so an ε-greedy
      learner explores uniformly among the safe actions and its greedy action is the best
      safe one; a post-posed shield would let it choose first and then replace an unsafe
      choice. Every legal action is judged, each step.
    - Choice: π^p(s) gets no exemption. `RiskAnalyzer.is_safe` calls the planner's own action
      safe without analysis (Section 5.5.1), a piece of the planner's guidance; the shield
      compares risk(s, a) with ε for every action instead.
    - Choice: the learner learns from the executed, shielded actions only (its next action a′
      was drawn from the shielded set of s′); Q-learning's max still runs over the domain's
      legal actions, as for the learner alone.
    - Choice: greedy acting (policy checks) is shielded too, with the evaluation generator
      (no draw from the behaviour or risk generators), and counts nothing.

    Complexity
    ----------
    |A| risk analyses per step (Θ(|A| 𝓜𝓗) with Algorithm 25) plus the learner's act/learn.

    Examples
    --------
    >>> from conjure.agents import SARSA
    >>> from conjure.domains import GridWorld
    >>> from conjure.experiments import run
    >>> from conjure.models.approximate_model import ApproximateModel
    >>> from conjure.planners import ModelPlanner
    >>> from conjure.representations import Tabular
    >>> from conjure.safety import NominalRiskAnalyzer
    >>> shielded = ShieldedLearner(
    ...     learner=SARSA(representation=Tabular()), planner=ModelPlanner(),
    ...     risk=NominalRiskAnalyzer(), model=ApproximateModel(domain=GridWorld(noise=0.0)))
    >>> result = run(domain=GridWorld(noise=0.0), agent=shielded, budget_steps=500, seed=0)
    >>> int(result.curve["learning_failures"].iloc[-1])  # no pit entered while learning
    0
    """

    def _build_tables(self, num_states: int, num_actions: int) -> None:
        self.num_shielded_steps_ = 0

    def _table_arrays(self) -> dict[str, np.ndarray]:
        return {}

    def _extra_state(self) -> dict[str, Any]:
        return {"num_shielded_steps": self.num_shielded_steps_}

    def safe_actions(
        self, state: np.ndarray, legal_actions: np.ndarray | None = None, greedy: bool = False
    ) -> np.ndarray:
        """S: the legal actions of ``state`` with risk below ε, else the least risky one."""
        check_is_set_up(self, "safe_actions")
        legal = self._actions(legal_actions)
        rng = self.eval_rng_ if greedy else None
        risks = np.array([self.risk_.risk(state, int(a), rng) for a in legal])
        is_safe = risks < self.risk_.risk_tolerance
        if is_safe.any():
            return legal[is_safe]
        least = int(np.argmin(risks))
        return legal[least : least + 1]

    def act(
        self, state: np.ndarray, greedy: bool = False, legal_actions: np.ndarray | None = None
    ) -> int:
        """The learner's action among the safe ones (the shield's S, Notes)."""
        check_is_set_up(self, "act")
        safe = self.safe_actions(state, legal_actions, greedy)
        if not greedy and safe.shape[0] < self._actions(legal_actions).shape[0]:
            self.num_shielded_steps_ += 1
        return int(self.learner_.act(state, greedy, safe))
