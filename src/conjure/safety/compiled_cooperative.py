"""The iCCA control box as the compiled learning loop reads it (`conjure.core.compiled_form`).

Geramifard (2012), Algorithms 23, 24 and 26 (Sections 5.3-5.5). `BoxKernel` holds what the
box needs per step: π^p(s) and the verdicts safe(s, a). On grid worlds π^p is tabulated per
row of the box's index (one feature per state; two tables for a switching planner) and
safe(s, a) is either tabulated too (a deterministic analyser) or Algorithm 25's rollouts in
the tabular T̂ re-indexed by those rows (`grid_failures`). On UAV missions the components'
own kernels are called per state: CBBA through its plan cache (`planned_action`, Section
5.3.1; conservative or aggressive by η̂ with a switching planner), the fuel rule
(`fuel_risk`, Section 5.3.5) or Algorithm 25's rollouts (`mission_failures`). `BoxParts`
holds those parts and the adaptive model's η̂ (`observe_moves`). The box builds its
`CompiledBox` once and keeps it as its state: the agent's own tables (Algorithm 23's visit
counts n(s); Algorithm 24's counts of unconsulted planner actions; Algorithm 26's η̂^p and
count of policy changes), T̂'s counts and the planner's switch are updated in place by the
kernels and by the Python methods alike, so nothing is taken back after a compiled call.
`box_action` is the box's ``act`` while learning (`cooperative_action`:
`CooperativeActorCritic`, `cooperative_learner_action`: `CooperativeLearner`); the learner's
updates stay the learner's own kernels. The control rules (knownness and consulting the
learner, b(n), the trust test, the tie-break toward π^p, the replan test) are
`conjure.safety._box_rules`' functions, njit-wrapped here and called as they are by the
boxes' Python ``act`` and ``learn``; what stays twice is each algorithm's order of calls
(a handful of lines per path), since the Python path calls the parts' own methods there.

The tables are made by calling the parts' own methods (the planner's compiled form, the
analyser's ``is_safe``, the model's ``count_unintended``) on every state the planner
planned, and the per-state parts are the components' own kernels, so no rule is coded twice.
A π^p table is exact while the planner does not replan (a static model, or a policy that
never changes with T̂: `PlannedPolicy.is_fixed`); a safe(s, a) table while, in addition, the
analyser draws no random number (`FixedRisk`). `box_learn` is Algorithm 26's model update
and switch after the learner's update.
"""

from __future__ import annotations

import functools
from typing import Any, NamedTuple

import numpy as np
from numba import njit, typeof
from numba.core import types
from numba.experimental import structref

from conjure.agents.compiled_agent import (
    ACTOR_CRITIC,
    AgentKernel,
    LearnerArrays,
    imagined_learn,
    q_values_into,
    shift_preference_into,
)
from conjure.core.compiled_form import compiled_form
from conjure.domains.uav_mission import count_unintended
from conjure.models.approximate_model import NoiseModel, observe_moves
from conjure.planners.cbba_planner import MissionPlanner, planned_action
from conjure.planners.model_planner import PlannedPolicy
from conjure.planners.switching_planner import (
    PlannerPair,
    active_planner,
    fixed_pair,
    switch_by_noise,
)
from conjure.policies import greedy_action
from conjure.policies.compiled_policy import PolicyKernel, select_action
from conjure.representations.compiled_representation import (
    HASHED_TABULAR,
    TABULAR,
    RepresentationKernel,
    encode_into,
    lookup_row,
    representation_kernel,
    rows_in_use,
)
from conjure.safety._box_rules import (
    NEVER_TRUSTED,
    consult_planner,
    is_trusted,
    is_unvisited,
    mentor_greedy_action,
    needs_replan,
    visit_bias,
)
from conjure.safety.fuel_risk import FuelRisk, fuel_risk
from conjure.safety.monte_carlo_risk import (
    GridRollouts,
    MissionRollouts,
    grid_failures,
    mission_failures,
)

__all__ = [
    "COOPERATIVE_LEARNER",
    "ICCA",
    "NO_BOX",
    "NO_PARTS",
    "BoxKernel",
    "BoxParts",
    "BoxTables",
    "CompiledBox",
    "FixedRisk",
    "alone",
    "box_action",
    "box_learn",
    "compiled_box",
    "cooperative_action",
    "cooperative_learner_action",
    "cooperative_learner_kernel",
    "greedy_box_action",
    "icca_kernel",
    "no_box",
    "pack_parts",
    "tabulate",
]

#: Box kinds of `BoxKernel`: none (a plain learner), Algorithm 23, Algorithm 24.
NO_BOX, ICCA, COOPERATIVE_LEARNER = 0, 1, 2
#: The generator a box without draws holds (the field's type is fixed).
_NO_DRAWS = np.random.default_rng(0)


