"""A small stand-in UAV mission domain and a go-home planner, for checks of mission components.

`MissionStub` implements the `NoisyDomain` interface on a `MissionGraph` with the state layout
of `conjure.domains.mission_graph` (positions, fuel, time; Section 5.3.5), so that the fuel
risk analyser and the common checks can run before the full UAV mission domain exists. It
leaves out the targets (no rewards are collected, the visited bits stay 0).
"""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np
from gymnasium import spaces

from conjure.core.cooperative import CooperativePlanner, NoisyDomain
from conjure.core.errors import IncompatibleComponentsError, InvalidParameterError
from conjure.core.interfaces import DomainSpec, check_is_set_up
from conjure.core.params import Constraint, InstanceOf, Interval
from conjure.domains.mission_graph import MissionGraph

__all__ = ["HomePlanner", "MissionStub", "tiny_mission"]


def tiny_mission() -> MissionGraph:
    """A 4-node line 0 - 1 - 2 - 3 with the base at 0, two UAVs with fuel 4, horizon 6."""
    return MissionGraph(num_nodes=4, edges=((0, 1), (1, 2), (2, 3)), fuel=(4, 4), horizon=6)


class MissionStub(NoisyDomain):
    """UAVs moving on a mission graph with edge-traverse failures (Sections 5.3.5 and 5.4.1).

    Each step every UAV goes to its destination (its node or a neighbour). With probability
    η (``traverse_failure``) a move fails: the fuel is burnt, the UAV stays. Every move or
    loiter burns one fuel, except loitering at the base. The mission fails (constrained,
    terminal, reward ``graph.crash_penalty``) when a UAV runs out of fuel away from the base or
    is not at the base at the horizon; it ends at the horizon. Each step earns minus the fuel
    burnt. Targets are left out.

    Parameters
    ----------
    graph : MissionGraph or None, default None
        The mission; ``None`` means `tiny_mission`.
    traverse_failure : float, default 0.05
        η in [0, 1].

    Attributes
    ----------
    graph_ : MissionGraph
        The mission.
    """

    noise_parameter: ClassVar[str] = "traverse_failure"
    parameter_constraints: ClassVar[dict[str, Constraint]] = {
        "graph": InstanceOf((MissionGraph, type(None)), "a MissionGraph or None"),
        "traverse_failure": Interval(float, 0.0, 1.0),
    }

    def __init__(self, *, graph: MissionGraph | None = None, traverse_failure: float = 0.05):
        self.graph = graph
        self.traverse_failure = traverse_failure
        self._build()

    def _build(self) -> None:
        self.validate_params()
        graph = tiny_mission() if self.graph is None else self.graph
        self.graph_ = graph
        low = np.zeros(graph.state_size)
        high = np.zeros(graph.state_size)
        high[0 : 2 * graph.num_uavs : 2] = graph.num_nodes - 1
        high[1 : 2 * graph.num_uavs : 2] = max(graph.fuel)
        high[2 * graph.num_uavs : -1] = 1
        high[-1] = graph.horizon
        self.observation_space = spaces.Box(low=low, high=high, dtype=np.float64)
        self.action_space = spaces.Discrete(graph.num_actions)
        self.domain_spec = DomainSpec(
            name=f"MissionStub({graph.num_nodes} nodes, {graph.num_uavs} UAVs)",
            low=low,
            high=high,
            is_discrete=np.ones(graph.state_size, dtype=bool),
            num_actions=graph.num_actions,
            discount=1.0,
            max_episode_steps=graph.horizon,
            has_action_constraints=True,
        )
        self._state = graph.initial_state()

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """Start with every UAV at the base, full fuel, t = 0."""
        super().reset(seed=seed)
        self._state = self.graph_.initial_state()
        return self._state.copy(), {}

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        """Move the UAVs (each move fails with probability η)."""
        next_state, reward, terminated = self.simulate(
            self._state, self.check_action(action), self.traverse_failure, self.np_random
        )
        self._state = next_state
        cost = float(self.is_constrained(next_state))
        return next_state.copy(), reward, terminated, False, {"cost": cost}

    def legal_actions(self, state: np.ndarray) -> np.ndarray:
        """Joint actions sending each UAV to its node or a neighbour."""
        graph = self.graph_
        options = [
            [node, *(n for n in graph.neighbours[node] if n >= 0)]
            for node in graph.locations(state).tolist()
        ]
        actions = [0]
        for uav, nodes in enumerate(options):
            actions = [a + n * graph.num_nodes**uav for a in actions for n in nodes]
        return np.array(sorted(actions), dtype=np.int64)

    def _move(
        self, state: np.ndarray, action: int, fails: np.ndarray
    ) -> tuple[np.ndarray, float, bool]:
        graph = self.graph_
        destinations = graph.decode_action(action)
        locations, fuels = graph.locations(state), graph.fuels(state)
        distance = graph.distances[locations, destinations]
        if np.any(distance > 1):
            raise InvalidParameterError(
                f"MissionStub: action {action} sends a UAV past a neighbour; legal: "
                f"{self.legal_actions(state).tolist()}."
            )
        stays_home = (locations == graph.base) & (destinations == graph.base)
        burnt = ~stays_home
        arrived = np.where((distance == 1) & fails, locations, destinations)
        next_state = state.copy()
        next_state[0 : 2 * graph.num_uavs : 2] = arrived
        next_state[1 : 2 * graph.num_uavs : 2] = np.maximum(fuels - burnt, 0)
        next_state[-1] = graph.time(state) + 1
        if self.is_constrained(next_state):
            return next_state, graph.crash_penalty, True
        return next_state, -float(burnt.sum()), graph.time(next_state) >= graph.horizon

    def simulate(
        self, state: np.ndarray, action: int, noise: float, rng: np.random.Generator
    ) -> tuple[np.ndarray, float, bool]:
        """Draw the next state: each UAV's move fails with probability ``noise``."""
        fails = rng.random(self.graph_.num_uavs) < noise
        return self._move(np.asarray(state, dtype=np.float64), int(action), fails)

    def nominal_next_state(self, state: np.ndarray, action: int) -> np.ndarray:
        """The next state when no move fails."""
        no_failure = np.zeros(self.graph_.num_uavs, dtype=bool)
        return self._move(np.asarray(state, dtype=np.float64), int(action), no_failure)[0]

    def count_unintended(
        self, state: np.ndarray, action: int, next_state: np.ndarray
    ) -> tuple[int, int]:
        """(failed moves, attempted moves) of an observed step."""
        graph = self.graph_
        destinations = graph.decode_action(action)
        moving = graph.locations(state) != destinations
        failed = moving & (graph.locations(next_state) != destinations)
        return int(failed.sum()), int(moving.sum())

    def is_constrained(self, state: np.ndarray) -> bool:
        """A crash: a UAV out of fuel away from the base, or away from it at the horizon."""
        graph = self.graph_
        away = graph.locations(state) != graph.base
        out_of_fuel = away & (graph.fuels(state) == 0)
        late = away & (graph.time(state) >= graph.horizon)
        return bool(np.any(out_of_fuel | late))


