"""UAV mission graphs: nodes, edges, targets, fuel and horizon (Geramifard 2012, Figure 5-4).

A `MissionGraph` is the data of a UAV mission-planning scenario, shared by the `UAVMission`
domain, the CBBA planners and the fuel risk analyser. It also fixes the meaning of a mission
state and action, so that every part reads them the same way.

State layout (Section 5.3.5, "UAV Mission Planning: MDP formulation"), for n UAVs on N nodes:
``[l_1, f_1, ..., l_n, f_n, v_0, ..., v_{N-1}, t]`` with l_i the node of UAV i (0-based), f_i
its fuel, v_j = 1 once node j's reward has been obtained, and t the time step. A joint action
``[l_1⁺, ..., l_n⁺]`` (each UAV's next node) is one integer a = Σ_i l_i⁺ · N^(i-1).

Notes
-----
- Choice: nodes are numbered from 0 and the base is node 0 in the shipped scenarios; node k
  here is node k + 1 of the thesis's Figure 5-4.
- [R] The thesis's graphs (Figure 5-4) are missing. `uav_7_2_spec` and `uav_10_2_spec` are
  the first reconstructions of ``domains-and-icca`` spec section 2.2, sized to the thesis's
  state-action counts (1.2e8 and 9.1e9); `uav_7_2` and `uav_10_2` (the defaults) keep their
  edges and are calibrated to spec 2.2's targets (Sections 5.3.5, 5.4.1 and 5.5.2: room for
  learning over CBBA, aggressive CBBA crashing about a quarter of the noisy missions,
  conservative CBBA rarely), as their docstrings report.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from conjure.core.errors import InvalidParameterError
from conjure.core.interfaces import DomainSpec

__all__ = [
    "MAX_NODES",
    "MissionGraph",
    "sample_mission",
    "uav_7_2",
    "uav_7_2_spec",
    "uav_10_2",
    "uav_10_2_spec",
]

UNREACHABLE = np.iinfo(np.int64).max // 4
#: Most nodes a mission graph may have: Floyd-Warshall's N × N table and N³ steps (8 MB at
#: N = 1000; 10⁶ nodes would need 7.3 TiB).
MAX_NODES = 1000
#: Spec 2.2's edges of UAV 7-2 (hops from the base 1, 1, 2, 2, 3, 3 for nodes 1-6).
EDGES_7_2 = ((0, 1), (0, 2), (1, 2), (1, 3), (2, 4), (3, 4), (3, 5), (4, 6), (5, 6))
#: Spec 2.2's edges of UAV 10-2 (hops from the base 1, 1, 2, 2, 3, 3, 4, 4, 4 for nodes 1-9).
EDGES_10_2 = (
    (0, 1), (0, 2), (1, 3), (2, 3), (2, 4), (3, 5), (4, 6), (5, 7), (6, 7), (5, 8), (6, 9),
    (7, 9), (8, 9),
)  # fmt: skip


@dataclass(frozen=True, eq=False)
class MissionGraph:
    """The data of a UAV mission (Figure 5-4), validated on construction.

    Parameters
    ----------
    num_nodes : int
        N in [2, `MAX_NODES`] nodes, numbered 0 .. N-1 (checked before anything is allocated:
        the distance table takes Θ(N²) memory and Θ(N³) time).
    edges : sequence of (int, int)
        Undirected edges between distinct nodes; the graph must be connected.
    fuel : sequence of int
        Initial fuel of each UAV (n = len(fuel) >= 1), each >= 1: a UAV without fuel could
        never leave the base.
    horizon : int
        The mission horizon H >= 1 (all UAVs must be home at t = H).
    base : int, default 0
        The base node; it needs at least one edge.
    rewards : sequence of float or None
        Reward of each node (>= 0, finite; 0 for a node without value). ``None``: all 0.
    probabilities : sequence of float or None
        Probability in [0, 1] that a visit obtains the node's reward. ``None``: all 1.
    windows : sequence of (int, int) or None
        Visit window [a, b] (0 <= a <= b) of each node; outside it a visit obtains nothing.
        ``None``: every node [0, H].

    Attributes
    ----------
    distances : ndarray of int64, shape (N, N)
        All-pairs shortest-path hop counts (Floyd-Warshall; Cormen et al. 2001).
    neighbours : ndarray of int64, shape (N, max degree)
        Each node's neighbours in increasing order, padded with -1.
    """

    num_nodes: int
    edges: tuple[tuple[int, int], ...]
    fuel: tuple[int, ...]
    horizon: int
    base: int = 0
    rewards: np.ndarray | None = None
    probabilities: np.ndarray | None = None
    windows: np.ndarray | None = None
    distances: np.ndarray = field(init=False, repr=False)
    neighbours: np.ndarray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        n = _check_num_nodes(self.num_nodes)
        horizon = _check_int("horizon", self.horizon, 1)
        base = _check_int("base", self.base, 0)
        if base >= n:
            raise InvalidParameterError(
                f"`MissionGraph.base` must be a node in [0, {n - 1}]; got {self.base!r}."
            )
        fuel = tuple(_check_fuel(i, f) for i, f in enumerate(_as_list(self.fuel)))
        if not fuel:
            raise InvalidParameterError("`MissionGraph.fuel` must list at least one UAV; got [].")
        edges = _check_edges(self.edges, n)
        rewards = _node_array("rewards", self.rewards, n, 0.0)
        if not (np.all(np.isfinite(rewards)) and np.all(rewards >= 0)):
            raise InvalidParameterError(
                f"`MissionGraph.rewards` must be finite and >= 0; got {rewards.tolist()}."
            )
        probabilities = _node_array("probabilities", self.probabilities, n, 1.0)
        if not np.all((probabilities >= 0) & (probabilities <= 1)):
            raise InvalidParameterError(
                f"`MissionGraph.probabilities` must lie in [0, 1]; got {probabilities.tolist()}."
            )
        windows = _check_windows(self.windows, n, horizon)
        distances = _floyd_warshall(n, edges)
        if not np.any(distances[base] == 1):
            raise InvalidParameterError(
                f"`MissionGraph.base` node {base} has no edge; the UAVs could never leave it."
            )
        unreachable = np.flatnonzero(distances[base] >= UNREACHABLE)
        if unreachable.size:
            raise InvalidParameterError(
                f"`MissionGraph.edges` leave nodes {unreachable.tolist()} disconnected from the "
                f"base {base}; every node must be reachable."
            )
        for name, value in (
            ("num_nodes", n),
            ("horizon", horizon),
            ("base", base),
            ("fuel", fuel),
            ("edges", edges),
            ("rewards", rewards),
            ("probabilities", probabilities),
            ("windows", windows),
            ("distances", distances),
            ("neighbours", _neighbour_table(n, edges)),
        ):
            if isinstance(value, np.ndarray):
                value.flags.writeable = False
            object.__setattr__(self, name, value)

    # ------------------------------------------------------------------ derived quantities

    @property
    def num_uavs(self) -> int:
        """n, the number of UAVs."""
        return len(self.fuel)

    @property
    def num_actions(self) -> int:
        """|A| = N^n joint destinations (illegal ones included)."""
        return self.num_nodes**self.num_uavs

    @property
    def state_size(self) -> int:
        """Length of a state vector: 2n + N + 1."""
        return 2 * self.num_uavs + self.num_nodes + 1

    @property
    def layout(self) -> np.ndarray:
        """The mission kernels' int64 [n, N, base, H] (`conjure.domains.uav_mission`)."""
        return np.array([self.num_uavs, self.num_nodes, self.base, self.horizon], dtype=np.int64)

    @property
    def node_table(self) -> np.ndarray:
        """The mission kernels' float64 (N, 4) per node: reward, probability, window."""
        columns = [self.rewards, self.probabilities, self.windows[:, 0], self.windows[:, 1]]
        return np.column_stack(columns).astype(np.float64)

    def state_spec(self, name: str) -> DomainSpec:
        """The mission's states and joint actions as a `DomainSpec` named ``name``.

        Integer dimensions from 0 up to [N − 1, f_1, ..., N − 1, f_n, 1, ..., 1, H], γ = 1,
        episodes of H steps, legal actions depending on the state.
        """
        high = np.array(
            [v for f in self.fuel for v in (self.num_nodes - 1, f)]
            + [1] * self.num_nodes
            + [self.horizon],
            dtype=np.float64,
        )
        return DomainSpec(
            name=name,
            low=np.zeros_like(high),
            high=high,
            is_discrete=np.ones(high.shape[0], dtype=bool),
            num_actions=self.num_actions,
            discount=1.0,
            max_episode_steps=self.horizon,
            has_action_constraints=True,
        )

    @property
    def crash_penalty(self) -> float:
        """The failure reward, −Σ node rewards (Section 5.3.5)."""
        return -float(self.rewards.sum())

    @property
    def targets(self) -> np.ndarray:
        """The nodes with a positive reward."""
        return np.flatnonzero(self.rewards > 0)

    def state_action_count(self) -> int:
        """|S × A| counted as N^n Π_i (F_i + 1) 2^N H N^n, F_i the initial fuels (spec 2.2).

        Spec 2.2 writes (F + 1)^n for n UAVs with the same fuel F.

        Examples
        --------
        >>> uav_7_2_spec().state_action_count()  # 49 · 7² · 128 · 8 · 49
        120472576
        """
        n, nodes = self.num_uavs, self.num_nodes
        fuel_levels = math.prod(f + 1 for f in self.fuel)
        return nodes**n * fuel_levels * 2**nodes * self.horizon * nodes**n

    # ------------------------------------------------------------------ the state layout

    def initial_state(self) -> np.ndarray:
        """s₀: every UAV at the base with its initial fuel, nothing visited, t = 0."""
        state = np.zeros(self.state_size, dtype=np.float64)
        state[0 : 2 * self.num_uavs : 2] = self.base
        state[1 : 2 * self.num_uavs : 2] = self.fuel
        return state

    def locations(self, state: np.ndarray) -> np.ndarray:
        """l_1 .. l_n as int64."""
        return np.asarray(state[0 : 2 * self.num_uavs : 2], dtype=np.int64)

    def fuels(self, state: np.ndarray) -> np.ndarray:
        """f_1 .. f_n as int64."""
        return np.asarray(state[1 : 2 * self.num_uavs : 2], dtype=np.int64)

    def visited(self, state: np.ndarray) -> np.ndarray:
        """v_0 .. v_{N-1} as bool."""
        start = 2 * self.num_uavs
        return np.asarray(state[start : start + self.num_nodes] > 0.5)

    def time(self, state: np.ndarray) -> int:
        """T, the time step."""
        return int(state[-1])

    def encode_action(self, destinations: Sequence[int]) -> int:
        """The joint action sending UAV i to ``destinations[i]``: Σ_i l_i⁺ N^(i-1)."""
        action = 0
        for i, node in enumerate(destinations):
            action += int(node) * self.num_nodes**i
        return action

    def decode_action(self, action: int) -> np.ndarray:
        """Each UAV's destination of joint action ``action``."""
        out = np.empty(self.num_uavs, dtype=np.int64)
        rest = int(action)
        for i in range(self.num_uavs):
            out[i] = rest % self.num_nodes
            rest //= self.num_nodes
        return out

    # ------------------------------------------------------------------ construction

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> MissionGraph:
        """Build from a config mapping (YAML).

        ``{num_nodes, edges: [[u, v], ...], fuel: [...], horizon, base,
        targets: {node: {reward, probability, window: [a, b]}}}``; nodes not listed in
        ``targets`` have no reward, probability 1 and window [0, H]. A node key may also be a
        string of digits (``"3"``), as JSON and resolved configs write integer keys.
        """
        known = {"num_nodes", "edges", "fuel", "horizon", "base", "targets"}
        unknown = sorted(set(data) - known)
        if unknown:
            raise InvalidParameterError(
                f"Unknown mission graph key {unknown[0]!r}; known: {', '.join(sorted(known))}."
            )
        missing = sorted({"num_nodes", "edges", "fuel", "horizon"} - set(data))
        if missing:
            raise InvalidParameterError(f"A mission graph needs `{missing[0]}`; it is missing.")
        n = _check_num_nodes(data["num_nodes"])
        horizon = _check_int("horizon", data["horizon"], 1)
        rewards, probabilities = np.zeros(n), np.ones(n)
        windows = np.tile(np.array([0, horizon], dtype=np.int64), (n, 1))
        targets = data.get("targets") or {}
        if not isinstance(targets, Mapping):
            raise InvalidParameterError(
                f"`targets` must map nodes to {{reward, probability, window}}; got {targets!r}."
            )
        for node, target in targets.items():
            # JSON and resolved configs turn integer keys into strings: accept "3" as node 3.
            key = int(node) if isinstance(node, str) and node.isdigit() else node
            j = _check_int(f"targets key {node!r}", key, 0)
            if j >= n or not isinstance(target, Mapping):
                raise InvalidParameterError(
                    f"`targets[{node!r}]` must be a node in [0, {n - 1}] mapped to "
                    f"{{reward, probability, window}}; got {target!r}."
                )
            extra = sorted(set(target) - {"reward", "probability", "window"})
            if extra:
                raise InvalidParameterError(
                    f"`targets[{node}]` has unknown key {extra[0]!r}; known: probability, "
                    f"reward, window."
                )
            rewards[j] = _check_float(f"targets[{node}].reward", target.get("reward", 0.0))
            probabilities[j] = _check_float(
                f"targets[{node}].probability", target.get("probability", 1.0)
            )
            if target.get("window") is not None:
                windows[j] = _check_window(f"targets[{node}].window", target["window"])
        return cls(
            num_nodes=n,
            edges=data["edges"],
            fuel=data["fuel"],
            horizon=horizon,
            base=data.get("base", 0),
            rewards=rewards,
            probabilities=probabilities,
            windows=windows,
        )

    def to_dict(self) -> dict[str, Any]:
        """The config mapping `from_dict` reads."""
        targets = {}
        for j in range(self.num_nodes):
            if self.rewards[j] > 0 or self.probabilities[j] < 1:
                entry: dict[str, Any] = {
                    "reward": float(self.rewards[j]),
                    "probability": float(self.probabilities[j]),
                }
                if (self.windows[j] != [0, self.horizon]).any():
                    entry["window"] = [int(x) for x in self.windows[j]]
                targets[j] = entry
        return {
            "num_nodes": self.num_nodes,
            "edges": [list(edge) for edge in self.edges],
            "fuel": list(self.fuel),
            "horizon": self.horizon,
            "base": self.base,
            "targets": targets,
        }


