"""Hand-coded grid-world policies: shortest paths to a goal (Geramifard 2012, Figure 5-10b,c)."""

from __future__ import annotations

from collections import deque
from collections.abc import Sequence
from typing import Any

import numpy as np

from conjure.core.cooperative import CooperativePlanner
from conjure.core.errors import IncompatibleComponentsError, InvalidParameterError
from conjure.core.interfaces import check_is_set_up
from conjure.core.params import InstanceOf, Predicate
from conjure.domains.gridworld import BLOCKED, GOAL, PIT, GridWorld
from conjure.planners.model_planner import PlannedPolicy

__all__ = ["ShortestPathPlanner"]

#: The goals of GridWorld-2's hand-coded policies (Figure 5-10): top left and top right.
CONSERVATIVE_GOAL = (0, 0)
AGGRESSIVE_GOAL = (0, 21)


def _is_cell(value: Any) -> bool:
    return (
        isinstance(value, Sequence)
        and not isinstance(value, str)
        and len(value) == 2
        and all(isinstance(v, (int, np.integer)) and not isinstance(v, bool) for v in value)
    )


class ShortestPathPlanner(CooperativePlanner):
    """π^p: in every cell, the first move of a shortest noise-free path to a goal.

    Geramifard (2012), Section 5.5.1 and Figure 5-10: GridWorld-2's hand-coded planner
    policies. The *conservative* policy (Figure 5-10b) takes the long, safe snake to the top
    left goal, 31 moves from the start; the *aggressive* one (Figure 5-10c) heads for the top
    right goal along row 2, 14 moves, passing just below the danger cell. Both are shortest
    paths to their goal, so one class builds them: `conservative` and `aggressive` give
    GridWorld-2's two. The policy ignores the wind, so `update` never changes it.

    Parameters
    ----------
    goal : (int, int) or None, default None
        The goal cell (row, col) to head for; it must be a goal (code 3) of the model's map.
        ``None`` heads for the nearest goal.

    Attributes
    ----------
    distances_ : ndarray of int64, shape (rows, cols)
        Moves to the goal along the shortest path; −1 where it cannot be reached (blocked
        cells, pits, other goals).
    policy_ : ndarray of int64, shape (rows * cols,)
        π^p per cell, row-major.

    Notes
    -----
    - [R] RLPy's MATLAB-era ``TwoGoals_SafePolicy.m`` and ``TwoGoals_AggressivePolicy.m`` (spec
      section 4.3) are not available; the policies are reconstructed as shortest paths, which
      reproduces their nominal paths (31 and 14 moves from the start) and defines them in every
      cell.
    - Choice: paths never pass through a pit or another goal (both end the episode).
    - Choice: ties are broken in action order up, down, left, right, so from GridWorld-2's
      windy block the aggressive policy climbs to row 2 first.
    - Choice: cells from which the goal cannot be reached, pits and goals take action 0 (up).

    Complexity
    ----------
    Θ(|S|) breadth-first search at setup; Θ(1) per action. The compiled iCCA box reads π^p
    as a table (`compiled_form`).

    Examples
    --------
    >>> from conjure.domains import GridWorld
    >>> from conjure.models.approximate_model import ApproximateModel
    >>> domain = GridWorld.gridworld_2()
    >>> model = ApproximateModel(domain=domain).setup(domain.domain_spec, seed=0)
    >>> planner = ShortestPathPlanner.aggressive().setup(model, seed=0)
    >>> int(planner.distances_[domain.start_])
    14
    """

    parameter_constraints = {
        "goal": Predicate(_is_cell, "a (row, col) pair of ints") | InstanceOf(type(None)),
    }

    def __init__(self, *, goal: Sequence[int] | None = None):
        self.goal = goal

    @classmethod
    def conservative(cls) -> ShortestPathPlanner:
        """GridWorld-2's conservative policy (Figure 5-10b): to the top left goal."""
        return cls(goal=CONSERVATIVE_GOAL)

    @classmethod
    def aggressive(cls) -> ShortestPathPlanner:
        """GridWorld-2's aggressive policy (Figure 5-10c): to the top right goal."""
        return cls(goal=AGGRESSIVE_GOAL)

    def setup(self, model: Any, seed: int | np.random.SeedSequence) -> ShortestPathPlanner:
        """Search shortest paths to the goal on the map of ``model.domain_``."""
        self.validate_params()
        domain = getattr(model, "domain_", None)
        if not isinstance(domain, GridWorld):
            raise IncompatibleComponentsError(
                f"ShortestPathPlanner plans on grid worlds: it needs an ApproximateModel of a "
                f"GridWorld; got a model of {type(domain).__name__}."
            )
        grid = domain.grid_
        goals = [tuple(int(x) for x in cell) for cell in np.argwhere(grid == GOAL)]
        if self.goal is None:
            targets = goals
        elif tuple(int(x) for x in self.goal) in goals:
            targets = [tuple(int(x) for x in self.goal)]
        else:
            rows, cols = grid.shape
            row, col = (int(x) for x in self.goal)
            where = "not a goal" if 0 <= row < rows and 0 <= col < cols else "off the map"
            raise InvalidParameterError(
                f"`ShortestPathPlanner.goal` must be a goal cell of the {rows}×{cols} map; got "
                f"{(row, col)}, {where}; goals are {goals}."
            )
        self.distances_ = _distances(grid, domain.feasible_moves_, targets)
        self.policy_ = _policy(grid, domain.feasible_moves_, self.distances_)
        self._grid, self._num_cols = grid, grid.shape[1]
        self.is_set_up_ = True
        return self

    compiled_methods = ("action", "update")

    def compiled_form(self) -> PlannedPolicy:
        """π^p over every open cell, a table that never changes (``is_fixed``)."""
        check_is_set_up(self, "compiled_form")
        cells = np.argwhere(self._grid != BLOCKED)
        actions = self.policy_[cells[:, 0] * self._num_cols + cells[:, 1]]
        return PlannedPolicy(
            states=cells.astype(np.float64), actions=actions.astype(np.int64), is_fixed=True
        )

    def action(self, state: np.ndarray) -> int:
        """π^p(s): the first move of the shortest path from cell s."""
        check_is_set_up(self, "action")
        return int(self.policy_[int(state[0]) * self._num_cols + int(state[1])])


