"""Persistent Surveillance: fuel-limited UAVs watch targets (Geramifard 2012, Section 4.1.4)."""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np
from gymnasium import spaces

from conjure.core.errors import InvalidParameterError
from conjure.core.interfaces import Domain, DomainSpec
from conjure.core.params import EPISODE_STEPS, Constraint, InstanceOf, Interval
from conjure.domains._uav_kernels import (
    NUM_LOCATIONS,
    PSTConstants,
    pst_fill_legal_mask,
    pst_legal_actions,
    pst_num_crashed,
    pst_start,
    pst_step,
)
from conjure.domains.action_masking import ActionMasking
from conjure.domains.compiled_domain import (
    PERSISTENT_SURVEILLANCE,
    DomainKernel,
    KeptCompiledForm,
    domain_kernel,
)

__all__ = ["PersistentSurveillance", "persistent_surveillance_state_action_count"]

_UAV_ACTIONS = ("RETREAT", "LOITER", "ADVANCE")
_FIELDS = ("fuel", "location", "actuator", "sensor")


def persistent_surveillance_state_action_count(num_uavs: int = 3, max_fuel: int = 10) -> int:
    """Return |S × A| = (4 locations · (F + 1) fuels · 2 · 2)^n · 3^n (Section 4.1.4).

    Examples
    --------
    >>> persistent_surveillance_state_action_count()
    147197952
    """
    return (NUM_LOCATIONS * (max_fuel + 1) * 2 * 2) ** num_uavs * 3**num_uavs