def uav_7_2_spec() -> MissionGraph:
    """[R] UAV 7-2 as spec 2.2 first reconstructed it: 7 nodes, fuel 6 and 6, horizon 8.

    Σ rewards 750. Kept for the results measured on it (scenario ``"uav-7-2-spec"``,
    ``conjure/UAV-7-2-v0``); it misses spec 2.2's calibration targets
    (``python docs/reproduction/uav_calibration.py --spec`` prints how).
    """
    return MissionGraph.from_dict(
        {
            "num_nodes": 7,
            "edges": EDGES_7_2,
            "fuel": [6, 6],
            "horizon": 8,
            "targets": {
                2: {"reward": 50, "probability": 0.8},
                3: {"reward": 100, "probability": 0.9, "window": [2, 4]},
                4: {"reward": 100, "probability": 0.5},
                5: {"reward": 300, "probability": 0.6, "window": [3, 5]},
                6: {"reward": 200, "probability": 0.7},
            },
        }
    )


def uav_10_2_spec() -> MissionGraph:
    """[R] UAV 10-2 as spec 2.2 first reconstructed it: 10 nodes, fuel 8 and 8, horizon 11.

    Σ rewards 1400. Kept for the results measured on it (scenario ``"uav-10-2-spec"``,
    ``conjure/UAV-10-2-v0``); it misses spec 2.2's calibration targets
    (``python docs/reproduction/uav_calibration.py --spec`` prints how).
    """
    return MissionGraph.from_dict(
        {
            "num_nodes": 10,
            "edges": EDGES_10_2,
            "fuel": [8, 8],
            "horizon": 11,
            "targets": {
                2: {"reward": 100, "probability": 0.5},
                4: {"reward": 100, "probability": 0.8, "window": [2, 4]},
                5: {"reward": 200, "probability": 0.6},
                6: {"reward": 100, "probability": 0.7},
                7: {"reward": 300, "probability": 0.5, "window": [4, 7]},
                8: {"reward": 200, "probability": 0.8},
                9: {"reward": 400, "probability": 0.6, "window": [5, 8]},
            },
        }
    )


