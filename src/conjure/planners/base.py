"""What every planner returns and shares: `Plan`, `Planner` and `PlanAgent` (Section 2.2).

A planner takes a model, never a domain (STYLE §2), and returns a `Plan`: a policy and a value
function (V or Q, as a table over the model's states or as weights over a representation's
features), with the iterations it took and the wall time it spent. ``plan.as_agent()`` turns
it into an `Agent` the experiment loop can evaluate.
"""

from __future__ import annotations

import time
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from conjure.core.errors import IncompatibleComponentsError, InvalidParameterError
from conjure.core.interfaces import Agent, Domain, DomainSpec, Representation, check_is_set_up
from conjure.core.params import Configurable, InstanceOf
from conjure.models.generative import GenerativeModel, generative_model
from conjure.models.tabular_model import TabularModel

__all__ = ["Plan", "PlanAgent", "Planner"]


@dataclass(eq=False)
class Plan:
    """A planner's result: policy π and value function V or Q (Section 2.2, Figure 2-1).

    Tables follow the conventions of `TabularModel` (Notes): ``q_values[s, a]`` is Q(s, a),
    V and Q are 0 in terminal states and ``policy`` is 0 there.

    Parameters
    ----------
    planner : str
        The planner's repr.
    spec : DomainSpec
        The spec of the planned model.
    iterations : int
        Iterations of the planner's main loop.
    wall_time_s : float
        Seconds spent planning.
    model : TabularModel or None
        The model planned on (``None`` for purely generative planning).
    policy : ndarray of int64, shape (|S|,), or None
        π(s) per model state (0 in terminal states).
    values : ndarray, shape (|S|,), or None
        V(s) per model state (V of the returned policy's evaluation, or the optimal V).
    q_values : ndarray, shape (|S|, |A|), or None
        Q(s, a) per model state, for planners that compute Q.
    representation : Representation or None
        φ of the linear planners (set up).
    weights : ndarray, shape (n, |A|) or (n,), or None
        θ of the linear planners (columns per action for Q; a vector for V).
    history : list of float
        A per-iteration convergence trace (max change of V, policy changes, ...).
    """

    planner: str
    spec: DomainSpec
    iterations: int
    wall_time_s: float
    model: TabularModel | None = None
    policy: np.ndarray | None = None
    values: np.ndarray | None = None
    q_values: np.ndarray | None = None
    representation: Representation | None = None
    weights: np.ndarray | None = None
    history: list[float] = field(default_factory=list)

    def state_values(self) -> np.ndarray:
        """V(s) for every model state (from Q's max when only Q is known)."""
        if self.values is not None:
            return self.values
        if self.q_values is not None:
            return self.q_values.max(axis=1)
        raise InvalidParameterError("This plan has no model, so no table of state values.")

    def action_values(self, state: Any) -> np.ndarray | None:
        """Q(s, ·) from the table or the linear weights, or ``None`` if the plan has no Q."""
        if self.q_values is not None and self.model is not None:
            return self.q_values[self.model.state_index(state)]
        if self.representation is not None and self.weights is not None and self.weights.ndim == 2:
            return self.representation.encode(np.asarray(state, float)).dot(self.weights)
        return None

    def action(self, state: Any) -> int:
        """π(s): the plan's (greedy) action."""
        if self.policy is not None and self.model is not None:
            return int(self.policy[self.model.state_index(state)])
        q = self.action_values(state)
        if q is None:
            raise InvalidParameterError("This plan holds no policy.")
        return int(np.argmax(q))

    def value(self, state: Any) -> float:
        """V(s) of one state."""
        if self.model is not None and (self.values is not None or self.q_values is not None):
            return float(self.state_values()[self.model.state_index(state)])
        q = self.action_values(state)
        if q is None:
            raise InvalidParameterError("This plan holds no value function.")
        return float(q.max())

    def start_value(self) -> float:
        """V(s₀) averaged over the model's start distribution."""
        if self.model is None:
            raise InvalidParameterError("This plan has no model, so no start distribution.")
        return float(self.model.start_distribution @ self.state_values())

    def as_agent(self) -> PlanAgent:
        """Return an `Agent` that acts greedily from this plan (``learn`` is a no-op)."""
        return PlanAgent(plan=self)


