"""Fakes that reproduce awkward but legal behaviour of real environments, for tests.

`SharedObservationBuffer` wraps a domain so that it returns one observation array, overwritten
in place at every ``reset`` and ``step``, as some Gymnasium wrappers and vectorised
environments do. Code that keeps a state across a ``step`` (the run loop, a learner's feature
cache, a batch learner's stored samples) must own a copy of it; tests drive it with this fake.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from conjure.core.interfaces import Domain
from conjure.core.params import InstanceOf

__all__ = ["SharedObservationBuffer"]


class SharedObservationBuffer(Domain):
    """A domain whose ``reset`` and ``step`` always return the same array, updated in place.

    Parameters
    ----------
    domain : Domain
        The wrapped domain; its spec, spaces, legal actions and model are passed through.

    Examples
    --------
    >>> from conjure.domains import ChainMDP
    >>> domain = SharedObservationBuffer(domain=ChainMDP())
    >>> first, _ = domain.reset(seed=0)
    >>> second = domain.step(0)[0]
    >>> second is first, first.tolist()
    (True, [1.0])
    """

    parameter_constraints = {"domain": InstanceOf(Domain, "a Domain")}

    def __init__(self, *, domain: Domain):
        self.domain = domain
        self._build()

    def _build(self) -> None:
        """Copy the wrapped domain's spaces and spec; allocate the shared buffer."""
        self.validate_params()
        self.observation_space = self.domain.observation_space
        self.action_space = self.domain.action_space
        self.domain_spec = self.domain.domain_spec
        self._buffer = np.zeros(self.domain_spec.num_dims)

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """Reset the wrapped domain and write its observation into the shared buffer."""
        super().reset(seed=seed)
        observation, info = self.domain.reset(seed=seed, options=options)
        self._buffer[:] = observation
        return self._buffer, info

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        """Step the wrapped domain and overwrite the shared buffer with its observation."""
        observation, reward, terminated, truncated, info = self.domain.step(action)
        self._buffer[:] = observation
        return self._buffer, reward, terminated, truncated, info

    def legal_actions(self, state: np.ndarray) -> np.ndarray:
        """The wrapped domain's legal actions."""
        return self.domain.legal_actions(state)

    def model(self) -> Any | None:
        """The wrapped domain's model."""
        return self.domain.model()

    def is_constrained(self, state: np.ndarray) -> bool:
        """The wrapped domain's failure states."""
        return self.domain.is_constrained(state)

    def value_bounds(self) -> tuple[float, float] | None:
        """The wrapped domain's value bounds."""
        return self.domain.value_bounds()

    def return_bounds(self) -> tuple[float, float] | None:
        """The wrapped domain's return bounds."""
        return self.domain.return_bounds()
