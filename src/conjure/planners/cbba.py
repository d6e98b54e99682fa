"""The consensus-based bundle algorithm, CBBA (Choi, Brunet & How 2009; thesis Section 5.3.1).

CBBA assigns tasks to agents by rounds of two phases. In Phase 1 each agent greedily builds a
*bundle*: it adds the task with the best marginal score (over insertion positions in its
path) as long as its bid beats the winning bid it knows. In Phase 2 neighbours exchange
winning bids y, winners z and time-stamps s, and each receiver updates, resets or leaves its
beliefs by the 17 cases of the paper's Table I; an agent outbid on a task then *releases* it
and every task it added later. With a score of diminishing marginal gain and a connected
network CBBA converges to a conflict-free assignment, the one sequential greedy would pick.

The thesis uses CBBA as a black box on the deterministic (expected-value) model of a UAV
mission (Section 5.3.1); `conjure.planners.cbba_planner.CBBAPlanner` maps a mission state onto
the generic problem solved here.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from conjure.core.errors import InvalidParameterError
from conjure.core.params import Configurable, InstanceOf, Interval
from conjure.planners._cbba_kernels import NONE, run_cbba

__all__ = ["CBBA", "Allocation", "default_max_rounds"]


@dataclass(frozen=True, eq=False)
class Allocation:
    """CBBA's result: bundles, paths and planned times of every agent (Section 5.3.1).

    Parameters
    ----------
    bundles : tuple of ndarray of int64
        b_i: the tasks of agent i in the order it added them.
    paths : tuple of ndarray of int64
        p_i: the same tasks in the order agent i executes them.
    arrivals : tuple of ndarray of float64
        The planned arrival time at each task of p_i, leaving at ``departures[i]``.
    departures : ndarray of float64, shape (n,)
        When each agent sets off (later than now only for an agent waiting at the base).
    returns : ndarray of float64, shape (n,)
        When each agent is back at the base.
    bids : ndarray of float64, shape (n, m)
        y_i: the winning bid of each task as agent i believes it.
    winners : ndarray of int64, shape (n, m)
        z_i: the winner of each task as agent i believes it (-1: nobody).
    rounds : int
        Communication rounds run.
    converged : bool
        Whether no agent placed a new bid for more than n rounds before ``max_rounds``.
    """

    bundles: tuple[np.ndarray, ...]
    paths: tuple[np.ndarray, ...]
    arrivals: tuple[np.ndarray, ...]
    departures: np.ndarray
    returns: np.ndarray
    bids: np.ndarray
    winners: np.ndarray
    rounds: int
    converged: bool

    @classmethod
    def from_kernel(cls, result: tuple) -> Allocation:
        """Wrap the tuple `run_cbba` returns."""
        bundles, lengths, paths, arrivals, departures, returns, bids, winners, rounds, done = result
        rows = range(lengths.shape[0])
        return cls(
            bundles=tuple(bundles[i, : lengths[i]].copy() for i in rows),
            paths=tuple(paths[i, : lengths[i]].copy() for i in rows),
            arrivals=tuple(arrivals[i, : lengths[i]].copy() for i in rows),
            departures=departures,
            returns=returns,
            bids=bids,
            winners=winners,
            rounds=int(rounds),
            converged=bool(done),
        )

    @property
    def num_agents(self) -> int:
        """n, the number of agents."""
        return len(self.paths)

    @property
    def fuel_used(self) -> np.ndarray:
        """Fuel each agent burns on its path: return time − departure time."""
        return self.returns - self.departures

    @property
    def assignment(self) -> np.ndarray:
        """The agent whose path holds each task (-1: unassigned; the last agent on a conflict)."""
        out = np.full(self.winners.shape[1], NONE, dtype=np.int64)
        for agent, path in enumerate(self.paths):
            out[path] = agent
        return out

    @property
    def is_conflict_free(self) -> bool:
        """Whether no task is in two agents' paths."""
        tasks = np.concatenate([np.asarray(p, dtype=np.int64) for p in self.paths])
        return bool(np.unique(tasks).size == tasks.size)