class BoxParts(NamedTuple):
    """The parts of a box called per state or step (Sections 5.3.1, 5.3.5, 5.5).

    On a UAV mission (`BoxKernel.is_mission`): CBBA, the fuel rule or Algorithm 25's
    rollouts. On a grid world: a switching planner's two π^p tables, Algorithm 25's rollouts
    in the tabular T̂ and the model's move table. Both: T̂'s η̂ and Algorithm 26's state.

    Parameters
    ----------
    planners : PlannerPair
        π^p on a mission: CBBA's `planned_action` (with the planner's own plan cache),
        conservative or aggressive by η̂ for a `SwitchingPlanner`, else one planner that never
        switches.
    has_rollouts : bool
        Whether proposals are judged by Algorithm 25 (``rollouts`` on a mission, ``grid`` on
        a grid world), or else by the fuel rule (mission) or the safe(s, a) table (grid).
    fuel : FuelRisk
        The fuel rule (`fuel_risk`).
    rollouts : MissionRollouts
        Algorithm 25's rollouts on a mission T̂ (`mission_failures`).
    tables : PlannerPair
        π^p per index row on a grid world (arrays of int64, −1: a row no planned state has;
        one table, never switching, for a single planner); the one in use is
        ``active_planner(tables)``, switched in place with the planner's own ``switch_``.
    grid : GridRollouts
        Algorithm 25's rollouts in a tabular T̂ (`grid_failures`), its tables re-indexed
        by the box's rows (π^p: the table in use).
    intended : ndarray of int64, shape (rows, |A|)
        On a grid world, the row T̂ expects a move to reach (−1: T̂ counts no move there),
        for Algorithm 26's move counts.
    model : NoiseModel
        T̂'s η̂ and its counts (updated in place by Algorithm 26's `box_learn`).
    layout : ndarray of int64, shape (4,)
        T̂'s mission layout (`MissionGraph.layout`), for counting moves.
    is_adaptive : bool
        Algorithm 26 (`AdaptiveCooperativeLearner`): T̂ learns, π^p may switch.
    replan_threshold : float
        ΔT.
    planned_noise : ndarray of float64, shape (1,)
        η̂^p, the box's own (`CooperativeAgent.replan_state_`), updated in place.
    policy_changes : ndarray of int64, shape (1,)
        How often π^p changed, the box's own likewise.
    """

    planners: PlannerPair
    has_rollouts: bool
    fuel: FuelRisk
    rollouts: MissionRollouts
    tables: PlannerPair
    grid: GridRollouts
    intended: np.ndarray
    model: NoiseModel
    layout: np.ndarray
    is_adaptive: bool
    replan_threshold: float
    planned_noise: np.ndarray
    policy_changes: np.ndarray


@structref.register
class _PartsStructType(types.StructRef):
    """The numba type of `_PartsStruct` (Algorithms 24-26, Sections 5.3.5 and 5.5)."""

    def preprocess_fields(self, fields):
        return tuple((name, types.unliteral(kind)) for name, kind in fields)


class _PartsStruct(structref.StructRefProxy):
    """A `BoxParts` as the compiled loop receives it: one reference (a numba structref).

    Geramifard (2012), Algorithms 24-26 (Sections 5.3.5 and 5.5). Its fields are the
    `BoxParts`'s, arrays shared: kernels read them by the same names. Made by
    `pack_parts`; nothing to construct by hand.
    """


structref.define_boxing(_PartsStructType, _PartsStruct)


def _no_parts() -> BoxParts:
    """The stand-in `BoxParts` of a box without such parts (every field of the loop's type)."""
    no_ints = np.zeros(0, dtype=np.int64)
    no_cache = representation_kernel(HASHED_TABULAR, 1)
    planner = MissionPlanner(
        distances=np.zeros((0, 0)),
        next_hop=np.zeros((0, 0), dtype=np.int64),
        node_tasks=np.zeros((0, 4)),
        num_uavs=0,
        base=0,
        horizon=0.0,
        settings=np.zeros(3),
        is_conservative=False,
        fuel_reserve=0.0,
        is_refuel_to_plan=False,
        max_rounds=0,
        cache=no_cache,
        cached=no_ints,
        has_cache=False,
    )
    layout = np.zeros(4, dtype=np.int64)
    no_flags = np.zeros(0, dtype=np.bool_)
    grid = GridRollouts(
        num_rollouts=0,
        horizon=0,
        risk_tolerance=1.0,
        num_actions=0,
        indptr=np.zeros(1, dtype=np.int64),
        indices=no_ints,
        probabilities=np.zeros(0),
        is_constrained=no_flags,
        is_terminal=no_flags,
        states=np.zeros((0, 2)),
        rng=_NO_DRAWS,
    )
    return BoxParts(
        planners=fixed_pair(planner),
        has_rollouts=False,
        fuel=FuelRisk(layout=layout, home=no_ints, risk_tolerance=1.0),
        rollouts=MissionRollouts(
            num_rollouts=0,
            horizon=0,
            risk_tolerance=1.0,
            layout=layout,
            node_table=np.zeros((0, 4)),
            rng=_NO_DRAWS,
        ),
        tables=fixed_pair(no_ints),
        grid=grid,
        intended=np.zeros((0, 0), dtype=np.int64),
        model=NoiseModel(
            counts=np.zeros(2, dtype=np.int64),
            noise=np.zeros(1),
            prior_noise=0.0,
            prior_weight=0.0,
            is_adaptive=False,
        ),
        layout=layout,
        is_adaptive=False,
        replan_threshold=0.0,
        planned_noise=np.zeros(1),
        policy_changes=np.zeros(1, dtype=np.int64),
    )