def uav_7_2() -> MissionGraph:
    """[R] UAV 7-2 (Figure 5-4a), calibrated: 7 nodes, fuel 6 and 7, horizon 8, Σ rewards 1750.

    Spec 2.2's edges (hops from the base 1, 1, 2, 2, 3, 3 for nodes 1-6) with targets, fuel
    and windows found by a search toward spec 2.2's calibration targets
    (``python docs/reproduction/uav_calibration.py --search 7-2`` searches,
    ``python docs/reproduction/uav_calibration.py`` prints the table). Targets (0-based):

    ====  ======  ====  ======
    node  reward  p     window
    ====  ======  ====  ======
    1     600     0.4   [1, 1]
    2     300     0.7
    3     250     0.9
    4     300     0.3
    5     150     1.0   [3, 5]
    6     150     0.8
    ====  ======  ====  ======

    Node 1 is worth most to two UAVs arriving together at t = 1 (1 − 0.6² = 0.64 against
    0.4), which CBBA's one-UAV-per-task model cannot plan (Section 5.3.1): CBBA's only
    mistake without noise is its first joint action, where the learners of Chapter 5 meet it
    in every mission. |S × A| = 49 · 7 · 8 · 128 · 8 · 49 = 1.38e8 (thesis: "more than 100
    million"). Its exact optimum and CBBA's values and crash probabilities, against the
    thesis's, are printed by ``python docs/reproduction/uav_calibration.py``.
    """
    return MissionGraph.from_dict(
        {
            "num_nodes": 7,
            "edges": EDGES_7_2,
            "fuel": [6, 7],
            "horizon": 8,
            "targets": {
                1: {"reward": 600, "probability": 0.4, "window": [1, 1]},
                2: {"reward": 300, "probability": 0.7},
                3: {"reward": 250, "probability": 0.9},
                4: {"reward": 300, "probability": 0.3},
                5: {"reward": 150, "probability": 1.0, "window": [3, 5]},
                6: {"reward": 150, "probability": 0.8},
            },
        }
    )


