"""The core interfaces: Domain, Representation, Policy, Agent, and the records they exchange.

Names follow Geramifard (2012): φ(s) ``encode`` (Eq. 2.11 builds φ(s, a) from it), θ
``weights``, δ ``td_error``, γ ``discount``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, ClassVar, NamedTuple

import gymnasium as gym
import numpy as np

from conjure.core.errors import IncompatibleComponentsError, InvalidParameterError, NotSetUpError
from conjure.core.params import Configurable

__all__ = [
    "Agent",
    "Domain",
    "DomainSpec",
    "Expansion",
    "Policy",
    "Representation",
    "SparseFeatures",
    "Transition",
    "check_binary_features",
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
    them (``None`` means every action). ``is_imagined`` marks a transition the agent did not
    experience (a cooperative learner's vetoed proposal learned as a failure, Algorithm 24):
    online learners update on it as on a one-step episode of its own, so the episode in
    progress is untouched (SARSA(λ)'s eligibility traces are neither used, decayed nor
    cleared) and it counts no learning step; batch learners store it as any other sample.
    ``cost`` is the step's c_t (``info["cost"]``, 0 when the domain reports none), read by a
    learner with a cost constraint (`conjure.safety.constraints`).
    """

    state: np.ndarray
    action: int
    reward: float
    next_state: np.ndarray
    next_action: int
    terminated: bool
    next_legal_actions: np.ndarray | None = None
    is_imagined: bool = False
    cost: float = 0.0