NO_PARTS = _no_parts()
#: Every `BoxParts` has the stand-in's field types (so one loop compilation serves all).
_PARTS_TYPE = _PartsStructType(
    [(name, typeof(getattr(NO_PARTS, name))) for name in BoxParts._fields]
)


@njit(cache=True)
def _pack(
    planners, has_rollouts, fuel, rollouts, tables, grid, intended, model, layout, is_adaptive,
    replan_threshold, planned_noise, policy_changes,
):  # fmt: skip
    parts = structref.new(_PARTS_TYPE)
    parts.planners = planners
    parts.has_rollouts = has_rollouts
    parts.fuel = fuel
    parts.rollouts = rollouts
    parts.tables = tables
    parts.grid = grid
    parts.intended = intended
    parts.model = model
    parts.layout = layout
    parts.is_adaptive = is_adaptive
    parts.replan_threshold = replan_threshold
    parts.planned_noise = planned_noise
    parts.policy_changes = policy_changes
    return parts


class FixedRisk(NamedTuple):
    """A risk analyser whose safe(s, a) is a fixed function of the state and action.

    Geramifard (2012), Section 5.3.3 (the nominal rule): the compiled form of the
    deterministic analysers (`NominalRiskAnalyzer`); the box tabulates their own ``is_safe``.

    Parameters
    ----------
    risk_tolerance : float
        The analyser's ε (its verdicts depend on it).
    """

    risk_tolerance: float


class BoxKernel(NamedTuple):
    """Algorithm 23's box for the compiled loop; `NO_BOX` for a learner alone.

    Parameters
    ----------
    kind : int
        `NO_BOX`, `ICCA` or `COOPERATIVE_LEARNER`.
    index : RepresentationKernel
        The box's index: the row of a state in the tables below.
    safe : ndarray of bool, shape (rows, |A|)
        safe(s, a) per row and action (true for a = π^p(s)); empty when rollouts judge.
    is_mission : bool
        Whether π^p and safe(s, a) are the UAV mission kernels of the box's `BoxParts`
        instead of the tables.
    visits : ndarray of int64, shape (rows,)
        n(s), the agent's ``visits_`` (updated in place).
    bias, half_life : float
        λ and N_b of the fading bias b(n) = λ·N_b/(N_b + n).
    is_fading : bool
        Whether the bias fades (``bias_half_life`` is not None).
    counts : ndarray of int32, shape (rows, |A|)
        Algorithm 24's count(s, a) of unconsulted planner actions, the agent's ``counts_``.
    num_known : float
        𝒦, the count after which a pair is known.
    veto_reward : float
        The reward a vetoed proposal is learned with, if ``has_veto``.
    has_veto : bool
        Whether vetoed proposals are learned (``veto_reward`` is not None).
    trusted : float
        The knownness from which the safety check is skipped (`NEVER_TRUSTED`: never).
    rng : numpy.random.Generator
        The agent's own generator (Algorithm 24's knownness draws).
    """

    kind: int
    index: RepresentationKernel
    safe: np.ndarray
    is_mission: bool
    visits: np.ndarray
    bias: float
    half_life: float
    is_fading: bool
    counts: np.ndarray
    num_known: float
    veto_reward: float
    has_veto: bool
    trusted: float
    rng: np.random.Generator


def no_box(index: RepresentationKernel) -> BoxKernel:
    """The `NO_BOX` form (empty tables) with a stand-in ``index`` of the loop's type."""
    empty = np.zeros(0, dtype=np.int64)
    no_table = np.zeros((0, 0), dtype=np.bool_)
    no_counts = np.zeros((0, 0), dtype=np.int32)
    return BoxKernel(
        kind=NO_BOX,
        index=index,
        safe=no_table,
        is_mission=False,
        visits=empty,
        bias=0.0,
        half_life=0.0,
        is_fading=False,
        counts=no_counts,
        num_known=1.0,
        veto_reward=0.0,
        has_veto=False,
        trusted=NEVER_TRUSTED,
        rng=_NO_DRAWS,
    )


class CompiledBox(NamedTuple):
    """A cooperative agent's compiled form, its state: its `BoxKernel` and its parts.

    Geramifard (2012), Algorithms 23, 24 and 26. Built once by the box and kept
    (`CooperativeAgent.compiled_form`): every array and generator in it is the box's, its
    parts' or the model's own, so the kernels and the Python methods read and write the same
    memory and nothing is taken back after a compiled call. The parts are one reference each
    (`pack_parts`): numba keeps a reference count per array of a tuple of ten or more arrays
    wherever it is passed, and the parts hold about forty.

    Parameters
    ----------
    box : BoxKernel
        The box (`NO_BOX` for a learner alone).
    parts : _PartsStruct
        Its parts called per state or step (the stand-in's when it has none).
    greedy_parts : _PartsStruct
        The same parts for greedy acting (a policy check): Algorithm 25's rollouts draw from
        the agent's ``eval_rng_`` (as ``is_safe(..., rng)`` in a policy check), not from the
        analyser's own generator; ``parts`` itself when nothing draws.
    """

    box: BoxKernel
    parts: _PartsStruct
    greedy_parts: _PartsStruct


