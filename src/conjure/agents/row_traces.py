"""Sparse eligibility traces by feature row, for the actor-critic (Sutton & Barto 2018, §13.5).

A trace z has the shape of the weights it updates (n_features × width): the critic's θ (width
|A| for Q, 1 for V) or the actor's ω (width |A|). Only the rows of features active since the
episode began are stored: ``rows[:count]`` with their ``traces[:count]``, and ``slot_of[f]``
gives feature f's row (−1: none), so a step costs Θ(live rows × width), never Θ(n).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from conjure.agents import _kernels
from conjure.core.interfaces import Expansion, SparseFeatures

__all__ = ["MIN_TRACE", "NO_ROW_TRACES", "RowTraceArrays", "RowTraces"]

#: Rows whose every entry decays below this are forgotten (as SARSA's ``min_trace``).
MIN_TRACE = 1e-3
_INITIAL_ROWS = 64


class RowTraceArrays(NamedTuple):
    """One `RowTraces` (Algorithm 12 with λ > 0) as the compiled loop reads it, in place.

    Parameters
    ----------
    slot_of : ndarray of int64, shape (n,)
        Feature f's row (−1: none).
    rows, values, count : ndarray
        ``rows[:count[0]]`` and ``values[:count[0]]``: the live features and their traces (a
        row of ``width`` entries each).
    """

    slot_of: np.ndarray
    rows: np.ndarray
    values: np.ndarray
    count: np.ndarray


#: The `RowTraceArrays` of a learner without row traces (the fields' types, empty).
NO_ROW_TRACES = RowTraceArrays(
    slot_of=np.zeros(0, dtype=np.int64),
    rows=np.zeros(0, dtype=np.int64),
    values=np.zeros((0, 0)),
    count=np.zeros(1, dtype=np.int64),
)


class RowTraces:
    """The live rows of one eligibility trace z (n_features × ``width``), cleared per episode.

    Algorithm 12's actor-critic with λ > 0: z ← γλ·z + φ(s) ⊗ g each step and w ← w + αδ·z.

    Parameters
    ----------
    num_features:
        n, the rows z could ever hold (``grow`` adds more).
    width:
        Columns of the weights z updates: |A| for Q or the actor, 1 for V.
    """

    def __init__(self, num_features: int, width: int):
        self.slot_of = np.full(num_features, -1, dtype=np.int64)
        self.rows = np.zeros(_INITIAL_ROWS, dtype=np.int64)
        self.traces = np.zeros((_INITIAL_ROWS, width))
        self.count = np.zeros(1, dtype=np.int64)

    def step(self, factor: float, phi: SparseFeatures, vector: np.ndarray) -> None:
        """One step: z ← factor·z + φ(s) ⊗ ``vector`` (``vector``: the per-column gradient)."""
        while not _kernels.step_row_traces(
            self.slot_of, self.rows, self.traces, self.count, factor, MIN_TRACE, phi[0], phi[1],
            vector,
        ):  # fmt: skip
            self.grow_rows()

    def apply(self, weights: np.ndarray, amount: float) -> None:
        """Update: weights ← weights + amount·z."""
        _kernels.apply_row_traces(weights, self.rows, self.traces, self.count, amount)

    def clear(self) -> None:
        """Forget every live row (a new episode)."""
        _kernels.clear_row_traces(self.slot_of, self.rows, self.count)

    def compiled_form(self) -> RowTraceArrays:
        """The traces' own arrays for the compiled loop (`RowTraceArrays`, updated in place)."""
        return RowTraceArrays(
            slot_of=self.slot_of, rows=self.rows, values=self.traces, count=self.count
        )

    def grow(self, expansion: Expansion) -> None:
        """Make room for the features an adaptive representation added (their z is 0)."""
        extra = np.full(expansion.num_new, -1, dtype=np.int64)
        self.slot_of = np.concatenate([self.slot_of, extra])

    def state_arrays(self, prefix: str) -> dict[str, np.ndarray]:
        """The live rows, for saving mid-episode."""
        count = int(self.count[0])
        return {f"{prefix}rows": self.rows[:count], f"{prefix}values": self.traces[:count]}

    def load(self, rows: np.ndarray, values: np.ndarray) -> None:
        """Restore the live rows ``state_arrays`` saved (validated by the caller)."""
        self.clear()
        while self.rows.shape[0] < rows.shape[0]:
            self.grow_rows()
        count = rows.shape[0]
        self.rows[:count] = rows
        self.traces[:count] = values
        self.slot_of[rows] = np.arange(count)
        self.count[0] = count

    def grow_rows(self) -> None:
        """Double the room for live rows (``step`` does when needed; the compiled loop asks)."""
        size, width = self.traces.shape
        self.rows = np.concatenate([self.rows, np.zeros(size, dtype=np.int64)])
        self.traces = np.concatenate([self.traces, np.zeros((size, width))])
