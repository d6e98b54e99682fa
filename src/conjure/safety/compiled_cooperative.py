"""The iCCA control box as the compiled learning loop reads it (`conjure.core.compiled_form`).

Geramifard (2012), Algorithm 23 (Section 5.3). `BoxKernel` holds what the box needs per step
when its planner and risk analyser are fixed functions of the state: π^p(s) and the verdicts
safe(s, a) tabulated per row of the box's index (one feature per state), the visit counts
n(s) (the agent's own table, updated in place) and the planner bias. `cooperative_action` is
`CooperativeActorCritic.act` (lines 1-6) for the loop; the learner's update stays the
learner's own kernel.

The tables are made by calling the parts' own methods (`planner.action` through its compiled
form, the analyser's ``is_safe``) on every state the planner planned, so no rule is coded
twice. They are exact while neither changes: the model is not adaptive and the analyser draws
no random number (`FixedRisk`).
"""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np
from numba import njit

from conjure.agents.compiled_agent import q_values_into, shift_preference_into
from conjure.core.compiled_form import compiled_form
from conjure.policies.compiled_policy import PolicyKernel, select_action
from conjure.representations.compiled_representation import (
    TABULAR,
    RepresentationKernel,
    encode_into,
)

__all__ = [
    "ICCA",
    "NO_BOX",
    "BoxKernel",
    "FixedRisk",
    "cooperative_action",
    "icca_kernel",
    "no_box",
]

#: Box kinds of `BoxKernel`: none (a plain learner), Algorithm 23.
NO_BOX, ICCA = 0, 1


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
        `NO_BOX` or `ICCA`.
    index : RepresentationKernel
        The box's index: the row of a state in the tables below.
    planner_actions : ndarray of int64, shape (rows,)
        π^p(s) per row.
    safe : ndarray of bool, shape (rows, |A|)
        safe(s, a) per row and action (true for a = π^p(s)).
    visits : ndarray of int64, shape (rows,)
        n(s), the agent's ``visits_`` (updated in place).
    bias, half_life : float
        λ and N_b of the fading bias b(n) = λ·N_b/(N_b + n).
    is_fading : bool
        Whether the bias fades (``bias_half_life`` is not None).
    """

    kind: int
    index: RepresentationKernel
    planner_actions: np.ndarray
    safe: np.ndarray
    visits: np.ndarray
    bias: float
    half_life: float
    is_fading: bool


def no_box(index: RepresentationKernel) -> BoxKernel:
    """The `NO_BOX` form (empty tables) with a stand-in ``index`` of the loop's type."""
    empty = np.zeros(0, dtype=np.int64)
    no_table = np.zeros((0, 0), dtype=np.bool_)
    return BoxKernel(NO_BOX, index, empty, no_table, empty, 0.0, 0.0, False)


def icca_kernel(agent: Any) -> BoxKernel | None:
    """The `ICCA` form of a set-up `CooperativeActorCritic`, or None when it cannot be tabulated.

    None unless the planner gives a table (`ModelPlanner`'s `PlannedPolicy`), the analyser
    is a `FixedRisk`, the index is tabular (one row per state) and the learner's features are
    fixed (Choice: a growing representation inside the box stays on the Python path).
    """
    if agent.learner_.representation_.is_adaptive:
        return None
    planned = compiled_form(agent.planner_)
    index = compiled_form(agent.index_)
    if planned is None or not isinstance(compiled_form(agent.risk_), FixedRisk):
        return None
    if not isinstance(index, RepresentationKernel) or index.kind != TABULAR:
        return None
    rows, num_actions = agent.visits_.shape[0], agent.spec_.num_actions
    planner_actions = np.full(rows, -1, dtype=np.int64)
    safe = np.zeros((rows, num_actions), dtype=np.bool_)
    for state, planner_action in zip(planned.states, planned.actions, strict=True):
        row = agent.state_row(state)
        planner_actions[row] = planner_action
        for action in range(num_actions):
            safe[row, action] = agent.risk_.is_safe(
                state, action, planner_action=int(planner_action)
            )
    half_life = agent.bias_half_life
    return BoxKernel(
        ICCA,
        index,
        planner_actions,
        safe,
        agent.visits_,
        float(agent.bias),
        0.0 if half_life is None else float(half_life),
        half_life is not None,
    )


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
    a^l is returned if safe, else ρ(s, a^l) −= λ and π^p(s) is returned.
    """
    row = encode_into(box.index, obs, quanta, row_buffer)[0]
    planner_action = box.planner_actions[row]
    visits = box.visits[row]
    box.visits[row] = visits + 1
    if visits == 0:  # Section 5.3.2: bias ρ toward π^p on the first visit
        shift_preference_into(actor_weights, phi, values, planner_action, box.bias)
    elif box.is_fading:  # the bias fades from b(n − 1) to b(n)
        fade = _planner_bias(box, visits) - _planner_bias(box, visits - 1)
        shift_preference_into(actor_weights, phi, values, planner_action, fade)
    q_values_into(actor_weights, phi, values, preferences)
    learner_action = select_action(policy, preferences, legal, rng)  # line 2
    if box.safe[row, learner_action]:  # line 4
        return learner_action  # line 3
    shift_preference_into(actor_weights, phi, values, learner_action, -box.bias)  # line 6
    return planner_action  # line 5
