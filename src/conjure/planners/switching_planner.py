"""AM-iCCA's planner: conservative while the noise is high, aggressive once it is low (5.5.2)."""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np
from numba import njit

from conjure.core.compiled_form import compiled_form
from conjure.core.cooperative import CooperativePlanner
from conjure.core.interfaces import check_is_set_up
from conjure.core.params import InstanceOf, Interval
from conjure.core.seeding import split_seed
from conjure.planners.cbba_planner import MissionPlanner
from conjure.planners.model_planner import PlannedPolicy

__all__ = [
    "PlannerPair",
    "SwitchingPlanner",
    "active_planner",
    "fixed_pair",
    "is_calm",
    "switch_by_noise",
]


class PlannerPair(NamedTuple):
    """A switching π^p as a compiled kernel reads it (Section 5.5.2).

    Parameters
    ----------
    conservative, aggressive : MissionPlanner or ndarray
        The two planners' forms: CBBA's (`MissionPlanner`), or π^p tabulated per state (an
        array of int64 actions, made by the compiled iCCA box from `PlannedPolicy` forms).
    noise_threshold : float
        The aggressive one is used while η̂ < ``noise_threshold``.
    is_aggressive : ndarray of bool, shape (1,)
        Which one is in use, updated in place (`switch_by_noise`).
    is_switching : bool
        False for a single planner (`fixed_pair`): it never switches.
    """

    conservative: MissionPlanner
    aggressive: MissionPlanner
    noise_threshold: float
    is_aggressive: np.ndarray
    is_switching: bool


def fixed_pair(planner: MissionPlanner) -> PlannerPair:
    """One planner as a `PlannerPair` that never switches."""
    return PlannerPair(
        conservative=planner,
        aggressive=planner,
        noise_threshold=0.0,
        is_aggressive=np.zeros(1, dtype=np.bool_),
        is_switching=False,
    )


@njit(cache=True, inline="always")
def active_planner(pair: PlannerPair) -> MissionPlanner:
    """The planner in use."""
    return pair.aggressive if pair.is_aggressive[0] else pair.conservative


def is_calm(noise: float, noise_threshold: float) -> bool:
    """The switch (Section 5.5.2): the aggressive planner is in use while η̂ < threshold.

    One source for `SwitchingPlanner.update` and, compiled, `switch_by_noise`.
    """
    return noise < noise_threshold


_is_calm = njit(cache=True, inline="always")(is_calm)


@njit(cache=True)
def switch_by_noise(pair: PlannerPair, noise: float) -> bool:
    """`SwitchingPlanner.update` for planners that never replan: whether π^p changed."""
    if not pair.is_switching:
        return False
    was_aggressive = pair.is_aggressive[0]
    pair.is_aggressive[0] = _is_calm(noise, pair.noise_threshold)
    return pair.is_aggressive[0] != was_aggressive


