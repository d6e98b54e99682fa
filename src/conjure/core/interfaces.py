"""The core interfaces: Domain, Representation, Policy, Agent, and the records they exchange.

Names follow Geramifard (2012): φ(s) ``active_features`` (Eq. 2.11 builds φ(s, a) from it),
θ ``weights``, δ ``td_error``, γ ``discount``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, ClassVar, NamedTuple

import gymnasium as gym
import numpy as np

from conjure.core.errors import InvalidParameterError, NotSetUpError
from conjure.core.params import Configurable

__all__ = [
    "Agent",
    "Domain",
    "DomainSpec",
    "Expansion",
    "Policy",
    "Representation",
    "Transition",
    "check_is_set_up",
]


# ---------------------------------------------------------------------------------------------
# Records


@dataclass(frozen=True, eq=False)
class DomainSpec:
    """What learners and planners need to know about a domain, beyond its Gymnasium spaces.

    Attributes
    ----------
    name : str
        The domain's name (``InvertedPendulum``).
    low, high : ndarray of float, shape (d,)
        Finite per-dimension state bounds; representations discretise within them.
    is_discrete : ndarray of bool, shape (d,)
        Which dimensions take only integer values ``low .. high``.
    num_actions : int
        |A|; actions are ``0 .. num_actions - 1``.
    discount : float
        γ in [0, 1].
    max_episode_steps : int
        The episode cap (the run loop truncates there).
    has_action_constraints : bool
        Whether some actions are illegal in some states (see `Domain.legal_actions`).
    """

    name: str
    low: np.ndarray
    high: np.ndarray
    is_discrete: np.ndarray
    num_actions: int
    discount: float
    max_episode_steps: int
    has_action_constraints: bool = False

    def __post_init__(self) -> None:
        low = np.asarray(self.low, dtype=np.float64).reshape(-1)
        high = np.asarray(self.high, dtype=np.float64).reshape(-1)
        is_discrete = np.asarray(self.is_discrete, dtype=bool).reshape(-1)
        if not (low.shape == high.shape == is_discrete.shape):
            raise InvalidParameterError(
                f"DomainSpec {self.name!r}: low, high and is_discrete must have one entry per "
                f"dimension; got shapes {low.shape}, {high.shape}, {is_discrete.shape}."
            )
        if not (np.all(np.isfinite(low)) and np.all(np.isfinite(high)) and np.all(low <= high)):
            raise InvalidParameterError(
                f"DomainSpec {self.name!r}: state bounds must be finite with low <= high; "
                f"got low={low.tolist()}, high={high.tolist()}."
            )
        if not (0.0 <= self.discount <= 1.0):
            raise InvalidParameterError(
                f"DomainSpec {self.name!r}: discount must be in [0, 1]; got {self.discount!r}."
            )
        for name, value in (("low", low), ("high", high), ("is_discrete", is_discrete)):
            value.flags.writeable = False
            object.__setattr__(self, name, value)

    @property
    def num_dims(self) -> int:
        """Number of state dimensions d."""
        return int(self.low.shape[0])

    def to_dict(self) -> dict[str, Any]:
        """Return a JSON-able dict (the inverse of :meth:`from_dict`)."""
        return {
            "name": self.name,
            "low": self.low.tolist(),
            "high": self.high.tolist(),
            "is_discrete": self.is_discrete.tolist(),
            "num_actions": int(self.num_actions),
            "discount": float(self.discount),
            "max_episode_steps": int(self.max_episode_steps),
            "has_action_constraints": bool(self.has_action_constraints),
        }

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> DomainSpec:
        """Build a spec from :meth:`to_dict`'s output."""
        return cls(**data)


class Transition(NamedTuple):
    """One interaction ⟨s, a, r, s', a'⟩ (Algorithm 11, line 4) shared by every online learner.

    ``next_action`` is the action the agent chose for ``next_state`` (SARSA's a'); Q-Learning
    ignores it. ``next_legal_actions`` lists the legal actions of s' when the domain constrains
    them (``None`` means every action).
    """

    state: np.ndarray
    action: int
    reward: float
    next_state: np.ndarray
    next_action: int
    terminated: bool
    next_legal_actions: np.ndarray | None = None