def default_max_rounds(num_agents: int, num_tasks: int, max_bundle: int, diameter: int) -> int:
    """Twice the rounds CBBA needs with a DMG score: min(N_t, N_u L_t)·D, plus N_u + 1 quiet ones.

    Examples
    --------
    >>> default_max_rounds(2, 3, 3, 1)
    12
    """
    return 2 * (min(num_tasks, num_agents * max_bundle) * max(diameter, 1) + num_agents + 1)


class CBBA(Configurable):
    """The consensus-based bundle algorithm (Choi, Brunet & How 2009), Section 5.3.1's planner.

    ``allocate`` assigns tasks (a location, a value and a time window each) to agents (a
    location and a fuel each) who must come back to a base by a horizon; travel times are a
    distance matrix between locations. Agent i's path p scores
    S_i(p) = Σ_j value_j·exp(−λ(arrival_j − start_j)) − ρ·d(location_i, location_j) when it is
    feasible, and CBBA maximises Σ_i S_i(p_i) with each task done at most once.

    Parameters
    ----------
    max_bundle_size : int or None, default None
        L_t >= 1, the most tasks one agent takes; ``None``: no limit.
    time_discount : float, default 0.0
        λ >= 0 (finite): value decays as exp(−λ·lateness) after the window opens (the ACL
        code's time-window score); 0 scores every feasible visit at its full value.
    fuel_weight : float, default 0.0
        ρ >= 0 (finite): the cost per unit of distance from the agent's current location to
        the task (the ACL code's constant fuel penalty, which keeps marginal gains diminishing).
    max_rounds : int or None, default None
        >= 1, the rounds after which CBBA gives up (``converged`` is then False); ``None``:
        `default_max_rounds` for the problem.

    Notes
    -----
    Symbols: y_i winning bids, z_i winners, s_i time-stamps, b_i bundle, p_i path, c_ij
    marginal score, n_ij its best insertion position, L_t the bundle limit.

    Phase 1 (bundle construction, each agent): while |b_i| < L_t, c_ij = max over insertion
    positions of S_i(p_i ⊕ j) − S_i(p_i), skipping infeasible positions (a window missed, the
    base reached after the horizon, more fuel burnt than the agent has); h_ij = [c_ij > y_ij
    or (c_ij = y_ij and i < z_ij)]; J = argmax c_ij h_ij, stopping when it is <= 0; append J to
    b_i, insert it into p_i at n_iJ, y_iJ = c_iJ, z_iJ = i.

    Phase 2 (consensus): each receiver i applies Table I (update, reset or leave; 17 cases) to
    every task of every neighbour's message, then sets s_ik to the round for a neighbour k and
    s_im = max(s_im, s_km) for the others. Bundle release then drops the first task of b_i
    that i no longer wins and all tasks after it.

    - Choice: feasibility and time. A task is reached at max(window start, previous arrival
      + travel) (waiting allowed) and must be reached by its window end; the first leg takes
      at least ``min_first_leg``. An agent at the base departs as late as its return time
      allows, since loitering at the base burns no fuel (thesis Section 5.3.5); elsewhere it
      departs at once. Fuel burnt = return time − departure time.
    - Choice: ties. Equal bids go to the lower agent index, in Phase 1 and in every bid
      comparison of Table I; equal marginal scores of one agent go to the task whose window
      opens first, then to the lower task index; equal insertions to the least fuel burnt,
      then the earliest return, then the earliest position.
    - Choice: the Table I case (sender thinks m, receiver thinks n) resets when n is newer and
      m is not, following the paraphrase of ``domains-and-icca`` spec section 1.4.
    - Choice: bundle release resets the later tasks i still believes it wins; a later task i
      already knows another agent won keeps that information.
    - Choice: rounds are synchronous; a receiver reads its neighbours' beliefs as they were at
      the start of the round and processes them in increasing index, raising its time-stamps
      after each message. Converged: no new bid for more than n rounds (the ACL driver).

    Complexity: each round Θ(n·L_t·m·L_t²) for Phase 1 and Θ(n²·m) for Phase 2.

    Examples
    --------
    Two agents at location 0 of a line 0-1-2-3, tasks at 1 and 3 worth 10 and 20:

    >>> line = np.abs(np.subtract.outer(np.arange(4), np.arange(4))).astype(float)
    >>> allocation = CBBA().allocate(
    ...     distances=line, agent_locations=[0, 0], agent_fuel=[6, 2],
    ...     task_locations=[1, 3], task_values=[10.0, 20.0])
    >>> [p.tolist() for p in allocation.paths], allocation.converged
    ([[0, 1], []], True)
    """

    parameter_constraints = {
        "max_bundle_size": Interval(int, 1, None) | InstanceOf(type(None)),
        "time_discount": Interval(float, 0.0, math.inf, closed="left"),
        "fuel_weight": Interval(float, 0.0, math.inf, closed="left"),
        "max_rounds": Interval(int, 1, None) | InstanceOf(type(None)),
    }

    def __init__(
        self,
        *,
        max_bundle_size: int | None = None,
        time_discount: float = 0.0,
        fuel_weight: float = 0.0,
        max_rounds: int | None = None,
    ):
        self.max_bundle_size = max_bundle_size
        self.time_discount = time_discount
        self.fuel_weight = fuel_weight
        self.max_rounds = max_rounds

    def allocate(
        self,
        *,
        distances: Any,
        agent_locations: Sequence[int],
        agent_fuel: Sequence[float],
        task_locations: Sequence[int],
        task_values: Sequence[float],
        task_windows: Any = None,
        base: int = 0,
        time: float = 0.0,
        horizon: float = math.inf,
        communication: Any = None,
        min_first_leg: float = 0.0,
    ) -> Allocation:
        """Run CBBA and return the `Allocation`.

        Parameters
        ----------
        distances : array of float, shape (L, L)
            Travel time between locations (finite, >= 0).
        agent_locations : sequence of int
            Each agent's location in [0, L); n = its length >= 1.
        agent_fuel : sequence of float
            Each agent's fuel (>= 0), one unit burnt per unit of time away from the base.
        task_locations : sequence of int
            Each task's location in [0, L).
        task_values : sequence of float
            Each task's value (finite).
        task_windows : array of float, shape (m, 2), or None
            Each task's [start, end] (start <= end); ``None``: [time, inf) (λ then discounts
            from now, as the ACL code's score without windows).
        base : int, default 0
            The location every agent returns to.
        time : float, default 0.0
            The current time.
        horizon : float, default inf
            Every agent must be back at the base by then.
        communication : array of bool, shape (n, n), or None
            ``communication[k, i]``: agent k's messages reach agent i; ``None``: every pair.
        min_first_leg : float, default 0.0
            The least time to reach the first task (1 when an agent standing on a task must
            spend a step to serve it again).
        """
        self.validate_params()
        problem = _check_problem(
            distances, agent_locations, agent_fuel, task_locations, task_values, task_windows,
            base, time, horizon, communication, min_first_leg,
        )  # fmt: skip
        distances, agents, tasks, adjacency = problem
        n, m = agents.shape[0], tasks.shape[0]
        max_bundle = m if self.max_bundle_size is None else min(self.max_bundle_size, m)
        rounds = self.max_rounds
        if rounds is None:
            rounds = default_max_rounds(n, m, max_bundle, _diameter(adjacency))
        settings = np.array([min_first_leg, self.time_discount, self.fuel_weight], dtype=float)
        result = run_cbba(
            distances, agents, tasks, adjacency, int(base), float(time), float(horizon),
            settings, max_bundle, rounds,
        )  # fmt: skip
        return Allocation.from_kernel(result)


