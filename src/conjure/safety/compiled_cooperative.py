"""The iCCA control box as the compiled learning loop reads it (`conjure.core.compiled_form`).

Geramifard (2012), Algorithms 23 and 24 (Sections 5.3-5.4). `BoxKernel` holds what the box
needs per step when its planner and risk analyser are fixed functions of the state: π^p(s)
per row of the box's index (one feature per state), tabulated from a planned policy or, for
CBBA on UAV missions (Section 5.3.1), planned by its own kernel (`first_move`) the first time
the box meets a state and kept for that row; the verdicts safe(s, a), tabulated, or the fuel
rule's kernel (`fuel_risk`, Section 5.3.5) called per proposal; and the agent's own tables,
updated in place (Algorithm 23's visit counts n(s) and planner bias; Algorithm 24's counts of
unconsulted planner actions, knownness and veto rule).
`box_action` is the box's ``act`` while learning (`cooperative_action`:
`CooperativeActorCritic`, `cooperative_learner_action`: `CooperativeLearner`); the learner's
updates stay the learner's own kernels.

The tables are made by calling the parts' own methods (`planner.action` through its compiled
form, the analyser's ``is_safe``) on every state the planner planned, and the per-state parts
are the components' own kernels, so no rule is coded twice. They are exact while neither
changes: the model is not adaptive and the analyser draws no random number (`FixedRisk`,
`FuelRisk`). CBBA is deterministic, so a row's kept plan is the one it would make again (the
Python planner's own cache relies on the same).
"""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np
from numba import njit

from conjure.agents.compiled_agent import (
    ACTOR_CRITIC,
    AgentKernel,
    LearnerArrays,
    imagined_learn,
    q_values_into,
    shift_preference_into,
)
from conjure.core.compiled_form import compiled_form
from conjure.planners.cbba_planner import MissionPlanner, first_move
from conjure.planners.model_planner import PlannedPolicy
from conjure.policies.compiled_policy import PolicyKernel, select_action
from conjure.representations.compiled_representation import (
    HASHED_TABULAR,
    TABULAR,
    RepresentationKernel,
    encode_into,
)
from conjure.safety.fuel_risk import FuelRisk, fuel_risk

__all__ = [
    "COOPERATIVE_LEARNER",
    "ICCA",
    "NO_BOX",
    "BoxKernel",
    "BoxTables",
    "FixedRisk",
    "box_action",
    "cooperative_action",
    "cooperative_learner_action",
    "cooperative_learner_kernel",
    "icca_kernel",
    "no_box",
    "tabulate",
]

