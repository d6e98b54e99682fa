"""Noisy grid worlds with pits: GridWorld-1 and GridWorld-2 of Geramifard (2012), Chapter 5."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any, ClassVar

import numpy as np
from gymnasium import spaces

from conjure.core.errors import InvalidParameterError
from conjure.core.interfaces import Domain, DomainSpec
from conjure.core.params import Constraint, InstanceOf, Interval, did_you_mean

__all__ = ["GridWorld", "load_map", "shipped_maps"]

MAPS_DIR = Path(__file__).resolve().parent / "maps"

FREE, BLOCKED, START, GOAL, PIT, WINDY = 0, 1, 2, 3, 4, 5
# Actions 0..3: up, down, left, right as (row, column) offsets (RLPy's order).
MOVES = ((-1, 0), (1, 0), (0, -1), (0, 1))


def shipped_maps() -> list[str]:
    """Return the names of the maps shipped in ``conjure/domains/maps`` (file stems, sorted)."""
    return sorted(path.stem for path in MAPS_DIR.glob("*.txt"))


def _resolve_map(map_name: str | os.PathLike[str]) -> Path:
    name = os.fspath(map_name)
    shipped = MAPS_DIR / f"{name}.txt"
    if os.sep not in name and "/" not in name and shipped.is_file():
        return shipped
    path = Path(name).expanduser()
    if path.is_file():
        return path
    known = shipped_maps()
    raise InvalidParameterError(
        f"`GridWorld.map_name` must be a shipped map name or the path of a map file; got "
        f"{name!r}.{did_you_mean(name, known)} Shipped maps: {', '.join(known)}."
    )


def load_map(map_name: str | os.PathLike[str]) -> np.ndarray:
    """Read a map (shipped name or path) into an int64 grid of cell codes 0-5.

    The file holds one row per line, cells separated by whitespace: 0 free, 1 blocked, 2 start,
    3 goal, 4 pit, 5 free (windy marker). Blank lines are ignored.

    Examples
    --------
    >>> load_map("gridworld1").shape
    (10, 7)
    """
    path = _resolve_map(map_name)
    rows = [line.split() for line in path.read_text().splitlines() if line.strip()]
    try:
        grid = np.array([[int(code) for code in row] for row in rows], dtype=np.int64)
    except ValueError as error:  # ragged rows or a non-integer code
        raise InvalidParameterError(
            f"GridWorld map {str(path)!r} must be a rectangle of integer codes 0-5 separated "
            f"by whitespace, one row per line; reading it failed: {error}."
        ) from None
    if grid.ndim != 2 or grid.size == 0:
        raise InvalidParameterError(
            f"GridWorld map {str(path)!r} must be a non-empty rectangle of codes; every line "
            f"must have the same number of cells."
        )
    bad = sorted(set(np.unique(grid).tolist()) - {FREE, BLOCKED, START, GOAL, PIT, WINDY})
    if bad:
        raise InvalidParameterError(
            f"GridWorld map {str(path)!r} has unknown cell codes {bad}; codes are 0 free, "
            f"1 blocked, 2 start, 3 goal, 4 pit, 5 free (windy)."
        )
    num_starts = int(np.count_nonzero(grid == START))
    if num_starts != 1 or not np.any(grid == GOAL):
        raise InvalidParameterError(
            f"GridWorld map {str(path)!r} needs exactly one start cell (code 2) and at least "
            f"one goal (code 3); it has {num_starts} start(s) and "
            f"{int(np.count_nonzero(grid == GOAL))} goal(s)."
        )
    return grid


class GridWorld(Domain):
    """Navigate a grid from the start to a goal, avoiding pits, under random wind.

    Geramifard (2012), Section 5.1 (GridWorld-1, Figure 5-1) and Section 5.5.1 (GridWorld-2,
    Figure 5-10). Actions are up, down, left, right. With probability η (``noise``) the chosen
    action is replaced by one drawn uniformly from the feasible moves of the current cell
    ("pushed into any unoccupied neighbouring cell"). Entering a goal earns +1 and entering a pit
    earns −1; both end the episode. Every other step earns ``step_reward``.

    Parameters
    ----------
    map_name : str or path, default="gridworld1"
        A shipped map (``gridworld1`` 10×7, ``gridworld2`` 5×22, ``4x5``) or a map file path.
    step_reward : float, default=-0.001
        Reward of every step that reaches neither a goal nor a pit; any finite float.
    noise : float, default=0.3
        η, the probability in [0, 1] that the action is replaced by a random feasible move.
    discount : float, default=1.0
        γ in [0, 1].
    max_episode_steps : int, default=1000
        Episode cap, in [1, inf).

    Attributes
    ----------
    grid_ : ndarray of int64, shape (rows, cols)
        The cell codes (read-only): 0 free, 1 blocked, 2 start, 3 goal, 4 pit, 5 free (windy).
    start_ : tuple of int
        The start cell (row, col).
    feasible_moves_ : ndarray of bool, shape (rows, cols, 4)
        Whether each action from each cell leads to another cell (not off the map or blocked).
    domain_spec : DomainSpec
        Bounds [0, rows − 1] × [0, cols − 1], both discrete; 4 actions.

    Notes
    -----
    ======  =================  ==============================================
    Symbol  Name               Meaning
    ======  =================  ==============================================
    s       obs                (row, col) as float64, row 0 at the top
    a       action             0 up, 1 down, 2 left, 3 right
    η       noise              probability of a random feasible move
    γ       discount           1.0 by default
    ======  =================  ==============================================

    - Choice: noise is RLPy-style: with probability η the action is replaced by one drawn
      uniformly from the *feasible* moves (those not leaving the map or entering a blocked
      cell); the replacement may equal the chosen action. A cell without feasible moves stays
      put.
    - Choice: a chosen (noise-free) move into the map edge or a blocked cell leaves the agent
      where it is and earns ``step_reward``; every action is always legal.
    - Choice: the goal and pit rewards replace ``step_reward`` (they are not added to it).
    - Choice: ``discount`` defaults to 1.0: the thesis treats both grid worlds as undiscounted
      episodic tasks (cumulative return per episode); RLPy uses 0.9.
    - Choice: code 5 (the windy cells of GridWorld-3) is free here; the noise is uniform.
    - Caveat: with this noise model value iteration reproduces the thesis's ratio of planner to
      optimal value for GridWorld-1 (about 3), but not its success rates (29% → 80%); the
      thesis's exact noise model is unknown.

    Complexity: Θ(1) per step (precomputed move tables).

    Examples
    --------
    >>> domain = GridWorld(map_name="4x5", noise=0.0)
    >>> obs, info = domain.reset(seed=0)
    >>> obs
    array([0., 0.])
    >>> domain.step(3)[:3]
    (array([0., 1.]), -0.001, False)
    """

    parameter_constraints: ClassVar[dict[str, Constraint]] = {
        "map_name": InstanceOf((str, os.PathLike), "a shipped map name or a path"),
        "step_reward": Interval(float, None, None),
        "noise": Interval(float, 0.0, 1.0),
        "discount": Interval(float, 0.0, 1.0),
        "max_episode_steps": Interval(int, 1, None),
    }

    def __init__(
        self,
        *,
        map_name: str | os.PathLike[str] = "gridworld1",
        step_reward: float = -0.001,
        noise: float = 0.3,
        discount: float = 1.0,
        max_episode_steps: int = 1000,
    ) -> None:
        self.map_name = map_name
        self.step_reward = step_reward
        self.noise = noise
        self.discount = discount
        self.max_episode_steps = max_episode_steps
        self._build()

    @classmethod
    def gridworld_1(cls, **params: Any) -> GridWorld:
        """GridWorld-1 (Section 5.1): 10×7 map, step reward −0.001, η = 0.3."""
        return cls(**{"map_name": "gridworld1", "step_reward": -0.001, "noise": 0.3, **params})

    @classmethod
    def gridworld_2(cls, **params: Any) -> GridWorld:
        """GridWorld-2 (Section 5.5.1): 5×22 map, two goals, step reward −0.01, η = 0.2."""
        return cls(**{"map_name": "gridworld2", "step_reward": -0.01, "noise": 0.2, **params})

    def _build(self) -> None:
        """Validate the parameters, read the map and precompute the move tables."""
        self.validate_params()
        if not np.isfinite(self.step_reward):
            raise InvalidParameterError(
                f"`GridWorld.step_reward` must be a finite float; got {self.step_reward!r}."
            )
        grid = load_map(self.map_name)
        grid.flags.writeable = False
        rows, cols = grid.shape
        self.grid_ = grid
        start = np.argwhere(grid == START)[0]
        self.start_ = (int(start[0]), int(start[1]))

        feasible = np.zeros((rows, cols, len(MOVES)), dtype=bool)
        next_cell: list[list[int]] = []
        for r in range(rows):
            for c in range(cols):
                targets = []
                for a, (dr, dc) in enumerate(MOVES):
                    nr, nc = r + dr, c + dc
                    if 0 <= nr < rows and 0 <= nc < cols and grid[nr, nc] != BLOCKED:
                        feasible[r, c, a] = True
                        targets.append(nr * cols + nc)
                    else:
                        targets.append(r * cols + c)
                next_cell.append(targets)
        feasible.flags.writeable = False
        self.feasible_moves_ = feasible

        # Per-cell Python lists: the fastest lookups from the step's Python code.
        codes = grid.reshape(-1).tolist()
        self._next_cell = next_cell
        self._feasible = [tuple(np.flatnonzero(f).tolist()) for f in feasible.reshape(-1, 4)]
        self._reward = [
            1.0 if code == GOAL else -1.0 if code == PIT else float(self.step_reward)
            for code in codes
        ]
        self._terminal = [code in (GOAL, PIT) for code in codes]
        self._coords = [(float(i // cols), float(i % cols)) for i in range(rows * cols)]
        self._start_cell = self.start_[0] * cols + self.start_[1]
        self._cell = self._start_cell
        self._noise = float(self.noise)

        low = np.zeros(2, dtype=np.float64)
        high = np.array([rows - 1, cols - 1], dtype=np.float64)
        self.observation_space = spaces.Box(low=low, high=high, dtype=np.float64)
        self.action_space = spaces.Discrete(len(MOVES))
        self.domain_spec = DomainSpec(
            name=f"GridWorld({Path(os.fspath(self.map_name)).stem})",
            low=low,
            high=high,
            is_discrete=[True, True],
            num_actions=len(MOVES),
            discount=float(self.discount),
            max_episode_steps=int(self.max_episode_steps),
        )

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """Start an episode at the map's start cell."""
        super().reset(seed=seed)
        self._cell = self._start_cell
        return np.array(self._coords[self._cell], dtype=np.float64), {}

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        """Move one cell (up, down, left, right); with probability η a random feasible move."""
        a = self.check_action(action)
        cell = self._cell
        if self._noise > 0.0:
            rng = self.np_random
            if rng.random() < self._noise:
                moves = self._feasible[cell]
                if moves:
                    a = moves[int(rng.random() * len(moves))]
        cell = self._next_cell[cell][a]
        self._cell = cell
        obs = np.array(self._coords[cell], dtype=np.float64)
        return obs, self._reward[cell], self._terminal[cell], False, {}
