"""The UAV fuel risk analyser (Geramifard 2012, Section 5.3.5)."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

from conjure.core.cooperative import RISK_TOLERANCE, RiskAnalyzer
from conjure.core.errors import IncompatibleComponentsError
from conjure.core.interfaces import check_is_set_up
from conjure.domains.mission_graph import MissionGraph
from conjure.domains.uav_mission import nominal_next_state

__all__ = ["FuelRisk", "FuelRiskAnalyzer", "fuel_risk", "is_stranded"]


class FuelRisk(NamedTuple):
    """The fuel rule as a compiled kernel reads it (`fuel_risk`; Section 5.3.5).

    Parameters
    ----------
    layout : ndarray of int64, shape (4,)
        The mission's [n, N, base, H] (`conjure.domains._mission_kernels`).
    home : ndarray of int64, shape (N,)
        Each node's shortest-path hops to the base (Floyd-Warshall).
    risk_tolerance : float
        ε: an action other than π^p(s) is safe iff its risk (0 or 1) is below it.
    """

    layout: np.ndarray
    home: np.ndarray
    risk_tolerance: float


@njit(cache=True)
def is_stranded(state: np.ndarray, layout: np.ndarray, home: np.ndarray) -> bool:
    """Whether some UAV has less fuel, or less time to the horizon, than its way home."""
    time_left = layout[3] - state[state.shape[0] - 1]
    for i in range(layout[0]):
        way_home = home[int(state[2 * i])]
        if state[2 * i + 1] < way_home or time_left < way_home:
            return True
    return False


@njit(cache=True)
def fuel_risk(risk: FuelRisk, state: np.ndarray, action: int) -> float:
    """1.0 if a legal ``action`` strands a UAV after its noise-free outcome, else 0.0."""
    outcome = nominal_next_state(state.astype(np.int64), action, risk.layout)
    return 1.0 if is_stranded(outcome, risk.layout, risk.home) else 0.0


class FuelRiskAnalyzer(RiskAnalyzer):
    """Unsafe iff after the action some UAV cannot get back to the base in time.

    Geramifard (2012), Section 5.3.5: "first all-pairs shortest paths were calculated using
    Floyd-Warshall algorithm and stored. On each step, an action was assumed unsafe if after
    executing the action, the UAV does not have enough fuel to return to the base using the
    shortest path values." The outcome is the noise-free one (``model.nominal_next_state``),
    the distances the model graph's ``distances`` (Floyd-Warshall, `MissionGraph`).

    Parameters
    ----------
    risk_tolerance : float, default 1.0
        ε in (0, 1]: an action other than π^p(s) is safe iff risk < ε. The risk is 0 or 1,
        so every ε in (0, 1] judges alike (see Notes).

    Attributes
    ----------
    graph_ : MissionGraph
        The mission of the model's domain (``model.domain_.graph_``).
    rng_ : numpy.random.Generator
        Unused: the analyser is deterministic.

    Notes
    -----
    - Choice (spec 2.1): an action is also unsafe when, after it, the time left to the
      horizon is shorter than some UAV's distance to the base (the mission fails if a UAV is
      not home at the horizon).
    - Choice: risk is 0 or 1, so ``risk_tolerance`` defaults to 1 (any ε in (0, 1] agrees):
      safe iff every UAV can make it home. It is a parameter, as on every analyser.

    Complexity
    ----------
    Θ(n) for n UAVs, after an Θ(N³) Floyd-Warshall done once by the `MissionGraph`.

    Examples
    --------
    >>> from conjure.domains.mission_graph import uav_7_2
    >>> graph = uav_7_2()
    >>> state = graph.initial_state()  # both UAVs at the base with full tanks, t = 0
    >>> FuelRiskAnalyzer.is_unsafe_outcome(graph, state)
    False
    >>> state[0], state[1] = 3, 1  # UAV 1 at node 3, two hops from the base, with 1 fuel
    >>> FuelRiskAnalyzer.is_unsafe_outcome(graph, state)
    True
    """

    parameter_constraints = {"risk_tolerance": RISK_TOLERANCE}

    def __init__(self, *, risk_tolerance: float = 1.0):
        self.risk_tolerance = risk_tolerance

    def _bind(self) -> None:
        domain = self.model_.domain_
        graph = getattr(domain, "graph_", None)
        if not isinstance(graph, MissionGraph):
            raise IncompatibleComponentsError(
                f"FuelRiskAnalyzer judges UAV missions: it needs a model whose domain has a "
                f"`graph_` (a MissionGraph), but {type(domain).__name__} has none; use "
                f"NominalRiskAnalyzer or MonteCarloRiskAnalyzer."
            )
        self.graph_ = graph
        layout, home = _fuel_tables(graph)
        self._form = FuelRisk(layout=layout, home=home, risk_tolerance=float(self.risk_tolerance))

    compiled_methods = ("risk", "is_safe")

    def compiled_form(self) -> FuelRisk:
        """The fuel rule for the compiled iCCA box (`fuel_risk`), built once with ε in setup."""
        check_is_set_up(self, "compiled_form")
        return self._form

    def risk(self, state: np.ndarray, action: int, rng: np.random.Generator | None = None) -> float:
        """1.0 if after the noise-free outcome some UAV cannot reach the base in time, else 0.0."""
        check_is_set_up(self, "risk")
        outcome = self.model_.nominal_next_state(state, action)
        return float(is_stranded(outcome, self._form.layout, self._form.home))

    @staticmethod
    def is_unsafe_outcome(graph: MissionGraph, state: np.ndarray) -> bool:
        """Whether some UAV has less fuel, or less time to the horizon, than its way home."""
        return bool(is_stranded(np.asarray(state, dtype=np.float64), *_fuel_tables(graph)))


def _fuel_tables(graph: MissionGraph) -> tuple[np.ndarray, np.ndarray]:
    """`FuelRisk`'s layout and hops home of ``graph``."""
    return graph.layout, np.ascontiguousarray(graph.distances[:, graph.base], dtype=np.int64)
