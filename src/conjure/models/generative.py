"""Generative models: draw s' ~ P(s, a) for the sampled algorithms (Geramifard 2012, Eq. 2.28).

Algorithms 5, 6, 8, 9 and 13 never read P; they ask a generative model for samples. Two
implementations share one interface: `ModelSampler` samples an exact `TabularModel`, and
`DomainSampler` drives any domain with a simulator that can be put in a given state
(``domain.set_state(state)``).
"""

from __future__ import annotations

import copy
from typing import Any

import numpy as np

from conjure.core.errors import IncompatibleComponentsError
from conjure.core.interfaces import Domain, DomainSpec
from conjure.models.tabular_model import TabularModel

__all__ = ["DomainSampler", "GenerativeModel", "ModelSampler", "generative_model"]


class GenerativeModel:
    """Sample s' ~ P(s, a): ``sample(state, action, rng) -> (next_state, reward, terminated)``."""

    spec: DomainSpec

    def sample_start(self, rng: np.random.Generator) -> np.ndarray:
        """Draw a start state s₀."""
        raise NotImplementedError

    def sample(
        self, state: np.ndarray, action: int, rng: np.random.Generator
    ) -> tuple[np.ndarray, float, bool]:
        """Draw ⟨s', r, terminated⟩ after taking ``action`` in ``state``."""
        raise NotImplementedError


class ModelSampler(GenerativeModel):
    """Samples an exact `TabularModel`; the reward is the expected reward R(s, a).

    Examples
    --------
    >>> from conjure.testing.planner_checks import three_state_model
    >>> sampler = ModelSampler(three_state_model())
    >>> rng = np.random.default_rng(0)
    >>> s0 = sampler.sample_start(rng)
    >>> next_state, reward, terminated = sampler.sample(s0, 0, rng)
    >>> next_state.shape
    (1,)
    """

    def __init__(self, model: TabularModel):
        self.model = model
        self.spec = model.domain_spec
        stacked = model.stacked_transitions
        self._indptr, self._indices = stacked.indptr, stacked.indices
        self._cumulative = np.empty_like(stacked.data)
        for row in range(stacked.shape[0]):  # per-row cumulative probabilities
            lo, hi = self._indptr[row], self._indptr[row + 1]
            self._cumulative[lo:hi] = np.cumsum(stacked.data[lo:hi])
        self._start_cumulative = np.cumsum(model.start_distribution)

    def sample_start_index(self, rng: np.random.Generator) -> int:
        """Draw the index of a start state."""
        u = rng.random() * self._start_cumulative[-1]
        return int(
            min(np.searchsorted(self._start_cumulative, u, side="right"), self.model.num_states - 1)
        )

    def sample_index(self, state: int, action: int, rng: np.random.Generator) -> int:
        """Draw the index of s' ~ P^a_{s·} (Θ(log k) for k successors)."""
        row = action * self.model.num_states + state
        lo, hi = self._indptr[row], self._indptr[row + 1]
        u = rng.random() * self._cumulative[hi - 1]
        k = int(np.searchsorted(self._cumulative[lo:hi], u, side="right"))
        return int(self._indices[lo + min(k, hi - lo - 1)])

    def sample_start(self, rng: np.random.Generator) -> np.ndarray:
        return self.model.states[self.sample_start_index(rng)].copy()

    def sample(
        self, state: np.ndarray, action: int, rng: np.random.Generator
    ) -> tuple[np.ndarray, float, bool]:
        model = self.model
        index = model.state_index(state)
        if model.is_terminal[index]:
            return model.states[index].copy(), 0.0, True
        following = self.sample_index(index, int(action), rng)
        reward = float(model.rewards[index, int(action)])
        return model.states[following].copy(), reward, bool(model.is_terminal[following])


class DomainSampler(GenerativeModel):
    """Samples a domain's simulator by putting a private copy in state s (``set_state``).

    Parameters
    ----------
    domain : Domain
        Must implement ``set_state(state)``; it is deep-copied, the original is never stepped.
    """

    def __init__(self, domain: Domain):
        if not callable(getattr(domain, "set_state", None)):
            raise IncompatibleComponentsError(
                f"{type(domain).__name__} has no set_state(state), so it cannot serve as a "
                f"generative model; give the planner its tabular model instead."
            )
        self.domain = copy.deepcopy(domain)
        self.spec = domain.domain_spec

    def sample_start(self, rng: np.random.Generator) -> np.ndarray:
        self.domain.reset(seed=int(rng.integers(2**31 - 1)))
        return np.asarray(self.domain.reset()[0], dtype=np.float64)

    def sample(
        self, state: np.ndarray, action: int, rng: np.random.Generator
    ) -> tuple[np.ndarray, float, bool]:
        domain = self.domain
        domain.np_random = rng
        domain.set_state(state)
        next_state, reward, terminated, _, _ = domain.step(int(action))
        return np.asarray(next_state, dtype=np.float64), float(reward), bool(terminated)


def generative_model(source: Any) -> GenerativeModel:
    """Return a generative model for a `TabularModel`, a domain or a `GenerativeModel`."""
    if isinstance(source, GenerativeModel):
        return source
    if isinstance(source, TabularModel):
        return ModelSampler(source)
    if isinstance(source, Domain):
        if callable(getattr(source, "set_state", None)):
            return DomainSampler(source)
        model = source.model()
        if model is not None:
            return ModelSampler(model)
    raise IncompatibleComponentsError(
        f"A sampled planner needs a generative model; {type(source).__name__} is neither a "
        f"TabularModel nor a domain with set_state() or model()."
    )