def uav_10_2() -> MissionGraph:
    """[R] UAV 10-2 (Figure 5-4b), calibrated: 10 nodes, fuel 9 and 7, horizon 11, Σ 2700.

    Spec 2.2's edges (hops from the base 1, 1, 2, 2, 3, 3, 4, 4, 4 for nodes 1-9) with
    targets, fuel and windows found as for `uav_7_2`. Targets (0-based):

    ====  ======  ====  =======
    node  reward  p     window
    ====  ======  ====  =======
    1     700     0.4   [1, 1]
    3     500     0.9   [8, 11]
    4     200     1.0
    5     150     0.9
    7     300     0.4
    8     450     0.3   [4, 11]
    9     400     1.0   [4, 7]
    ====  ======  ====  =======

    As in UAV 7-2, node 1 pays most to both UAVs at t = 1, and sending both there at s₀ is
    the whole of CBBA's noise-free gap. |S × A| = 100 · 10 · 8 · 1024 · 11 · 100 = 9.01e9
    (thesis: "about 9 billion"). Its exact optimum and CBBA's values and crash probabilities,
    without noise and at Section 6.2.6's 5% traverse failures, are printed by
    ``python docs/reproduction/uav_calibration.py``.
    """
    return MissionGraph.from_dict(
        {
            "num_nodes": 10,
            "edges": EDGES_10_2,
            "fuel": [9, 7],
            "horizon": 11,
            "targets": {
                1: {"reward": 700, "probability": 0.4, "window": [1, 1]},
                3: {"reward": 500, "probability": 0.9, "window": [8, 11]},
                4: {"reward": 200, "probability": 1.0},
                5: {"reward": 150, "probability": 0.9},
                7: {"reward": 300, "probability": 0.4},
                8: {"reward": 450, "probability": 0.3, "window": [4, 11]},
                9: {"reward": 400, "probability": 1.0, "window": [4, 7]},
            },
        }
    )


