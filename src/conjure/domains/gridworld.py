"""Noisy grid worlds with pits: GridWorld-1 and GridWorld-2 of Geramifard (2012), Chapter 5."""

from __future__ import annotations

import os
from pathlib import Path
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np
from gymnasium import spaces

from conjure.core.cooperative import NoisyDomain
from conjure.core.errors import InvalidParameterError
from conjure.core.interfaces import DomainSpec
from conjure.core.params import (
    EPISODE_STEPS,
    Constraint,
    InstanceOf,
    Interval,
    Options,
    did_you_mean,
)
from conjure.domains._kernels import GW_COUNT, GW_MOVES, GW_NOISY, gridworld_move
from conjure.domains.compiled_domain import (
    GRIDWORLD,
    DomainKernel,
    GridConstants,
    KeptCompiledForm,
    domain_kernel,
)

if TYPE_CHECKING:  # the model and SciPy load when `model` is first called
    from conjure.models.tabular_model import TabularModel

__all__ = ["GridWorld", "check_grid", "load_map", "open_grid", "shipped_maps"]

MAPS_DIR = Path(__file__).resolve().parent / "maps"

FREE, BLOCKED, START, GOAL, PIT, WINDY = 0, 1, 2, 3, 4, 5
# Actions 0..3: up, down, left, right as (row, column) offsets (RLPy's order).
MOVES = ((-1, 0), (1, 0), (0, -1), (0, 1))
_MOVE_NAMES = ("up", "down", "left", "right")


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
    return check_grid(grid, repr(str(path)))


def check_grid(grid: np.ndarray, where: str = "array") -> np.ndarray:
    """Validate a grid of cell codes 0-5 (one start, at least one goal) and return it as int64.

    Examples
    --------
    >>> check_grid(np.array([[2, 0, 3]])).tolist()
    [[2, 0, 3]]
    """
    grid = np.asarray(grid)
    if grid.ndim != 2 or grid.size == 0 or not np.issubdtype(grid.dtype, np.integer):
        raise InvalidParameterError(
            f"GridWorld map {where} must be a non-empty 2-D integer array of cell codes; got "
            f"shape {grid.shape} and dtype {grid.dtype}."
        )
    grid = grid.astype(np.int64)
    bad = sorted(set(np.unique(grid).tolist()) - {FREE, BLOCKED, START, GOAL, PIT, WINDY})
    if bad:
        raise InvalidParameterError(
            f"GridWorld map {where} has unknown cell codes {bad}; codes are 0 free, "
            f"1 blocked, 2 start, 3 goal, 4 pit, 5 free (windy)."
        )
    num_starts = int(np.count_nonzero(grid == START))
    if num_starts != 1 or not np.any(grid == GOAL):
        raise InvalidParameterError(
            f"GridWorld map {where} needs exactly one start cell (code 2) and at least "
            f"one goal (code 3); it has {num_starts} start(s) and "
            f"{int(np.count_nonzero(grid == GOAL))} goal(s)."
        )
    return grid


def open_grid(rows: int, cols: int, *, blocked_fraction: float = 0.1, seed: int = 0) -> np.ndarray:
    """Return a large random map: start at the top left, goal at the bottom right.

    A fraction of the other cells is blocked and 0.5% are pits (drawn with ``seed``); used
    for the 10⁴-10⁶-state planning benchmarks.

    Examples
    --------
    >>> open_grid(3, 4, blocked_fraction=0.0).tolist()
    [[2, 0, 0, 0], [0, 0, 0, 0], [0, 0, 0, 3]]
    """
    rng = np.random.default_rng(seed)
    u = rng.random((rows, cols))
    grid = np.where(u < blocked_fraction, BLOCKED, FREE).astype(np.int64)
    grid[(u >= blocked_fraction) & (u < blocked_fraction + 0.005)] = PIT
    grid[0, 0], grid[-1, -1] = START, GOAL
    return grid


