"""The control rules of iCCA's box, one source for its Python methods and its kernels.

Geramifard (2012), Algorithms 23, 24 and 26 (Sections 5.3-5.5): the planner bias b(n) and
its per-visit shift (Algorithm 23), knownness, consulting the learner and the count of
unconsulted planner actions (Algorithm 24, lines 2-3 and 8), the trust test of Section
5.5.3, the learner's greedy action with ties toward π^p, and the replan test (Algorithm 26,
line 11). The cooperative learners' Python ``act`` and ``learn`` call these functions; the
compiled loop runs the same source compiled by numba (`conjure.safety.compiled_cooperative`
wraps each with ``njit``), as `conjure.core.schedules` does for step sizes.

Choice: the rules are plain functions, not kernels the Python path dispatches to. From
Python a numba call that takes the agent's generator unboxes it on every call (tens of µs),
and one that takes the box's named form types its nested tuples on every call (hundreds of
µs), while a plain call costs well under a µs; the source, and so every rounding and every
draw from the generator, is the same on both paths. The per-state parts (π^p, safe(s, a))
are the planner's and the analyser's own methods on the Python path and their own kernels
(or tables made by calling them) on the compiled path.
"""

from __future__ import annotations

import numpy as np
from numba.extending import register_jitable

from conjure.policies import greedy_action

__all__ = [
    "NEVER_TRUSTED",
    "consult_planner",
    "fading_bias",
    "is_trusted",
    "is_unvisited",
    "mentor_greedy_action",
    "needs_replan",
    "visit_bias",
]

#: The trust threshold of a box that always checks (``trusted_knownness=None``): above 1.
NEVER_TRUSTED = 2.0


@register_jitable
def fading_bias(bias: float, half_life: float, visits: int) -> float:
    """b(n) = λ·N_b/(N_b + n), the fading planner bias after n visits (Algorithm 23).

    A plain function that compiled code may call too (``register_jitable``), so that
    `visit_bias` calls it on both paths.
    """
    return bias * half_life / (half_life + visits)


def visit_bias(
    visits: np.ndarray, row: int, bias: float, half_life: float, is_fading: bool
) -> tuple[bool, float]:
    """Count a learning visit of ``row`` (n(s) += 1); return (is ρ(s, π^p(s)) moved, by how much).

    Algorithm 23 with Section 5.3.2's bias: the first visit adds b(0) = λ; a later one, with a
    fading bias, moves it from b(n − 1) to b(n); a printed (constant) bias moves nothing.
    """
    count = int(visits[row])  # a Python int on the Python path (numpy scalars are slow)
    visits[row] = count + 1
    if count == 0:
        return True, bias
    if is_fading:
        return True, fading_bias(bias, half_life, count) - fading_bias(bias, half_life, count - 1)
    return False, 0.0


def is_unvisited(visits: np.ndarray, row: int) -> bool:
    """Whether greedy acting treats the state as biased by λ (never visited, or never seen: −1)."""
    return row < 0 or visits[row] == 0


def consult_planner(
    counts: np.ndarray,
    num_known: float,
    row: int,
    planner_action: int,
    rng: np.random.Generator,
    is_greedy: bool,
) -> tuple[float, bool]:
    """Algorithm 24, lines 2-3 and 8: (knownness of ⟨s, π^p(s)⟩, whether the learner is consulted).

    knownness = min(1, count(s, a)/𝒦), 0 for a state the index never saw (``row`` −1). While
    learning the learner is consulted with probability knownness (a draw from ``rng`` only
    strictly between 0 and 1), and an unconsulted planner action is counted (line 8); greedy
    acting consults only a known pair (knownness 1) and records nothing.
    """
    knownness = 0.0 if row < 0 else min(1.0, counts[row, planner_action] / num_known)
    if is_greedy:
        return knownness, knownness >= 1.0
    if knownness >= 1.0 or (knownness > 0.0 and rng.random() < knownness):
        return knownness, True
    counts[row, planner_action] += 1  # line 8
    return knownness, False


def is_trusted(knownness: float, trusted: float) -> bool:
    """Whether a consulted learner's action skips the safety check (Section 5.5.3).

    ``trusted``: the threshold, `NEVER_TRUSTED` for a box that always checks.
    """
    return knownness >= trusted


def mentor_greedy_action(values: np.ndarray, legal: np.ndarray, planner_action: int) -> int:
    """The learner's greedy action with ties broken toward π^p(s) (`CooperativeLearner`, Notes).

    π^p(s) unless another legal action has a strictly higher value.
    """
    best = greedy_action(values, legal)
    return planner_action if values[planner_action] >= values[best] else best


def needs_replan(noise: float, planned_noise: float, replan_threshold: float) -> bool:
    """Algorithm 26, line 11: ‖T̂^p − T̂‖ = |η̂^p − η̂| > ΔT."""
    return abs(noise - planned_noise) > replan_threshold