def pack_parts(parts: BoxParts) -> _PartsStruct:
    """``parts`` as the loop's `_PartsStruct` (the same arrays and generators)."""
    return _pack(*parts)


@functools.cache
def _no_packed_parts() -> _PartsStruct:
    """`NO_PARTS` packed, made once per process."""
    return pack_parts(NO_PARTS)


def compiled_box(
    box: BoxKernel, parts: BoxParts, evaluation_rng: np.random.Generator
) -> CompiledBox:
    """The `CompiledBox` of ``box`` and ``parts``; its greedy parts draw from ``evaluation_rng``."""
    packed = pack_parts(parts)
    if not parts.has_rollouts:
        return CompiledBox(box=box, parts=packed, greedy_parts=packed)
    greedy = parts._replace(
        rollouts=parts.rollouts._replace(rng=evaluation_rng),
        grid=parts.grid._replace(rng=evaluation_rng),
    )
    return CompiledBox(box=box, parts=packed, greedy_parts=pack_parts(greedy))


def alone(index: RepresentationKernel) -> CompiledBox:
    """The `NO_BOX` form of a learner alone (``index`` a stand-in of the loop's type)."""
    parts = _no_packed_parts()
    return CompiledBox(box=no_box(index), parts=parts, greedy_parts=parts)


class BoxTables(NamedTuple):
    """A box's tabulated parts (`tabulate`).

    Geramifard (2012), Sections 5.3.1, 5.3.3 and 5.5: π^p and the risk analyser's verdicts or
    rollouts, per row of the box's index; on a UAV mission the parts are per-state kernels.

    Parameters
    ----------
    index : RepresentationKernel
        The index's compiled form (a state's row).
    tables : PlannerPair
        π^p per row (arrays of int64; −1: a row no planned state has); empty on a mission.
    safe : ndarray of bool, shape (rows, |A|)
        safe(s, a) per row and action; empty on a mission or with rollouts.
    grid : GridRollouts or None
        Algorithm 25's rollouts re-indexed by row, when they judge on a grid world.
    intended : ndarray of int64, shape (rows, |A|)
        The row T̂ expects each move to reach (−1: no move counted); empty unless T̂ adapts.
    is_mission : bool
        Whether π^p and safe(s, a) are the mission's kernels (`box_parts`).
    """

    index: RepresentationKernel
    tables: PlannerPair
    safe: np.ndarray
    grid: GridRollouts | None
    intended: np.ndarray
    is_mission: bool

    def box(self, kind: int) -> BoxKernel:
        """A ``kind`` box around these tables (the agent's own fields still to be set)."""
        return no_box(self.index)._replace(kind=kind, safe=self.safe, is_mission=self.is_mission)

    def compiled_box(self, box: BoxKernel, agent: Any) -> CompiledBox:
        """``box`` with ``agent``'s parts (`box_parts`): the box's compiled form."""
        return compiled_box(box, box_parts(agent, self), agent.eval_rng_)


def _is_aggressive(agent: Any) -> bool:
    """Whether ``agent``'s π^p is a `SwitchingPlanner`'s aggressive planner."""
    return bool(getattr(agent.planner_, "is_aggressive_", False))


def tabulate(agent: Any) -> BoxTables | None:
    """π^p and safe(s, a) (or the rollouts) per index row of a set-up box, or None.

    On a UAV mission, CBBA (`MissionPlanner`, or a `PlannerPair` of them) and the fuel rule
    (`FuelRisk`) or Algorithm 25's rollouts (`MissionRollouts`) are called per state, with any
    one-row-per-state index and a static or adaptive model. Elsewhere a `Tabular` index and a
    planned policy (`PlannedPolicy`, or a `PlannerPair` of two) that holds while the box
    learns (a static model, or policies that never replan, ``is_fixed``) are tabulated by
    calling the planner's own compiled form on every planned state, with a `FixedRisk` under a
    static model (its own ``is_safe`` tabulated) or Algorithm 25's `GridRollouts` (its tables
    re-indexed by row). The agent keeps the result until it replans
    (`CooperativeAgent.compiled_tables`).
    """
    planned, risk = compiled_form(agent.planner_), compiled_form(agent.risk_)
    index = compiled_form(agent.index_)
    if not isinstance(index, RepresentationKernel) or index.kind not in (TABULAR, HASHED_TABULAR):
        return None
    no_table, no_moves = np.zeros((0, 0), dtype=np.bool_), np.zeros((0, 0), dtype=np.int64)
    if _is_mission_planner(planned):
        if not isinstance(risk, (FuelRisk, MissionRollouts)):
            return None
        return BoxTables(
            index=index,
            tables=NO_PARTS.tables,
            safe=no_table,
            grid=None,
            intended=no_moves,
            is_mission=True,
        )
    policies = _planned_policies(planned)
    is_static = not agent.model_.is_adaptive
    if policies is None or index.kind != TABULAR:
        return None
    if not (is_static or all(policy.is_fixed for policy in policies)):
        return None
    is_fixed_risk = isinstance(risk, FixedRisk) and is_static
    if not (is_fixed_risk or isinstance(risk, GridRollouts)):
        return None
    rows_of = [np.array([agent.state_row(s) for s in p.states], dtype=np.int64) for p in policies]
    tables = [_table(agent, rows, p.actions) for rows, p in zip(rows_of, policies, strict=True)]
    pair = (
        fixed_pair(tables[0])
        if len(tables) == 1
        else planned._replace(conservative=tables[0], aggressive=tables[1])
    )
    active = pair.aggressive if _is_aggressive(agent) else pair.conservative
    safe = _safe_table(agent, policies[0].states, rows_of[0], active) if is_fixed_risk else no_table
    grid = None if is_fixed_risk else _rollouts_by_row(agent, risk)
    intended = no_moves if is_static else _intended_rows(agent, policies[0].states)
    return BoxTables(
        index=index, tables=pair, safe=safe, grid=grid, intended=intended, is_mission=False
    )