class GridWorld(KeptCompiledForm, NoisyDomain):
    """Navigate a grid from the start to a goal, avoiding pits, under random wind.

    Geramifard (2012), Section 5.1 (GridWorld-1, Figure 5-1), Section 5.5.1 (GridWorld-2,
    Figure 5-10) and Section 5.5.3 (GridWorld-3, Figure 5-14: noise only in the windy cells).
    Actions are up, down, left, right. With probability η (``noise``) the chosen action is
    replaced by one drawn uniformly from the feasible moves of the current cell ("pushed into
    any unoccupied neighbouring cell"). Entering a goal earns +1 and entering a pit earns −1;
    both end the episode. Every other step earns ``step_reward``. Pits are the constrained
    states of iCCA (`is_constrained`); the step entering one reports ``info["cost"] = 1.0``.

    Parameters
    ----------
    map_name : str, path or ndarray, default="gridworld1"
        A shipped map (``gridworld1`` 10×7, ``gridworld2`` and ``gridworld3`` 5×22, ``4x5``),
        a map file path or a 2-D integer array of cell codes (see `from_grid` and `open_grid`).
    step_reward : float, default=-0.001
        Reward of every step that reaches neither a goal nor a pit; any finite float.
    noise : float, default=0.3
        η, the probability in [0, 1] that the action is replaced by a random feasible move.
    noise_cells : {"all", "windy"}, default="all"
        Where the noise acts: in every cell, or only in the windy cells (code 5; GridWorld-3).
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
    - Choice: code 5 marks the windy cells; they are free cells, and with
      ``noise_cells="windy"`` the only cells where the noise acts.
    - [R] GridWorld-3 (`gridworld_3`, map ``gridworld3``): Figure 5-14 is missing. Section
      5.5.3 needs a world where "passing close to the danger zone is safe" but an agent that
      assumes uniform noise "generalizes the noisy movements to all states including the
      area close to the danger zone", so that AM-iCCA's "risk analyzer filters optimal
      actions suggested by the learner". Reconstruction: GridWorld-2's map with wind in every
      free cell (code 5) except the corridor from beside the danger cell to the right goal
      (row 2, columns 16-21, and (1, 21)), at η = 0.55 instead of the thesis's 20%. Why so
      strong: AM-iCCA's uniform estimate η̂ is the fraction of unintended moves among all
      moves, so a 20% wind can never keep it above Section 5.5.2's 25% switch; the planner
      turns aggressive, and its own actions are never filtered (the earlier reading,
      GridWorld-2's code-5 block windy at 20%, ``gridworld_2(noise_cells="windy")``, left
      every learner at 0.870). Following the conservative policy, 27.2% of the moves are
      unintended at η = 0.55 (24.7% at 0.5), so η̂ stays above 25% and π^p conservative while
      the agent learns on the windy side. Exact targets from `model`
      (tests/domains/test_gridworld.py): the aggressive policy never enters the pit and is
      worth 0.783 (optimum 0.786), the conservative one 0.329; at η̂ = 0.272 the analyser
      (𝓜 = 5, ε = 0.2, rollouts following the conservative π^p) lets the seven steps from
      (2, 16) to the right goal all pass with probability 0.05. The learners' results on it
      are in docs/reproduction/chapter5/fig_5_14_selection.md.
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
        "map_name": InstanceOf(
            (str, os.PathLike, np.ndarray), "a shipped map name, a path or a grid array"
        ),
        "step_reward": Interval(float, None, None),
        "noise": Interval(float, 0.0, 1.0),
        "noise_cells": Options(("all", "windy")),
        "discount": Interval(float, 0.0, 1.0),
        "max_episode_steps": EPISODE_STEPS,
    }

    def __init__(
        self,
        *,
        map_name: str | os.PathLike[str] = "gridworld1",
        step_reward: float = -0.001,
        noise: float = 0.3,
        noise_cells: str = "all",
        discount: float = 1.0,
        max_episode_steps: int = 1000,
    ) -> None:
        self.map_name = map_name
        self.step_reward = step_reward
        self.noise = noise
        self.noise_cells = noise_cells
        self.discount = discount
        self.max_episode_steps = max_episode_steps
        self._build()

    @classmethod
    def from_grid(cls, grid: np.ndarray, **params: Any) -> GridWorld:
        """A grid world on a map given as a 2-D array of cell codes (e.g. `open_grid`)."""
        return cls(map_name=np.asarray(grid, dtype=np.int64), **params)

    @classmethod
    def gridworld_1(cls, **params: Any) -> GridWorld:
        """GridWorld-1 (Section 5.1): 10×7 map, step reward −0.001, η = 0.3."""
        return cls(**{"map_name": "gridworld1", "step_reward": -0.001, "noise": 0.3, **params})

    @classmethod
    def gridworld_2(cls, **params: Any) -> GridWorld:
        """GridWorld-2 (Section 5.5.1): 5×22 map, two goals, step reward −0.01, η = 0.2."""
        return cls(**{"map_name": "gridworld2", "step_reward": -0.01, "noise": 0.2, **params})

    @classmethod
    def gridworld_3(cls, **params: Any) -> GridWorld:
        """GridWorld-3 (Section 5.5.3, Figure 5-14) [R]: GridWorld-2's map, η = 0.55 in windy cells.

        Wind everywhere but the corridor from beside the danger cell to the right goal (Notes).
        """
        return cls.gridworld_2(
            **{"map_name": "gridworld3", "noise": 0.55, "noise_cells": "windy", **params}
        )

    def _build(self) -> None:
        """Validate the parameters, read the map and precompute the move tables."""
        self.validate_params()
        if not np.isfinite(self.step_reward):
            raise InvalidParameterError(
                f"`GridWorld.step_reward` must be a finite float; got {self.step_reward!r}."
            )
        if isinstance(self.map_name, np.ndarray):
            grid = check_grid(self.map_name.copy())
            map_label = f"array {grid.shape[0]}x{grid.shape[1]}"
        else:
            grid = load_map(self.map_name)
            map_label = Path(os.fspath(self.map_name)).stem
        grid.flags.writeable = False
        rows, cols = grid.shape
        self.grid_ = grid
        start = np.argwhere(grid == START)[0]
        self.start_ = (int(start[0]), int(start[1]))

        # Vectorised move tables (maps of 10^6 cells build in about a second).
        r, c = np.indices((rows, cols))
        feasible = np.zeros((rows, cols, len(MOVES)), dtype=bool)
        targets = np.empty((rows, cols, len(MOVES)), dtype=np.int64)
        for a, (dr, dc) in enumerate(MOVES):
            nr, nc = r + dr, c + dc
            inside = (nr >= 0) & (nr < rows) & (nc >= 0) & (nc < cols)
            ok = inside.copy()
            ok[inside] = grid[nr[inside], nc[inside]] != BLOCKED
            feasible[:, :, a] = ok
            targets[:, :, a] = np.where(ok, nr * cols + nc, r * cols + c)
        feasible.flags.writeable = False
        self.feasible_moves_ = feasible
        self._targets = targets.reshape(-1, len(MOVES))

        # Per-cell Python lists: the fastest lookups from the step's Python code.
        codes = grid.reshape(-1)
        flat_feasible = feasible.reshape(-1, len(MOVES))
        self._next_cell = self._targets.tolist()
        self._feasible = [tuple(a for a in range(4) if row[a]) for row in flat_feasible.tolist()]
        reward = np.where(codes == GOAL, 1.0, np.where(codes == PIT, -1.0, self.step_reward))
        self._reward = reward.astype(np.float64).tolist()
        self._terminal = ((codes == GOAL) | (codes == PIT)).tolist()
        self._is_pit = (codes == PIT).tolist()
        self._is_noisy = (
            np.ones(codes.size, dtype=bool) if self.noise_cells == "all" else codes == WINDY
        ).tolist()
        self._move_array = self._move_table(flat_feasible, codes)  # the compiled loop's
        self._moves = self._move_array.tolist()  # the Python step's (faster lookups)
        self._coords = list(
            zip(
                (np.arange(rows * cols) // cols).astype(np.float64).tolist(),
                (np.arange(rows * cols) % cols).astype(np.float64).tolist(),
                strict=True,
            )
        )
        rows_of, cols_of = zip(*self._coords, strict=True)
        self._cell_table = np.column_stack(  # the compiled loop's `cells` (built once)
            [self._reward, self._terminal, self._is_pit, self._is_noisy, rows_of, cols_of]
        )
        self._start_cell = self.start_[0] * cols + self.start_[1]
        self._state = np.array([self._start_cell], dtype=np.int64)  # shared with the form
        self._noise = float(self.noise)

        low = np.zeros(2, dtype=np.float64)
        high = np.array([rows - 1, cols - 1], dtype=np.float64)
        self.observation_space = spaces.Box(low=low, high=high, dtype=np.float64)
        self.action_space = spaces.Discrete(len(MOVES))
        self.domain_spec = DomainSpec(
            name=f"GridWorld({map_label})",
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
        cell = self._next(self._cell, a, self._noise, self.np_random)
        self._cell = cell
        obs = np.array(self._coords[cell], dtype=np.float64)
        cost = 1.0 if self._is_pit[cell] else 0.0
        return obs, self._reward[cell], self._terminal[cell], False, {"cost": cost}

    def _next(self, cell: int, action: int, noise: float, rng: np.random.Generator) -> int:
        """The next cell; with probability ``noise`` (in a noisy cell) a random feasible move."""
        return gridworld_move(self._moves, noise, cell, action, rng)

    def _move_table(self, feasible: np.ndarray, codes: np.ndarray) -> np.ndarray:
        """`gridworld_move`'s table: targets, feasible count, feasible moves, noisy flag."""
        table = np.zeros((codes.size, GW_NOISY + 1), dtype=np.int64)
        table[:, :4] = self._targets
        table[:, GW_COUNT] = feasible.sum(axis=1)
        order = np.argsort(~feasible, axis=1, kind="stable")  # feasible moves first, in order
        table[:, GW_MOVES:GW_NOISY] = np.where(np.sort(~feasible, axis=1), 0, order)
        table[:, GW_NOISY] = self._is_noisy
        return table

    compiled_methods = ("step", "reset", "_next")

    def compiled_form(self) -> DomainKernel:
        """The grid for the compiled loop (layout in `conjure.domains.compiled_domain`).

        `GridConstants` (η, start cell); table `gridworld_move`'s; cells[c] reward, terminal,
        pit, noisy, row, column; state the cell (`KeptCompiledForm`).
        """
        return self._kept_form(
            lambda: domain_kernel(
                GRIDWORLD,
                len(MOVES),
                constants=GridConstants(noise=float(self._noise), start_cell=int(self._start_cell)),
                table=self._move_array,
                cells=self._cell_table,
                state=self._state,
            )
        )

    @property
    def _cell(self) -> int:
        """The current cell, kept in the compiled form's ``state`` (`KeptCompiledForm`)."""
        return int(self._state[0])

    @_cell.setter
    def _cell(self, cell: int) -> None:
        self._state[0] = cell

    def _cell_of(self, state: Any) -> int:
        row, col = (round(float(x)) for x in np.asarray(state).reshape(-1)[:2])
        rows, cols = self.grid_.shape
        if not (0 <= row < rows and 0 <= col < cols) or self.grid_[row, col] == BLOCKED:
            raise InvalidParameterError(
                f"GridWorld: ({row}, {col}) is not a free cell of the {rows}x{cols} map."
            )
        return row * cols + col

    def simulate(
        self, state: np.ndarray, action: int, noise: float, rng: np.random.Generator
    ) -> tuple[np.ndarray, float, bool]:
        """Draw ⟨s', r, terminated⟩ from ``state`` at noise η = ``noise`` (the T̂ of Section 5.5)."""
        cell = self._next(self._cell_of(state), self.check_action(action), noise, rng)
        obs = np.array(self._coords[cell], dtype=np.float64)
        return obs, self._reward[cell], self._terminal[cell]

    def nominal_next_state(self, state: np.ndarray, action: int) -> np.ndarray:
        """The cell the action leads to without wind."""
        cell = self._next_cell[self._cell_of(state)][self.check_action(action)]
        return np.array(self._coords[cell], dtype=np.float64)

    def count_unintended(
        self, state: np.ndarray, action: int, next_state: np.ndarray
    ) -> tuple[int, int]:
        """(1, 1) if the agent did not land where the action leads, else (0, 1).

        Moves from terminal cells, and (with ``noise_cells="windy"``) from calm cells, count
        as no move: the model's form says no noise acts there.
        """
        cell = self._cell_of(state)
        if self._terminal[cell] or not self._is_noisy[cell]:
            return 0, 0
        intended = self._next_cell[cell][self.check_action(action)]
        return int(self._cell_of(next_state) != intended), 1

    def noise_decomposition(self) -> tuple[TabularModel, TabularModel]:
        """(the model at η = 0, the model at η = 1): one wind draw per step makes P linear in η.

        P_η = (1 − η)·P_0 + η·P_1 row by row (calm cells have P_1 = P_0), so T̂ at any η̂ is
        sampled by drawing the wind with probability η̂, then a successor from P_1 or P_0.
        """
        return (
            self.clone().set_params(noise=0.0).model(),
            self.clone().set_params(noise=1.0).model(),
        )

    def return_bounds(self) -> tuple[float, float]:
        """(lowest, highest) return of any episode within the cap T (cuts intervals only).

        An episode of L ≤ T steps earns ``step_reward`` s on each step but a last one that
        enters a goal (+1) or a pit (−1), or T·s when it is cut at the cap: the return lies in
        [min(−1 + min(0, (T−1)s), T·s), max(1 + max(0, (T−1)s), T·s)] (+1 for −1 on a map
        without pits). GridWorld-1 (s = −0.001, T = 1,000): [−1.999, 1].

        Examples
        --------
        >>> GridWorld.gridworld_1().return_bounds()
        (-1.999, 1.0)
        """
        steps, s = int(self.max_episode_steps), float(self.step_reward)
        worst_end = -1.0 if PIT in self.grid_ else 1.0
        lowest = min(worst_end + min(0.0, (steps - 1) * s), steps * s)
        return lowest, max(1.0 + max(0.0, (steps - 1) * s), steps * s)

    def is_constrained(self, state: np.ndarray) -> bool:
        """Whether ``state`` is a pit (the danger zones of Figures 5-1 and 5-10)."""
        return bool(self._is_pit[self._cell_of(state)])

    def describe_action(self, action: int) -> str:
        """Return the action as a move: ``up``, ``down``, ``left`` or ``right``."""
        return _MOVE_NAMES[self.check_action(action)]

    def set_state(self, state: Any) -> None:
        """Put the agent in cell ``state`` = (row, col) (the generative-model hook, Eq. 2.28)."""
        self._cell = self._cell_of(state)

    def model(self) -> TabularModel:
        """Return the exact model: one state per non-blocked cell, goals and pits absorbing.

        P^a_{ss'} = (1 − η_s)·[s' = move(s, a)] + η_s/k·[s' ∈ feasible moves of s] (k of them; a
        cell without feasible moves stays put), R(s, a) = Σ P^a_{ss'} r(s'), built vectorised
        in Θ(|S||A|) (Section 2.3's P and R).
        """
        import scipy.sparse as sp

        from conjure.models.tabular_model import TabularModel

        grid = self.grid_
        rows, cols = grid.shape
        codes = grid.reshape(-1)
        cells = np.flatnonzero(codes != BLOCKED)
        num_states = cells.size
        index = np.full(rows * cols, -1, dtype=np.int64)
        index[cells] = np.arange(num_states)
        terminal = (codes[cells] == GOAL) | (codes[cells] == PIT)
        cell_reward = np.asarray(self._reward)
        targets = self._targets[cells]  # (|S|, 4) cell ids
        feasible = self.feasible_moves_.reshape(-1, len(MOVES))[cells]
        num_feasible = feasible.sum(axis=1)
        eta = float(self.noise) * np.asarray(self._is_noisy, dtype=np.float64)[cells]
        live = np.flatnonzero(~terminal)
        transitions, rewards = [], np.zeros((num_states, len(MOVES)))
        for a in range(len(MOVES)):
            r_parts = [live]
            c_parts = [index[targets[live, a]]]
            p_parts = [1.0 - eta[live]]
            if eta.any():
                has_moves = live[num_feasible[live] > 0]
                stuck = live[num_feasible[live] == 0]
                for m in range(len(MOVES)):
                    chosen = has_moves[feasible[has_moves, m]]
                    r_parts.append(chosen)
                    c_parts.append(index[targets[chosen, m]])
                    p_parts.append(eta[chosen] / num_feasible[chosen])
                r_parts.append(stuck)
                c_parts.append(stuck)
                p_parts.append(eta[stuck])
            absorbing = np.flatnonzero(terminal)
            r_parts.append(absorbing)
            c_parts.append(absorbing)
            p_parts.append(np.ones(absorbing.size))
            row_ids, col_ids = np.concatenate(r_parts), np.concatenate(c_parts)
            probs = np.concatenate(p_parts)
            matrix = sp.csr_matrix((probs, (row_ids, col_ids)), shape=(num_states, num_states))
            matrix.sum_duplicates()
            transitions.append(matrix)
            live_rows = row_ids < num_states
            reward_of = cell_reward[cells[col_ids]] * probs
            reward_of[terminal[row_ids]] = 0.0
            rewards[:, a] = np.bincount(row_ids[live_rows], reward_of[live_rows], num_states)
        states = np.stack([cells // cols, cells % cols], axis=1).astype(np.float64)
        start = np.zeros(num_states)
        start[index[self._start_cell]] = 1.0
        return TabularModel(
            transitions=transitions,
            rewards=rewards,
            is_terminal=terminal,
            discount=float(self.discount),
            states=states,
            start_distribution=start,
            name=self.domain_spec.name,
            spec=self.domain_spec,
        )