def sample_mission(
    rng: np.random.Generator, graph: MissionGraph, base_target_rate: float = 0.0
) -> MissionGraph:
    """[R] A random mission on ``graph``'s nodes, edges, base and horizon: targets and fuel drawn.

    The sampler the calibration of `uav_7_2` and `uav_10_2` searched with
    (docs/reproduction/uav_calibration.py), and the missions ``UAVMission(mission_seed=...)``
    generates. Each node after the base is skipped with probability 0.2; otherwise it gets a
    reward in {50, 100, ..., 450}, a probability in {0.3, 0.4, ..., 1.0} and, with
    probability 0.3, a window [a, a + k] (a from the node's hop count h to H − h, k in 0-3,
    cut at H). The fuel pair is drawn from {6, 7}² (7 nodes) or {(8, 8), (9, 7)} (others).

    Parameters
    ----------
    rng : numpy.random.Generator
        The only source of randomness.
    graph : MissionGraph
        Gives the nodes, edges, base and horizon; its targets and fuel are replaced.
    base_target_rate : float, default 0.0
        Probability in [0, 1] of first planting the calibration's motif: node 1 worth
        400-700 with probability 0.3-0.5 inside the window [1, 1], which makes CBBA's whole
        gap one decision at s₀. The calibration searched with 0.7; the generated missions
        use 0, and no draw is made for it.

    Notes
    -----
    - Choice: a mission whose nodes are all skipped (probability 0.2^(N−1)) has no target;
      it is returned as drawn, and its V* is 0.
    """
    if not 0.0 <= base_target_rate <= 1.0:
        raise InvalidParameterError(
            f"`base_target_rate` must be a probability in [0, 1]; got {base_target_rate!r}."
        )
    horizon, targets = graph.horizon, {}
    if base_target_rate > 0 and rng.random() < base_target_rate:
        reward, p = rng.choice([400, 500, 600, 700]), rng.choice([0.3, 0.4, 0.5])
        targets[1] = {"reward": float(reward), "probability": float(p), "window": [1, 1]}
    for node in range(len(targets) + 1, graph.num_nodes):
        if node == graph.base:
            continue
        if rng.random() < 0.2:
            continue
        target = {
            "reward": float(rng.choice(np.arange(50, 500, 50))),
            "probability": float(rng.choice(np.arange(3, 11) / 10)),
        }
        if rng.random() < 0.3:
            hops = int(graph.distances[graph.base, node])
            start = int(rng.integers(hops, horizon - hops + 1))
            target["window"] = [start, min(start + int(rng.integers(0, 4)), horizon)]
        targets[node] = target
    fuel_pairs = [[6, 6], [6, 7], [7, 6], [7, 7]] if graph.num_nodes == 7 else [[8, 8], [9, 7]]
    data = graph.to_dict()
    data.update(targets=targets, fuel=fuel_pairs[int(rng.integers(len(fuel_pairs)))])
    return MissionGraph.from_dict(data)