@dataclass(frozen=True)
class Expansion:
    """Features an adaptive representation added in one step (Algorithms 20-22).

    New features are numbered ``first_new .. first_new + len(parents) - 1``; row i of
    ``parents`` holds the two existing features g, h whose conjunction is new feature i, so
    learners set θ_i = θ_g + θ_h (Section 4.1.1). A parent of −1 contributes nothing: a split
    tile (adaptive tile coding) lists (t, −1) to copy θ_t, a new prototype (−1, −1) starts at
    zero. A parent may be a feature added earlier in the same expansion. Features are never
    removed: a representation that retires a feature simply stops activating it.
    """

    first_new: int
    parents: np.ndarray = field(default_factory=lambda: np.empty((0, 2), dtype=np.int64))

    @property
    def num_new(self) -> int:
        """Number of features added."""
        return int(self.parents.shape[0])


def check_is_set_up(component: Any, method: str) -> None:
    """Raise `NotSetUpError` unless ``component.setup`` has run."""
    if not getattr(component, "is_set_up_", False):
        raise NotSetUpError(
            f"{type(component).__name__}.{method}() was called before setup(); "
            f"call {type(component).__name__}.setup(spec, seed) first."
        )


# ---------------------------------------------------------------------------------------------
# Domain


class Domain(gym.Env, Configurable):
    """A conjure domain: a `gymnasium.Env` that also describes itself to learners and planners.

    Subclasses build ``observation_space``, ``action_space`` and ``domain_spec`` in ``_build``,
    which their constructor calls (Gymnasium's ``make`` and wrappers need the spaces at once,
    so domains validate at construction, unlike other components) and which `set_params`
    calls again; every random number comes from ``self.np_random``, seeded by
    ``reset(seed=...)``.

    Notes
    -----
    - Choice: the spec is ``domain_spec``, not ``spec``: Gymnasium's ``make`` writes its own
      ``EnvSpec`` into ``env.spec``.
    - Choice: a domain does not truncate at its cap by itself; the run loop and Gymnasium's
      ``TimeLimit`` (added by ``gymnasium.make``) do, from ``domain_spec.max_episode_steps``.
    """

    metadata: ClassVar[dict[str, Any]] = {"render_modes": []}
    domain_spec: DomainSpec

    def _build(self) -> None:
        """Validate the parameters and build the spaces and ``domain_spec`` from them."""
        raise NotImplementedError

    def set_params(self, **params: Any) -> Domain:
        """Set parameters, then rebuild the spaces and spec from them."""
        super().set_params(**params)
        self._build()
        return self

    def legal_actions(self, state: np.ndarray) -> np.ndarray:
        """Return the sorted legal actions of ``state`` (every action unless constrained)."""
        return np.arange(self.domain_spec.num_actions, dtype=np.int64)

    def model(self) -> Any | None:
        """Return the exact tabular (P, R) model, or ``None`` if the domain has none."""
        return None

    def is_constrained(self, state: np.ndarray) -> bool:
        """Whether ``state`` is a failure the learner must not reach (constrained(s), Alg. 25).

        Safety-relevant domains return True for crash, pit or fall states and mark the step that
        enters one with ``info["cost"] = 1.0`` (0.0 otherwise); the default is False.
        """
        return False

    def value_bounds(self) -> tuple[float, float] | None:
        """Return (worst, best) expected return from the start over all policies, if known.

        Domains that can solve themselves exactly (UAV 7-2 by backward induction) return the
        values "optimality" is scaled between (Figure 5-6b); the default is ``None``.
        """
        return None

    def check_action(self, action: Any) -> int:
        """Return ``action`` as an int, or raise a clear error if it is not a valid action."""
        n = self.domain_spec.num_actions
        try:
            as_int = int(action)
        except (TypeError, ValueError):
            as_int = -1
        if as_int != action or not 0 <= as_int < n:
            raise InvalidParameterError(
                f"{type(self).__name__}.step: action must be an int in [0, {n - 1}]; "
                f"got {action!r}."
            )
        return as_int


# ---------------------------------------------------------------------------------------------
# Representation


