"""The deterministic risk analyser of GridWorld-1 (Geramifard 2012, Section 5.3.5)."""

from __future__ import annotations

import numpy as np

from conjure.core.cooperative import RISK_TOLERANCE, RiskAnalyzer
from conjure.core.interfaces import check_is_set_up
from conjure.safety.compiled_cooperative import FixedRisk

__all__ = ["NominalRiskAnalyzer"]


class NominalRiskAnalyzer(RiskAnalyzer):
    """Unsafe iff the noise-free outcome of the action is a constrained state.

    Geramifard (2012), Sections 5.3.3 and 5.3.5: "For GridWorld-1, based on the noise-free
    model, an action was assumed safe if it does not deliberately move the UAV to one of the
    off-limit grid cells." The deterministic risk model of Section 5.3.3: risk(s, a) is 1 if
    ``model.nominal_next_state(s, a)`` is constrained, else 0. It judges any `NoisyDomain`
    (a pit, a crash).

    Parameters
    ----------
    risk_tolerance : float, default 1.0
        ε in (0, 1]: an action other than π^p(s) is safe iff risk < ε. The risk is 0 or 1,
        so every ε in (0, 1] judges alike (see Notes).

    Attributes
    ----------
    rng_ : numpy.random.Generator
        Unused: the analyser is deterministic.

    Notes
    -----
    - Choice: risk is 0 or 1, so ``risk_tolerance`` defaults to 1 (any ε in (0, 1] agrees):
      safe iff the nominal outcome is not constrained. It is a parameter, as on every
      analyser, so that configs and sweeps name ε alike.

    Complexity
    ----------
    Θ(1): one noise-free step.

    Examples
    --------
    >>> from conjure.domains import GridWorld
    >>> from conjure.models.approximate_model import ApproximateModel
    >>> from conjure.planners import ShortestPathPlanner
    >>> domain = GridWorld.gridworld_1()  # pits at (2, 0) and (6, 2)
    >>> model = ApproximateModel(domain=domain).setup(domain.domain_spec, seed=0)
    >>> planner = ShortestPathPlanner().setup(model, seed=0)
    >>> analyser = NominalRiskAnalyzer().setup(model, planner, seed=0)
    >>> analyser.is_safe(np.array([1.0, 0.0]), 1)  # down, into the pit at (2, 0)
    False
    """

    parameter_constraints = {"risk_tolerance": RISK_TOLERANCE}

    def __init__(self, *, risk_tolerance: float = 1.0):
        self.risk_tolerance = risk_tolerance

    def _bind(self) -> None:
        """Build the compiled form (with ε) once, as the analyser's state."""
        self._form = FixedRisk(risk_tolerance=float(self.risk_tolerance))

    compiled_methods = ("risk", "is_safe")

    def compiled_form(self) -> FixedRisk:
        """Deterministic: the compiled iCCA box tabulates ``is_safe`` (`FixedRisk`, from setup)."""
        check_is_set_up(self, "compiled_form")
        return self._form

    def risk(self, state: np.ndarray, action: int, rng: np.random.Generator | None = None) -> float:
        """1.0 if the noise-free successor is constrained, else 0.0."""
        check_is_set_up(self, "risk")
        model = self.model_
        return float(model.is_constrained(model.nominal_next_state(state, action)))
