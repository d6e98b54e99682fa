"""A cooperative planner alone, as an `Agent` (the baselines of Geramifard 2012, Section 5.3.5)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from conjure.agents import persistence
from conjure.core.cooperative import CooperativePlanner
from conjure.core.interfaces import Agent, DomainSpec, Transition, check_is_set_up
from conjure.core.params import InstanceOf
from conjure.core.seeding import split_seed
from conjure.models.approximate_model import ApproximateModel
from conjure.safety._control_box import set_up_control_box

__all__ = ["PlannerAgent"]


class PlannerAgent(Agent):
    """Act by π^p alone: the "planner" curves of Figures 5-5, 5-8, 5-12 and 5-13.

    Geramifard (2012), Section 5.3.5: the baseline planners (value iteration on GridWorld-1's
    noise-free model, Figure 5-1b; GridWorld-2's conservative and aggressive policies; the
    conservative and aggressive CBBA of UAV missions) are evaluated like any learner, so
    `conjure run` and `conjure sweep` draw their curves next to the learners'. ``act`` returns
    π^p(s), greedy or not; ``learn`` changes nothing.

    Parameters
    ----------
    planner : CooperativePlanner
        π^p.
    model : ApproximateModel
        The T̂ π^p is planned on (a model of the learning domain's map or graph).

    Attributes
    ----------
    model_, planner_
        The set-up parts.

    Notes
    -----
    - Choice: the model stays as set up (a static planner); η̂ is not re-estimated.

    Complexity
    ----------
    The planner's action per step; nothing to learn.

    Examples
    --------
    >>> from conjure.domains import GridWorld
    >>> from conjure.experiments import run
    >>> from conjure.planners import ModelPlanner
    >>> vi_planner = PlannerAgent(planner=ModelPlanner(),
    ...                           model=ApproximateModel(domain=GridWorld(noise=0.0)))
    >>> result = run(domain=GridWorld(noise=0.0), agent=vi_planner, budget_steps=100, seed=0)
    >>> round(float(result.curve["return"].iloc[-1]), 3)  # 15 moves, the last to the goal
    0.986
    """

    parameter_constraints = {
        "planner": InstanceOf(CooperativePlanner, "a CooperativePlanner"),
        "model": InstanceOf(ApproximateModel, "an ApproximateModel"),
    }
    expected_check_failures = {
        "check_converges_on_chain": "a planner does not learn, and needs a NoisyDomain model",
    }

    def __init__(self, *, planner: CooperativePlanner, model: ApproximateModel):
        self.planner = planner
        self.model = model

    def setup(self, spec: DomainSpec, seed: int | np.random.SeedSequence) -> PlannerAgent:
        """Set up the model, then plan on it."""
        self.validate_params()
        seeds = split_seed(seed, ("model", "planner"))
        self.spec_ = spec
        self.model_, self.planner_, _ = set_up_control_box(spec, seeds, self.model, self.planner)
        self.is_set_up_ = True
        return self

    def begin_episode(self) -> None:
        """Nothing to do."""
        check_is_set_up(self, "begin_episode")

    def act(
        self, state: np.ndarray, greedy: bool = False, legal_actions: np.ndarray | None = None
    ) -> int:
        """π^p(s)."""
        check_is_set_up(self, "act")
        return self.planner_.action(state)

    def learn(self, transition: Transition) -> float:
        """Do nothing; return 0."""
        check_is_set_up(self, "learn")
        return 0.0

    @property
    def num_features(self) -> int:
        """0: a planner has no features."""
        check_is_set_up(self, "num_features")
        return 0

    def save(self, path: str | Path) -> Path:
        """Write the agent's parameters and spec to directory ``path`` (π^p is re-planned)."""
        check_is_set_up(self, "save")
        return persistence.write_agent(path, self, {}, {})

    @classmethod
    def restore(cls, path: str | Path) -> PlannerAgent:
        """Rebuild the agent written by `save` and plan again (with seed 0)."""
        saved = persistence.read(path)
        with saved.loading():
            return persistence.read_agent(cls, saved)