class Representation(Configurable):
    """Maps a state to features φ(s); Q(s, ·) = θᵀφ(s) with θ of shape (n_features, |A|).

    Binary representations (``is_binary = True``) return the indices of the active features as
    a sorted int64 array from `active_features` (the sparse φ(s) of Eq. 2.11, per action via
    the weight column). Dense ones (Gaussian RBF) return all feature values from
    `feature_values`. A representation never owns weights.

    Adaptive representations (``is_adaptive = True``) implement `discover`, returning an
    `Expansion`; learners then grow their weights (θ_f = θ_g + θ_h, Section 4.1.1).
    """

    is_binary: ClassVar[bool] = True
    is_adaptive: ClassVar[bool] = False

    def setup(self, spec: DomainSpec, seed: int | np.random.SeedSequence) -> Representation:
        """Validate parameters, build the feature tables for ``spec`` and return ``self``."""
        raise NotImplementedError

    def active_features(self, state: np.ndarray) -> np.ndarray:
        """Return the sorted indices of the active binary features of ``state``."""
        raise NotImplementedError

    def feature_values(self, state: np.ndarray) -> np.ndarray:
        """Return the dense feature vector φ(s) of length ``num_features_``."""
        check_is_set_up(self, "feature_values")
        phi = np.zeros(self.num_features_, dtype=np.float64)
        phi[self.active_features(state)] = 1.0
        return phi

    def discover(
        self, active: np.ndarray, td_error: float, state: np.ndarray | None = None
    ) -> Expansion | None:
        """Update relevances from one TD error and return new features, if any (Alg 20-22).

        ``active`` is the φ(s) the learner just updated with δ = ``td_error``; ``state`` is s
        itself, for representations that split the state space (ARiFDD, adaptive tile coding).
        """
        return None

    def check_state(self, state: Any) -> np.ndarray:
        """Return ``state`` as a float64 vector of the set-up dimension, or raise clearly.

        A float64 vector of the right length is returned as it is (the hot path: one type and
        one shape test).
        """
        if (
            type(state) is np.ndarray
            and state.dtype == np.float64
            and state.shape == self.spec_.low.shape
        ):
            return state
        array = np.asarray(state, dtype=np.float64)
        if array.ndim != 1 or array.shape[0] != self.spec_.num_dims:
            raise InvalidParameterError(
                f"{type(self).__name__} was set up for a {self.spec_.num_dims}-D state "
                f"({self.spec_.name}) but received shape {array.shape}; was it set up with "
                f"another domain's spec?"
            )
        return array

    def state_arrays(self) -> dict[str, np.ndarray]:
        """Return the arrays that, with the parameters and spec, rebuild the set-up state."""
        return {}

    def load_state_arrays(self, arrays: dict[str, np.ndarray]) -> None:
        """Restore what `state_arrays` returned."""


# ---------------------------------------------------------------------------------------------
# Policy


class Policy(Configurable):
    """Chooses an action from Q-values (or preferences) alone: ε-greedy (Eq. 2.27), Gibbs (2.32)."""

    def select(
        self, values: np.ndarray, rng: np.random.Generator, legal_actions: np.ndarray
    ) -> int:
        """Draw an action among ``legal_actions`` given ``values`` for every action."""
        raise NotImplementedError

    def probabilities(self, values: np.ndarray, legal_actions: np.ndarray) -> np.ndarray:
        """Return the probability of each action (zero for illegal ones)."""
        raise NotImplementedError


# ---------------------------------------------------------------------------------------------
# Agent


class Agent(Configurable):
    """A learner: ``setup``, ``act``, ``learn``, ``before_policy_check``, ``save``, ``restore``.

    The run loop calls ``begin_episode`` at every reset, ``act`` for every state it sees,
    ``learn`` with each `Transition` and ``before_policy_check`` before each greedy
    evaluation; it never knows which algorithm it drives. Online learners update in ``learn``;
    batch learners (Algorithms 13-16) store the transitions there and fit on them in
    ``before_policy_check`` (or every N samples).
    """

    def setup(self, spec: DomainSpec, seed: int | np.random.SeedSequence) -> Agent:
        """Validate parameters, build weights and RNGs for ``spec`` and return ``self``."""
        raise NotImplementedError

    def begin_episode(self) -> None:
        """Mark the start of an episode (step-size schedules count episodes; traces reset)."""
        raise NotImplementedError

    def act(
        self, state: np.ndarray, greedy: bool = False, legal_actions: np.ndarray | None = None
    ) -> int:
        """Return the action for ``state``: exploratory, or greedy for policy checks."""
        raise NotImplementedError

    def learn(self, transition: Transition) -> float:
        """Update from one transition and return the TD error δ."""
        raise NotImplementedError

    def before_policy_check(self) -> None:
        """Prepare the greedy policy the run loop is about to evaluate; a no-op by default.

        Batch learners fit on the samples gathered since their last fit here, so a policy
        check evaluates what they learned; online learners have nothing to do.
        """

    @property
    def num_features(self) -> int:
        """Number of features currently in use (grows for adaptive representations)."""
        raise NotImplementedError

    def save(self, path: str | Path) -> Path:
        """Write the agent to directory ``path`` (JSON metadata + ``.npy`` arrays, no pickle)."""
        raise NotImplementedError

    @classmethod
    def restore(cls, path: str | Path) -> Agent:
        """Load an agent written by `save`, ready to continue exactly where it stopped."""
        raise NotImplementedError