def _is_mission_planner(planned: Any) -> bool:
    if isinstance(planned, PlannerPair):
        return isinstance(planned.conservative, MissionPlanner)
    return isinstance(planned, MissionPlanner)


def _planned_policies(planned: Any) -> list[PlannedPolicy] | None:
    """The `PlannedPolicy` forms of π^p: one, or a switching planner's two; None otherwise."""
    if isinstance(planned, PlannedPolicy):
        return [planned]
    if isinstance(planned, PlannerPair) and isinstance(planned.conservative, PlannedPolicy):
        return [planned.conservative, planned.aggressive]
    return None


def _table(agent: Any, rows: np.ndarray, actions: np.ndarray) -> np.ndarray:
    """π^p per row of the agent's index (−1 where no planned state lies)."""
    table = np.full(agent.index_.num_features_, -1, dtype=np.int64)
    table[rows] = actions
    return table


def _safe_table(
    agent: Any, states: np.ndarray, rows: np.ndarray, planner_actions: np.ndarray
) -> np.ndarray:
    """The analyser's own ``is_safe`` per planned state and action, by row."""
    num_actions = agent.spec_.num_actions
    safe = np.zeros((agent.index_.num_features_, num_actions), dtype=np.bool_)
    for state, row in zip(states, rows, strict=True):
        for action in range(num_actions):
            safe[row, action] = agent.risk_.is_safe(
                state, action, planner_action=int(planner_actions[row])
            )
    return safe


def _rollouts_by_row(agent: Any, rollouts: GridRollouts) -> GridRollouts:
    """``rollouts`` with T̂'s states renumbered by the agent's index rows.

    CSR row (k·|S| + s)·|A| + a becomes (k·R + row(s))·|A| + a for R rows, each keeping its
    entries in order (the same draws pick the same successors); π^p is then the box's
    per-row table. Rows no state of T̂ has are empty (a rollout never reaches them).
    """
    row_of = np.array([agent.state_row(s) for s in rollouts.states], dtype=np.int64)
    num_rows, num_actions = agent.index_.num_features_, rollouts.num_actions
    num_states = row_of.shape[0]
    old = np.arange(2 * num_states * num_actions)
    table, rest = np.divmod(old, num_states * num_actions)
    state, action = np.divmod(rest, num_actions)
    new = (table * num_rows + row_of[state]) * num_actions + action
    lengths = np.diff(rollouts.indptr)
    sizes = np.zeros(2 * num_rows * num_actions, dtype=np.int64)
    sizes[new] = lengths
    order = np.argsort(np.repeat(new, lengths), kind="stable")
    is_constrained = np.zeros(num_rows, dtype=np.bool_)
    is_terminal = np.zeros(num_rows, dtype=np.bool_)
    is_constrained[row_of] = rollouts.is_constrained
    is_terminal[row_of] = rollouts.is_terminal
    return rollouts._replace(
        indptr=np.concatenate(([0], np.cumsum(sizes))), indices=row_of[rollouts.indices[order]],
        probabilities=rollouts.probabilities[order], is_constrained=is_constrained,
        is_terminal=is_terminal,
    )  # fmt: skip


def _intended_rows(agent: Any, states: np.ndarray) -> np.ndarray:
    """The row T̂ expects each move to reach, −1 where T̂ counts no move (Algorithm 26).

    Choice: a grid world's step is one move, unintended iff s' is not the model's nominal
    successor (`GridWorld.count_unintended`); the table asks the model's ``count_unintended``
    of that successor whether a move counts at all.
    """
    model, num_actions = agent.model_, agent.spec_.num_actions
    intended = np.full((agent.index_.num_features_, num_actions), -1, dtype=np.int64)
    for state in states:
        for action in range(num_actions):
            successor = model.nominal_next_state(state, action)
            if model.domain_.count_unintended(state, action, successor)[1] > 0:
                intended[agent.state_row(state), action] = agent.state_row(successor)
    return intended


