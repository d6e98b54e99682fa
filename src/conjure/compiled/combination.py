"""Which (domain, representation, agent) combinations have a compiled path, and their packing.

`pack_combination` recognises a supported combination by exact type (a subclass, a wrapper or a
user-written component takes the Python path) and packs the constants of its domain,
representation, agent, policy and step-size schedules into the few arrays that
`conjure.compiled._kernels.advance_kernel` reads.

Supported (Geramifard 2012, Algorithms 10-12):

- domains: `InvertedPendulum`, `GridWorld`, `ChainMDP`;
- representations: `TileCoding` (hashed or not), `Tabular`, `IndependentDiscretization`,
  `RBF` (real-valued φ, Section 3.1.2);
- agents: `SARSA` (with or without replacing/accumulating traces), `QLearning`,
  `ActorCritic` (actor sharing the critic's features);
- policies: `EpsilonGreedy`, `Gibbs`; schedules: `ConstantStepSize`,
  `FeatureNormalizedDecay`, `EpisodicDecay`.

and, in `conjure.compiled._adaptive_kernel` (Sections 4.1.4 and 5.3.5, Algorithms 19-21):

- domains with legal actions: `BlocksWorld`, `PersistentSurveillance`, `RescueMission`,
  `UAVMission`, with `BinaryIndicators` or `IndependentDiscretization`, alone or as the base
  of `OnlineIFDD` (any relevance, threshold or fixed-rate discovery);
- `InvertedPendulum`, `GridWorld`, `ChainMDP` with `OnlineIFDD` over `TileCoding` (hashed or
  not), `Tabular` or `IndependentDiscretization`;
- agents: `SARSA` (with or without traces), `QLearning`, `ActorCritic` (Algorithm 12 as
  printed: a Q critic, ``actor_update="features"``, the actor sharing the critic's features);
  the policies and schedules above.

Notes
-----
- Choice: the packing reads the components' set-up tables (tile layout, strides, offsets, move
  tables), so both paths compute φ(s) and the domain step from the same numbers.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from conjure.agents.actor_critic import ActorCritic
from conjure.agents.q_learning import QLearning
from conjure.agents.sarsa import SARSA
from conjure.compiled import _adaptive_kernel as ak
from conjure.compiled import _kernels as k
from conjure.core.interfaces import Agent, Domain, check_is_set_up
from conjure.core.schedules import (
    ConstantStepSize,
    EpisodicDecay,
    FeatureNormalizedDecay,
    StepSizeSchedule,
)
from conjure.domains._uav_kernels import pst_fill_legal_mask, rescue_fill_legal_mask
from conjure.domains.blocksworld import BlocksWorld
from conjure.domains.chain import ChainMDP
from conjure.domains.gridworld import GridWorld
from conjure.domains.pendulum import InvertedPendulum
from conjure.domains.persistent_surveillance import PersistentSurveillance
from conjure.domains.rescue_mission import RescueMission
from conjure.domains.uav_mission import UAVMission
from conjure.policies import EpsilonGreedy, Gibbs
from conjure.representations import (
    RBF,
    BinaryIndicators,
    IndependentDiscretization,
    OnlineIFDD,
    Tabular,
    TileCoding,
)

__all__ = ["Combination", "pack_combination", "why_not_compiled"]

#: Empty stand-ins for the kernels' unused array arguments: numba types an array by its dtype
#: and dimensions, so one compilation serves every combination.
EMPTY_INTS = np.zeros(0, dtype=np.int64)
EMPTY_INT_TABLE = np.zeros((0, 0), dtype=np.int64)
EMPTY_FLOATS = np.zeros(0)
EMPTY_FLOAT_TABLE = np.zeros((0, 0))


@dataclass
class Combination:
    """The packed constants of one compiled combination (see `conjure.compiled._kernels`).

    Attributes
    ----------
    ints, floats : ndarray
        Codes, sizes and parameters (``I_*``, ``F_*`` in `conjure.compiled._kernels`).
    domain_arrays : tuple of ndarray
        ``(dparams, dtable, dcells)``, the domain's constants.
    representation_arrays : tuple of ndarray
        ``(rdims, rlayout, rgroups, rvec, htable, hcounts, rbf)``; the hash table is the
        representation's own (updated in place by both paths); ``rbf`` is None (binary φ) or
        `RBF`'s ``(affine, scaled centers)``. The adaptive kernel's are those of
        `OnlineIFDD`'s base (binary: ``rbf`` is None); it reads `OnlineIFDD`'s tables at every
        call (they grow).
    read_domain, write_domain : callable
        Copy the domain's internal state to / from a float64 vector (int64 for `BlocksWorld`
        and `PersistentSurveillance`).
    is_adaptive : bool
        Whether `conjure.compiled._adaptive_kernel` runs it (else ``advance_kernel``).
    """

    ints: np.ndarray
    floats: np.ndarray
    domain_arrays: tuple[np.ndarray, np.ndarray, np.ndarray]
    representation_arrays: tuple[np.ndarray, ...]
    read_domain: Callable[[Domain], np.ndarray]
    write_domain: Callable[[Domain, np.ndarray], None]
    is_adaptive: bool = False


# ---------------------------------------------------------------------------------------------
# Domains


def _pendulum(domain: InvertedPendulum) -> tuple:
    dparams = np.array([float(domain.force_noise), float(domain.start_noise)])

    def read(d: InvertedPendulum) -> np.ndarray:
        return np.array([d._theta, d._theta_dot])

    def write(d: InvertedPendulum, state: np.ndarray) -> None:
        d._theta, d._theta_dot = float(state[0]), float(state[1])

    return k.PENDULUM, (dparams, EMPTY_INT_TABLE, EMPTY_FLOAT_TABLE), read, write


def _gridworld(domain: GridWorld) -> tuple:
    codes = domain.grid_.reshape(-1)
    num_cells = codes.shape[0]
    table = np.zeros((num_cells, 9), dtype=np.int64)
    table[:, :4] = domain._targets
    for cell, moves in enumerate(domain._feasible):
        table[cell, 4] = len(moves)
        table[cell, 5 : 5 + len(moves)] = moves
    cells = np.zeros((num_cells, 6))
    cells[:, k.C_REWARD] = domain._reward
    cells[:, k.C_TERMINAL] = domain._terminal
    cells[:, k.C_PIT] = domain._is_pit
    cells[:, k.C_NOISY] = domain._is_noisy
    cells[:, k.C_ROW] = [row for row, _ in domain._coords]
    cells[:, k.C_COL] = [col for _, col in domain._coords]
    dparams = np.array([float(domain._noise), float(domain._start_cell)])

    def read(d: GridWorld) -> np.ndarray:
        return np.array([float(d._cell)])

    def write(d: GridWorld, state: np.ndarray) -> None:
        d._cell = int(state[0])

    return k.GRIDWORLD, (dparams, table, cells), read, write


def _chain(domain: ChainMDP) -> tuple:
    dparams = np.array([float(domain.num_states), domain._step_reward, domain._slip])

    def read(d: ChainMDP) -> np.ndarray:
        return np.array([float(d._state)])

    def write(d: ChainMDP, state: np.ndarray) -> None:
        d._state = int(state[0])

    return k.CHAIN, (dparams, EMPTY_INT_TABLE, EMPTY_FLOAT_TABLE), read, write


def _blocks(domain: BlocksWorld) -> tuple:
    n = domain._n
    dparams = np.array([float(n), domain._drop, domain._step_reward, domain._goal_reward])

    def read(d: BlocksWorld) -> np.ndarray:
        return np.concatenate([d._obs.astype(np.int64), d._on, d._above]).astype(np.int64)

    def write(d: BlocksWorld, state: np.ndarray) -> None:
        d._obs[:] = state[: n * n]
        d._on = [int(x) for x in state[n * n : n * n + n]]
        d._above = [int(x) for x in state[n * n + n :]]

    return ak.BLOCKS, (dparams, EMPTY_INT_TABLE, EMPTY_FLOAT_TABLE), read, write


def _persistent_surveillance(domain: PersistentSurveillance) -> tuple:
    dparams = np.array([float(x) for x in domain._args])

    def read(d: PersistentSurveillance) -> np.ndarray:
        return d._state.copy()

    def write(d: PersistentSurveillance, state: np.ndarray) -> None:
        d._state[:] = state
        pst_fill_legal_mask(d._state, d._n, d._mask)

    return ak.PERSISTENT_SURVEILLANCE, (dparams, EMPTY_INT_TABLE, EMPTY_FLOAT_TABLE), read, write


def _rescue(domain: RescueMission) -> tuple:
    horizon, fuel_penalty, failure_penalty = domain._scalars
    start = domain._start_state()
    dparams = np.array([float(horizon), fuel_penalty, failure_penalty, *start])
    table = np.column_stack([domain.neighbours_, domain._degrees]).astype(np.int64)
    cells = np.column_stack([domain._is_near, domain._people, domain._success]).astype(float)

    def read(d: RescueMission) -> np.ndarray:
        return d._state.copy()

    def write(d: RescueMission, state: np.ndarray) -> None:
        d._state[:] = state
        rescue_fill_legal_mask(d._state, d.neighbours_, d._degrees, d._mask)

    return ak.RESCUE, (dparams, table, cells), read, write


def _uav_mission(domain: UAVMission) -> tuple:
    graph = domain.graph_
    dparams = np.array([domain._eta, *graph.initial_state()])
    layout, adjacency = domain._layout, domain._adjacency
    nodes = adjacency.shape[0]
    table = np.zeros((nodes + 1, max(nodes, layout.shape[0])), dtype=np.int64)
    table[0, : layout.shape[0]] = layout
    table[1:, :nodes] = adjacency

    def read(d: UAVMission) -> np.ndarray:
        return d._state.astype(np.int64)

    def write(d: UAVMission, state: np.ndarray) -> None:
        d._state = state.astype(np.float64)

    cells = np.array(domain._tables[3], dtype=np.float64)  # node table (a writeable copy)
    return ak.UAV_MISSION, (dparams, table, cells), read, write


_DOMAINS: dict[type, Callable[[Any], tuple]] = {
    InvertedPendulum: _pendulum,
    GridWorld: _gridworld,
    ChainMDP: _chain,
    BlocksWorld: _blocks,
    PersistentSurveillance: _persistent_surveillance,
    RescueMission: _rescue,
    UAVMission: _uav_mission,
}
#: The domains with legal actions (`conjure.compiled._adaptive_kernel` only).
_CONSTRAINED = (ak.BLOCKS, ak.PERSISTENT_SURVEILLANCE, ak.RESCUE, ak.UAV_MISSION)


# ---------------------------------------------------------------------------------------------
# Representations


def _tables(
    dims: np.ndarray = EMPTY_FLOAT_TABLE,
    layout: np.ndarray = EMPTY_INT_TABLE,
    groups: np.ndarray = EMPTY_INT_TABLE,
    vector: np.ndarray = EMPTY_INTS,
    hash_table: np.ndarray = EMPTY_INT_TABLE,
    hash_counts: np.ndarray = EMPTY_INTS,
    rbf: tuple[np.ndarray, np.ndarray] | None = None,
) -> tuple:
    """The representation tuple `conjure.compiled._kernels.encode` reads; unused parts empty."""
    return (dims, layout, groups, vector, hash_table, hash_counts, rbf)


def _representation(rep: Any) -> tuple[int, int, int, tuple[np.ndarray, ...]] | None:
    """(code, number of tilings, most active features, arrays), or None if not compiled."""
    kind = type(rep)
    if kind is TileCoding:
        code = k.HASHED_TILES if rep._is_hashed else k.TILES
        hashed = (rep._hash_table, rep._hash_counts) if rep._is_hashed else ()
        arrays = _tables(rep._dims, rep._layout, rep._group_table, EMPTY_INTS, *hashed)
        return code, rep._num_tilings, rep.num_active_, arrays
    if kind is Tabular:
        return k.TABULAR, 0, 1, _tables(rep._dims, vector=rep._strides)
    if kind is IndependentDiscretization:
        return k.INDEPENDENT, 0, rep.offsets_.shape[0], _tables(rep._dims, vector=rep.offsets_)
    if kind is RBF:  # φ(s) lists every feature (a writable copy of `encode`'s indices)
        rbf = (rep._affine, rep._scaled_centers)
        return k.RBF, 0, rep.num_features_, _tables(vector=rep._indices.copy(), rbf=rbf)
    return None


def _adaptive_representation(
    rep: Any, is_constrained: bool
) -> tuple[int, int, int, tuple[np.ndarray, ...]] | None:
    """`_representation`'s answer for the adaptive kernel, or None.

    For `OnlineIFDD`'s base; on a constrained domain also for the base alone.
    """
    is_ifdd = type(rep) is OnlineIFDD
    base = rep.base_ if is_ifdd else rep
    if is_constrained and type(base) is BinaryIndicators:
        return ak.INDICATORS, 0, 0, _tables()
    if is_constrained and type(base) is not IndependentDiscretization:
        return None
    return _representation(base) if is_ifdd or is_constrained else None


# ---------------------------------------------------------------------------------------------
# Agents, policies, schedules


def _schedule(schedule: StepSizeSchedule) -> tuple[int, float, float] | None:
    kind = type(schedule)
    if kind is ConstantStepSize:
        return k.CONSTANT, float(schedule.alpha_0), 0.0
    if kind is FeatureNormalizedDecay:
        return k.FEATURE_NORMALIZED, float(schedule.alpha_0), float(schedule.n_0)
    if kind is EpisodicDecay:
        return k.EPISODIC, float(schedule.alpha_0), float(schedule.n_0)
    return None


def _policy(policy: Any) -> tuple[int, float] | None:
    if type(policy) is EpsilonGreedy:
        return k.EPSILON_GREEDY, float(policy.epsilon)
    if type(policy) is Gibbs:
        return k.GIBBS, float(policy.temperature)
    return None


def _agent(agent: Agent) -> tuple[int, int, float, float, tuple | None] | None:
    """(agent code, trace code, trace factor, min trace, actor schedule), or None."""
    kind = type(agent)
    if kind is SARSA:
        if not agent._has_traces:
            return k.SARSA, k.NO_TRACES, 0.0, 0.0, None
        traces = k.REPLACING if agent.trace_kind == "replacing" else k.ACCUMULATING
        return k.SARSA, traces, agent._trace_factor, float(agent.min_trace), None
    if kind is QLearning:
        return k.Q_LEARNING, k.NO_TRACES, 0.0, 0.0, None
    printed = agent.critic == "q" and agent.actor_update == "features"  # Algorithm 12
    if kind is ActorCritic and agent._is_shared and printed:
        actor = _schedule(agent.actor_schedule_)
        return None if actor is None else (k.ACTOR_CRITIC, k.NO_TRACES, 0.0, 0.0, actor)
    return None


def pack_combination(domain: Domain, agent: Agent) -> Combination | None:
    """Pack a set-up ``agent`` on ``domain``, or return ``None`` when a part is not compiled.

    Raises
    ------
    NotSetUpError
        If ``agent.setup`` has not run.
    """
    packed = _pack(domain, agent)
    return packed if isinstance(packed, Combination) else None


def why_not_compiled(domain: Domain, agent: Agent) -> str | None:
    """Name the first part of a set-up ``agent`` on ``domain`` with no compiled kernel.

    ``None`` when every part has one (then `pack_combination` packs them).
    """
    packed = _pack(domain, agent)
    return None if isinstance(packed, Combination) else packed


def _pack(domain: Domain, agent: Agent) -> Combination | str:
    """The packed combination, or why a part has no compiled kernel."""
    domain_packer = _DOMAINS.get(type(domain))
    if domain_packer is None:
        return f"the domain {type(domain).__name__} has no compiled kernel"
    if type(agent) not in (SARSA, QLearning, ActorCritic):
        return f"the agent {type(agent).__name__} has no compiled kernel"  # exact types only
    check_is_set_up(agent, "pack_combination")
    agent_codes = _agent(agent)
    if agent_codes is None:
        return f"{type(agent).__name__} with these parameters has no compiled kernel" + (
            " (only Algorithm 12 as printed: critic='q', actor_update='features', no traces)"
            if type(agent) is ActorCritic
            else ""
        )
    domain_code, domain_arrays, read, write = domain_packer(domain)
    is_constrained = domain_code in _CONSTRAINED
    if not is_constrained and domain.domain_spec.has_action_constraints:
        return f"the action constraints of {type(domain).__name__} have no compiled kernel"
    is_ifdd = type(agent.representation_) is OnlineIFDD
    is_adaptive = is_constrained or is_ifdd
    if is_adaptive:
        rep = _adaptive_representation(agent.representation_, is_constrained)
    else:
        rep = _representation(agent.representation_)
    policy = _policy(agent.policy_)
    schedule = _schedule(agent.schedule_)
    for part, component, packed in (
        ("representation", agent.representation_, rep),
        ("policy", agent.policy_, policy),
        ("step-size schedule", agent.schedule_, schedule),
    ):
        if packed is None:
            return f"the {part} {type(component).__name__} has no compiled kernel here"
    agent_code, traces, trace_factor, min_trace, actor = agent_codes
    actor = schedule if actor is None else actor
    rep_code, num_tilings, max_active, rep_arrays = rep
    spec = domain.domain_spec
    ints = np.zeros(k.NUM_INTS, dtype=np.int64)
    ints[[k.I_DOMAIN, k.I_REP, k.I_AGENT, k.I_POLICY]] = (
        domain_code,
        rep_code,
        agent_code,
        policy[0],
    )
    ints[[k.I_SCHEDULE, k.I_ACTOR_SCHEDULE, k.I_CAP, k.I_TRACES]] = (
        schedule[0],
        actor[0],
        spec.max_episode_steps,
        traces,
    )
    ints[[k.I_NUM_TILINGS, k.I_MAX_ACTIVE, k.I_NUM_ACTIONS, k.I_IFDD]] = (
        num_tilings,
        max_active,
        spec.num_actions,
        is_ifdd,
    )
    floats = np.zeros(k.NUM_FLOATS)
    floats[[k.F_DISCOUNT, k.F_POLICY, k.F_ALPHA, k.F_N0]] = (
        float(spec.discount),
        policy[1],
        schedule[1],
        schedule[2],
    )
    floats[[k.F_ACTOR_ALPHA, k.F_ACTOR_N0, k.F_TRACE_FACTOR, k.F_MIN_TRACE]] = (
        actor[1],
        actor[2],
        trace_factor,
        min_trace,
    )
    contiguous = tuple(np.ascontiguousarray(a) for a in rep_arrays[:4]) + rep_arrays[4:]
    return Combination(
        ints=ints,
        floats=floats,
        domain_arrays=tuple(np.ascontiguousarray(a) for a in domain_arrays),
        representation_arrays=contiguous,
        read_domain=read,
        write_domain=write,
        is_adaptive=is_adaptive,
    )
