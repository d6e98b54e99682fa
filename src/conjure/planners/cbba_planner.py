"""CBBA as iCCA's cooperative planner on UAV missions (Section 5.3.1 and Algorithm 27).

π^p(s) is the first move of the CBBA plan made from s on the deterministic (expected-value)
model of the mission: every UAV steps along a shortest path to the first target of its CBBA
path. The thesis replans "on each step of the simulation ... to cope with the stochasticity of
the environment" (Section 5.5.2), so every call plans from the state it is given.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np
from numba import njit

from conjure.core.cooperative import CooperativePlanner
from conjure.core.errors import IncompatibleComponentsError, InvalidParameterError
from conjure.core.interfaces import check_is_set_up
from conjure.core.params import Interval, Options
from conjure.domains.mission_graph import MissionGraph
from conjure.planners._cbba_kernels import encode_destinations, is_mission_state, plan_mission
from conjure.planners.cbba import Allocation, default_max_rounds
from conjure.representations.compiled_representation import (
    RepresentationKernel,
    clear_index,
    index_row,
)
from conjure.representations.hashed_tabular import HashedTabular

__all__ = [
    "CBBAPlanner",
    "MissionPlan",
    "MissionPlanner",
    "first_move",
    "mission_plan",
    "planned_action",
]


class MissionPlanner(NamedTuple):
    """CBBA's π^p as a compiled kernel reads it (`first_move`): the arguments of `plan_mission`.

    Geramifard (2012), Section 5.3.1 and Algorithm 27; built by `CBBAPlanner.setup`.

    Parameters
    ----------
    distances : ndarray of float64, shape (N, N)
        Hop counts (CBBA's travel times).
    next_hop : ndarray of int64, shape (N, N)
        The next node on a shortest path.
    node_tasks : ndarray of float64, shape (N, 4)
        Every node as a CBBA task: [node, r_j p_j, window start, window end].
    num_uavs, base : int
        n and the base node.
    horizon : float
        H.
    settings : ndarray of float64, shape (3,)
        CBBA's [min first leg, λ, ρ].
    is_conservative : bool
        Algorithm 27 (True) or one aggressive CBBA run.
    fuel_reserve : float
        Algorithm 27's reserve.
    is_refuel_to_plan : bool
        ``refuel="empty_plan"``.
    max_rounds : int
        CBBA's round limit.
    cache : RepresentationKernel
        The plan cache's index of states (a `HashedTabular`'s form), updated in place.
    cached : ndarray of int64
        π^p of each cached row (−1: none yet), updated in place.
    has_cache : bool
        Whether states are cached (``cache_size`` > 0).
    """

    distances: np.ndarray
    next_hop: np.ndarray
    node_tasks: np.ndarray
    num_uavs: int
    base: int
    horizon: float
    settings: np.ndarray
    is_conservative: bool
    fuel_reserve: float
    is_refuel_to_plan: bool
    max_rounds: int
    cache: RepresentationKernel
    cached: np.ndarray
    has_cache: bool


@njit(cache=True)
def mission_plan(planner: MissionPlanner, state: np.ndarray) -> tuple:
    """`plan_mission`'s plan of a valid mission ``state`` (float64, the observation layout)."""
    return plan_mission(
        state, planner.distances, planner.next_hop, planner.node_tasks, planner.num_uavs,
        planner.base, planner.horizon, planner.settings, planner.is_conservative,
        planner.fuel_reserve, planner.is_refuel_to_plan, planner.max_rounds,
    )  # fmt: skip


@njit(cache=True)
def first_move(planner: MissionPlanner, state: np.ndarray) -> int:
    """π^p(s): the joint first move of the plan made from a valid ``state`` (not cached)."""
    destinations = mission_plan(planner, state)[0]
    return encode_destinations(destinations, planner.distances.shape[0])


@njit(cache=True, inline="always")
def planned_action(planner: MissionPlanner, state: np.ndarray) -> int:
    """π^p(s) of a valid ``state`` through the plan cache (`CBBAPlanner.action`).

    A state met before answers from the cache; a new one is planned (`first_move`) and
    cached; a full cache is emptied first. Plans are deterministic, so the cache never
    changes an answer.
    """
    if not planner.has_cache:
        return first_move(planner, state)
    row = index_row(planner.cache, state)
    if row < 0:  # full
        clear_index(planner.cache)
        planner.cached.fill(-1)
        row = index_row(planner.cache, state)
    action = planner.cached[row]
    if action < 0:
        action = first_move(planner, state)
        planner.cached[row] = action
    return action


