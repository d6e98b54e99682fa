"""The approximate model T̂ of iCCA, static or adaptive (Geramifard 2012, Sections 5.3 and 5.5).

T̂ has the parametric form of the true domain (a `NoisyDomain`) with an estimated noise
probability η̂. It is shared by the cooperative planner and the risk analyser (Figure 5-11) and,
when adaptive, re-estimated from every observed transition (Algorithm 26, line 9).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

from conjure.core.cooperative import NoisyDomain
from conjure.core.errors import IncompatibleComponentsError
from conjure.core.interfaces import DomainSpec, check_is_set_up
from conjure.core.params import Configurable, InstanceOf, Interval

__all__ = ["ApproximateModel", "NoiseModel", "check_same_spec", "estimate_noise", "observe_moves"]


class NoiseModel(NamedTuple):
    """T̂'s noise estimate as a compiled kernel reads and updates it (`observe_moves`).

    Parameters
    ----------
    counts : ndarray of int64, shape (2,)
        [#unintended moves, #moves], updated in place.
    noise : ndarray of float64, shape (1,)
        η̂, updated in place.
    prior_noise, prior_weight : float
        η̂₀ and w.
    is_adaptive : bool
        Whether moves are counted (Algorithm 26) or η̂ stays at η̂₀.
    """

    counts: np.ndarray
    noise: np.ndarray
    prior_noise: float
    prior_weight: float
    is_adaptive: bool


@njit(cache=True)
def estimate_noise(
    num_unintended: int, num_moves: int, prior_noise: float, prior_weight: float
) -> float:
    """η̂ = (#unintended + w·η̂₀) / (#moves + w) (Section 5.5.2, see `ApproximateModel`)."""
    return (num_unintended + prior_weight * prior_noise) / (num_moves + prior_weight)


@njit(cache=True)
def observe_moves(model: NoiseModel, num_unintended: int, num_moves: int) -> None:
    """model.update (Algorithm 26, line 10) from one transition's counted moves."""
    if not model.is_adaptive:
        return
    model.counts[0] += num_unintended
    model.counts[1] += num_moves
    if model.counts[1] + model.prior_weight > 0:
        model.noise[0] = estimate_noise(
            model.counts[0], model.counts[1], model.prior_noise, model.prior_weight
        )


class ApproximateModel(Configurable):
    """T̂: a `NoisyDomain` simulated at an estimated noise η̂ (Section 5.5.2).

    η̂ = (#unintended moves + w·η̂₀) / (#moves + w), with prior η̂₀ (``initial_noise``) and prior
    weight w (``prior_weight``); the thesis starts at η̂₀ = 0.4 with w = 100.

    Parameters
    ----------
    domain : NoisyDomain
        The model's form: the domain as the planner believes it (its map, graph, rewards).
    initial_noise : float or None, default None
        η̂₀ in [0, 1]; ``None`` takes the noise ``domain`` was built with.
    prior_weight : float, default 100.0
        w in [0, inf): how many moves the prior counts for.
    is_adaptive : bool, default False
        Whether `update` re-estimates η̂ (AM-iCCA, Algorithm 26) or η̂ stays at η̂₀ (iCCA).

    Attributes
    ----------
    domain_ : NoisyDomain
        The set-up copy of ``domain``.
    noise_ : float
        The current estimate η̂.
    num_unintended_, num_moves_ : int
        The counts behind η̂.
    form_ : NoiseModel
        η̂ and its counts as arrays: the model's state, which ``noise_`` and the counts read
        and compiled kernels update in place (`observe_moves`).

    Notes
    -----
    - Choice: the thesis prints noise = (#unintended + initial weight)/(#moves + initial
      weight), which would start at 100%, contradicting "started with the noise estimate of
      40% with the count weight of 100"; the prior therefore enters as w·η̂₀ in the numerator.

    Examples
    --------
    >>> from conjure.domains import GridWorld
    >>> model = ApproximateModel(domain=GridWorld(map_name="4x5", noise=0.0), initial_noise=0.4,
    ...                          is_adaptive=True)
    >>> model = model.setup(model.domain.domain_spec, seed=0)
    >>> s = np.array([0.0, 0.0])
    >>> model.update(s, 3, np.array([0.0, 1.0]))  # moved right as intended
    >>> round(model.noise_, 4)  # (0 + 100 * 0.4) / (1 + 100)
    0.396
    """

    parameter_constraints = {
        "domain": InstanceOf(NoisyDomain, "a NoisyDomain (e.g. GridWorld or UAVMission)"),
        "initial_noise": Interval(float, 0.0, 1.0) | InstanceOf(type(None)),
        "prior_weight": Interval(float, 0.0, None),
        "is_adaptive": InstanceOf(bool, "a bool"),
    }

    def __init__(
        self,
        *,
        domain: NoisyDomain,
        initial_noise: float | None = None,
        prior_weight: float = 100.0,
        is_adaptive: bool = False,
    ):
        self.domain = domain
        self.initial_noise = initial_noise
        self.prior_weight = prior_weight
        self.is_adaptive = is_adaptive

    def setup(self, spec: DomainSpec, seed: int | np.random.SeedSequence = 0) -> ApproximateModel:
        """Check that the model describes the domain of ``spec`` and reset η̂ to η̂₀."""
        self.validate_params()
        check_same_spec(self.domain.domain_spec, spec, what=f"{type(self).__name__}.domain")
        self.domain_ = self.domain.clone()
        self.prior_noise_ = (
            self.domain_.noise_level if self.initial_noise is None else float(self.initial_noise)
        )
        self.form_ = NoiseModel(
            counts=np.zeros(2, dtype=np.int64),
            noise=np.array([self.prior_noise_]),
            prior_noise=float(self.prior_noise_),
            prior_weight=float(self.prior_weight),
            is_adaptive=bool(self.is_adaptive),
        )
        self.is_set_up_ = True
        return self

    @property
    def noise_(self) -> float:
        """η̂ (``form_.noise[0]``)."""
        return float(self.form_.noise[0])

    @noise_.setter
    def noise_(self, noise: float) -> None:
        self.form_.noise[0] = noise

    @property
    def num_unintended_(self) -> int:
        """#unintended moves behind η̂ (``form_.counts[0]``)."""
        return int(self.form_.counts[0])

    @property
    def num_moves_(self) -> int:
        """#moves behind η̂ (``form_.counts[1]``)."""
        return int(self.form_.counts[1])

    def sample(
        self, state: np.ndarray, action: int, rng: np.random.Generator
    ) -> tuple[np.ndarray, float, bool]:
        """Draw ⟨s', r, terminated⟩ ~ T̂(s, a) at η̂."""
        return self.domain_.simulate(state, action, self.noise_, rng)

    def nominal_next_state(self, state: np.ndarray, action: int) -> np.ndarray:
        """Return s' without noise (the deterministic view of T̂)."""
        return self.domain_.nominal_next_state(state, action)

    def is_constrained(self, state: np.ndarray) -> bool:
        """constrained(s) of Algorithm 25."""
        return self.domain_.is_constrained(state)

    def update(self, state: np.ndarray, action: int, next_state: np.ndarray) -> None:
        """model.update(s, a, s') (Algorithm 26, line 9): count moves and re-estimate η̂.

        The compiled box's kernel on the model's own form (`observe_moves`).
        """
        check_is_set_up(self, "update")
        if not self.is_adaptive:
            return
        unintended, moves = self.domain_.count_unintended(state, action, next_state)
        observe_moves(self.form_, unintended, moves)

    def load_counts(self, num_unintended: int, num_moves: int) -> None:
        """Set the counts behind η̂ and re-estimate it (also how saved agents restore T̂)."""
        check_is_set_up(self, "load_counts")
        form = self.form_
        form.counts[:] = (num_unintended, num_moves)
        weight = form.prior_weight
        if form.is_adaptive and form.counts[1] + weight > 0:
            form.noise[0] = estimate_noise(
                int(form.counts[0]), int(form.counts[1]), form.prior_noise, weight
            )

    def noise_model(self) -> NoiseModel:
        """η̂ and its counts for a compiled kernel: the model's own ``form_`` (no copy).

        A kernel's `observe_moves` updates it in place, so nothing is taken back.
        """
        check_is_set_up(self, "noise_model")
        return self.form_

    def domain_at_noise(self) -> NoisyDomain:
        """A copy of the model's domain built with η = η̂ (for planners that need P and R)."""
        check_is_set_up(self, "domain_at_noise")
        return self.domain_.clone().set_params(**{self.domain_.noise_parameter: self.noise_})


def check_same_spec(model_spec: DomainSpec, spec: DomainSpec, *, what: str) -> None:
    """Raise `IncompatibleComponentsError` unless the two specs share states and actions."""
    same = (
        model_spec.num_actions == spec.num_actions
        and model_spec.low.shape == spec.low.shape
        and np.array_equal(model_spec.low, spec.low)
        and np.array_equal(model_spec.high, spec.high)
    )
    if not same:
        raise IncompatibleComponentsError(
            f"{what} describes {model_spec.name} ({model_spec.num_dims}-D states, "
            f"{model_spec.num_actions} actions) but the agent runs on {spec.name} "
            f"({spec.num_dims}-D states, {spec.num_actions} actions); give the model the "
            f"learning domain's map or graph."
        )