def box_parts(agent: Any, tables: BoxTables) -> BoxParts:
    """The `BoxParts` of a set-up box, from its parts' forms: their own arrays, shared.

    Algorithm 26's η̂^p and count of policy changes are the box's ``replan_state_``; T̂'s η̂
    and counts its ``form_`` (`ApproximateModel.noise_model`); which planner a switching π^p
    uses its ``switch_`` (`SwitchingPlanner`, also in the grid tables' pair). Every one is
    updated in place by the kernels and by the Python methods alike.
    """
    is_adaptive = agent.adapts_model  # Algorithm 26
    replan = agent.replan_state_
    parts = NO_PARTS._replace(
        model=agent.model_.noise_model(), is_adaptive=is_adaptive,
        replan_threshold=float(agent.replan_threshold) if is_adaptive else 0.0,
        planned_noise=replan.planned_noise, policy_changes=replan.policy_changes,
    )  # fmt: skip
    if not tables.is_mission:
        grid = NO_PARTS.grid if tables.grid is None else tables.grid._replace(
            rng=agent.risk_.rng_
        )  # fmt: skip
        return parts._replace(
            tables=tables.tables, has_rollouts=tables.grid is not None, grid=grid,
            intended=tables.intended,
        )  # fmt: skip
    planners = compiled_form(agent.planner_)
    if isinstance(planners, MissionPlanner):
        planners = fixed_pair(planners)
    risk = compiled_form(agent.risk_)
    has_rollouts = isinstance(risk, MissionRollouts)
    return parts._replace(
        planners=planners, has_rollouts=has_rollouts,
        fuel=NO_PARTS.fuel if has_rollouts else risk,
        rollouts=risk if has_rollouts else NO_PARTS.rollouts,
        layout=agent.model_.domain_.graph_.layout,
    )  # fmt: skip


def icca_kernel(agent: Any) -> CompiledBox | None:
    """The `ICCA` form of a set-up `CooperativeActorCritic`, or None when it cannot be tabulated.

    None unless `tabulate` can: the planner gives a table (`ModelPlanner`'s `PlannedPolicy`,
    with a `Tabular` index) or a per-state kernel (`CBBAPlanner`'s `MissionPlanner`), the
    analyser is a `FixedRisk` (with a table) or the fuel rule (`FuelRisk`), the model is not
    adaptive, the index gives one row per state, and the learner's features are fixed
    (Choice: a growing representation inside the box stays on the Python path).
    """
    tables = agent.compiled_tables()
    if tables is None or agent.learner_.representation_.is_adaptive:
        return None
    half_life = agent.bias_half_life
    fading = (float(agent.bias), 0.0 if half_life is None else float(half_life))
    box = tables.box(ICCA)._replace(
        visits=agent.visits_, bias=fading[0], half_life=fading[1], is_fading=half_life is not None
    )
    return tables.compiled_box(box, agent)


def cooperative_learner_kernel(agent: Any) -> CompiledBox | None:
    """The `COOPERATIVE_LEARNER` form of a set-up `CooperativeLearner`, or None.

    As `icca_kernel`, for a SARSA or Q-Learning learner (the compiled imagined update of a
    vetoed proposal is theirs), on fixed features or online iFDD with sparsified activation
    (Algorithm 19; `ARiFDD` too; the loop discovers after a vetoed proposal's update,
    `learning_loop`).
    """
    tables = agent.compiled_tables()
    learner_form = compiled_form(agent.learner_)
    if tables is None or learner_form is None or learner_form.kind == ACTOR_CRITIC:
        return None
    representation = agent.learner_.representation_
    if representation.is_adaptive and getattr(representation, "sparsify", False) is not True:
        return None
    veto, trusted = agent.veto_reward, agent.trusted_knownness
    box = tables.box(COOPERATIVE_LEARNER)._replace(
        counts=agent.counts_, num_known=float(agent.num_known_visits),
        veto_reward=0.0 if veto is None else float(veto), has_veto=veto is not None,
        trusted=NEVER_TRUSTED if trusted is None else float(trusted), rng=agent.rng_,
    )  # fmt: skip
    return tables.compiled_box(box, agent)


@njit(cache=True, inline="always")
def _planner_action(box: BoxKernel, parts: BoxParts, row: int, obs: np.ndarray) -> int:
    """π^p(s) of the state ``obs`` at ``row``: its table entry, or the CBBA planner in use."""
    if not box.is_mission:
        return active_planner(parts.tables)[row]
    return planned_action(active_planner(parts.planners), obs)


