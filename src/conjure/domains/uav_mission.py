"""UAV mission planning: fuel-limited UAVs visit targets on a graph (Geramifard 2012, §5.3.5)."""

from __future__ import annotations

import json
import math
from collections import OrderedDict
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
from gymnasium import spaces

from conjure.core.cooperative import NoisyDomain
from conjure.core.errors import InvalidParameterError
from conjure.core.params import Constraint, InstanceOf, Interval, Options, did_you_mean
from conjure.domains._mission_dp import (
    action_values,
    evaluate_policy,
    layer_size,
    solve_mission,
    state_key,
)
from conjure.domains._mission_kernels import (
    ILLEGAL,
    checked_legal_actions,
    checked_legal_mask,
    checked_transition,
    count_unintended,
    is_crashed,
    is_legal,
    is_terminal,
    mission_step,
    nominal_next_state,
    state_from_observation,
)
from conjure.domains.action_masking import ActionMasking
from conjure.domains.compiled_domain import (
    UAV_MISSION,
    DomainKernel,
    KeptCompiledForm,
    MissionConstants,
    domain_kernel,
)
from conjure.domains.mission_graph import (
    MissionGraph,
    sample_mission,
    uav_7_2,
    uav_7_2_spec,
    uav_10_2,
    uav_10_2_spec,
)

#: The mission's kernels that iCCA's compiled parts reuse: the noise-free step (the fuel rule,
#: `conjure.safety.fuel_risk`), the random step and crash test (Algorithm 25's rollouts) and
#: the move counts of the adaptive model (Algorithm 26).
__all__ = [
    "MissionSolution",
    "PolicyEvaluation",
    "UAVMission",
    "count_unintended",
    "is_crashed",
    "mission_step",
    "nominal_next_state",
]

SCENARIOS = {
    "uav-7-2": uav_7_2,
    "uav-10-2": uav_10_2,
    "uav-7-2-spec": uav_7_2_spec,
    "uav-10-2-spec": uav_10_2_spec,
}
#: Largest joint action space N^n accepted (the legal-action sampler builds masks of this size).
MAX_JOINT_ACTIONS = 1_000_000
#: Largest time layer 2^m Π(F_i + 1) N^n `exact_solution` accepts (~33 bytes per key in memory).
MAX_LAYER_KEYS = 20_000_000
#: Largest H · 2^m Π(F_i + 1) N^n `exact_solution` accepts: it visits every key of every
#: layer (UAV 10-2: 1.1e7 keys).
MAX_SOLVE_KEYS = 500_000_000
_SOLUTIONS: OrderedDict[tuple[str, float], MissionSolution] = OrderedDict()
_CACHE_SIZE = 8