#: Box kinds of `BoxKernel`: none (a plain learner), Algorithm 23, Algorithm 24.
NO_BOX, ICCA, COOPERATIVE_LEARNER = 0, 1, 2
#: The generator a box without draws holds (the field's type is fixed).
_NO_DRAWS = np.random.default_rng(0)
#: Stand-ins of the per-state planner and fuel rule for boxes that tabulate them.
_NO_MISSION = MissionPlanner(
    np.zeros((0, 0)), np.zeros((0, 0), dtype=np.int64), np.zeros((0, 4)), 0, 0, 0.0,
    np.zeros(3), False, 0.0, False, 0,
)  # fmt: skip
_NO_FUEL = FuelRisk(np.zeros(4, dtype=np.int64), np.zeros(0, dtype=np.int64), 1.0)


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
    planner_actions : ndarray of int64, shape (rows,)
        π^p(s) per row (−1: not planned yet, with ``plans_online``).
    safe : ndarray of bool, shape (rows, |A|)
        safe(s, a) per row and action (true for a = π^p(s)); empty with ``has_fuel_risk``.
    mission : MissionPlanner
        CBBA's kernel form, which plans a row's π^p(s) on the first visit if ``plans_online``.
    plans_online : bool
        Whether ``planner_actions`` is a cache that `first_move` fills.
    fuel : FuelRisk
        The fuel rule, which judges proposals if ``has_fuel_risk`` (else ``safe`` does).
    has_fuel_risk : bool
        Whether ``fuel`` judges proposals.
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
        The knownness from which the safety check is skipped (2.0: never).
    rng : numpy.random.Generator
        The agent's own generator (Algorithm 24's knownness draws).
    """

    kind: int
    index: RepresentationKernel
    planner_actions: np.ndarray
    safe: np.ndarray
    mission: MissionPlanner
    plans_online: bool
    fuel: FuelRisk
    has_fuel_risk: bool
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
        NO_BOX, index, empty, no_table, _NO_MISSION, False, _NO_FUEL, False, empty, 0.0, 0.0,
        False, no_counts, 1.0, 0.0, False, 2.0, _NO_DRAWS,
    )  # fmt: skip


class BoxTables(NamedTuple):
    """A box's tabulated parts (`tabulate`).

    Geramifard (2012), Sections 5.3.1, 5.3.3 and 5.3.5: π^p and the risk analyser's verdicts,
    per row of the box's index, or the kernels that give them per state.

    Parameters
    ----------
    index : RepresentationKernel
        The index's compiled form (a state's row).
    planner_actions : ndarray of int64, shape (rows,)
        π^p(s) per row (−1: a row no planned state has, or one not planned yet).
    safe : ndarray of bool, shape (rows, |A|)
        safe(s, a) per row and action (empty with a ``fuel`` rule).
    mission : MissionPlanner or None
        CBBA's form when π^p is planned per state (``planner_actions`` is then its cache).
    fuel : FuelRisk or None
        The fuel rule when it judges proposals per state.
    """

    index: RepresentationKernel
    planner_actions: np.ndarray
    safe: np.ndarray
    mission: MissionPlanner | None
    fuel: FuelRisk | None

    def box(self, kind: int) -> BoxKernel:
        """A ``kind`` box around these tables (the agent's own fields still to be set)."""
        return no_box(self.index)._replace(
            kind=kind, planner_actions=self.planner_actions, safe=self.safe,
            mission=self.mission or _NO_MISSION, plans_online=self.mission is not None,
            fuel=self.fuel or _NO_FUEL, has_fuel_risk=self.fuel is not None,
        )  # fmt: skip


def tabulate(agent: Any) -> BoxTables | None:
    """π^p and safe(s, a) per index row of a set-up box, or the kernels; None (`icca_kernel`).

    A planned policy (`PlannedPolicy`) and a `FixedRisk` are tabulated by calling the
    planner's and the analyser's own methods on every planned state (a `Tabular` index); CBBA
    (`MissionPlanner`) and the fuel rule (`FuelRisk`) are the components' kernels, called per
    state (any one-row-per-state index). The agent keeps the result until it replans
    (`CooperativeAgent.compiled_tables`).
    """
    if agent.model_.is_adaptive:
        return None
    planned, risk = compiled_form(agent.planner_), compiled_form(agent.risk_)
    index = compiled_form(agent.index_)
    if not isinstance(index, RepresentationKernel) or index.kind not in (TABULAR, HASHED_TABULAR):
        return None
    rows, num_actions = agent.index_.num_features_, agent.spec_.num_actions
    planner_actions = np.full(rows, -1, dtype=np.int64)
    safe = np.zeros((0, 0), dtype=np.bool_)
    if isinstance(planned, PlannedPolicy) and index.kind == TABULAR:
        for state, planner_action in zip(planned.states, planned.actions, strict=True):
            planner_actions[agent.state_row(state)] = planner_action
    elif not isinstance(planned, MissionPlanner):
        return None
    if isinstance(risk, FixedRisk) and isinstance(planned, PlannedPolicy):
        safe = np.zeros((rows, num_actions), dtype=np.bool_)
        for state, planner_action in zip(planned.states, planned.actions, strict=True):
            row = agent.state_row(state)
            for action in range(num_actions):
                safe[row, action] = agent.risk_.is_safe(
                    state, action, planner_action=int(planner_action)
                )
    elif not isinstance(risk, FuelRisk):
        return None
    mission = planned if isinstance(planned, MissionPlanner) else None
    fuel = risk if isinstance(risk, FuelRisk) else None
    return BoxTables(index, planner_actions, safe, mission, fuel)


def icca_kernel(agent: Any) -> BoxKernel | None:
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
    return tables.box(ICCA)._replace(
        visits=agent.visits_, bias=fading[0], half_life=fading[1], is_fading=half_life is not None
    )


def cooperative_learner_kernel(agent: Any) -> BoxKernel | None:
    """The `COOPERATIVE_LEARNER` form of a set-up `CooperativeLearner`, or None.

    As `icca_kernel`, for a SARSA or Q-Learning learner (the compiled imagined update of a
    vetoed proposal is theirs), on fixed features or online iFDD with sparsified activation
    (Algorithm 19; the loop discovers after a vetoed proposal's update, `learning_loop`).
    """
    tables = agent.compiled_tables()
    learner_form = compiled_form(agent.learner_)
    if tables is None or learner_form is None or learner_form.kind == ACTOR_CRITIC:
        return None
    representation = agent.learner_.representation_
    if representation.is_adaptive and getattr(representation, "sparsify", False) is not True:
        return None
    veto, trusted = agent.veto_reward, agent.trusted_knownness
    return tables.box(COOPERATIVE_LEARNER)._replace(
        counts=agent.counts_, num_known=float(agent.num_known_visits),
        veto_reward=0.0 if veto is None else float(veto), has_veto=veto is not None,
        trusted=2.0 if trusted is None else float(trusted), rng=agent.rng_,
    )  # fmt: skip


@njit(cache=True, inline="always")
def _planner_action(box: BoxKernel, row: int, obs: np.ndarray) -> int:
    """π^p(s) of the state ``obs`` at ``row``: its table entry, planned on the first visit."""
    action = box.planner_actions[row]
    if action < 0 and box.plans_online:
        action = first_move(box.mission, obs)
        box.planner_actions[row] = action
    return action


@njit(cache=True, inline="always")
def _is_safe(box: BoxKernel, row: int, obs: np.ndarray, action: int, planner_action: int) -> bool:
    """safe(s, a) (`RiskAnalyzer.is_safe`): π^p(s) is safe; else the table or the fuel rule."""
    if not box.has_fuel_risk:
        return box.safe[row, action]
    return action == planner_action or fuel_risk(box.fuel, obs, action) < box.fuel.risk_tolerance


@njit(cache=True, inline="always")
def _planner_bias(box: BoxKernel, visits: int) -> float:
    """b(n) = λ·N_b/(N_b + n) (`CooperativeActorCritic.planner_bias`)."""
    return box.bias * box.half_life / (box.half_life + visits)


@njit(cache=True)
def cooperative_action(
    box: BoxKernel,
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
    planner_action = _planner_action(box, row, obs)
    visits = box.visits[row]
    box.visits[row] = visits + 1
    if visits == 0:  # Section 5.3.2: bias ρ toward π^p on the first visit
        shift_preference_into(actor_weights, phi, values, planner_action, box.bias)
    elif box.is_fading:  # the bias fades from b(n − 1) to b(n)
        fade = _planner_bias(box, visits) - _planner_bias(box, visits - 1)
        shift_preference_into(actor_weights, phi, values, planner_action, fade)
    q_values_into(actor_weights, phi, values, preferences)
    learner_action = select_action(policy, preferences, legal, rng)  # line 2
    if _is_safe(box, row, obs, learner_action, planner_action):  # line 4
        return learner_action  # line 3
    shift_preference_into(actor_weights, phi, values, learner_action, -box.bias)  # line 6
    return planner_action  # line 5


@njit(cache=True)
def cooperative_learner_action(
    box: BoxKernel,
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
    planner_action = _planner_action(box, row, obs)  # line 1
    knownness = min(1.0, box.counts[row, planner_action] / box.num_known)  # line 2
    consult = knownness >= 1.0 or (knownness > 0.0 and box.rng.random() < knownness)
    if not consult:  # line 3 failed
        box.counts[row, planner_action] += 1  # line 8
        return planner_action, 0.0, False
    learner_action = select_action(agent.policy, q, legal, rng)  # line 4
    if knownness >= box.trusted or _is_safe(box, row, obs, learner_action, planner_action):
        return learner_action, 0.0, False  # line 6
    if not box.has_veto:
        return planner_action, 0.0, False
    # The veto rule: ⟨s, a′, veto_reward, terminated⟩, imagined.
    delta = imagined_learn(agent, arrays, phi, values, learner_action, box.veto_reward, episode)
    q_values_into(arrays.weights, phi, values, q)
    return planner_action, delta, True


@njit(cache=True, inline="always")
def box_action(
    box: BoxKernel,
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
            box, arrays.actor_weights, phi, values, q, legal, agent.policy, rng, obs, quanta,
            row_buffer,
        )  # fmt: skip
        return action, 0.0, False
    q_values_into(arrays.weights, phi, values, q)
    row = encode_into(box.index, obs, quanta, row_buffer)[0]
    if row < 0:
        return -1, 0.0, False
    return cooperative_learner_action(
        box, agent, arrays, phi, values, q, legal, rng, obs, row, episode
    )
