"""Binary indicators: one feature per binary state dimension (BlocksWorld's On(·,·) features)."""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from conjure.core.errors import InvalidParameterError
from conjure.core.interfaces import DomainSpec, Representation, check_is_set_up
from conjure.core.seeding import as_seed_sequence
from conjure.representations.compiled_representation import (
    INDICATORS,
    RepresentationKernel,
    representation_kernel,
)

__all__ = ["BinaryIndicators"]


class BinaryIndicators(Representation):
    """φ(s) with feature i active exactly when state dimension i is nonzero.

    Geramifard (2012), Section 4.1.4 (BlocksWorld): "Initial features were directly derived
    from the relations On(o1, o2) which led to 6 × 6 × 36 = 1296 features", i.e. one indicator
    per dimension of the 36-dimensional Boolean On(·,·) state, times 36 actions once φ(s, a) is
    built as in Eq. 2.11. These are the initial features iFDD conjoins (Alg 17, 19).

    Attributes
    ----------
    spec_ : DomainSpec
        The spec given to `setup`.
    num_features_ : int
        d, one feature per state dimension.
    is_set_up_ : bool
        Whether `setup` has run.

    Notes
    -----
    - Symbols: φ(s) ``active_features``; d ``spec.num_dims``.
    - Choice: "active" means nonzero (any nonzero value counts, NaN included); `setup` only
      accepts specs whose every dimension has bounds within [0, 1].
    - Choice: a state with no nonzero dimension has an empty φ(s) (an empty int64 array);
      learners then read Q(s, ·) = θᵀφ(s) = 0 and make no update. BlocksWorld states always
      have exactly b active features (one support per block).

    Complexity
    ----------
    Θ(d) per call to `active_features` (one vectorised scan); k = number of nonzero dims.

    Examples
    --------
    >>> from conjure.core import DomainSpec
    >>> spec = DomainSpec(name="bits", low=[0, 0, 0], high=[1, 1, 1],
    ...                   is_discrete=[True, True, True], num_actions=2, discount=1.0,
    ...                   max_episode_steps=10)
    >>> rep = BinaryIndicators().setup(spec, seed=0)
    >>> rep.num_features_, rep.active_features([1.0, 0.0, 1.0]).tolist()
    (3, [0, 2])
    """

    parameter_constraints: ClassVar[dict] = {}

    def __init__(self) -> None:
        pass

    def setup(self, spec: DomainSpec, seed: int | np.random.SeedSequence) -> BinaryIndicators:
        """Check that every dimension of ``spec`` lies within [0, 1] and return ``self``."""
        self.validate_params()
        as_seed_sequence(seed)  # no randomness; the seed is checked for uniformity
        bad = np.flatnonzero((spec.low < 0.0) | (spec.high > 1.0))
        if bad.size:
            shown = ", ".join(
                f"{int(i)} [{spec.low[i]:g}, {spec.high[i]:g}]" for i in bad[:10].tolist()
            )
            more = f" and {bad.size - 10} more" if bad.size > 10 else ""
            raise InvalidParameterError(
                f"BinaryIndicators needs every state dimension within [0, 1], but {spec.name!r} "
                f"has dimensions {shown}{more}; use IndependentDiscretization for "
                f"non-binary dimensions."
            )
        self.spec_ = spec
        self._num_dims = spec.num_dims
        self.num_features_ = int(spec.num_dims)
        self.is_set_up_ = True
        return self

    compiled_methods = ("active_features", "encode")

    def compiled_form(self) -> RepresentationKernel:
        """The nonzero dimensions are φ(s): nothing to pack (`encode_into`'s last case)."""
        check_is_set_up(self, "compiled_form")
        return representation_kernel(INDICATORS, self._num_dims)

    def active_features(self, state: np.ndarray) -> np.ndarray:
        """Return the sorted int64 indices of the nonzero dimensions of ``state`` (maybe empty)."""
        try:
            num_dims = self._num_dims
        except AttributeError:
            check_is_set_up(self, "active_features")
            raise
        if type(state) is not np.ndarray or state.shape != (num_dims,):
            state = self.check_state(state)
        return np.flatnonzero(state)