class UAVMission(KeptCompiledForm, ActionMasking, NoisyDomain):
    """A team of fuel-limited UAVs collects stochastic target rewards on a mission graph.

    Geramifard (2012), Section 5.3.5 ("UAV Mission Planning: MDP formulation", Figure 5-4,
    footnotes 3-4) and Section 5.4.1 (edge-traverse failures); spec ``domains-and-icca``
    section 2. n UAVs start at the base with their initial fuel at t = 0. Each step every UAV
    stays (loiters) at its node or moves along an edge; moving or loitering burns one fuel unit
    and takes one step, except loitering at the base, which is free. With probability η
    (``traverse_failure``, unknown to the planner's model in Section 5.4.1) a UAV trying to
    traverse an edge burns its fuel but does not move. A UAV at an unvisited target inside the
    target's window obtains its reward r_j with probability p_j (k UAVs there together:
    1 − (1 − p_j)^k); only then does v_j turn on. The step's reward is Σ newly obtained r_j minus
    the fuel burnt. The mission fails, with reward −Σ_j r_j, when a UAV is away from the base
    without fuel or when t = H finds a UAV away from the base; it ends successfully at t = H
    with every UAV home. γ = 1.

    Parameters
    ----------
    scenario : {"uav-7-2", "uav-10-2", "uav-7-2-spec", "uav-10-2-spec"}, default="uav-7-2"
        A shipped scenario of Figure 5-4 (`conjure.domains.mission_graph`): the calibrated
        reconstructions, or spec 2.2's first ones (``-spec``); ignored when ``graph`` is given.
    graph : mapping or None, default=None
        Any mission graph, as a config mapping ``MissionGraph.from_dict`` reads (``num_nodes``,
        ``edges``, ``fuel``, ``horizon``, ``base``, ``targets``); it replaces ``scenario``. At
        most 10⁶ joint actions N^n (checked first) and 1000 nodes (`mission_graph.MAX_NODES`).
    mission_seed : int or None, default=None
        A generated mission: on the nodes, edges, base and horizon of ``scenario`` (or
        ``graph``), targets and fuel drawn by `mission_graph.sample_mission` from
        ``numpy.random.default_rng(mission_seed)``, without the calibrated graphs' target
        planted beside the base. The same seed gives the same mission; the run's seed only
        drives the episodes. ``None``: the graph as given.
    traverse_failure : float, default=0.0
        η in [0, 1], the probability that a UAV trying to traverse an edge stays where it is
        (Section 5.4.1 uses 0.05; Section 5.3.5 uses 0).
    illegal_action : {"raise", "ignore", "penalize"}, default="raise"
        What an illegal joint action does: raise, or a no-op step with reward 0 or
        −``illegal_action_penalty`` (`conjure.domains.action_masking`).
    illegal_action_penalty : float, default=1.0
        Penalty in [0, inf) of ``illegal_action="penalize"``.

    Attributes
    ----------
    graph_ : MissionGraph
        The mission: nodes, edges, fuel, horizon, targets, shortest-path distances. CBBA and
        the fuel risk analyser read it as ``model.domain_.graph_``.
    domain_spec : DomainSpec
        2n + N + 1 integer dimensions in the layout of `conjure.domains.mission_graph`:
        l_i ∈ [0, N − 1], f_i ∈ [0, F_i], v_j ∈ {0, 1}, t ∈ [0, H]; N^n joint actions,
        γ = 1, cap H, ``has_action_constraints=True``.

    Notes
    -----
    ========  ==================  ==================================================
    Symbol    Name                Meaning
    ========  ==================  ==================================================
    l_i       obs[2i]             node of UAV i (0-based; the base is node 0)
    f_i       obs[2i + 1]         remaining fuel of UAV i
    v_j       obs[2n + j]         1 once node j's reward was obtained
    t         obs[-1]             time step, 0 .. H
    a         action              Σ_i l_i⁺ N^i, l_i⁺ the next node of UAV i
    η         traverse_failure    probability that a traversal fails
    γ         discount            1.0
    ========  ==================  ==================================================

    - Choice: a UAV obtains a target whenever it *is* at the unvisited node inside the window
      after a step, so loitering at a target retries the draw (one fuel unit per try). The
      state ⟨l, f, v, t⟩ keeps no record of earlier tries, the thesis lets UAVs loiter "if they
      believe loitering to be the optimal action", and a planner that arrives before a window
      opens waits at the target (spec 1.7), which only pays if the wait can obtain it.
    - Choice: the window [a_j, b_j] is tested at the arrival time t + 1 (the t of the next
      state); default windows are [0, H].
    - Choice: only nodes with a positive reward can be obtained; v_j of a node without value
      stays 0 (nothing is obtained there, and the bits would only split states).
    - Choice: the failure reward −Σ_j r_j replaces the step's reward (no fuel, no target on the
      crashing step), as the goal and pit rewards of GridWorld do; a crash is charged once
      however many UAVs fail. ``info["cost"]`` is 1.0 on that step and 0.0 otherwise.
    - Choice: "runs out of fuel" means f_i = 0 away from the base after a step, which is a
      crash even if the UAV could still reach the base; at the base f_i = 0 is safe and the UAV
      can only stay. Fuel never goes below 0: moving needs f_i >= 1, and a UAV away from the base
      always has f_i >= 1 in a non-terminal state.
    - Choice: every step draws exactly 2n uniforms from ``np_random``, used or not: u_i decides
      UAV i's traversal (fails if u_i < η), u_{n+c} the c-th target that may be obtained (in
      the order of the first UAV at each). The compiled kernel ``mission_step`` draws the same
      numbers from a Generator, so a compiled loop replays `step` exactly. A terminal state
      absorbs (reward 0). A rejected illegal action (``illegal_action`` "ignore"/"penalize")
      draws them too.
    - Choice: illegal joint actions raise `InvalidParameterError` unless ``illegal_action``
      says otherwise; ``action_masks()`` and ``info["action_mask"]`` give the legal ones as a
      bool mask (`conjure.domains.action_masking`). A no-op leaves t unchanged, so the episode
      then ends at the cap H (``TimeLimit``, the run loop) rather than at t = H.
    - Choice: the domain never truncates; the episode ends (terminated) at t = H or a crash, so
      ``max_episode_steps`` is H.
    - [R] The graphs of Figure 5-4 are lost; the shipped scenarios are the reconstructions
      documented in `conjure.domains.mission_graph`.

    Complexity: Θ(n² + N^n) per step (the step, then the new state's legal mask over the N^n
    joint actions, which `legal_actions` of the current state reads); Θ(Π_i (deg(l_i) + 1))
    per `legal_actions` of any other state. `exact_solution`
    takes Θ(Σ_t |S_t| · |A(s)| · 4^n) time over the reachable states S_t of each time layer and
    Θ(2^m Π_i (F_i + 1) N^n + Σ_t |S_t|) memory (m targets).

    Examples
    --------
    >>> domain = UAVMission()
    >>> obs, info = domain.reset(seed=0)
    >>> obs.tolist()  # l_1, f_1, l_2, f_2, v_0..v_6, t
    [0.0, 6.0, 0.0, 7.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]
    >>> domain.legal_actions(obs).size  # each UAV: stay, or fly to node 1 or 2
    9
    >>> obs, reward, terminated, truncated, info = domain.step(domain.graph_.encode_action([1, 0]))
    >>> obs[:4].tolist(), obs[5], reward, info["cost"]  # node 1's 600 obtained, 1 fuel burnt
    ([1.0, 5.0, 0.0, 7.0], np.float64(1.0), 599.0, 0.0)
    """

    noise_parameter: ClassVar[str] = "traverse_failure"
    parameter_constraints: ClassVar[dict[str, Constraint]] = {
        "scenario": Options(tuple(SCENARIOS)),
        "graph": InstanceOf(
            (Mapping, type(None)), "a mission-graph mapping (see MissionGraph.from_dict) or None"
        ),
        "mission_seed": Interval(int, 0, None) | InstanceOf(type(None)),
        "traverse_failure": Interval(float, 0.0, 1.0),
        **ActionMasking.masking_constraints,
    }

    def __init__(
        self,
        *,
        scenario: str = "uav-7-2",
        graph: Mapping[str, Any] | None = None,
        mission_seed: int | None = None,
        traverse_failure: float = 0.0,
        illegal_action: str = "raise",
        illegal_action_penalty: float = 1.0,
    ) -> None:
        self.scenario = scenario
        self.graph = graph
        self.mission_seed = mission_seed
        self.traverse_failure = traverse_failure
        self.illegal_action = illegal_action
        self.illegal_action_penalty = illegal_action_penalty
        self._build()

    def _build(self) -> None:
        """Validate the parameters, read the graph and build the kernel tables and spaces."""
        if isinstance(self.scenario, str) and self.scenario not in SCENARIOS:
            raise InvalidParameterError(
                f"`UAVMission.scenario` must be one of {', '.join(map(repr, SCENARIOS))}; got "
                f"{self.scenario!r}.{did_you_mean(self.scenario, SCENARIOS)}"
            )
        self.validate_params()
        graph = self._read_graph()
        n, num_nodes = graph.num_uavs, graph.num_nodes
        self.graph_ = graph
        adjacency = np.eye(num_nodes, dtype=np.uint8)
        for u, v in graph.edges:
            adjacency[u, v] = adjacency[v, u] = 1
        node_table, layout = graph.node_table, graph.layout
        name = self.scenario if self.graph is None else f"{num_nodes} nodes, {n} UAVs"
        if self.mission_seed is not None:
            name = f"{name}, mission {self.mission_seed}"
        self.domain_spec = graph.state_spec(f"UAVMission({name})")
        high = self.domain_spec.high.copy()
        for table in (adjacency, node_table, layout, high):
            table.flags.writeable = False
        self._adjacency = adjacency
        self._node_table = node_table
        self._layout = layout
        self._high = high
        self._tables = (high, layout, adjacency, node_table)  # checked_transition's order
        self._eta = float(self.traverse_failure)
        self._num_uniforms = 2 * n
        self.observation_space = spaces.Box(low=np.zeros_like(high), high=high, dtype=np.float64)
        # the state (int64, the observation layout), shared with the compiled form
        self._int_state = graph.initial_state().astype(np.int64)
        self._mask_of: tuple[bytes, np.ndarray] | None = None  # (state bytes, its mask)
        self._set_action_space()

    def _read_graph(self) -> MissionGraph:
        graph = self._given_graph()
        if self.mission_seed is None:
            return graph
        return sample_mission(np.random.default_rng(self.mission_seed), graph)

    def _given_graph(self) -> MissionGraph:
        if self.graph is None:
            return SCENARIOS[self.scenario]()
        _check_joint_actions(self.graph)  # before the graph's Θ(N³) distances
        try:
            return MissionGraph.from_dict(self.graph)
        except InvalidParameterError as error:
            raise InvalidParameterError(
                f"`UAVMission.graph` is not a valid mission graph: {error}"
            ) from None

    # ------------------------------------------------------------------ episode

    compiled_methods = ("step", "reset", "legal_actions")

    def compiled_form(self) -> DomainKernel:
        """The mission for the compiled loop (`mission_step`).

        `MissionConstants` (s₀, traverse failure); table[0] the state layout, table[1:] the
        adjacency; cells the node table; the domain's state (`KeptCompiledForm`).
        """
        return self._kept_form(self._build_compiled_form)

    def _build_compiled_form(self) -> DomainKernel:
        layout, adjacency = self._layout, self._adjacency
        nodes = adjacency.shape[0]
        start = np.asarray(self.graph_.initial_state(), dtype=np.int64)
        table = np.zeros((nodes + 1, max(nodes, layout.shape[0])), dtype=np.int64)
        table[0, : layout.shape[0]] = layout
        table[1:, :nodes] = adjacency
        return domain_kernel(
            UAV_MISSION,
            int(self.domain_spec.num_actions),
            constants=MissionConstants(
                start=start,
                horizon=0,
                fuel_penalty=0.0,
                failure_penalty=0.0,
                traverse_failure=float(self._eta),
            ),
            table=table,
            cells=self._tables[3],
            state=self._int_state,
        )

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """Start with every UAV at the base with its initial fuel, nothing visited, t = 0."""
        super().reset(seed=seed)
        self._int_state[:] = self.graph_.initial_state()
        return self._state, self._with_mask({})

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        """Fly every UAV one step; ``info["cost"]`` is 1.0 on a crash (Section 5.3.5)."""
        a = self.check_action(action)
        uniforms = self.np_random.random(self._num_uniforms)  # as mission_step draws them
        state, reward, terminated, cost, status = checked_transition(
            self._state, a, *self._tables, self._eta, uniforms
        )
        if status != -1:
            return self._reject(a, "each UAV stays or moves to a neighbour, with fuel left")
        self._int_state[:] = state
        return state, reward, terminated, False, self._with_mask({"cost": cost})

    @property
    def _state(self) -> np.ndarray:
        """A float64 copy of the current state (the observation); its legal mask is ``_mask``."""
        return self._int_state.astype(np.float64)

    @property
    def _mask(self) -> np.ndarray:
        """The legal mask of the current state: one legality pass, at its first read.

        Choice: computed on demand and kept with the state's bytes (the compiled loop steps
        the same state array and computes legality its own way), so a compiled run pays no
        Θ(N^n) pass that nothing reads, and a state changed by either path is never read
        with another state's mask.
        """
        key = self._int_state.tobytes()
        if self._mask_of is None or self._mask_of[0] != key:
            mask = checked_legal_mask(
                self._state, self._high, self._layout, self._adjacency, self.graph_.num_actions
            )
            self._mask_of = (key, mask)
        return self._mask_of[1]

    def _observed_state(self) -> np.ndarray:
        return self._state

    def describe_action(self, action: int) -> str:
        """Return the joint action as destinations, e.g. ``(UAV 0 to node 1, UAV 1 to node 0)``."""
        nodes = self.graph_.decode_action(action)
        return "(" + ", ".join(f"UAV {i} to node {d}" for i, d in enumerate(nodes)) + ")"

    # ------------------------------------------------------------------ states

    def _as_array(self, state: Any, where: str) -> np.ndarray:
        try:
            return np.asarray(state, dtype=np.float64)
        except (TypeError, ValueError):
            raise InvalidParameterError(
                f"UAVMission.{where} expects a numeric state vector; got {state!r}."
            ) from None

    def _state_error(self, array: np.ndarray, where: str) -> InvalidParameterError:
        """The error for ``array`` not being a mission state: its shape or its bad dimension."""
        if array.shape != self._high.shape:
            return InvalidParameterError(
                f"UAVMission.{where} expects a state of shape {self._high.shape} (the layout of "
                f"conjure.domains.mission_graph); got shape {array.shape}."
            )
        bad = state_from_observation(array, self._high)[1]
        return InvalidParameterError(
            f"UAVMission.{where}: {self._dimension_name(bad)} must be an integer in "
            f"[0, {self._high[bad]:g}]; got {array[bad]!r}."
        )

    def _checked_state(self, state: Any, where: str) -> np.ndarray:
        """``state`` as an int64 vector, or a clear error naming the bad dimension."""
        array = self._as_array(state, where)
        if array.shape == self._high.shape:
            ints, bad = state_from_observation(array, self._high)
            if bad < 0:
                return ints
        raise self._state_error(array, where)

    def _dimension_name(self, k: int) -> str:
        n = self.graph_.num_uavs
        if k < 2 * n:
            return f"dimension {k} ({'fuel' if k % 2 else 'location'} of UAV {k // 2})"
        if k < self._high.shape[0] - 1:
            return f"dimension {k} (visited bit of node {k - 2 * n})"
        return f"dimension {k} (time step)"

    def _legal_actions_of(self, state: np.ndarray) -> np.ndarray:
        legal, bad = checked_legal_actions(state, self._high, self._layout, self._adjacency)
        if bad < 0:
            return legal
        raise self._state_error(state, "legal_actions")

    def is_constrained(self, state: np.ndarray) -> bool:
        """Whether ``state`` is a crash: a UAV away from the base without fuel or at t = H."""
        return bool(is_crashed(self._checked_state(state, "is_constrained"), self._layout))

    def simulate(
        self, state: np.ndarray, action: int, noise: float, rng: np.random.Generator
    ) -> tuple[np.ndarray, float, bool]:
        """Draw ⟨s', r, terminated⟩ from ``state`` with traverse failure η = ``noise``.

        The same compiled step as `step`; the episode and ``np_random`` are not touched.
        """
        if not (isinstance(noise, (float, int)) and 0.0 <= noise <= 1.0):
            raise InvalidParameterError(
                f"UAVMission.simulate: noise must be a float in [0, 1]; got {noise!r}."
            )
        if not isinstance(rng, np.random.Generator):
            raise InvalidParameterError(
                f"UAVMission.simulate: rng must be a numpy.random.Generator; got {rng!r}."
            )
        observation = self._as_array(state, "simulate")
        a = self.check_action(action)
        if observation.shape == self._high.shape:
            uniforms = rng.random(self._num_uniforms)
            next_obs, reward, terminated, _, status = checked_transition(
                observation, a, *self._tables, float(noise), uniforms
            )
            if status == -1:
                return next_obs, reward, terminated
            if status == ILLEGAL:
                raise InvalidParameterError(
                    f"UAVMission.simulate: action {a} {self.describe_action(a)} is illegal in "
                    f"state {observation.tolist()}."
                )
        raise self._state_error(observation, "simulate")

    def nominal_next_state(self, state: np.ndarray, action: int) -> np.ndarray:
        """Return s' if every traversal succeeds and every target draw fails (as CBBA plans)."""
        ints = self._checked_state(state, "nominal_next_state")
        a = self.check_action(action)
        if not is_legal(ints, a, self._layout, self._adjacency):
            raise InvalidParameterError(
                f"UAVMission.nominal_next_state: action {a} {self.describe_action(a)} is "
                f"illegal in state {ints.tolist()}."
            )
        return nominal_next_state(ints, a, self._layout).astype(np.float64)

    def count_unintended(
        self, state: np.ndarray, action: int, next_state: np.ndarray
    ) -> tuple[int, int]:
        """(#UAVs that tried to traverse an edge and did not move, #UAVs that tried; Section 5.5.2).

        A transition from a terminal state counts as no move.
        """
        ints = self._checked_state(state, "count_unintended")
        after = self._checked_state(next_state, "count_unintended")
        num_failed, num_tried = count_unintended(
            ints, self.check_action(action), after, self._layout
        )
        return int(num_failed), int(num_tried)

    def state_action_count(self) -> int:
        """|S × A| as the thesis counts it (spec 2.2): UAV 7-2 1.4e8 (-spec 1.2e8), 10-2 9.0e9."""
        return self.graph_.state_action_count()

    # ------------------------------------------------------------------ exact solution

    def exact_solution(self) -> MissionSolution:
        """Solve the mission exactly at this η by backward induction over reachable states.

        Section 5.3.5 ("the optimal solutions were obtained using dynamic programming"; about a
        day for UAV 7-2 in the thesis, footnote 4). Solutions are cached per graph and η.
        Feasible while one time layer, 2^m Π_i (F_i + 1) N^n keys (m targets), stays within
        2·10⁷ (UAV 7-2 has 1.8e5, its -spec graph 7.7e4, UAV 10-2 1.0e6) and H times that
        within 5·10⁸ (UAV 10-2: 1.1e7); beyond either it raises `InvalidParameterError`.
        """
        graph = self.graph_
        cache_key = (json.dumps(graph.to_dict(), sort_keys=True), self._eta)
        if cache_key in _SOLUTIONS:
            _SOLUTIONS.move_to_end(cache_key)
            return _SOLUTIONS[cache_key]
        targets = graph.targets
        num_keys = layer_size(graph.num_nodes, graph.fuel, targets.size)
        if num_keys > MAX_LAYER_KEYS:
            raise InvalidParameterError(
                f"UAVMission.exact_solution: one time layer of this graph has 2^{targets.size} · "
                f"Π(F_i + 1) · {graph.num_nodes}^{graph.num_uavs} = {num_keys:.3g} states (fuel "
                f"{list(graph.fuel)}), more than the {MAX_LAYER_KEYS:.0e} that fit in memory; "
                f"use less fuel or a smaller graph."
            )
        if graph.horizon * num_keys > MAX_SOLVE_KEYS:
            raise InvalidParameterError(
                f"UAVMission.exact_solution: horizon {graph.horizon:,} × {num_keys:.3g} states "
                f"per time layer = {graph.horizon * num_keys:.3g} states to visit, more than the "
                f"{MAX_SOLVE_KEYS:.0e} solved in a few minutes; use a shorter horizon or less fuel."
            )
        target_bit = np.full(graph.num_nodes, -1, dtype=np.int64)
        target_bit[targets] = np.arange(targets.size)
        fuel_caps = np.array(graph.fuel, dtype=np.int64)
        sizes, keys, best, worst, best_actions, worst_actions = solve_mission(
            graph.initial_state().astype(np.int64),
            self._layout,
            self._adjacency,
            self._node_table,
            self._eta,
            fuel_caps,
            target_bit,
            targets.astype(np.int64),
            num_keys,
        )
        times = np.repeat(np.arange(graph.horizon, dtype=np.int64), sizes)
        solution = MissionSolution(
            optimal_return=float(best[0]),
            worst_return=float(worst[0]),
            layer_sizes=sizes,
            keys=times * num_keys + keys,
            values=best,
            worst_values=worst,
            actions=best_actions,
            worst_actions=worst_actions,
            num_layer_keys=num_keys,
            layout=self._layout,
            fuel_caps=fuel_caps,
            target_bit=target_bit,
            adjacency=self._adjacency,
            node_table=self._node_table,
            traverse_failure=self._eta,
        )
        _SOLUTIONS[cache_key] = solution
        if len(_SOLUTIONS) > _CACHE_SIZE:
            _SOLUTIONS.popitem(last=False)
        return solution

    def evaluate_policy(self, policy: Callable[[np.ndarray], int]) -> PolicyEvaluation:
        """Evaluate a deterministic policy exactly at this η, by a forward pass from s₀.

        Section 5.3.5 estimates a planner's quality "online for 10,000 episodes"; a policy
        that is a fixed function of the state (CBBA replanned at every step, the DP optimum)
        can instead be evaluated exactly over the states it reaches: each is asked for its
        action once, and the probability of reaching it, times the expected reward of that
        action, sums to V^π(s₀). The transitions are those of `exact_solution`.

        Parameters
        ----------
        policy : callable
            Maps a state (float64, the observation layout) to a legal joint action.

        Returns
        -------
        PolicyEvaluation
            V^π(s₀), the crash probability and the reached states with their probabilities.

        Examples
        --------
        >>> domain = UAVMission(traverse_failure=0.05)
        >>> solution = domain.exact_solution()
        >>> result = domain.evaluate_policy(solution.action)
        >>> bool(abs(result.value - solution.optimal_return) < 1e-9)
        True
        >>> domain.evaluate_policy(lambda state: 0).value  # everyone stays at the base
        0.0
        """
        if not callable(policy):
            raise InvalidParameterError(
                f"UAVMission.evaluate_policy: policy must map a state to a joint action; got "
                f"{policy!r}."
            )
        graph = self.graph_
        target_bit = np.full(graph.num_nodes, -1, dtype=np.int64)
        target_bit[graph.targets] = np.arange(graph.targets.size)
        try:
            value, crash, states, reach, actions = evaluate_policy(
                graph.initial_state().astype(np.int64),
                lambda state: policy(state.astype(np.float64)),
                self._layout, self._adjacency, self._node_table, self._eta,
                np.array(graph.fuel, dtype=np.int64), target_bit, graph.targets.astype(np.int64),
            )  # fmt: skip
        except ValueError as error:
            raise InvalidParameterError(
                f"UAVMission.evaluate_policy: the policy's {error}; a policy may only stay or "
                f"move each UAV along an edge with fuel left."
            ) from None
        return PolicyEvaluation(
            value=float(value),
            crash_probability=float(crash),
            states=states.astype(np.float64),
            reach_probabilities=reach,
            actions=actions,
        )

    def value_bounds(self) -> tuple[float, float]:
        """(worst, best) expected return from s₀ at this η, between which optimality is scaled.

        Figure 5-6b; from `exact_solution` (cached).
        """
        solution = self.exact_solution()
        return solution.worst_return, solution.optimal_return