# ----------------------------------------------------------------------------- validation


def _fail(name: str, expected: str, value: Any) -> InvalidParameterError:
    return InvalidParameterError(
        f"`CBBA.allocate` argument `{name}` must be {expected}; got {value!r}."
    )


def _vector(name: str, value: Any, length: int | None = None) -> np.ndarray:
    try:
        array = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise _fail(name, "a sequence of numbers", value) from exc
    if array.ndim != 1 or (length is not None and array.shape[0] != length):
        size = "a sequence" if length is None else f"a sequence of {length} numbers"
        raise _fail(name, size, value)
    if not np.all(np.isfinite(array)):
        raise _fail(name, "finite", value)
    return array


def _locations(name: str, value: Any, num_locations: int, length: int | None = None) -> np.ndarray:
    array = _vector(name, value, length)
    if not np.all((array == np.floor(array)) & (array >= 0) & (array < num_locations)):
        raise _fail(name, f"locations (ints in [0, {num_locations - 1}])", value)
    return array


def _check_problem(
    distances: Any,
    agent_locations: Any,
    agent_fuel: Any,
    task_locations: Any,
    task_values: Any,
    task_windows: Any,
    base: Any,
    time: Any,
    horizon: Any,
    communication: Any,
    min_first_leg: Any,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    for name, value in (("time", time), ("min_first_leg", min_first_leg)):
        if not (isinstance(value, (int, float, np.number)) and math.isfinite(value)):
            raise _fail(name, "a finite number", value)
    if min_first_leg < 0:
        raise _fail("min_first_leg", ">= 0", min_first_leg)
    if not isinstance(horizon, (int, float, np.number)) or math.isnan(horizon):
        raise _fail("horizon", "a number (inf for none)", horizon)
    matrix = np.asarray(distances, dtype=np.float64)
    if matrix.ndim != 2 or matrix.shape[0] != matrix.shape[1] or matrix.shape[0] == 0:
        raise _fail("distances", "a square (L, L) matrix", distances)
    if not (np.all(np.isfinite(matrix)) and np.all(matrix >= 0)):
        raise _fail("distances", "finite and >= 0", distances)
    num_locations = matrix.shape[0]
    locations = _locations("agent_locations", agent_locations, num_locations)
    n = locations.shape[0]
    if n == 0:
        raise _fail("agent_locations", "at least one agent", agent_locations)
    fuel = _vector("agent_fuel", agent_fuel, n)
    if np.any(fuel < 0):
        raise _fail("agent_fuel", ">= 0", agent_fuel)
    if not (isinstance(base, (int, np.integer)) and 0 <= base < num_locations):
        raise _fail("base", f"a location in [0, {num_locations - 1}]", base)
    task_nodes = _locations("task_locations", task_locations, num_locations)
    m = task_nodes.shape[0]
    values = _vector("task_values", task_values, m)
    if task_windows is None:
        windows = np.tile([float(time), math.inf], (m, 1))
    else:
        windows = np.asarray(task_windows, dtype=np.float64)
        if windows.shape != (m, 2) or np.any(np.isnan(windows)):
            raise _fail("task_windows", f"an ({m}, 2) array of [start, end]", task_windows)
        if np.any(windows[:, 0] > windows[:, 1]):
            raise _fail("task_windows", "[start, end] with start <= end", task_windows)
    if communication is None:
        adjacency = np.ones((n, n), dtype=np.bool_)
    else:
        adjacency = np.asarray(communication)
        if adjacency.shape != (n, n) or adjacency.dtype != np.bool_:
            raise _fail("communication", f"an ({n}, {n}) bool matrix", communication)
    agents = np.column_stack([locations, fuel])
    tasks = np.column_stack([task_nodes, values, windows])
    return np.ascontiguousarray(matrix), agents, tasks.reshape(m, 4), adjacency.copy()


def _diameter(adjacency: np.ndarray) -> int:
    """The communication graph's diameter in hops (n when some message never arrives)."""
    n = adjacency.shape[0]
    reach = adjacency | np.eye(n, dtype=bool)
    known = np.eye(n, dtype=bool)
    for hops in range(n):
        if known.all():
            return hops
        known = (known.astype(int) @ reach.astype(int)) > 0
    return n
