"""The interfaces of the iCCA architecture (Geramifard 2012, Section 5.2, Figures 5-3 and 5-11).

iCCA's control box couples three parts around an approximate model T̂ = (P̂, R̂):

- a **cooperative planner** π^p (Section 5.3.1): a fast, safe policy computed from T̂
  (value iteration on a small model, CBBA on UAV missions, a hand-coded policy);
- a **risk analyser** (Sections 5.3.3 and 5.5, Algorithm 25): is action a safe in state s?
- a **learner**: any online `Agent` (Algorithms 23, 24, 26 wrap it).

T̂ has the parametric form of the true domain with one unknown noise probability η (Section
5.5: "assuming an unknown uniform noise parameter"); a `NoisyDomain` supplies that form:
it can simulate a step from any state at any η, say what the step would be without noise,
and count the unintended moves of an observed transition so that η can be estimated.

Notes
-----
- Choice: `RiskAnalyzer.is_safe` returns True for a *safe* action. Section 5.3.3 defines
  ``safe`` as True for a catastrophic outcome, but Algorithms 23, 24 and 26 use it as "safe";
  the function is named by what it returns.
- Choice: failures are also reported the way constrained-RL libraries (Safety-Gymnasium)
  expect: every safety-relevant domain puts ``info["cost"] = 1.0`` in the step that enters a
  constrained state (crash, pit, fall) and 0.0 otherwise; `Domain.is_constrained` answers the
  same question for any state, for the risk analysers.
- Choice: the planner's own action is always safe (`RiskAnalyzer.is_safe` answers True for
  a = π^p(s) without analysing it): "the planner's policy should be seen safe through the
  eyes of the risk analyzer at all times" (end of Section 5.5.1), and π^p(s) is the fallback
  of every unsafe action anyway.
"""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np

from conjure.core.interfaces import Domain, check_is_set_up
from conjure.core.params import Configurable, Interval
from conjure.core.seeding import make_rng

__all__ = ["RISK_TOLERANCE", "CooperativePlanner", "NoisyDomain", "RiskAnalyzer"]

#: The constraint on ε (``risk_tolerance``) every `RiskAnalyzer` declares: a float in (0, 1];
#: an action other than π^p(s) is safe iff risk(s, a) < ε (Algorithm 25).
RISK_TOLERANCE = Interval(float, 0.0, 1.0, closed="right")


class NoisyDomain(Domain):
    """A domain whose randomness is governed by one noise probability η (Section 5.5.1).

    The parametric form of the approximate model T̂ (Figure 5-11): `ApproximateModel` in
    `conjure.models` simulates it at an estimated η̂, and estimates η̂ from the unintended moves
    `count_unintended` reports. ``noise_parameter`` names the constructor parameter that holds
    η (``noise`` for grid worlds, ``traverse_failure`` for UAV missions).
    """

    noise_parameter: ClassVar[str] = "noise"

    @property
    def noise_level(self) -> float:
        """The η this domain was built with."""
        return float(getattr(self, self.noise_parameter))

    def simulate(
        self, state: np.ndarray, action: int, noise: float, rng: np.random.Generator
    ) -> tuple[np.ndarray, float, bool]:
        """Draw ⟨s', r, terminated⟩ ~ T(s, a) at noise η = ``noise``, leaving the episode alone.

        ``state`` may be any valid state; the domain's own current state and ``np_random`` are
        not touched (the risk analyser's rollouts and the planners' models use this).
        """
        raise NotImplementedError

    def nominal_next_state(self, state: np.ndarray, action: int) -> np.ndarray:
        """Return s' when no noise acts (the deterministic model of Sections 5.3.1 and 5.3.5).

        Any other random event (a target's reward draw) takes its unsuccessful outcome.
        """
        raise NotImplementedError

    def count_unintended(
        self, state: np.ndarray, action: int, next_state: np.ndarray
    ) -> tuple[int, int]:
        """Return (#unintended moves, #moves) in an observed transition (Section 5.5.2's counts)."""
        raise NotImplementedError

    def noise_decomposition(self) -> tuple[Any, Any] | None:
        """Return the tabular models (T at η = 0, T at η = 1) if T_η = (1 − η)·T_0 + η·T_1.

        That holds when one Bernoulli(η) event per step decides whether the noise acts (the
        grid worlds' wind); a Monte-Carlo risk analyser then samples T̂ at any η̂ from two fixed
        tables in compiled code. ``None`` (the default): no such decomposition is known.
        """
        return None