class SwitchingPlanner(CooperativePlanner):
    """π^p = the aggressive planner's policy if η̂ < threshold, else the conservative one's.

    Geramifard (2012), Section 5.5.2 and Algorithm 26, lines 10-14: "the planner switched from
    the conservative to the aggressive policy (Figure 5-10-c), whenever the noise estimate
    dropped below 25%" in GridWorld-2, and from conservative to aggressive CBBA (Algorithm 27)
    in the UAV 7-2 mission. `update` re-reads η̂ from the model: a switch changes π^p, so the
    cooperative learner resets its knownness counts (Algorithm 26, line 14).

    Parameters
    ----------
    conservative : CooperativePlanner
        The planner for a noisy world (GridWorld-2: `ShortestPathPlanner.conservative`).
    aggressive : CooperativePlanner
        The planner for a calm world (GridWorld-2: `ShortestPathPlanner.aggressive`).
    noise_threshold : float, default 0.25
        Use the aggressive planner while η̂ < ``noise_threshold``; a float in [0, 1].

    Attributes
    ----------
    conservative_, aggressive_ : CooperativePlanner
        The set-up planners.
    is_aggressive_ : bool
        Whether the aggressive planner is in use.
    switch_ : ndarray of bool, shape (1,)
        The same, as the array the compiled form (`PlannerPair`) shares.

    Notes
    -----
    - Choice: the switch is a function of η̂ at the last update, so it also switches back if
      η̂ rises above the threshold again; the thesis only describes the downward switch.
    - Choice: strictly below the threshold (the thesis: "dropped below 25%"; RLPy's
      ``TwoGoals_Policy.m`` used ≤).
    - Choice: only the planner in use is updated (replanning the other is wasted work); a
      planner becoming active is updated first, so it plans at the current η̂.

    Complexity
    ----------
    That of the planner in use.

    Examples
    --------
    >>> from conjure.domains import GridWorld
    >>> from conjure.models.approximate_model import ApproximateModel
    >>> from conjure.planners import ShortestPathPlanner
    >>> domain = GridWorld.gridworld_2()
    >>> model = ApproximateModel(domain=domain, initial_noise=0.4, is_adaptive=True)
    >>> model = model.setup(domain.domain_spec, seed=0)
    >>> planner = SwitchingPlanner(conservative=ShortestPathPlanner.conservative(),
    ...                            aggressive=ShortestPathPlanner.aggressive())
    >>> planner.setup(model, seed=0).is_aggressive_
    False
    >>> model.load_counts(num_unintended=0, num_moves=61)  # η̂ = 40 / 161 < 0.25
    >>> planner.update(model), planner.is_aggressive_
    (True, True)
    """

    parameter_constraints = {
        "conservative": InstanceOf(CooperativePlanner, "a CooperativePlanner"),
        "aggressive": InstanceOf(CooperativePlanner, "a CooperativePlanner"),
        "noise_threshold": Interval(float, 0.0, 1.0),
    }

    def __init__(
        self,
        *,
        conservative: CooperativePlanner,
        aggressive: CooperativePlanner,
        noise_threshold: float = 0.25,
    ):
        self.conservative = conservative
        self.aggressive = aggressive
        self.noise_threshold = noise_threshold

    def setup(self, model: Any, seed: int | np.random.SeedSequence) -> SwitchingPlanner:
        """Set up both planners on ``model`` and pick one by its η̂."""
        self.validate_params()
        seeds = split_seed(seed, ("conservative", "aggressive"))
        self.conservative_ = self.conservative.clone().setup(model, seeds["conservative"])
        self.aggressive_ = self.aggressive.clone().setup(model, seeds["aggressive"])
        self.switch_ = np.array([is_calm(model.noise_, self.noise_threshold)], dtype=np.bool_)
        self.is_set_up_ = True
        return self

    @property
    def is_aggressive_(self) -> bool:
        """Whether the aggressive planner is in use (``switch_[0]``)."""
        return bool(self.switch_[0])

    @is_aggressive_.setter
    def is_aggressive_(self, is_aggressive: bool) -> None:
        self.switch_[0] = is_aggressive

    compiled_methods = ("action", "update")

    def compiled_form(self) -> PlannerPair | None:
        """Both planners' forms, or None.

        Both CBBA's (`MissionPlanner`), or both tables that never change with T̂ (a
        `PlannedPolicy` with ``is_fixed``: `ShortestPathPlanner`); a planner that replans as
        η̂ moves has no compiled switch. ``is_aggressive`` is the planner's own ``switch_``
        (a kernel's `switch_by_noise` switches it in place).
        """
        check_is_set_up(self, "compiled_form")
        forms = compiled_form(self.conservative_), compiled_form(self.aggressive_)
        is_cbba = all(isinstance(form, MissionPlanner) for form in forms)
        is_table = all(isinstance(form, PlannedPolicy) and form.is_fixed for form in forms)
        if not (is_cbba or is_table):
            return None
        return PlannerPair(
            conservative=forms[0],
            aggressive=forms[1],
            noise_threshold=float(self.noise_threshold),
            is_aggressive=self.switch_,
            is_switching=True,
        )

    def _active(self) -> CooperativePlanner:
        return self.aggressive_ if self.is_aggressive_ else self.conservative_

    def action(self, state: np.ndarray) -> int:
        """π^p(s) of the planner in use."""
        check_is_set_up(self, "action")
        return self._active().action(state)

    def update(self, model: Any) -> bool:
        """Switch by the model's η̂ and update the planner in use; return whether π^p changed."""
        check_is_set_up(self, "update")
        was_aggressive = self.is_aggressive_
        self.is_aggressive_ = is_calm(float(model.noise_), self.noise_threshold)
        changed = self._active().update(model)
        return changed or self.is_aggressive_ != was_aggressive