# ---------------------------------------------------------------------------------------------
# Validation helpers


def _as_list(value: Any) -> list[Any]:
    if isinstance(value, (str, bytes)) or not isinstance(value, (Sequence, np.ndarray)):
        raise InvalidParameterError(f"Expected a list; got {value!r}.")
    return list(value)


def _check_int(name: str, value: Any, low: int) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < low:
        raise InvalidParameterError(
            f"`MissionGraph.{name}` must be an int in [{low}, inf); got {value!r}."
        )
    return int(value)


def _check_num_nodes(value: Any) -> int:
    """N in [2, `MAX_NODES`], checked before any table of N or N² entries is allocated."""
    n = _check_int("num_nodes", value, 2)
    if n > MAX_NODES:
        raise InvalidParameterError(
            f"`MissionGraph.num_nodes` must be at most {MAX_NODES:,} (all-pairs distances take "
            f"N² = {n * n:.3g} entries and N³ steps); got {n:,}."
        )
    return n


def _check_fuel(uav: int, value: Any) -> int:
    """F_i >= 1: with no fuel a UAV can only stay at the base (and every return is 0)."""
    fuel = _check_int(f"fuel[{uav}]", value, 0)
    if fuel == 0:
        raise InvalidParameterError(
            f"`MissionGraph.fuel[{uav}]` must be an int in [1, inf): a UAV with fuel 0 can never "
            f"leave the base; got 0."
        )
    return fuel


