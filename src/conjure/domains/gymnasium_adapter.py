"""Learn on any Gymnasium environment with a Box/Discrete observation and Discrete actions."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any, ClassVar

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from conjure.core.errors import IncompatibleComponentsError, InvalidParameterError
from conjure.core.interfaces import Domain, DomainSpec
from conjure.core.params import (
    EPISODE_STEPS,
    Constraint,
    InstanceOf,
    Interval,
    Predicate,
    did_you_mean,
)
from conjure.domains.compiled_domain import DomainKernel, callback_kernel

__all__ = ["DEFAULT_BOUNDS", "GymnasiumDomain", "from_gymnasium"]

# Finite bounds for observation dimensions that Gymnasium declares infinite, per env id.
# Entries are (low, high) or None (keep the space's own finite bound).
DEFAULT_BOUNDS: dict[str, tuple[tuple[float, float] | None, ...]] = {
    # CartPole: x, ẋ, θ, θ̇. The space gives ±4.8 and ±0.418 rad; the velocities are infinite.
    "CartPole-v0": (None, (-3.0, 3.0), None, (-3.5, 3.5)),
    "CartPole-v1": (None, (-3.0, 3.0), None, (-3.5, 3.5)),
}


def _is_bounds(value: Any) -> bool:
    if value is None:
        return True
    if isinstance(value, (str, bytes)) or not isinstance(value, Sequence):
        return False
    for entry in value:
        if entry is None:
            continue
        if isinstance(entry, (str, bytes)) or len(entry) != 2:
            return False
        low, high = float(entry[0]), float(entry[1])
        if not (math.isfinite(low) and math.isfinite(high) and low < high):
            return False
    return True


class GymnasiumDomain(Domain):
    """Wrap a Gymnasium environment so that conjure's agents can learn on it.

    Geramifard (2012), Section 2.1: any MDP with a finite action set and a bounded state space
    fits the learners of Chapters 2-4; this adapter adds the `DomainSpec` (finite bounds,
    number of actions, γ, cap) that Gymnasium does not carry. Made for classic-control tasks
    such as ``CartPole-v1``, ``MountainCar-v0`` and ``Acrobot-v1``.

    Parameters
    ----------
    env_id : str
        A registered Gymnasium id (``"CartPole-v1"``); the environment is built with
        ``gymnasium.make(env_id, **env_kwargs)`` and used ``.unwrapped``.
    env_kwargs : dict or None, default=None
        Keyword arguments for ``gymnasium.make``.
    bounds : list of (low, high) or None, default=None
        Finite bounds per observation dimension; an entry may be ``None`` to keep the space's
        own bound. Needed for every dimension the space declares infinite, except where
        `DEFAULT_BOUNDS` has an entry (CartPole velocities: ẋ in [−3, 3], θ̇ in [−3.5, 3.5]).
    discount : float, default=0.99
        γ in [0, 1].
    max_episode_steps : int or None, default=None
        Episode cap in [1, 10^6]; ``None`` takes the registered ``max_episode_steps``.

    Attributes
    ----------
    env_ : gymnasium.Env
        The unwrapped environment.
    domain_spec : DomainSpec
        The bounds (as above), ``is_discrete`` for integer and Discrete observations.

    Notes
    -----
    - Choice: the environment is used ``.unwrapped`` (no ``TimeLimit``, ``OrderEnforcing`` or
      checker wrappers) for speed; the cap comes from the registered spec instead.
    - Choice: observations are flattened to 1-D float64 and clipped into the bounds, so they
      always lie in ``observation_space``; a Discrete observation space becomes one discrete
      dimension in [0, n − 1].
    - Choice: a Discrete action space with ``start ≠ 0`` is shifted to 0 .. n − 1.
    - Choice: ``truncated`` is always False (the wrapped env is unwrapped; the run loop caps).
    - Choice: the step's constraint cost is ``info["cost"]`` (the third value of a 6-value
      safety-gymnasium step, else the environment's own ``info["cost"]``, else 0.0); the run
      counts a step with a positive cost as a failure, as for conjure's domains.
    - Choice: ``reset(seed=...)`` seeds both this domain's ``np_random`` and the wrapped env.

    Examples
    --------
    >>> domain = GymnasiumDomain(env_id="CartPole-v1")
    >>> obs, info = domain.reset(seed=0)
    >>> obs.shape, domain.domain_spec.num_actions, domain.domain_spec.max_episode_steps
    ((4,), 2, 500)
    """

    parameter_constraints: ClassVar[dict[str, Constraint]] = {
        "env_id": InstanceOf(str, "a registered Gymnasium id"),
        "env_kwargs": InstanceOf((dict, type(None)), "a dict or None"),
        "bounds": Predicate(
            _is_bounds, "None or a list with one (low, high) or None per observation dimension"
        ),
        "discount": Interval(float, 0.0, 1.0),
        "max_episode_steps": EPISODE_STEPS | InstanceOf(type(None)),
    }

    def __init__(
        self,
        *,
        env_id: str,
        env_kwargs: dict[str, Any] | None = None,
        bounds: Sequence[tuple[float, float] | None] | None = None,
        discount: float = 0.99,
        max_episode_steps: int | None = None,
    ) -> None:
        self.env_id = env_id
        self.env_kwargs = env_kwargs
        self.bounds = bounds
        self.discount = discount
        self.max_episode_steps = max_episode_steps
        self._build()

    def _build(self, env: gym.Env | None = None) -> None:
        """Validate the parameters, make the environment and derive spaces and spec."""
        self.validate_params()
        if self.env_id not in gym.registry:
            raise InvalidParameterError(
                f"`GymnasiumDomain.env_id` must be a registered Gymnasium id; got "
                f"{self.env_id!r}.{did_you_mean(self.env_id, gym.registry)}"
            )
        if env is None:
            env = gym.make(self.env_id, disable_env_checker=True, **(self.env_kwargs or {}))
        self.env_ = env.unwrapped

        action_space = self.env_.action_space
        if not isinstance(action_space, spaces.Discrete):
            raise IncompatibleComponentsError(
                f"GymnasiumDomain needs a Discrete action space, but {self.env_id!r} has "
                f"{action_space}; conjure's learners pick among finitely many actions. "
                f"Discretise the actions with a wrapper, or choose an environment with "
                f"discrete actions."
            )
        self._action_start = int(action_space.start)
        num_actions = int(action_space.n)

        low, high, is_discrete = self._observation_bounds()
        self._low, self._high = low, high
        self.observation_space = spaces.Box(low=low, high=high, dtype=np.float64)
        self.action_space = spaces.Discrete(num_actions)
        self.domain_spec = DomainSpec(
            name=self.env_id,
            low=low,
            high=high,
            is_discrete=is_discrete,
            num_actions=num_actions,
            discount=float(self.discount),
            max_episode_steps=self._episode_cap(),
        )

    def _observation_bounds(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        space = self.env_.observation_space
        if isinstance(space, spaces.Discrete):
            low = np.array([float(space.start)])
            high = np.array([float(space.start + space.n - 1)])
            is_discrete = np.array([True])
        elif isinstance(space, spaces.Box):
            low = np.asarray(space.low, dtype=np.float64).reshape(-1).copy()
            high = np.asarray(space.high, dtype=np.float64).reshape(-1).copy()
            is_discrete = np.full(low.shape, np.issubdtype(space.dtype, np.integer))
        else:
            raise IncompatibleComponentsError(
                f"GymnasiumDomain needs a Box or Discrete observation space, but "
                f"{self.env_id!r} has {space}; flatten it with "
                f"gymnasium.wrappers.FlattenObservation and register the wrapped env."
            )
        given = self.bounds if self.bounds is not None else DEFAULT_BOUNDS.get(self.env_id)
        if given is not None:
            if len(given) != low.shape[0]:
                raise InvalidParameterError(
                    f"`GymnasiumDomain.bounds` must have one entry per observation dimension "
                    f"({low.shape[0]} for {self.env_id!r}); got {len(given)}."
                )
            for i, entry in enumerate(given):
                if entry is not None:
                    low[i], high[i] = float(entry[0]), float(entry[1])
        infinite = np.flatnonzero(~(np.isfinite(low) & np.isfinite(high))).tolist()
        if infinite:
            raise InvalidParameterError(
                f"{self.env_id!r} declares infinite observation bounds in dimension(s) "
                f"{infinite} (low={low.tolist()}, high={high.tolist()}); pass finite "
                f"`bounds=[(low, high) or None, ...]` with one entry per dimension, e.g. "
                f"from_gymnasium({self.env_id!r}, bounds=[...])."
            )
        return low, high, is_discrete

    def _episode_cap(self) -> int:
        if self.max_episode_steps is not None:
            return int(self.max_episode_steps)
        cap = gym.registry[self.env_id].max_episode_steps
        if cap is None:
            raise InvalidParameterError(
                f"{self.env_id!r} registers no max_episode_steps; pass "
                f"`max_episode_steps=<int>` to GymnasiumDomain."
            )
        return int(cap)

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """Reset the wrapped environment, passing ``seed`` and ``options`` through."""
        super().reset(seed=seed)
        obs, info = self.env_.reset(seed=seed, options=options)
        return self._observe(obs), dict(info)

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        """Step the wrapped environment; ``truncated`` is always False.

        Takes Gymnasium's 5-value step and the 6-value step of safety-gymnasium-style
        environments, (obs, reward, cost, terminated, truncated, info); either way the step's
        cost (0.0 when the environment reports none) is ``info["cost"]``, a finite float ≥ 0.
        """
        a = self.check_action(action) + self._action_start
        result = self.env_.step(a)
        if len(result) == 6:
            obs, reward, cost, terminated, _, info = result
        elif len(result) == 5:
            obs, reward, terminated, _, info = result
            cost = info.get("cost", 0.0)
        else:
            raise IncompatibleComponentsError(
                f"{self.env_id!r}'s step returned {len(result)} values; GymnasiumDomain "
                f"expects (obs, reward, terminated, truncated, info) or (obs, reward, cost, "
                f"terminated, truncated, info)."
            )
        info = dict(info)
        info["cost"] = self._checked_cost(cost)
        return self._observe(obs), float(reward), bool(terminated), False, info

    def _checked_cost(self, cost: Any) -> float:
        try:
            value = float(cost)
        except (TypeError, ValueError):
            value = math.nan
        if not (math.isfinite(value) and value >= 0.0):
            raise IncompatibleComponentsError(
                f"{self.env_id!r} reported the step cost {cost!r}; conjure expects a finite "
                f"number ≥ 0 (a constraint's cost, Section 5.4)."
            )
        return value

    def compiled_form(self) -> DomainKernel:
        """A `CALLBACK` form: the compiled loop calls this domain's own ``reset`` and ``step``.

        The learner's features, action choice and TD update then run compiled around the
        environment (`conjure.domains.compiled_domain.callback_kernel`), one object-mode call
        per step instead of four compiled dispatches and the Python loop.
        """
        return callback_kernel(self)

    def _observe(self, obs: Any) -> np.ndarray:
        flat = np.asarray(obs).astype(np.float64).ravel()  # a copy: clipped in place
        return flat.clip(self._low, self._high, out=flat)

    def close(self) -> None:
        """Close the wrapped environment."""
        self.env_.close()


def from_gymnasium(
    env: str | gym.Env,
    *,
    bounds: Sequence[tuple[float, float] | None] | None = None,
    discount: float = 0.99,
    max_episode_steps: int | None = None,
) -> GymnasiumDomain:
    """Return a `GymnasiumDomain` for a Gymnasium id or a registered environment instance.

    An instance must have been made by ``gymnasium.make`` (it needs ``env.spec``) so that the
    domain can be cloned; its unwrapped environment is reused, and its ``max_episode_steps``
    is the default cap.

    Examples
    --------
    >>> domain = from_gymnasium("MountainCar-v0")
    >>> domain.domain_spec.max_episode_steps
    200
    """
    if isinstance(env, str):
        return GymnasiumDomain(
            env_id=env, bounds=bounds, discount=discount, max_episode_steps=max_episode_steps
        )
    if not isinstance(env, gym.Env):
        raise InvalidParameterError(
            f"from_gymnasium needs a Gymnasium id or a gymnasium.Env; got {env!r}."
        )
    spec = env.spec
    if spec is None or spec.id not in gym.registry:
        raise InvalidParameterError(
            f"from_gymnasium needs an environment made by gymnasium.make (so it can be "
            f"rebuilt from its id), but {env!r} has no registered spec; register it with "
            f"gymnasium.register(id=..., entry_point=...) and pass the id."
        )
    domain = GymnasiumDomain.__new__(GymnasiumDomain)
    domain.env_id = spec.id
    domain.env_kwargs = dict(spec.kwargs) or None
    domain.bounds = bounds
    domain.discount = discount
    # An explicit cap wins; else the instance's own (``gymnasium.make(..., max_episode_steps=)``).
    domain.max_episode_steps = max_episode_steps or spec.max_episode_steps
    domain._build(env)
    return domain
