"""The UAV fuel risk analyser (Geramifard 2012, Section 5.3.5)."""

from __future__ import annotations

import numpy as np

from conjure.core.cooperative import RISK_TOLERANCE, RiskAnalyzer
from conjure.core.errors import IncompatibleComponentsError
from conjure.core.interfaces import check_is_set_up
from conjure.domains.mission_graph import MissionGraph

__all__ = ["FuelRiskAnalyzer"]


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

    def risk(self, state: np.ndarray, action: int, rng: np.random.Generator | None = None) -> float:
        """1.0 if after the noise-free outcome some UAV cannot reach the base in time, else 0.0."""
        check_is_set_up(self, "risk")
        outcome = self.model_.nominal_next_state(state, action)
        return float(self.is_unsafe_outcome(self.graph_, outcome))

    @staticmethod
    def is_unsafe_outcome(graph: MissionGraph, state: np.ndarray) -> bool:
        """Whether some UAV has less fuel, or less time to the horizon, than its way home."""
        home = graph.distances[graph.locations(state), graph.base]
        time_left = graph.horizon - graph.time(state)
        return bool(np.any(graph.fuels(state) < home) or np.any(time_left < home))
