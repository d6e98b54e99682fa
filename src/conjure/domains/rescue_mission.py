"""Rescue Mission: a medic UAV and a relay UAV save victims (Geramifard 2012, Section 4.1.4)."""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np
from gymnasium import spaces

from conjure.core.errors import InvalidParameterError
from conjure.core.interfaces import Domain, DomainSpec
from conjure.core.params import Constraint, Interval
from conjure.domains._uav_kernels import (
    COMM_SLOTS,
    MEDIC_SLOTS,
    rescue_fill_legal_mask,
    rescue_is_failed,
    rescue_legal_actions,
    rescue_step,
)
from conjure.domains.action_masking import ActionMasking
from conjure.domains.compiled_domain import (
    RESCUE,
    DomainKernel,
    KeptCompiledForm,
    MissionConstants,
    domain_kernel,
)

__all__ = ["RescueMission", "rescue_mission_state_action_count"]

# [R] The reconstructed graph (spec 3.2), nodes 0..7 = thesis nodes 1..8, base 0.
EDGES = ((0, 1), (0, 2), (1, 3), (2, 3), (2, 4), (3, 5), (4, 6), (5, 7), (6, 7))
NUM_NODES = 8
# [R] Victims and rescue success probability per node (node 0, the base, has none); 23 people.
PEOPLE = (0, 2, 3, 1, 5, 4, 6, 2)
SUCCESS = (0.0, 0.9, 0.8, 0.7, 0.6, 0.8, 0.5, 0.9)
NUM_ACTIONS = MEDIC_SLOTS * COMM_SLOTS  # 20
_MEDIC_NAMES = ("hover", "move to neighbour 1", "move to neighbour 2", "move to neighbour 3")
_COMM_NAMES = (
    "hover",
    "perch",
    "move to neighbour 1",
    "move to neighbour 2",
    "move to neighbour 3",
)


def rescue_mission_state_action_count(max_fuel: int = 10, horizon: int = 10) -> int:
    """Return |S × A| = N² (F + 1)² · 2 · 2^(N−1) · H · 20 (spec 3.2; 3.96e8 by default).

    Examples
    --------
    >>> rescue_mission_state_action_count()
    396492800
    """
    return NUM_NODES**2 * (max_fuel + 1) ** 2 * 2 * 2 ** (NUM_NODES - 1) * horizon * NUM_ACTIONS


def _graph_tables() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    neighbours = np.full((NUM_NODES, 3), -1, dtype=np.int64)
    degrees = np.zeros(NUM_NODES, dtype=np.int64)
    is_near = np.eye(NUM_NODES, dtype=np.bool_)
    for u, v in EDGES:
        for x, y in ((u, v), (v, u)):
            neighbours[x, degrees[x]] = y
            degrees[x] += 1
            is_near[x, y] = True
    for x in range(NUM_NODES):  # neighbour slots in increasing node order
        neighbours[x, : degrees[x]] = np.sort(neighbours[x, : degrees[x]])
    return neighbours, degrees, is_near