_MOVES = ((-1, 0), (1, 0), (0, -1), (0, 1))


def _distances(
    grid: np.ndarray, feasible: np.ndarray, targets: list[tuple[int, int]]
) -> np.ndarray:
    """Breadth-first search from the targets through the non-terminal cells."""
    distances = np.full(grid.shape, -1, dtype=np.int64)
    queue: deque[tuple[int, int]] = deque()
    for cell in targets:
        distances[cell] = 0
        queue.append(cell)
    while queue:
        row, col = queue.popleft()
        for a, (dr, dc) in enumerate(_MOVES):
            if not feasible[row, col, a]:
                continue  # moves are symmetric: a feasible move out is a feasible move in
            nr, nc = row + dr, col + dc
            if distances[nr, nc] < 0 and grid[nr, nc] not in (GOAL, PIT):
                distances[nr, nc] = distances[row, col] + 1
                queue.append((nr, nc))
    return distances


def _policy(grid: np.ndarray, feasible: np.ndarray, distances: np.ndarray) -> np.ndarray:
    """The first action (up, down, left, right) whose move gets one step closer."""
    rows, cols = grid.shape
    policy = np.zeros(rows * cols, dtype=np.int64)
    for row in range(rows):
        for col in range(cols):
            d = distances[row, col]
            if d <= 0:
                continue
            for a, (dr, dc) in enumerate(_MOVES):
                if feasible[row, col, a] and distances[row + dr, col + dc] == d - 1:
                    policy[row * cols + col] = a
                    break
    return policy