class SparseFeatures(NamedTuple):
    """φ(s) as its non-zero entries: the one feature encoding learners and planners read.

    ``indices`` are sorted, unique int64 feature numbers and ``values`` the float64 φ_i(s) at
    them (same length); every feature not listed is 0. Binary representations give values of
    1 (the active features of Eq. 2.11); Gaussian RBF gives every feature with its value.

    Examples
    --------
    >>> phi = SparseFeatures(np.array([0, 2]), np.array([0.5, 1.0]))
    >>> phi.dense(3).tolist(), phi.has_unit_values()
    ([0.5, 0.0, 1.0], False)
    >>> phi.dot(np.array([[2.0, 0.0], [9.0, 9.0], [1.0, 3.0]])).tolist()
    [2.0, 3.0]
    """

    indices: np.ndarray
    values: np.ndarray

    def dense(self, num_features: int) -> np.ndarray:
        """Return φ(s) as a dense float64 vector of length ``num_features``."""
        phi = np.zeros(num_features, dtype=np.float64)
        phi[self.indices] = self.values
        return phi

    def dot(self, weights: np.ndarray) -> np.ndarray:
        """Return θᵀφ(s) for θ of shape (n_features, |A|): Q(s, ·) (Eq. 2.11).

        The numpy form for planners and batch learners; online learners use the numba
        kernels of `conjure.agents._kernels`.
        """
        return (weights[self.indices] * self.values[:, None]).sum(axis=0)

    def has_unit_values(self) -> bool:
        """Whether every listed value is 1, i.e. φ(s) is binary."""
        return bool(np.all(self.values == 1.0))


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
    #: Parameters a compiled form need not carry (`conjure.core.compiled_form`): γ and the cap
    #: reach the compiled loop through ``domain_spec`` (the learner's γ, the episode cap).
    compiled_irrelevant_params: ClassVar[frozenset[str]] = frozenset(
        {"discount", "max_episode_steps"}
    )

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

    def action_masks(self) -> np.ndarray:
        """Return a bool array, True at the legal actions of the current state.

        The method sb3-contrib's ``MaskablePPO`` reads. Every action by default; domains with
        action constraints (`conjure.domains.action_masking`) return their current mask and
        also put it in ``info["action_mask"]`` at ``reset`` and ``step``.
        """
        return np.ones(self.domain_spec.num_actions, dtype=bool)

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

    def return_bounds(self) -> tuple[float, float] | None:
        """Return (lowest, highest) return any episode from the start can have, if known.

        Used only to cut the confidence intervals of the return (`conjure.experiments.
        metric_ranges`), never to scale a metric: unlike `value_bounds` the two ends need not
        be any policy's expected return, only hold for every episode within the episode cap.
        Domains whose rewards make them exact and cheap (`GridWorld`, `ChainMDP`) return them;
        the default is ``None`` (the return is then cut only at `value_bounds`, if any).
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

_NO_VALUES = np.zeros(0, dtype=np.float64)
_NO_VALUES.flags.writeable = False


class Representation(Configurable):
    """Maps a state to features φ(s); Q(s, ·) = θᵀφ(s) with θ of shape (n_features, |A|).

    `encode` is the one contract learners and planners use: it returns φ(s) as a
    `SparseFeatures` (sorted indices with their values; Eq. 2.11 takes φ(s, a) from it per
    action through θ's column). Binary representations implement `active_features`, the
    sorted int64 indices of the active features, and inherit `encode` with values of 1;
    real-valued ones (Gaussian RBF) implement `encode` and leave `active_features` raising.
    `feature_values` is the dense φ(s), built from `encode`. A representation never owns
    weights.

    Adaptive representations (``is_adaptive = True``) implement `discover`, returning an
    `Expansion`; learners then grow their weights (θ_f = θ_g + θ_h, Section 4.1.1).
    """

    is_adaptive: ClassVar[bool] = False
    # The values `encode` gives binary φ (a read-only view of the ones buffer `_unit_buffer`).
    _unit_values: np.ndarray = _NO_VALUES
    _unit_buffer: np.ndarray = _NO_VALUES

    def setup(self, spec: DomainSpec, seed: int | np.random.SeedSequence) -> Representation:
        """Validate parameters, build the feature tables for ``spec`` and return ``self``."""
        raise NotImplementedError

    def active_features(self, state: np.ndarray) -> np.ndarray:
        """Return the sorted indices of the active binary features of ``state``.

        Representations with real-valued features do not implement it (it raises
        `IncompatibleComponentsError`); use `encode`.
        """
        raise IncompatibleComponentsError(
            f"{type(self).__name__} has real-valued features, not binary active features; "
            f"use encode (a component needing binary active_features cannot use it)."
        )

    def encode(self, state: np.ndarray) -> SparseFeatures:
        """Return φ(s) as `SparseFeatures`: the active features of ``state`` with values 1.

        The values are a read-only view of a buffer of ones the representation keeps (grown
        when a state has more active features), so encoding allocates nothing per step.
        """
        return self._binary(self.active_features(state))

    def peek(self, state: np.ndarray) -> SparseFeatures:
        """Return φ(s) as `encode` does, storing nothing (greedy acting and inspection).

        The default is `encode`. The representations whose `encode` stores (`HashedTabular`'s
        cells, `TileCoding`'s hashed tiles) override it to give the indices storing would
        give without storing them, so a policy check leaves them as they were.
        """
        return self.encode(state)

    def _binary(self, indices: np.ndarray) -> SparseFeatures:
        """``indices`` with values 1 (a view of the ones buffer)."""
        ones = self._unit_values
        if len(ones) != len(indices):
            ones = self._unit_values = self._ones(len(indices))
        return _sparse_features(SparseFeatures, (indices, ones))

    def _ones(self, count: int) -> np.ndarray:
        """A read-only view of ``count`` ones on a buffer grown (doubled) when too short."""
        buffer = self._unit_buffer
        if buffer.shape[0] < count:
            buffer = self._unit_buffer = np.ones(max(count, 2 * buffer.shape[0]))
            buffer.flags.writeable = False
        return buffer[:count]

    @property
    def num_features_in_use_(self) -> int:
        """Features φ(s) can activate now; the learners' ``num_features`` (a run's curve).

        ``num_features_`` (θ's rows) unless the representation reserves rows for features it
        has not created yet (`HashedTabular`: its capacity, against the cells indexed so far).
        """
        check_is_set_up(self, "num_features_in_use_")
        return int(self.num_features_)

    def feature_values(self, state: np.ndarray) -> np.ndarray:
        """Return the dense feature vector φ(s) of length ``num_features_`` (from `encode`)."""
        check_is_set_up(self, "feature_values")
        return self.encode(state).dense(self.num_features_)

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
        one shape test). Before `setup` it raises `NotSetUpError`.
        """
        try:
            shape = self.spec_.low.shape
        except AttributeError:
            check_is_set_up(self, "encode")
            raise
        if type(state) is np.ndarray and state.dtype == np.float64 and state.shape == shape:
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


_sparse_features = tuple.__new__  # SparseFeatures without its Python-level __new__ (per step)


def check_binary_features(representation: Representation, user: str) -> None:
    """Raise `IncompatibleComponentsError` unless ``representation`` is binary.

    For components that conjoin binary features (iFDD, FDLSTD). Binary is the contract of
    `Representation`: the class implements `active_features` and inherits `encode` (values 1).
    """
    cls = type(representation)
    if (
        cls.active_features is Representation.active_features
        or cls.encode is not Representation.encode
    ):
        raise IncompatibleComponentsError(
            f"{user} conjoins binary features, but {cls.__name__} encodes states with "
            f"real values (it implements encode, not active_features); use "
            f"IndependentDiscretization, TileCoding or Tabular."
        )


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

    Two contracts complete it: persistence (``state_metadata``, ``state_arrays``,
    ``load_state``, behind ``save`` and ``restore``) and, for an agent with a compiled form,
    the compiled state (the form is the agent's state; ``reserve_rows`` grows it).
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

    # The persistence contract: `save` and `restore` delegate to
    # `conjure.agents.persistence` (``save_agent``, ``restore_agent``), which call these.

    def state_metadata(self) -> dict[str, Any]:
        """The agent's scalar state for `save`, as JSON values.

        Counters (episodes, learning steps) and generator states
        (`conjure.core.seeding.rng_state`); never arrays, never pickled objects.
        """
        raise NotImplementedError

    def state_arrays(self) -> dict[str, np.ndarray]:
        """The agent's own arrays for `save`, by name (weights, live traces, samples).

        The representation's arrays are saved apart (its ``state_arrays``); names are the
        keys `load_state` reads back.
        """
        raise NotImplementedError

    def load_state(self, saved: Any) -> None:
        """Restore what `state_metadata` and `state_arrays` saved, on a freshly set-up agent.

        ``saved`` is a `conjure.agents.persistence.SavedAgent`; read every array through
        ``saved.array`` (or ``saved.indices``), which checks its shape, dtype and finiteness,
        so a damaged save raises `InvalidParameterError` naming the file.
        """
        raise NotImplementedError

    # The compiled-state contract, for agents with a ``compiled_form``
    # (`conjure.core.compiled_form`): the agent's compiled form is its state, built in
    # ``setup`` (``kernel_``, ``arrays_``, ``row_traces_``); the compiled loop
    # (`conjure.compiled.stepper`) updates those arrays in place and takes nothing back.

    def reserve_rows(self, rows: int) -> None:
        """Give the compiled form's weights (and what grows with them) ``rows`` feature rows.

        For an adaptive representation (Section 4.1.1): when they have fewer, the arrays are
        reallocated with their leading rows kept and the new form replaces the old as the
        agent's state (a `conjure.agents.compiled_agent.LearnerArrays` in ``arrays_``).
        """
        raise NotImplementedError