class PlanAgent(Agent):
    """An agent acting from a `Plan` (Section 2.2's policy π, Eq. 2.2), for the experiment loop.

    Parameters
    ----------
    plan : Plan
        The plan to follow; ``act`` returns π(s) whether greedy or not, ``learn`` does nothing.

    Notes
    -----
    - Choice: a plan is re-made by planning, so ``save`` and ``restore`` are not supported.
    """

    parameter_constraints = {"plan": InstanceOf(Plan, "a Plan")}
    expected_check_failures = {
        "check_save_restore_continues": "a plan is re-made by planning, not restored",
        "check_converges_on_chain": "a plan does not learn",
    }

    def __init__(self, *, plan: Plan):
        self.plan = plan

    def setup(self, spec: DomainSpec, seed: int | np.random.SeedSequence) -> PlanAgent:
        """Check the plan fits ``spec`` and return ``self``."""
        self.validate_params()
        if spec.num_actions != self.plan.spec.num_actions:
            raise IncompatibleComponentsError(
                f"The plan was made for {self.plan.spec.num_actions} actions "
                f"({self.plan.spec.name}) but the domain {spec.name} has {spec.num_actions}."
            )
        self.spec_ = spec
        self.is_set_up_ = True
        return self

    def begin_episode(self) -> None:
        """Nothing to do."""

    def act(
        self, state: np.ndarray, greedy: bool = False, legal_actions: np.ndarray | None = None
    ) -> int:
        """Return π(s) (the best legal action when the domain constrains actions)."""
        check_is_set_up(self, "act")
        if legal_actions is not None:
            q = self.plan.action_values(state)
            if q is not None:
                legal = np.asarray(legal_actions)
                return int(legal[np.argmax(q[legal])])
        return self.plan.action(state)

    def learn(self, transition: Any) -> float:
        """Do nothing (a plan is fixed); return 0."""
        check_is_set_up(self, "learn")
        return 0.0

    @property
    def num_features(self) -> int:
        """States in the plan's table, or features of its representation."""
        if self.plan.representation is not None:
            return int(self.plan.representation.num_features_)
        return 0 if self.plan.model is None else self.plan.model.num_states

    def save(self, path: str | Path) -> Path:
        raise IncompatibleComponentsError(
            "PlanAgent cannot be saved: re-run the planner (its config identifies the plan)."
        )

    @classmethod
    def restore(cls, path: str | Path) -> PlanAgent:
        raise IncompatibleComponentsError("PlanAgent cannot be restored; re-run the planner.")


class Iterations:
    """A planner's main loop: counts its iterations and records their convergence trace.

    Every planner of Section 2.2 loops "while time left" or until π stops changing; the
    count becomes `Plan.iterations` and one recorded number per iteration `Plan.history`.

    Parameters
    ----------
    max_iterations : int
        Cap on the loop, at least 1.

    Examples
    --------
    >>> loop = Iterations(10)
    >>> for _ in loop:
    ...     if loop.record(1.0 / loop.count) < 0.3:
    ...         break
    >>> loop.count, loop.history
    (4, [1.0, 0.5, 0.3333333333333333, 0.25])
    """

    def __init__(self, max_iterations: int):
        self.max_iterations = max_iterations
        self.count = 0
        self.history: list[float] = []

    def __iter__(self) -> Iterator[int]:
        for iteration in range(1, self.max_iterations + 1):
            self.count = iteration
            yield iteration

    def record(self, change: float) -> float:
        """Append ``change`` (max |Δ|, policy changes, ...) to the trace and return it."""
        self.history.append(float(change))
        return self.history[-1]

    def plan(self, spec: DomainSpec, **results: Any) -> Plan:
        """Return the `Plan` of this loop (``Planner.plan`` fills its name and wall time)."""
        return Plan(
            planner="",
            spec=spec,
            iterations=self.count,
            wall_time_s=0.0,
            history=self.history,
            **results,
        )


class Planner(Configurable):
    """Base of the planners (Algorithms 1-9, 13): ``plan(model) -> Plan``; not used directly."""

    #: Whether the planner only needs a generative model (Algorithms 6, 8, 9, 13).
    is_sampled = False

    def plan(self, model: TabularModel | Any) -> Plan:
        """Plan on ``model`` and return a `Plan`."""
        self.validate_params()
        started = time.perf_counter()
        plan = self._plan(model)
        plan.wall_time_s = time.perf_counter() - started
        plan.planner = repr(self)
        return plan

    def _plan(self, model: Any) -> Plan:
        raise NotImplementedError

    def _tabular(self, source: Any) -> TabularModel:
        """Return the exact model of ``source`` (a model, or a domain with ``model()``)."""
        if isinstance(source, TabularModel):
            return source
        if isinstance(source, Domain):
            model = source.model()
            if isinstance(model, TabularModel):
                return model
            raise IncompatibleComponentsError(
                f"{type(self).__name__} needs `domain.model()`, but {type(source).__name__} has "
                f"no tabular model; use a sampled planner (Alg 6, 8, 9 or 13) or discretise."
            )
        raise IncompatibleComponentsError(
            f"{type(self).__name__}.plan needs a TabularModel; got {type(source).__name__}."
        )

    def _generative(self, source: Any) -> tuple[GenerativeModel, TabularModel | None]:
        """Return a generative model of ``source`` and its exact model when there is one."""
        model = source if isinstance(source, TabularModel) else None
        if isinstance(source, Domain) and not callable(getattr(source, "set_state", None)):
            model = self._tabular(source)
            return generative_model(model), model
        return generative_model(source), model