@njit(cache=True, inline="always")
def _is_safe(
    box: BoxKernel, parts: BoxParts, row: int, obs: np.ndarray, action: int, planner_action: int
) -> bool:
    """safe(s, a) (`RiskAnalyzer.is_safe`): π^p(s) is safe; else the table, rule or rollouts."""
    if action == planner_action:
        return True
    if not parts.has_rollouts:  # the table, or the fuel rule on a mission
        if not box.is_mission:
            return box.safe[row, action]
        return fuel_risk(parts.fuel, obs, action) < parts.fuel.risk_tolerance
    noise = parts.model.noise[0]
    if not box.is_mission:
        grid = parts.grid
        policy = active_planner(parts.tables)
        risk = grid_failures(grid, row, action, noise, policy) / grid.num_rollouts
        return risk < grid.risk_tolerance
    rollouts, planner = parts.rollouts, active_planner(parts.planners)
    risk = mission_failures(rollouts, planner, obs, action, noise) / rollouts.num_rollouts
    return risk < rollouts.risk_tolerance


#: The box's control rules (`conjure.safety._box_rules`), compiled: one source with the Python
#: methods of `CooperativeActorCritic`, `CooperativeLearner` and `AdaptiveCooperativeLearner`.
_visit_bias = njit(cache=True, inline="always")(visit_bias)
_is_unvisited = njit(cache=True, inline="always")(is_unvisited)
_consult_planner = njit(cache=True, inline="always")(consult_planner)
_is_trusted = njit(cache=True, inline="always")(is_trusted)
_mentor_greedy_action = njit(cache=True, inline="always")(mentor_greedy_action)
_needs_replan = njit(cache=True, inline="always")(needs_replan)


@njit(cache=True, inline="always")
def cooperative_action(
    box: BoxKernel,
    parts: BoxParts,
    actor_weights: np.ndarray,
    phi: np.ndarray,
    values: np.ndarray | None,
    preferences: np.ndarray,
    legal: np.ndarray,
    policy: PolicyKernel,
    rng: np.random.Generator,
    obs: np.ndarray,
    quanta: np.ndarray,
    row_buffer: np.ndarray,
) -> int:
    """Algorithm 23, lines 1-6, while learning (`CooperativeActorCritic.act`).

    n(s) is counted, ρ(s, π^p(s)) moved to hold b(n), the actor proposes a^l from
    ``preferences`` (rewritten after the move: the learner's π(s, ·) is drawn from them);
    a^l is returned if safe, else ρ(s, a^l) −= λ and π^p(s) is returned; −1 if a full
    index could not store s.
    """
    row = encode_into(box.index, obs, quanta, row_buffer)[0]
    if row < 0:
        return -1
    planner_action = _planner_action(box, parts, row, obs)
    is_shifted, shift = _visit_bias(box.visits, row, box.bias, box.half_life, box.is_fading)
    if is_shifted:  # Section 5.3.2: ρ(s, π^p(s)) holds b(n)
        shift_preference_into(actor_weights, phi, values, planner_action, shift)
    q_values_into(actor_weights, phi, values, preferences)
    learner_action = select_action(policy, preferences, legal, rng)  # line 2
    if _is_safe(box, parts, row, obs, learner_action, planner_action):  # line 4
        return learner_action  # line 3
    shift_preference_into(actor_weights, phi, values, learner_action, -box.bias)  # line 6
    return planner_action  # line 5


@njit(cache=True, inline="always")
def cooperative_learner_action(
    box: BoxKernel,
    parts: BoxParts,
    agent: AgentKernel,
    arrays: LearnerArrays,
    phi: np.ndarray,
    values: np.ndarray | None,
    q: np.ndarray,
    legal: np.ndarray,
    rng: np.random.Generator,
    obs: np.ndarray,
    row: int,
    episode: int,
) -> tuple[int, float, bool]:
    """Algorithm 24, lines 1-8, while learning (`CooperativeLearner.act`).

    Returns (action, veto δ, whether a vetoed proposal was learned (`imagined_learn`)); the
    δ is 0 unless one was, and a non-finite one diverged. ``q``: the learner's Q(s, ·)
    (recomputed after that update); ``row``: the index row of s (``obs``).
    """
    planner_action = _planner_action(box, parts, row, obs)  # line 1
    knownness, is_consulted = _consult_planner(  # lines 2-3 and 8
        box.counts, box.num_known, row, planner_action, box.rng, False
    )
    if not is_consulted:
        return planner_action, 0.0, False
    learner_action = select_action(agent.policy, q, legal, rng)  # line 4
    if _is_trusted(knownness, box.trusted) or _is_safe(  # line 5
        box, parts, row, obs, learner_action, planner_action
    ):
        return learner_action, 0.0, False  # line 6
    if not box.has_veto:
        return planner_action, 0.0, False
    # The veto rule: ⟨s, a′, veto_reward, terminated⟩, imagined.
    delta = imagined_learn(agent, arrays, phi, values, learner_action, box.veto_reward, episode)
    q_values_into(arrays.weights, phi, values, q)
    return planner_action, delta, True