class HomePlanner(CooperativePlanner):
    """π^p for missions: every UAV flies one hop closer to the base, or stays there (safe).

    The most conservative mission policy (Section 5.3.5's fuel rule never flags it while the
    UAVs can get home): a test planner for mission components.
    """

    def __init__(self) -> None:
        pass

    def setup(self, model: Any, seed: int | np.random.SeedSequence) -> HomePlanner:
        """Read the mission graph of ``model.domain_``."""
        graph = getattr(getattr(model, "domain_", None), "graph_", None)
        if not isinstance(graph, MissionGraph):
            raise IncompatibleComponentsError(
                "HomePlanner plans on UAV missions: it needs a model whose domain has a "
                "`graph_` (a MissionGraph)."
            )
        self.graph_ = graph
        self.is_set_up_ = True
        return self

    def action(self, state: np.ndarray) -> int:
        """Each UAV's next hop on a shortest path to the base."""
        check_is_set_up(self, "action")
        graph = self.graph_
        hops = []
        for node in graph.locations(state).tolist():
            closer = [
                n
                for n in graph.neighbours[node]
                if n >= 0 and graph.distances[n, graph.base] < graph.distances[node, graph.base]
            ]
            hops.append(min(closer) if closer else node)
        return graph.encode_action(hops)
