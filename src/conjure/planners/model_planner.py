"""A cooperative planner that runs any planner of the library on T̂ (Geramifard 2012, 5.3.1)."""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np

from conjure.core.cooperative import CooperativePlanner
from conjure.core.errors import IncompatibleComponentsError
from conjure.core.interfaces import check_is_set_up
from conjure.core.params import InstanceOf
from conjure.models.approximate_model import ApproximateModel
from conjure.models.tabular_model import TabularModel
from conjure.planners.base import Plan, Planner
from conjure.planners.value_iteration import ValueIteration

__all__ = ["ModelPlanner", "PlannedPolicy"]


class PlannedPolicy(NamedTuple):
    """A planner's π^p as a table: ``actions[i]`` = π^p(``states[i]``) for every planned state.

    Geramifard (2012), Section 5.3.1: the cooperative planner's policy, here as the compiled
    iCCA box reads it (`conjure.safety.compiled_cooperative`).

    Parameters
    ----------
    states : ndarray of shape (|S|, dims)
        The planned model's states.
    actions : ndarray of int64, shape (|S|,)
        π^p of each.
    is_fixed : bool, default False
        Whether π^p never changes with T̂ (``update`` never replans it), so the table also
        holds while an adaptive model learns (Algorithm 26).
    """

    states: np.ndarray
    actions: np.ndarray
    is_fixed: bool = False


class ModelPlanner(CooperativePlanner):
    """π^p from a planner run on the tabular model of T̂ (Section 5.3.1; Algorithm 2 by default).

    "For small MDPs, given the approximated model, value iteration (i.e., Algorithm 2) is used
    to generate the planner's policy" (Section 5.3.1). The model is the exact (P, R) of the
    model's domain built at the current estimate η̂ (``model.domain_at_noise().model()``);
    GridWorld-1's planner (Figure 5-1b) is value iteration on the noise-free model, i.e. an
    `ApproximateModel` whose noise is 0.

    Parameters
    ----------
    planner : Planner or None, default None
        Any planner of `conjure.planners` that accepts a `TabularModel` (Algorithms 1-9, 13);
        ``None`` means ``ValueIteration()`` (Algorithm 2).

    Attributes
    ----------
    planner_ : Planner
        The planner used.
    plan_ : Plan
        The current plan.
    policy_ : ndarray of int64, shape (|S|,)
        π^p(s) for every state of the planned model.
    planned_noise_ : float
        The η̂ the current plan was made at.

    Notes
    -----
    - Choice: `update` always replans (the learner decides when, Algorithm 26 line 11) and
      reports a change when π^p differs in any state.
    - Choice: the wrapped planner's own parameters fix its randomness; ``setup``'s seed is
      unused.

    Complexity
    ----------
    Planning: the wrapped planner's (Θ(|A||S|k) per value-iteration sweep); acting: Θ(1).

    Examples
    --------
    >>> from conjure.domains import GridWorld
    >>> domain = GridWorld(map_name="4x5", noise=0.0)
    >>> model = ApproximateModel(domain=domain).setup(domain.domain_spec, seed=0)
    >>> planner = ModelPlanner().setup(model, seed=0)
    >>> planner.action(np.array([0.0, 0.0]))  # down: two 7-move paths, the first action wins
    1
    """

    parameter_constraints = {
        "planner": InstanceOf((Planner, type(None)), "a Planner (e.g. ValueIteration) or None"),
    }

    def __init__(self, *, planner: Planner | None = None):
        self.planner = planner

    def setup(self, model: Any, seed: int | np.random.SeedSequence) -> ModelPlanner:
        """Plan on the tabular model of ``model`` at its current η̂."""
        self.validate_params()
        if not isinstance(model, ApproximateModel):
            raise IncompatibleComponentsError(
                f"ModelPlanner plans on an ApproximateModel; got {type(model).__name__}."
            )
        self.planner_ = ValueIteration() if self.planner is None else self.planner.clone()
        self._replan(model)
        self.is_set_up_ = True
        return self

    def _replan(self, model: ApproximateModel) -> None:
        tabular = model.domain_at_noise().model()
        if not isinstance(tabular, TabularModel):
            raise IncompatibleComponentsError(
                f"ModelPlanner needs the exact model of the model's domain, but "
                f"{type(model.domain_).__name__} has no `model()`; use a planner made for it "
                f"(e.g. CBBA for UAV missions)."
            )
        plan: Plan = self.planner_.plan(tabular)
        policy = plan.policy
        if policy is None:  # linear planners: greedy in their Q
            policy = np.array([plan.action(s) for s in tabular.states], dtype=np.int64)
        self.plan_ = plan
        self._model = tabular
        self.policy_ = np.asarray(policy, dtype=np.int64)
        self.planned_noise_ = float(model.noise_)

    compiled_methods = ("action",)

    def compiled_form(self) -> PlannedPolicy:
        """π^p of the current plan over the tabular model's states (a copy of the table)."""
        check_is_set_up(self, "compiled_form")
        return PlannedPolicy(states=self._model.states.copy(), actions=self.policy_.copy())

    def action(self, state: np.ndarray) -> int:
        """π^p(s) of the current plan."""
        check_is_set_up(self, "action")
        return int(self.policy_[self._model.state_index(state)])

    def update(self, model: Any) -> bool:
        """Replan at the model's current η̂; return whether π^p changed in any state."""
        check_is_set_up(self, "update")
        before = self.policy_
        self._replan(model)
        return not np.array_equal(before, self.policy_)