@dataclass(frozen=True, eq=False)
class MissionPlan:
    """The CBBA plan of one mission state and the joint action it implies (Section 5.3.1).

    Parameters
    ----------
    time : int
        The state's time step t.
    task_nodes : ndarray of int64
        The nodes CBBA was given as tasks (task k is node ``task_nodes[k]``).
    fuel : ndarray of float64, shape (n,)
        The fuel each UAV was planned with (after Algorithm 27's loop for the conservative
        variant; the real fuel for the aggressive one).
    cbba_runs : int
        How many times CBBA ran (Algorithm 27's loop; 1 for the aggressive variant).
    allocation : Allocation
        CBBA's result, in task indices.
    destinations : ndarray of int64, shape (n,)
        Each UAV's next node (π^p(s) decoded).
    action : int
        The joint action ``MissionGraph.encode_action(destinations)``.
    """

    time: int
    task_nodes: np.ndarray
    fuel: np.ndarray
    cbba_runs: int
    allocation: Allocation
    destinations: np.ndarray
    action: int

    @property
    def paths(self) -> tuple[np.ndarray, ...]:
        """Each UAV's target nodes in the order it visits them."""
        return tuple(self.task_nodes[path] for path in self.allocation.paths)

    @property
    def arrivals(self) -> tuple[np.ndarray, ...]:
        """The planned arrival time at each target of `paths`."""
        return self.allocation.arrivals

    @property
    def assignment(self) -> dict[int, int]:
        """Target node → the UAV assigned to it."""
        return {
            int(self.task_nodes[task]): int(agent)
            for task, agent in enumerate(self.allocation.assignment)
            if agent >= 0
        }