@njit(cache=True)
def box_action(
    box: BoxKernel,
    parts: BoxParts,
    agent: AgentKernel,
    arrays: LearnerArrays,
    phi: np.ndarray,
    values: np.ndarray | None,
    q: np.ndarray,
    legal: np.ndarray,
    rng: np.random.Generator,
    obs: np.ndarray,
    quanta: np.ndarray,
    row_buffer: np.ndarray,
    episode: int,
) -> tuple[int, float, bool]:
    """The box's action in ``obs`` while learning, a vetoed proposal's δ, whether one was learned.

    Writes the learner's values at s into ``q`` (Algorithm 23: the preferences after ρ moved).
    The action is −1 when a full index could not store s. A learned vetoed proposal (the
    veto rule of Algorithm 24) is the learner's update on φ(s) with that δ; the loop follows
    it with the representation's discovery, as the Python learner's ``learn`` does.
    """
    if box.kind == ICCA:
        action = cooperative_action(
            box, parts, arrays.actor_weights, phi, values, q, legal, agent.policy, rng, obs,
            quanta, row_buffer,
        )  # fmt: skip
        return action, 0.0, False
    q_values_into(arrays.weights, phi, values, q)
    row = encode_into(box.index, obs, quanta, row_buffer)[0]
    if row < 0:
        return -1, 0.0, False
    return cooperative_learner_action(
        box, parts, agent, arrays, phi, values, q, legal, rng, obs, row, episode
    )


@njit(cache=True)
def greedy_box_action(
    box: BoxKernel,
    parts: BoxParts,
    chooser: np.ndarray,
    phi: np.ndarray,
    values: np.ndarray | None,
    q: np.ndarray,
    legal: np.ndarray,
    obs: np.ndarray,
) -> int:
    """The greedy action in ``obs`` (a policy check's ``act(s, greedy=True)``); records nothing.

    ``chooser``: the weights the agent acts on (the actor's, or θ). A learner alone takes
    argmax over them. Algorithm 23's box (`CooperativeActorCritic.act`) adds λ to π^p(s) in
    an unvisited state; Algorithm 24's (`CooperativeLearner.act`) consults the learner only in
    a known pair, breaking ties toward π^p(s). Both replace an unsafe action by π^p(s) (the
    analyser's draws come from the generator of `CompiledBox.greedy_parts`). The index is looked
    up without storing s (`lookup_row`, −1: never seen).
    """
    q_values_into(chooser, phi, values, q)
    if box.kind == NO_BOX:
        return greedy_action(q, legal)
    row = lookup_row(box.index, obs)
    planner_action = _planner_action(box, parts, row, obs)
    if box.kind == ICCA:
        if _is_unvisited(box.visits, row):
            q[planner_action] += box.bias
        learner_action = greedy_action(q, legal)
    else:
        knownness, is_consulted = _consult_planner(
            box.counts, box.num_known, row, planner_action, box.rng, True
        )
        if not is_consulted:
            return planner_action
        learner_action = _mentor_greedy_action(q, legal, planner_action)
        if _is_trusted(knownness, box.trusted):
            return learner_action
    if _is_safe(box, parts, row, obs, learner_action, planner_action):
        return learner_action
    return planner_action


@njit(cache=True, inline="always")
def _moves(
    box: BoxKernel, parts: BoxParts, obs: np.ndarray, action: int, next_obs: np.ndarray
) -> tuple[int, int]:
    """(#unintended, #moves) of a transition as T̂ counts them (``count_unintended``).

    On a mission the kernel reads the float observations in place: they hold the state's
    integers, and the kernel only compares them (no int copy per step).
    """
    if box.is_mission:
        return count_unintended(obs, action, next_obs, parts.layout)
    intended = parts.intended[lookup_row(box.index, obs), action]
    if intended < 0:
        return 0, 0
    return int(lookup_row(box.index, next_obs) != intended), 1


@njit(cache=True, inline="always")
def _switch(box: BoxKernel, parts: BoxParts, noise: float) -> bool:
    """The planner's switch by η̂ (`switch_by_noise`): CBBA's pair, or the grid tables' pair."""
    if box.is_mission:
        return switch_by_noise(parts.planners, noise)
    return switch_by_noise(parts.tables, noise)


@njit(cache=True)
def box_learn(
    box: BoxKernel, parts: BoxParts, obs: np.ndarray, action: int, next_obs: np.ndarray
) -> None:
    """Algorithm 26, lines 10-15, after the learner's update (`AdaptiveCooperativeLearner.learn`).

    T̂ counts the transition's moves (`observe_moves`); when η̂ moved more than ΔT from η̂^p,
    η̂^p ← η̂ and the planner switches by η̂ (CBBA and the tabulated policies never replan,
    `switch_by_noise`); if π^p changed, every count restarts at zero (the box's ``counts``,
    the rows in use: untouched rows of a lazily indexed table stay unmapped). For a box with
    ``parts.is_adaptive``.
    """
    unintended, moves = _moves(box, parts, obs, action, next_obs)
    model = parts.model
    noise = model.noise[0]
    observe_moves(model, unintended, moves)  # line 10
    if model.noise[0] == noise:  # T̂ unchanged
        return
    if _needs_replan(model.noise[0], parts.planned_noise[0], parts.replan_threshold):  # line 11
        parts.planned_noise[0] = model.noise[0]  # line 12
        if _switch(box, parts, model.noise[0]):  # lines 13-14
            box.counts[: rows_in_use(box.index, box.counts.shape[0])] = 0  # line 15
            parts.policy_changes[0] += 1