class RescueMission(KeptCompiledForm, ActionMasking, Domain):
    """Fly a medic UAV to victims while a communication UAV stays within one edge to relay.

    Geramifard (2012), Section 4.1.4, Figure 4-3(b) and footnote 3 (T:2500-2502, T:3097);
    spec section 3.2. The figure's graph and numbers are lost, so the graph, victims and
    probabilities here are the spec's reconstruction [R]. Both UAVs start at the base (node 0)
    with 10 fuel. Each step the medic hovers or moves along an edge; the communication UAV
    hovers, perches or moves. When the medic is at an unrescued node and the communication UAV
    is at most one edge away, all its victims are saved with the node's success probability
    (+1 per person). Every fuel unit costs −0.1; being away from the base when t reaches 10, or
    a UAV running out of fuel away from the base, costs −23 and ends the episode. That failure
    is the domain's constrained state (`is_constrained`; ``info["cost"] = 1.0`` on the failing
    step, 0.0 otherwise). γ = 1.

    Parameters
    ----------
    max_fuel : int, default=10
        Initial (and maximum) fuel F of each UAV, in [1, 100].
    horizon : int, default=10
        Mission length H in steps, in [1, 1000]; the episode ends when t reaches H.
    fuel_penalty : float, default=0.1
        Penalty per fuel unit burnt; any finite float.
    failure_penalty : float, default=23.0
        Penalty for a crash or for not being home at the horizon, in [0, inf).
    illegal_action : {"raise", "ignore", "penalize"}, default="raise"
        What an illegal joint action does: raise, or a no-op step with reward 0 or
        −``illegal_action_penalty`` (`conjure.domains.action_masking`).
    illegal_action_penalty : float, default=1.0
        Penalty in [0, inf) of ``illegal_action="penalize"``.

    Attributes
    ----------
    neighbours_ : ndarray of int64, shape (8, 3)
        Neighbours of each node in increasing order, padded with −1 (read-only).
    domain_spec : DomainSpec
        13 discrete dimensions (see Notes), 20 actions, γ = 1, cap H,
        ``has_action_constraints=True``.

    Notes
    -----
    ========  ===========  ========================================================
    Symbol    Name         Meaning
    ========  ===========  ========================================================
    s         obs[0:2]     medic node (0..7), medic fuel (0..F)
              obs[2:5]     comm node, comm fuel, comm mode (0 flying, 1 perched)
              obs[5:12]    rescued bit of nodes 1..7 (thesis nodes 2..8)
    t         obs[12]      time step, 0..H (H only in the final observation)
    a         action       medic slot × 5 + comm slot
    γ         discount     1.0
    ========  ===========  ========================================================

    - [R] Graph (thesis numbering 1..8, base 1): edges 1-2, 1-3, 2-4, 3-4, 3-5, 4-6, 5-7, 6-8,
      7-8 (maximum degree 3). Code numbers nodes 0..7.
    - [R] Victims (people, success probability) at thesis nodes 2..8: (2, 0.9), (3, 0.8),
      (1, 0.7), (5, 0.6), (4, 0.8), (6, 0.5), (2, 0.9); 23 people in total, which is why the
      failure penalty is −23 (inferred by analogy with the UAV crash penalty).
    - [R] Size: 8² · 11² · 2 · 2⁷ · 10 · 20 = 3.96e8 state-action pairs (thesis: "exceeded
      200 million"), from `state_action_count`.
    - Choice: fixed joint-action index space of 20 = 4 medic slots × 5 comm slots. Medic slots:
      0 hover, 1..3 move to the 1st..3rd neighbour (increasing node number). Comm slots: 0 hover,
      1 perch, 2..4 move to the 1st..3rd neighbour. A slot beyond the node's degree, a move
      without fuel, or a move of a perched comm UAV ("a perched UAV must hover before moving")
      is illegal; illegal actions raise `InvalidParameterError` unless ``illegal_action`` says
      otherwise; ``action_masks()`` and ``info["action_mask"]`` give the legal ones as a bool
      mask (`conjure.domains.action_masking`).
    - Choice: no fuel burn while hovering at the base; a hovering comm UAV burns 1 elsewhere;
      perching is free; every move burns 1. Fuel never goes below 0.
    - Choice: the comm UAV starts flying (mode 0). Its mode does not affect relaying.
    - Choice: the rescue condition is checked after both UAVs move; one uniform draw per step
      (used only when the condition holds) decides success.
    - Choice: the −23 is charged once even if a crash and the deadline coincide; the episode
      ends (terminated, not truncated) at t = H or on a crash. t is part of the state.

    Complexity: Θ(20) per step (one compiled pass: the step, then the new state's legal-action
    mask, which `legal_actions` of the current state reads); Θ(20) per `legal_actions` of any
    other state.

    Examples
    --------
    >>> domain = RescueMission()
    >>> obs, info = domain.reset(seed=0)
    >>> obs[:5].tolist()
    [0.0, 10.0, 0.0, 10.0, 0.0]
    >>> domain.step(0 * 5 + 1)[1]  # medic hovers at base, comm perches: free
    0.0
    """

    parameter_constraints: ClassVar[dict[str, Constraint]] = {
        "max_fuel": Interval(int, 1, 100),
        "horizon": Interval(int, 1, 1000),
        "fuel_penalty": Interval(float, None, None),
        "failure_penalty": Interval(float, 0.0, None),
        **ActionMasking.masking_constraints,
    }

    def __init__(
        self,
        *,
        max_fuel: int = 10,
        horizon: int = 10,
        fuel_penalty: float = 0.1,
        failure_penalty: float = 23.0,
        illegal_action: str = "raise",
        illegal_action_penalty: float = 1.0,
    ) -> None:
        self.max_fuel = max_fuel
        self.horizon = horizon
        self.fuel_penalty = fuel_penalty
        self.failure_penalty = failure_penalty
        self.illegal_action = illegal_action
        self.illegal_action_penalty = illegal_action_penalty
        self._build()

    def _build(self) -> None:
        """Validate the parameters and build the graph tables, spaces, spec and start state."""
        self.validate_params()
        for name in ("fuel_penalty", "failure_penalty"):
            value = getattr(self, name)
            if not np.isfinite(value):
                raise InvalidParameterError(
                    f"`RescueMission.{name}` must be a finite float; got {value!r}."
                )
        neighbours, degrees, is_near = _graph_tables()
        for table in (neighbours, degrees, is_near):
            table.flags.writeable = False
        self.neighbours_ = neighbours
        self._degrees = degrees
        self._is_near = is_near
        self._people = np.array(PEOPLE, dtype=np.float64)
        self._success = np.array(SUCCESS, dtype=np.float64)
        fuel, horizon = int(self.max_fuel), int(self.horizon)
        num_bits = NUM_NODES - 1
        high = np.array(
            [NUM_NODES - 1, fuel, NUM_NODES - 1, fuel, 1] + [1] * num_bits + [horizon],
            dtype=np.float64,
        )
        low = np.zeros_like(high)
        self._high = high
        self._scalars = (horizon, float(self.fuel_penalty), float(self.failure_penalty))
        self.observation_space = spaces.Box(low=low, high=high, dtype=np.float64)
        self.domain_spec = DomainSpec(
            name="RescueMission",
            low=low,
            high=high,
            is_discrete=np.ones(high.shape[0], dtype=bool),
            num_actions=NUM_ACTIONS,
            discount=1.0,
            max_episode_steps=horizon,
            has_action_constraints=True,
        )
        # the state and its legal actions, shared with the compiled form
        self._state = np.empty(5 + NUM_NODES, dtype=np.int64)
        self._mask = np.zeros(NUM_ACTIONS, dtype=np.int8)
        self._set_start()
        self._set_action_space()

    def _start_state(self) -> np.ndarray:
        """s₀: both UAVs at the base with full fuel, the comm UAV flying, nothing rescued, t = 0."""
        fuel = int(self.max_fuel)
        state = np.zeros(5 + NUM_NODES, dtype=np.int64)
        state[1] = fuel
        state[3] = fuel
        return state

    def _set_start(self) -> None:
        state = self._state
        state[:] = self._start_state()
        rescue_fill_legal_mask(state, self.neighbours_, self._degrees, self._mask)

    def state_action_count(self) -> int:
        """Return |S × A| of the reconstruction (3.96e8 by default), Section 4.1.4."""
        return rescue_mission_state_action_count(int(self.max_fuel), int(self.horizon))

    compiled_methods = ("step", "reset", "legal_actions")

    def compiled_form(self) -> DomainKernel:
        """The mission for the compiled loop (`rescue_step`).

        `MissionConstants` (s₀, horizon, fuel penalty, failure penalty); table the neighbours
        and degree of each node; cells the one-edge-away table, the people and the success
        probability; the domain's state and legal-action mask (`KeptCompiledForm`).
        """
        return self._kept_form(self._build_compiled_form)

    def _build_compiled_form(self) -> DomainKernel:
        horizon, fuel_penalty, failure_penalty = self._scalars
        start = np.asarray(self._start_state(), dtype=np.int64)
        constants = MissionConstants(
            start=start,
            horizon=int(horizon),
            fuel_penalty=fuel_penalty,
            failure_penalty=failure_penalty,
            traverse_failure=0.0,
        )
        return domain_kernel(
            RESCUE,
            NUM_ACTIONS,
            constants=constants,
            table=np.column_stack([self.neighbours_, self._degrees]),
            cells=np.column_stack([self._is_near, self._people, self._success]),
            state=self._state,
            mask=self._mask,
        )

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """Start with both UAVs at the base, full fuel, the comm UAV flying, t = 0."""
        super().reset(seed=seed)
        self._set_start()
        return self._state.astype(np.float64), self._with_mask({})

    def _legal_actions_of(self, state: np.ndarray) -> np.ndarray:
        legal, bad = rescue_legal_actions(state, self._high, self.neighbours_, self._degrees)
        if bad >= 0:
            raise InvalidParameterError(
                f"RescueMission.legal_actions: dimension {bad} must be an integer in "
                f"[0, {self._high[bad]:g}]; got {state[bad]!r}."
            )
        return legal

    def _observed_state(self) -> np.ndarray:
        return self._state

    @staticmethod
    def describe_action(action: int) -> str:
        """Return the joint action in words, e.g. ``medic: hover, comm: perch``."""
        medic, comm = divmod(int(action), COMM_SLOTS)
        return f"medic: {_MEDIC_NAMES[medic]}, comm: {_COMM_NAMES[comm]}"

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        """Move both UAVs, try the rescue at the medic's node, charge fuel and failures."""
        a = self.check_action(action)
        if not self._mask[a]:
            return self._reject(
                a, "a slot within the node's degree, fuel to move, a perched UAV hovers first"
            )
        obs, reward, terminated, failed = rescue_step(
            self._state,
            a,
            self.np_random.random(),
            self.neighbours_,
            self._degrees,
            self._is_near,
            self._people,
            self._success,
            *self._scalars,
            self._mask,
        )
        return obs, reward, terminated, False, self._with_mask({"cost": 1.0 if failed else 0.0})

    def is_constrained(self, state: np.ndarray) -> bool:
        """Whether ``state`` is a failure: a UAV out of fuel, or away from the base at t = H."""
        array = np.asarray(state, dtype=np.float64)
        if array.shape != self._high.shape:
            raise InvalidParameterError(
                f"RescueMission.is_constrained expects a state of shape {self._high.shape}; "
                f"got shape {array.shape}."
            )
        return bool(rescue_is_failed(np.rint(array).astype(np.int64), int(self.horizon)))