class CBBAPlanner(CooperativePlanner):
    """π^p of iCCA on UAV missions: aggressive or conservative CBBA (Section 5.3.1, Algorithm 27).

    CBBA (Choi, Brunet & How 2009; `conjure.planners.cbba.CBBA`) runs on the deterministic view
    of the mission T̂, where every random event takes its expected value (Section 5.3.1: "an
    80% chance ... achieving a reward of 100 ... is assumed to be successful all the time with
    the corresponding reward of 80"). From a state s:

    - tasks: the unvisited target nodes j with r_j p_j > 0 whose window is still open, worth
      r_j p_j; travel times are the Floyd-Warshall hop counts of the mission graph;
    - agents: the UAVs at their nodes with their fuel (aggressive: all of it; conservative:
      Algorithm 27); a path is feasible when every target is reached inside its window and
      the UAV is back at the base by the horizon within that fuel;
    - π^p(s): each UAV steps along a shortest path (ties: the lowest-numbered neighbour) to
      the first target of its path, or stays there while early; a UAV with no target goes
      back to (or stays at) the base.

    Algorithm 27 (conservative CBBA): MaxFuel ← the UAVs' fuel; plan with fuel − reserve
    (clamped at 0); while some UAV has no feasible plan, give each such UAV one more unit of
    fuel, up to MaxFuel, and run CBBA again. A UAV whose path is empty but which can fly home
    within its reduced fuel has a feasible plan, going home (``refuel="home"``, see Notes).
    Aggressive CBBA is one CBBA run with the full fuel.

    Parameters
    ----------
    variant : {"conservative", "aggressive"}, default "conservative"
        Algorithm 27 or plain CBBA with all remaining fuel (Section 5.5.2).
    fuel_reserve : int, default 3
        >= 0, the fuel Algorithm 27 holds back at first (line 2).
    refuel : {"home", "empty_plan"}, default "home"
        When Algorithm 27 gives a UAV with an empty path one more fuel unit (line 8): while it
        cannot fly home within its reduced fuel ("home": the reserve is released only to bring
        it home), or while its path is empty ("empty_plan": the printed test Plan[u] = ∅ read
        alone, spec 1.7, whose reserve erodes under per-step replanning; see Notes).
    fuel_weight : float, default 1.0
        ρ >= 0 (finite): CBBA's fuel penalty per hop from a UAV to a target (the ACL code's
        constant fuel cost; 1 is the mission's fuel cost per move).
    cache_size : int, default 65536
        >= 0, the most states whose action is remembered (0: no cache); a full cache is
        emptied and fills again.

    Attributes
    ----------
    graph_ : MissionGraph
        The mission of the model's domain.
    next_hop_ : ndarray of int64, shape (N, N)
        The next node on a shortest path from each node to each node.
    distances_ : ndarray of float64, shape (N, N)
        The graph's hop counts, CBBA's travel times.
    node_tasks_ : ndarray of float64, shape (N, 4)
        Every node as a CBBA task: [node, r_j p_j, window start, window end].
    num_cached_ : int
        States whose action is remembered.

    Notes
    -----
    - Choice: the loop condition of Algorithm 27, printed "while not ok or MaxFuel =
      UAVs.fuel", runs until every UAV is ok or every UAV that is not already has its full
      fuel, and returns the last plan (``domains-and-icca`` spec section 1.7, item 4).
    - Choice (``refuel="home"``, the default): which UAV is "ok". Section 5.5.2 explains the
      loop: "If the resulting plan allows all UAVs to get back to the base safely, it will be
      returned as the solution. Otherwise, UAVs with no feasible plan (i.e., Plan[u] = ∅) will
      have their fuels incremented". A UAV with no target but enough reduced fuel to fly home
      has a feasible plan, going home, and is ok; fuel comes back one unit at a time, capped
      at the real fuel, only while a UAV cannot even reach the base within its reduced fuel.
      The reserve is therefore never spent on targets: each UAV is planned with at most
      max(fuel − reserve, its distance home), and an idle UAV (no target left, late in a
      mission) keeps its reserve. π^p is replanned at every step
      (Section 5.5.2) from the current fuel, so under the printed test alone ("empty_plan")
      a UAV without a plan regains the reserve and spends it on a target at the next replan,
      and the reserve erodes to nothing, where the thesis reports "rare chances of
      crashing" (both readings' exact crash probabilities on spec 2.2's UAV 7-2:
      ``python docs/reproduction/uav_calibration.py --refuel``).
    - Choice: the score is Σ r_j p_j minus ρ·(hops from the UAV to each of its targets); this
      fuel term is constant per UAV-target pair, so marginal gains still diminish and CBBA
      still equals sequential greedy (the ACL code's device). Equal bids go to the lower UAV.
    - Choice: fuel burnt = return time − departure time: loitering costs fuel away from the
      base, so a UAV at the base waits there (free) until it must leave to keep its return
      time; elsewhere it leaves at once and waits at a target if early (Section 5.3.5).
    - Choice: a visit at time t has already been drawn in a state at time t, so the first
      target is reached at t + 1 at the earliest (a UAV standing on an unvisited target
      loiters one step to try again, inside its window).
    - Choice: ``update`` returns False. CBBA's deterministic model takes every move as
      succeeding, so the noise estimate η̂ never enters the plan; AM-iCCA's switch from the
      conservative to the aggressive variant when η̂ drops (Section 5.5.2) belongs to the
      cooperative learner, which holds one planner of each variant.
    - The cache indexes states as a `HashedTabular` does (a row per state, first seen first)
      and keeps the joint action per row; a full cache is emptied and fills again. Plans are
      deterministic, so it never changes an answer. The compiled loop's iCCA box uses the same
      cache (`planned_action`).

    Complexity: one CBBA run costs Θ(rounds·n·m·L²) with m <= N targets and paths of L <= m;
    Algorithm 27 runs it at most 1 + n·reserve times (per-plan cost, uncached and cached:
    ``python benchmarks/cbba_speed.py``).

    Examples
    --------
    >>> from types import SimpleNamespace
    >>> from conjure.domains.mission_graph import uav_7_2
    >>> graph = uav_7_2()
    >>> model = SimpleNamespace(domain_=SimpleNamespace(graph_=graph))
    >>> planner = CBBAPlanner(variant="aggressive").setup(model, seed=0)
    >>> plan = planner.plan(graph.initial_state())
    >>> [p.tolist() for p in plan.paths]  # one UAV per target: node 1 gets one
    [[1, 3, 4, 2], [6, 5]]
    >>> plan.destinations.tolist()
    [1, 2]
    >>> conservative = CBBAPlanner().setup(model, seed=0).plan(graph.initial_state())
    >>> [p.tolist() for p in conservative.paths], conservative.fuel.tolist()  # fuel − 3
    ([[1, 2], [3]], [3.0, 4.0])
    """

    parameter_constraints = {
        "variant": Options(("conservative", "aggressive")),
        "fuel_reserve": Interval(int, 0, None),
        "refuel": Options(("home", "empty_plan")),
        "fuel_weight": Interval(float, 0.0, math.inf, closed="left"),
        "cache_size": Interval(int, 0, None),
    }

    def __init__(
        self,
        *,
        variant: str = "conservative",
        fuel_reserve: int = 3,
        refuel: str = "home",
        fuel_weight: float = 1.0,
        cache_size: int = 65536,
    ):
        self.variant = variant
        self.fuel_reserve = fuel_reserve
        self.refuel = refuel
        self.fuel_weight = fuel_weight
        self.cache_size = cache_size

    def setup(self, model: Any, seed: int | np.random.SeedSequence = 0) -> CBBAPlanner:
        """Read the mission graph of ``model.domain_`` (CBBA is deterministic: no seed used)."""
        self.validate_params()
        graph = getattr(getattr(model, "domain_", None), "graph_", None)
        if not isinstance(graph, MissionGraph):
            domain = getattr(model, "domain_", None)
            raise IncompatibleComponentsError(
                f"CBBAPlanner plans UAV missions: its model's domain needs a MissionGraph "
                f"`graph_`; got {type(domain).__name__} (was the model set up with UAVMission?)."
            )
        self.graph_ = graph
        self.next_hop_ = _next_hops(graph)
        self.distances_ = graph.distances.astype(np.float64)
        values = graph.rewards * graph.probabilities
        self.node_tasks_ = np.column_stack(
            [np.arange(graph.num_nodes), values, graph.windows.astype(np.float64)]
        )
        self._cache = HashedTabular(capacity=max(self.cache_size, 1)).setup(
            graph.state_spec("CBBAPlanner's plan cache"), 0
        )
        self._form = MissionPlanner(
            distances=self.distances_,
            next_hop=self.next_hop_,
            node_tasks=self.node_tasks_,
            num_uavs=graph.num_uavs,
            base=graph.base,
            horizon=float(graph.horizon),
            settings=np.array([1.0, 0.0, float(self.fuel_weight)]),
            is_conservative=self.variant == "conservative",
            fuel_reserve=float(self.fuel_reserve),
            is_refuel_to_plan=self.refuel == "empty_plan",
            max_rounds=default_max_rounds(graph.num_uavs, graph.num_nodes, graph.num_nodes, 1),
            cache=self._cache.compiled_form(),
            cached=np.full(self._cache.num_features_, -1, dtype=np.int64),
            has_cache=self.cache_size > 0,
        )
        self.is_set_up_ = True
        return self

    compiled_methods = ("action",)
    #: The cache size reaches the kernel only as the cache's length, which is the number of
    #: mission states when that is smaller (then no size changes the form).
    compiled_irrelevant_params = frozenset({"cache_size"})

    def compiled_form(self) -> MissionPlanner:
        """π^p for the compiled iCCA box (`planned_action`, with this planner's own cache)."""
        check_is_set_up(self, "compiled_form")
        return self._form

    @property
    def num_cached_(self) -> int:
        """States whose action is remembered."""
        check_is_set_up(self, "num_cached_")
        return int(np.count_nonzero(self._form.cached >= 0)) if self.cache_size else 0

    def action(self, state: np.ndarray) -> int:
        """π^p(s): the joint first move of the CBBA plan made from ``state`` (cached)."""
        check_is_set_up(self, "action")
        state = np.asarray(state, dtype=np.float64)
        self._check_state(state)
        return int(planned_action(self._form, state))

    def plan(self, state: np.ndarray) -> MissionPlan:
        """The full CBBA plan made from ``state`` (not cached), for inspection."""
        check_is_set_up(self, "plan")
        state = np.asarray(state, dtype=np.float64)
        self._check_state(state)
        destinations, task_nodes, fuel, runs, result = mission_plan(self._form, state)
        action = int(encode_destinations(destinations, self.graph_.num_nodes))
        return MissionPlan(
            time=int(state[-1]),
            task_nodes=task_nodes,
            fuel=fuel,
            cbba_runs=int(runs),
            allocation=Allocation.from_kernel(result),
            destinations=destinations,
            action=action,
        )

    def update(self, model: Any) -> bool:
        """Return False: the noise estimate never enters CBBA's deterministic plan."""
        check_is_set_up(self, "update")
        return False

    def _check_state(self, state: np.ndarray) -> None:
        graph = self.graph_
        if state.shape != (graph.state_size,):
            raise InvalidParameterError(
                f"CBBAPlanner was set up for {graph.state_size}-long mission states; got shape "
                f"{state.shape}. Was it set up with another mission's model?"
            )
        if not is_mission_state(state, graph.num_uavs, graph.num_nodes):
            raise InvalidParameterError(
                f"CBBAPlanner got an invalid mission state {state.tolist()}: locations must be "
                f"nodes in [0, {graph.num_nodes - 1}], fuel and time ints >= 0."
            )


def _next_hops(graph: MissionGraph) -> np.ndarray:
    """next_hop[u, g]: the lowest-numbered neighbour of u one hop closer to g (u itself at g)."""
    n = graph.num_nodes
    distances, neighbours = graph.distances, graph.neighbours
    table = np.empty((n, n), dtype=np.int64)
    for u in range(n):
        for g in range(n):
            table[u, g] = u
            if u != g:
                row = neighbours[u][neighbours[u] >= 0]
                table[u, g] = int(row[distances[row, g] == distances[u, g] - 1][0])
    return table