def _check_float(name: str, value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.number)):
        raise InvalidParameterError(f"`MissionGraph.{name}` must be a number; got {value!r}.")
    return float(value)


def _check_edges(edges: Any, n: int) -> tuple[tuple[int, int], ...]:
    out = []
    for k, edge in enumerate(_as_list(edges)):
        pair = _as_list(edge)
        if len(pair) != 2:
            raise InvalidParameterError(
                f"`MissionGraph.edges[{k}]` must be a pair of nodes; got {edge!r}."
            )
        u, v = (_check_int(f"edges[{k}]", x, 0) for x in pair)
        if u >= n or v >= n or u == v:
            raise InvalidParameterError(
                f"`MissionGraph.edges[{k}]` must join two distinct nodes in [0, {n - 1}]; "
                f"got {edge!r}."
            )
        out.append((min(u, v), max(u, v)))
    if not out:
        raise InvalidParameterError("`MissionGraph.edges` must list at least one edge; got [].")
    return tuple(sorted(set(out)))


def _node_array(name: str, values: Any, n: int, default: float) -> np.ndarray:
    if values is None:
        return np.full(n, default, dtype=np.float64)
    array = np.asarray(values, dtype=np.float64).reshape(-1)
    if array.shape != (n,):
        raise InvalidParameterError(
            f"`MissionGraph.{name}` must have one value per node ({n}); got shape {array.shape}."
        )
    return array.copy()


def _check_window(name: str, window: Any) -> np.ndarray:
    pair = _as_list(window)
    if len(pair) != 2:
        raise InvalidParameterError(f"`MissionGraph.{name}` must be [a, b]; got {window!r}.")
    a, b = (_check_int(name, x, 0) for x in pair)
    if a > b:
        raise InvalidParameterError(
            f"`MissionGraph.{name}` must have a <= b; got [{a}, {b}] (a > b)."
        )
    return np.array([a, b], dtype=np.int64)


def _check_windows(windows: Any, n: int, horizon: int) -> np.ndarray:
    if windows is None:
        return np.tile(np.array([0, horizon], dtype=np.int64), (n, 1))
    rows = _as_list(windows)
    if len(rows) != n:
        raise InvalidParameterError(
            f"`MissionGraph.windows` must have one [a, b] per node ({n}); got {len(rows)}."
        )
    return np.stack([_check_window(f"windows[{j}]", row) for j, row in enumerate(rows)])


def _floyd_warshall(n: int, edges: tuple[tuple[int, int], ...]) -> np.ndarray:
    """All-pairs shortest hop counts (Θ(N³); UNREACHABLE where no path exists)."""
    distances = np.full((n, n), UNREACHABLE, dtype=np.int64)
    np.fill_diagonal(distances, 0)
    for u, v in edges:
        distances[u, v] = distances[v, u] = 1
    for k in range(n):
        distances = np.minimum(distances, distances[:, k : k + 1] + distances[k : k + 1, :])
    return distances


def _neighbour_table(n: int, edges: tuple[tuple[int, int], ...]) -> np.ndarray:
    lists: list[list[int]] = [[] for _ in range(n)]
    for u, v in edges:
        lists[u].append(v)
        lists[v].append(u)
    width = max(len(items) for items in lists)
    table = np.full((n, width), -1, dtype=np.int64)
    for node, items in enumerate(lists):
        table[node, : len(items)] = sorted(items)
    return table
