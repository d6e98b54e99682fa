"""A safety shield for any Gymnasium environment: iCCA's risk filter without the learner."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import gymnasium as gym
import numpy as np

from conjure.core.cooperative import CooperativePlanner, RiskAnalyzer
from conjure.core.errors import InvalidParameterError
from conjure.core.interfaces import Domain
from conjure.core.seeding import split_seed
from conjure.models.approximate_model import ApproximateModel
from conjure.safety._control_box import set_up_control_box

__all__ = ["SafetyShield"]


def _flatten(observation: Any) -> np.ndarray:
    return np.asarray(observation, dtype=np.float64).reshape(-1)


class SafetyShield(gym.Wrapper):
    """Replace unsafe actions by the planner's before they reach the environment.

    Geramifard (2012), Section 5.3.4 and Algorithm 23, lines 4-5, with the learner left
    outside: "if the action is safe, it will be executed ..., otherwise the action is replaced
    with the planner's action, which is assumed to be safe". Any agent, from any library, that
    steps this wrapper explores under iCCA's risk filter. Each step reports
    ``info["shielded"]`` (whether the action was replaced) and ``info["executed_action"]``.

    Parameters
    ----------
    env : gymnasium.Env
        The environment to protect: a conjure domain or any Gymnasium environment.
    model : ApproximateModel
        T̂: a model of ``env`` (for a conjure domain, of its map or graph).
    planner : CooperativePlanner
        The fallback policy π^p.
    risk : RiskAnalyzer
        The ``safe`` test (e.g. `NominalRiskAnalyzer`, `MonteCarloRiskAnalyzer`).
    seed : int, default 0
        Split into the model's, the planner's and the analyser's seeds.
    observation_to_state : callable or None, default None
        Maps an observation of ``env`` to a state of the model's domain; ``None`` flattens it
        to a float64 vector (right for conjure domains).
    action_map : sequence of int or None, default None
        ``action_map[a]`` is the model's action for the environment's action ``a`` (a
        permutation); ``None`` when both number actions alike.

    Attributes
    ----------
    model_, planner_, risk_
        The set-up parts.
    num_shielded_ : int
        Actions replaced so far.

    Notes
    -----
    - Choice: the model is static (η̂ is not re-estimated from the shielded steps); use
      `AdaptiveCooperativeLearner` for Algorithm 26's adaptive model.
    - Choice: the model is checked against ``env``'s `DomainSpec` when ``env`` is a conjure
      domain, and against its own domain's otherwise.

    Examples
    --------
    >>> from conjure.domains import GridWorld
    >>> from conjure.planners import ShortestPathPlanner
    >>> from conjure.safety import NominalRiskAnalyzer
    >>> shield = SafetyShield(GridWorld.gridworld_1(noise=0.0),
    ...                       model=ApproximateModel(domain=GridWorld.gridworld_1(noise=0.0)),
    ...                       planner=ShortestPathPlanner(), risk=NominalRiskAnalyzer())
    >>> _ = shield.reset(seed=0)
    >>> for action in (1, 1):  # down, down: the second would enter the pit at (2, 0)
    ...     observation, reward, terminated, truncated, info = shield.step(action)
    >>> info["shielded"], info["executed_action"], observation.tolist()  # right instead
    (True, 3, [1.0, 1.0])
    """

    def __init__(
        self,
        env: gym.Env,
        *,
        model: ApproximateModel,
        planner: CooperativePlanner,
        risk: RiskAnalyzer,
        seed: int = 0,
        observation_to_state: Callable[[Any], np.ndarray] | None = None,
        action_map: Sequence[int] | None = None,
    ):
        super().__init__(env)
        for name, value, kind in (
            ("model", model, ApproximateModel),
            ("planner", planner, CooperativePlanner),
            ("risk", risk, RiskAnalyzer),
        ):
            if not isinstance(value, kind):
                raise InvalidParameterError(
                    f"`SafetyShield.{name}` must be a {kind.__name__}; got {value!r}."
                )
        inner = env.unwrapped
        spec = inner.domain_spec if isinstance(inner, Domain) else model.domain.domain_spec
        seeds = split_seed(seed, ("model", "planner", "risk"))
        self.model_, self.planner_, self.risk_ = set_up_control_box(
            spec, seeds, model, planner, risk
        )
        self._to_state = _flatten if observation_to_state is None else observation_to_state
        self._to_model, self._to_env = _action_maps(action_map, spec.num_actions)
        self._state: np.ndarray | None = None
        self.num_shielded_ = 0

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[Any, dict[str, Any]]:
        """Reset the environment and remember its state."""
        observation, info = self.env.reset(seed=seed, options=options)
        self._state = self._to_state(observation)
        return observation, info

    def step(self, action: Any) -> tuple[Any, Any, bool, bool, dict[str, Any]]:
        """Execute ``action`` if safe, else the planner's action; report ``info["shielded"]``."""
        if self._state is None:
            raise gym.error.ResetNeeded("SafetyShield.step() was called before reset().")
        proposed = self._to_model[int(action)]
        planner_action = self.planner_.action(self._state)
        is_shielded = not self.risk_.is_safe(self._state, proposed, planner_action=planner_action)
        executed = self._to_env[planner_action] if is_shielded else int(action)
        self.num_shielded_ += int(is_shielded)
        observation, reward, terminated, truncated, info = self.env.step(executed)
        self._state = self._to_state(observation)
        info = {**info, "shielded": is_shielded, "executed_action": executed}
        return observation, reward, terminated, truncated, info


def _action_maps(action_map: Sequence[int] | None, num_actions: int) -> tuple[list, list]:
    """(environment → model, model → environment) action lookups."""
    identity = list(range(num_actions))
    if action_map is None:
        return identity, identity
    mapping = [int(a) for a in action_map]
    if sorted(mapping) != identity:
        raise InvalidParameterError(
            f"`SafetyShield.action_map` must be a permutation of 0..{num_actions - 1}; got "
            f"{list(action_map)!r}."
        )
    inverse = [0] * num_actions
    for env_action, model_action in enumerate(mapping):
        inverse[model_action] = env_action
    return mapping, inverse
