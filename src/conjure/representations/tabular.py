"""The tabular representation: one binary feature per cell of a grid over the state space."""

from __future__ import annotations

import numpy as np

from conjure.core.errors import InvalidParameterError
from conjure.core.interfaces import DomainSpec, Representation, check_is_set_up
from conjure.core.seeding import as_seed_sequence
from conjure.representations._kernels import (
    MAX_FEATURES,
    BucketTable,
    dimension_table,
    per_dimension,
    positive_ints,
    tabular_feature,
)
from conjure.representations.compiled_representation import (
    TABULAR,
    RepresentationKernel,
    representation_kernel,
)

__all__ = ["Tabular"]


class Tabular(BucketTable, Representation):
    """Tabular φ(s): exactly one active feature, the cell of the product grid holding s.

    Geramifard (2012), Section 3.1.3 (a unique feature per state reduces linear function
    approximation to a lookup table, Eq. 2.1) and Section 4.1.4 (the tabular baseline on the
    inverted pendulum); φ(s, a) follows Eq. 2.11. Each feature has coverage G(f) = 1/|S|
    (Section 3.1.1).

    Parameters
    ----------
    num_buckets : int or list of int, default 20
        Equal buckets per continuous dimension over ``[low, high]``, in [1, inf); a list gives
        one entry per state dimension. Discrete dimensions always get one bucket per integer
        value ``low .. high`` and ignore their entry.

    Attributes
    ----------
    spec_ : DomainSpec
        The spec given to `setup`.
    num_features_ : int
        Number of grid cells, the product of the buckets per dimension (pendulum: 20 × 20).
    num_buckets_ : ndarray of int64, shape (d,)
        Buckets actually used per dimension.
    is_set_up_ : bool
        Whether `setup` has run.

    Notes
    -----
    - Symbols: φ(s) ``active_features``; |S| ``num_features_``.
    - Choice: values outside ``[low, high]`` are clipped into the edge buckets; ``high``
      itself falls in the last bucket; NaN falls in the first.
    - Choice: a continuous dimension with ``low == high`` gets a single bucket.
    - Choice: cells are numbered row-major (the last dimension varies fastest).

    Complexity
    ----------
    Θ(d) per call to `active_features`; k = 1 active feature (sparsity 1/n, Section 3.1.2).

    Examples
    --------
    >>> from conjure.core import DomainSpec
    >>> spec = DomainSpec(name="box", low=[0.0, 0.0], high=[1.0, 1.0], is_discrete=[False, False],
    ...                   num_actions=2, discount=0.9, max_episode_steps=10)
    >>> rep = Tabular(num_buckets=4).setup(spec, seed=0)
    >>> rep.num_features_
    16
    >>> rep.active_features([0.3, 0.9]).tolist()
    [7]
    """

    parameter_constraints = {"num_buckets": positive_ints()}

    def __init__(self, *, num_buckets: int | list[int] = 20):
        self.num_buckets = num_buckets

    def setup(self, spec: DomainSpec, seed: int | np.random.SeedSequence) -> Tabular:
        """Validate ``num_buckets`` against ``spec``, build the grid and return ``self``."""
        self.validate_params()
        as_seed_sequence(seed)  # no randomness; the seed is checked for uniformity
        table, sizes = dimension_table(spec, per_dimension(self, "num_buckets", spec))
        num_features = 1
        for size in sizes.tolist():
            num_features *= size
        if num_features > MAX_FEATURES:
            raise InvalidParameterError(
                f"`Tabular.num_buckets` = {self.num_buckets!r} gives {num_features} grid cells "
                f"for {spec.name!r}, more than an int64 index allows; use fewer buckets, "
                f"IndependentDiscretization or TileCoding with memory_size."
            )
        strides = np.ones(spec.num_dims, dtype=np.int64)
        for i in range(spec.num_dims - 2, -1, -1):
            strides[i] = strides[i + 1] * sizes[i + 1]
        self._dims = table
        self._strides = strides
        self.spec_ = spec
        self.num_buckets_ = sizes
        self.num_features_ = int(num_features)
        self.is_set_up_ = True
        return self

    compiled_methods = ("active_features", "encode")

    def compiled_form(self) -> RepresentationKernel:
        """The bucket table and strides for the compiled loop (`tabular_feature`)."""
        check_is_set_up(self, "compiled_form")
        return representation_kernel(TABULAR, 1, dims=self._dims, vector=self._strides)

    def active_features(self, state: np.ndarray) -> np.ndarray:
        """Return φ(s) as the one-element sorted int64 array of the cell holding ``state``."""
        dims, state = self._dims_and_state(state)
        return tabular_feature(state, dims, self._strides)