class CooperativePlanner(Configurable):
    """π^p of iCCA (Section 5.3.1): a safe policy computed quickly from the model T̂.

    Lifecycle: ``setup(model, seed)`` plans on an `ApproximateModel`; ``action(state)`` returns
    π^p(s) (always a legal action); ``update(model)`` replans after T̂ changed (Algorithm 26,
    lines 10-12) and returns whether π^p changed, so that the cooperative learner can reset its
    knownness counts (line 13).
    """

    def setup(self, model: Any, seed: int | np.random.SeedSequence) -> CooperativePlanner:
        """Validate parameters, plan on ``model`` and return ``self``."""
        raise NotImplementedError

    def action(self, state: np.ndarray) -> int:
        """π^p(s)."""
        raise NotImplementedError

    def update(self, model: Any) -> bool:
        """Replan on the updated ``model``; return whether π^p changed."""
        return False


class RiskAnalyzer(Configurable):
    """Judges the learner's suggested actions (Section 5.3.3; Algorithm 25).

    ``setup(model, planner, seed)`` binds the analyser to T̂ and π^p (the Monte-Carlo analyser
    follows π^p after the first action) and seeds its generator ``rng_``; ``risk(s, a)``
    estimates the probability of reaching a constrained state; ``is_safe(s, a)`` is the
    ``safe`` test of Algorithms 23-26: the planner's own action always is, any other action is
    safe iff its risk is below ε, the ``risk_tolerance`` parameter every analyser declares
    (`RISK_TOLERANCE`). ``update(is_policy_changed=...)`` is called after T̂ or π^p changed
    (Algorithm 26, lines 10-13) so that analysers can refresh what they derived from them. An
    analyser that cannot judge the model's domain raises `IncompatibleComponentsError` in
    ``setup`` (from `_bind`).

    Sampling analysers draw from ``rng_``, or from the ``rng`` given to `risk`/`is_safe` (the
    cooperative learners pass a separate evaluation generator when acting greedily, so that
    policy checks never perturb learning).
    """

    risk_tolerance: float  # ε, a constructor parameter of every analyser (`RISK_TOLERANCE`)

    def setup(
        self, model: Any, planner: CooperativePlanner, seed: int | np.random.SeedSequence
    ) -> RiskAnalyzer:
        """Validate parameters, bind to ``model`` and ``planner`` and return ``self``."""
        self.validate_params()
        self.model_ = model
        self.planner_ = planner
        self.rng_ = make_rng(seed)
        self._bind()
        self.is_set_up_ = True
        self.update()
        return self

    def _bind(self) -> None:
        """Derive what the analyser needs from ``model_`` (or refuse a domain it cannot judge).

        Raises `IncompatibleComponentsError` naming the domain and what the analyser needs.
        """

    def simulated_steps(self) -> int:
        """Transitions of T̂ one judgement simulates at most (none by default; Algorithm 25: 𝓜𝓗).

        The compiled loop sizes its calls by it, so that Ctrl-C is seen between them.
        """
        return 0

    def update(self, *, is_policy_changed: bool = True) -> None:
        """T̂ or π^p changed: refresh anything derived from them (nothing by default).

        ``is_policy_changed`` False: only T̂ changed (η̂ moved), π^p is the one judged before.
        """

    def risk(self, state: np.ndarray, action: int, rng: np.random.Generator | None = None) -> float:
        """The estimated probability that ``action`` in ``state`` leads to a constrained state."""
        raise NotImplementedError

    def is_safe(
        self,
        state: np.ndarray,
        action: int,
        rng: np.random.Generator | None = None,
        *,
        planner_action: int | None = None,
    ) -> bool:
        """safe(s, a): a = π^p(s), or risk(s, a) < ``risk_tolerance``.

        ``planner_action``: π^p(s) when the caller already has it (the cooperative learners
        ask π^p first, Algorithms 23-24, line 1), so that the planner is not asked twice;
        ``None`` asks the planner.
        """
        check_is_set_up(self, "is_safe")
        if planner_action is None:
            planner_action = self.planner_.action(state)
        if action == planner_action:  # the planner's own action (Section 5.5.1)
            return True
        return self.risk(state, action, rng) < self.risk_tolerance