def _check_joint_actions(graph: Mapping[str, Any]) -> None:
    """Refuse more than `MAX_JOINT_ACTIONS` joint actions N^n, read from the raw mapping.

    Only well-typed ``num_nodes`` and ``fuel`` are read; `MissionGraph.from_dict` reports the
    others.
    """
    num_nodes, fuel = graph.get("num_nodes"), graph.get("fuel")
    if not isinstance(num_nodes, (int, np.integer)) or isinstance(num_nodes, bool):
        return
    if isinstance(fuel, (str, bytes)) or not isinstance(fuel, (Sequence, np.ndarray)):
        return
    num_nodes = int(num_nodes)
    if num_nodes < 2:
        return
    digits = len(fuel) * math.log10(num_nodes)  # no exact power of a huge count
    num_actions = f"{num_nodes ** len(fuel)}" if digits < 30 else f"about 1e{digits:.0f}"
    if digits >= 30 or num_nodes ** len(fuel) > MAX_JOINT_ACTIONS:
        raise InvalidParameterError(
            f"`UAVMission.graph` has {num_nodes}^{len(fuel)} = {num_actions} joint actions; "
            f"at most {MAX_JOINT_ACTIONS} are supported (fewer UAVs or nodes)."
        )


@dataclass(frozen=True, eq=False)
class MissionSolution:
    """The exact optimal and worst policies of a UAV mission (Section 5.3.5, Figure 5-6b).

    Rows are the non-terminal states reachable from s₀, by time and then by key (see
    `conjure.domains._mission_dp`); terminal states have value 0. Built by
    `UAVMission.exact_solution`.

    Parameters
    ----------
    optimal_return, worst_return : float
        V*(s₀) and the worst policy's V(s₀).
    layer_sizes : ndarray of int64, shape (H,)
        Number of reachable non-terminal states at t = 0 .. H − 1.
    keys : ndarray of int64
        t · num_layer_keys + the state's key within its layer, ascending.
    values, worst_values : ndarray of float64
        V*(s) and V_worst(s) of each row.
    actions, worst_actions : ndarray of int64
        An optimal and a worst joint action of each row (lowest index among ties).
    num_layer_keys : int
        Number of keys of one time layer, 2^m Π_i (F_i + 1) N^n.
    layout, fuel_caps, target_bit : ndarray of int64
        The state encoding: ``[n, N, base, H]``, each UAV's initial fuel, and each node's bit
        among the visited targets (−1 for a node without reward).
    adjacency, node_table : ndarray
        The mission's transition tables (`conjure.domains._mission_kernels`), for `q_values`.
    traverse_failure : float
        The η the mission was solved at.
    """

    optimal_return: float
    worst_return: float
    layer_sizes: np.ndarray
    keys: np.ndarray
    values: np.ndarray
    worst_values: np.ndarray
    actions: np.ndarray
    worst_actions: np.ndarray
    num_layer_keys: int
    layout: np.ndarray
    fuel_caps: np.ndarray
    target_bit: np.ndarray
    adjacency: np.ndarray
    node_table: np.ndarray
    traverse_failure: float

    @property
    def num_states(self) -> int:
        """Number of reachable non-terminal states."""
        return int(self.keys.shape[0])

    def _row(self, state: np.ndarray) -> int:
        ints = np.asarray(state, dtype=np.int64)
        key = int(ints[-1]) * self.num_layer_keys + state_key(
            ints, self.layout, self.fuel_caps, self.target_bit
        )
        row = int(np.searchsorted(self.keys, key))
        if row == self.keys.shape[0] or self.keys[row] != key:
            raise InvalidParameterError(
                f"MissionSolution: state {ints.tolist()} is terminal or not reachable from s₀."
            )
        return row

    def value(self, state: np.ndarray) -> float:
        """V*(s); 0 for a terminal state."""
        if is_terminal(np.asarray(state, dtype=np.int64), self.layout):
            return 0.0
        return float(self.values[self._row(state)])

    def action(self, state: np.ndarray) -> int:
        """An optimal joint action π*(s) of a reachable non-terminal state."""
        return int(self.actions[self._row(state)])

    def worst_action(self, state: np.ndarray) -> int:
        """A joint action of the worst policy in a reachable non-terminal state."""
        return int(self.worst_actions[self._row(state)])

    def q_values(self, state: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(legal joint actions, Q*(s, a) of each) of a reachable non-terminal state.

        Q*(s, a) = Σ_{s'} P^a_{ss'} (R + V*(s')), the backup of `UAVMission.exact_solution`;
        its maximum is V*(s).
        """
        self._row(state)  # refuses terminal and unreachable states
        return action_values(
            np.asarray(state, dtype=np.int64), self.layout, self.adjacency, self.node_table,
            self.traverse_failure, self.fuel_caps, self.target_bit, self.keys, self.values,
            self.num_layer_keys,
        )  # fmt: skip


@dataclass(frozen=True, eq=False)
class PolicyEvaluation:
    """The exact value and crash probability of a deterministic policy (Section 5.3.5).

    Built by `UAVMission.evaluate_policy`.

    Parameters
    ----------
    value : float
        V^π(s₀), the policy's expected return (γ = 1).
    crash_probability : float
        The probability that the mission fails (Section 5.3.5's crash).
    states : ndarray of float64, shape (k, 2n + N + 1)
        The non-terminal states the policy reaches with positive probability, by time.
    reach_probabilities : ndarray of float64, shape (k,)
        The probability that the mission passes through each state; over the states of one
        time step they sum to the probability that the mission is still running then.
    actions : ndarray of int64, shape (k,)
        The policy's joint action in each state.
    """

    value: float
    crash_probability: float
    states: np.ndarray
    reach_probabilities: np.ndarray
    actions: np.ndarray