class PersistentSurveillance(KeptCompiledForm, ActionMasking, Domain):
    """Keep targets under surveillance with fuel-limited, failure-prone UAVs.

    Geramifard (2012), Section 4.1.4 and Figure 4-3(a) (T:2492-2494); spec section 3.1, after
    RLPy's ``PST``. Each UAV sits at one of four locations on a line, BASE (maintenance) 0,
    REFUEL 1, COMMS 2, SURVEIL 3, and each step RETREATs (−1), LOITERs or ADVANCEs (+1). Every
    action burns one fuel unit except loitering at REFUEL or BASE; loitering at REFUEL refuels
    fully and loitering at BASE repairs both parts. Each step the actuator (motor) and the sensor
    (camera) of every UAV fail independently with probability 0.05. The team earns +20 per
    target reported (a healthy sensor at SURVEIL while a UAV relays from COMMS), −1 per UAV that
    burnt fuel, and −50 per UAV that runs out of fuel outside REFUEL, which ends the episode;
    such a crash is the domain's failure (`is_constrained`, ``info["cost"] = 1.0`` on that step,
    0.0 otherwise). γ = 0.9; episodes are capped at 1000 steps.

    Parameters
    ----------
    num_uavs : int, default=3
        n, the number of UAVs, in [1, 6]; 3^n joint actions and 4n state dimensions.
    num_targets : int, default=2
        Targets; the surveillance reward counts min(num_targets, healthy sensors at SURVEIL).
        In [1, inf). The thesis has 2; RLPy has 1.
    crash_penalty : float, default=50.0
        Penalty (subtracted) when the episode ends by running out of fuel; in [0, inf).
    crash_penalty_per_uav : bool, default=True
        Charge ``crash_penalty`` per UAV out of fuel (thesis) or once (RLPy).
    is_relay_actuator_checked : bool, default=True
        Whether the relaying UAV at COMMS needs a working actuator (thesis default; RLPy's
        docstring says so but its code does not check).
    surveillance_reward : float, default=20.0
        Reward per reported target per step; any finite float.
    fuel_penalty : float, default=1.0
        Penalty per UAV that burnt a fuel unit this step; any finite float.
    failure_probability : float, default=0.05
        Per-step failure probability of each actuator and each sensor, in [0, 1].
    max_fuel : int, default=10
        Full tank F, in [1, 100].
    discount : float, default=0.9
        γ in [0, 1].
    max_episode_steps : int, default=1000
        Episode cap, in [1, inf).
    illegal_action : {"raise", "ignore", "penalize"}, default="raise"
        What an illegal joint action does: raise, or a no-op step with reward 0 or
        −``illegal_action_penalty`` (`conjure.domains.action_masking`).
    illegal_action_penalty : float, default=1.0
        Penalty in [0, inf) of ``illegal_action="penalize"``.

    Attributes
    ----------
    domain_spec : DomainSpec
        4n discrete dimensions, per UAV (fuel ∈ [0, F], location ∈ [0, 3], actuator ∈ {0, 1},
        sensor ∈ {0, 1}); 3^n actions; ``has_action_constraints=True``.

    Notes
    -----
    ======  ==================  ===========================================================
    Symbol  Name                Meaning
    ======  ==================  ===========================================================
    s       obs[4i:4i+4]        UAV i: fuel, location, actuator (1 works), sensor (1 works)
    a       action              Σ_i a_i 3^i, a_i ∈ {0 RETREAT, 1 LOITER, 2 ADVANCE}
    γ       discount            0.9
    ======  ==================  ===========================================================

    - Choice: the thesis's details are fixed by RLPy's ``PST`` (spec 3.1): a line of four
      locations, actions RETREAT/LOITER/ADVANCE, fuel 0..10, start at BASE with full fuel and
      working parts; (4·11·2·2)³·27 = 147,197,952 ≈ 1.5e8 matches the thesis's count.
    - Choice: observation layout grouped per UAV (fuel, location, actuator, sensor), in the
      thesis's order; RLPy groups by field (all locations, then all fuels, ...).
    - Choice: joint action a = Σ_i a_i 3^i (UAV 0 is the least significant digit, as RLPy).
    - Legal actions (RLPy): LOITER needs a working actuator unless at REFUEL or BASE; ADVANCE
      needs fuel > 0, a working actuator and not being at SURVEIL; RETREAT needs fuel > 0 and
      not being at BASE; a UAV with none of these gets a dummy LOITER. Illegal joint actions
      raise `InvalidParameterError` unless ``illegal_action`` says otherwise;
      ``action_space.sample()`` draws only legal ones; ``action_masks()`` and
      ``info["action_mask"]`` give them as a bool mask (`conjure.domains.action_masking`).
    - Step order (RLPy): move; burn fuel unless loitering at REFUEL/BASE; actuator then sensor
      failures (2n uniform draws: all actuators, then all sensors); a UAV that stayed at REFUEL
      gets full fuel; a UAV that stayed at BASE is repaired (after failures, so it leaves BASE
      healthy).
    - Choice: the surveillance reward is computed from the pre-step state (RLPy); fuel and
      crash penalties from the step itself. Terminal: some UAV with fuel 0 outside REFUEL.
    - Choice: thesis defaults for the three thesis/RLPy differences (two targets, −50 per UAV,
      relay actuator checked); `rlpy` builds RLPy's variant.
    - Choice: fuel never goes below 0 (only a terminal state could burn further).

    Complexity: Θ(n + 3^n) per step (one compiled pass: the step, then the new state's
    legal-action mask, which `legal_actions` of the current state reads); Θ(3^n) per
    `legal_actions` of any other state.

    Examples
    --------
    >>> domain = PersistentSurveillance()
    >>> obs, info = domain.reset(seed=0)
    >>> obs[:4].tolist()  # UAV 0: fuel, location, actuator, sensor
    [10.0, 0.0, 1.0, 1.0]
    >>> domain.legal_actions(obs).size  # each UAV: LOITER or ADVANCE at BASE
    8
    >>> domain.step(1 + 3 + 9)[1]  # all loiter at BASE: no fuel, no reward
    0.0
    """

    parameter_constraints: ClassVar[dict[str, Constraint]] = {
        "num_uavs": Interval(int, 1, 6),
        "num_targets": Interval(int, 1, None),
        "crash_penalty": Interval(float, 0.0, None),
        "crash_penalty_per_uav": InstanceOf(bool),
        "is_relay_actuator_checked": InstanceOf(bool),
        "surveillance_reward": Interval(float, None, None),
        "fuel_penalty": Interval(float, None, None),
        "failure_probability": Interval(float, 0.0, 1.0),
        "max_fuel": Interval(int, 1, 100),
        "discount": Interval(float, 0.0, 1.0),
        "max_episode_steps": EPISODE_STEPS,
        **ActionMasking.masking_constraints,
    }

    def __init__(
        self,
        *,
        num_uavs: int = 3,
        num_targets: int = 2,
        crash_penalty: float = 50.0,
        crash_penalty_per_uav: bool = True,
        is_relay_actuator_checked: bool = True,
        surveillance_reward: float = 20.0,
        fuel_penalty: float = 1.0,
        failure_probability: float = 0.05,
        max_fuel: int = 10,
        discount: float = 0.9,
        max_episode_steps: int = 1000,
        illegal_action: str = "raise",
        illegal_action_penalty: float = 1.0,
    ) -> None:
        self.num_uavs = num_uavs
        self.num_targets = num_targets
        self.crash_penalty = crash_penalty
        self.crash_penalty_per_uav = crash_penalty_per_uav
        self.is_relay_actuator_checked = is_relay_actuator_checked
        self.surveillance_reward = surveillance_reward
        self.fuel_penalty = fuel_penalty
        self.failure_probability = failure_probability
        self.max_fuel = max_fuel
        self.discount = discount
        self.max_episode_steps = max_episode_steps
        self.illegal_action = illegal_action
        self.illegal_action_penalty = illegal_action_penalty
        self._build()

    @classmethod
    def rlpy(cls, **params: Any) -> PersistentSurveillance:
        """RLPy's ``PST`` variant: one target, −50 once, relay actuator not checked."""
        rlpy_params = {
            "num_targets": 1,
            "crash_penalty_per_uav": False,
            "is_relay_actuator_checked": False,
        }
        return cls(**{**rlpy_params, **params})

    def _build(self) -> None:
        """Validate the parameters and build the spaces, the spec and the start state."""
        self.validate_params()
        for name in ("crash_penalty", "surveillance_reward", "fuel_penalty"):
            value = getattr(self, name)
            if not np.isfinite(value):
                raise InvalidParameterError(
                    f"`PersistentSurveillance.{name}` must be a finite float; got {value!r}."
                )
        n = int(self.num_uavs)
        self._n = n
        self._num_actions = 3**n
        self._constants = PSTConstants(
            num_uavs=n,
            num_targets=int(self.num_targets),
            max_fuel=int(self.max_fuel),
            failure_probability=float(self.failure_probability),
            surveillance_reward=float(self.surveillance_reward),
            fuel_penalty=float(self.fuel_penalty),
            crash_penalty=float(self.crash_penalty),
            crash_penalty_per_uav=bool(self.crash_penalty_per_uav),
            is_relay_actuator_checked=bool(self.is_relay_actuator_checked),
        )
        low = np.zeros(4 * n, dtype=np.float64)
        high = np.tile(np.array([self.max_fuel, NUM_LOCATIONS - 1, 1, 1], dtype=np.float64), n)
        self.observation_space = spaces.Box(low=low, high=high, dtype=np.float64)
        self.domain_spec = DomainSpec(
            name=f"PersistentSurveillance({n} UAVs)",
            low=low,
            high=high,
            is_discrete=np.ones(4 * n, dtype=bool),
            num_actions=self._num_actions,
            discount=float(self.discount),
            max_episode_steps=int(self.max_episode_steps),
            has_action_constraints=True,
        )
        # the UAVs' state and its legal actions, shared with the compiled form
        self._state = np.empty(4 * self._n, dtype=np.int64)
        self._mask = np.zeros(self._num_actions, dtype=np.int8)
        self._set_start()
        self._set_action_space()

    def _set_start(self) -> None:
        pst_start(self._constants, self._state)  # the compiled loop's reset too
        pst_fill_legal_mask(self._state, self._n, self._mask)

    def state_action_count(self) -> int:
        """Return |S × A| (147,197,952 for the thesis's 3 UAVs), Section 4.1.4."""
        return persistent_surveillance_state_action_count(self._n, int(self.max_fuel))

    compiled_methods = ("step", "reset", "legal_actions")

    def compiled_form(self) -> DomainKernel:
        """The mission for the compiled loop: `pst_step`'s `PSTConstants`, the UAVs' state.

        Kept, with the domain's state and legal-action mask (`KeptCompiledForm`).
        """
        return self._kept_form(
            lambda: domain_kernel(
                PERSISTENT_SURVEILLANCE,
                self._num_actions,
                constants=self._constants,
                state=self._state,
                mask=self._mask,
                num_units=self._n,
                num_uniforms=2 * self._n,
            )
        )

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """Start with every UAV at BASE, full fuel and working parts."""
        super().reset(seed=seed)
        self._set_start()
        return self._state.astype(np.float64), self._with_mask({})

    def _legal_actions_of(self, state: np.ndarray) -> np.ndarray:
        legal, bad = pst_legal_actions(state, self._n, int(self.max_fuel))
        if bad >= 0:
            raise InvalidParameterError(
                f"PersistentSurveillance.legal_actions: dimension {bad} (UAV {bad // 4} "
                f"{_FIELDS[bad % 4]}) must be an integer within its bounds; got {state[bad]!r}."
            )
        return legal

    def _observed_state(self) -> np.ndarray:
        return self._state

    def describe_action(self, action: int) -> str:
        """Return the joint action as per-UAV names, e.g. ``(LOITER, ADVANCE, RETREAT)``."""
        digits = [(int(action) // 3**i) % 3 for i in range(self._n)]
        return "(" + ", ".join(_UAV_ACTIONS[d] for d in digits) + ")"

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        """Apply one joint action: move, burn, fail, refuel, repair; reward as in RLPy."""
        a = self.check_action(action)
        if not self._mask[a]:
            return self._reject(a, "see PersistentSurveillance's notes on legal actions")
        uniforms = self.np_random.random(2 * self._n)
        obs, reward, terminated = pst_step(self._state, a, uniforms, self._constants, self._mask)
        info = {"cost": 1.0 if terminated else 0.0}
        return obs, reward, terminated, False, self._with_mask(info)

    def is_constrained(self, state: np.ndarray) -> bool:
        """Whether a UAV is out of fuel outside REFUEL (the crash that ends the episode)."""
        array = np.asarray(state, dtype=np.float64)
        if array.shape != (4 * self._n,):
            raise InvalidParameterError(
                f"PersistentSurveillance.is_constrained expects a state of shape "
                f"({4 * self._n},); got shape {array.shape}."
            )
        return pst_num_crashed(np.rint(array).astype(np.int64), self._n) > 0
