"""Independent discretization: the "initial features" of iFDD, one bucket set per dimension."""

from __future__ import annotations

import numpy as np

from conjure.core.interfaces import DomainSpec, Representation, check_is_set_up
from conjure.core.seeding import as_seed_sequence
from conjure.representations._kernels import (
    BucketTable,
    dimension_table,
    independent_features,
    per_dimension,
    positive_ints,
)
from conjure.representations.compiled_representation import (
    INDEPENDENT,
    RepresentationKernel,
    representation_kernel,
)

__all__ = ["IndependentDiscretization"]


class IndependentDiscretization(BucketTable, Representation):
    """φ(s) with one active feature per dimension: the bucket of s_d within dimension d.

    Geramifard (2012), Section 4.1.4: "The initial features consisted of discretizing each
    dimension into 20 levels (for 120 features total)" on the inverted pendulum, i.e.
    2 dimensions × 20 buckets × 3 actions once φ(s, a) is built as in Eq. 2.11. Every feature
    is sub-dimensional (Eq. 3.7): it ignores all dimensions but its own, so its coverage is
    G(f) = 1 / buckets_d (Eq. 3.4). These are the initial features iFDD conjoins (Alg 17).

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
        Σ_d buckets_d (pendulum: 20 + 20 = 40).
    num_buckets_ : ndarray of int64, shape (d,)
        Buckets actually used per dimension.
    offsets_ : ndarray of int64, shape (d,)
        Index of the first feature of each dimension's block.
    is_set_up_ : bool
        Whether `setup` has run.

    Notes
    -----
    - Symbols: φ(s) ``active_features``; d ``spec.num_dims``.
    - Features of dimension d are ``offsets_[d] .. offsets_[d] + num_buckets_[d] - 1``, so the
      d active indices are sorted by dimension.
    - Choice: values outside ``[low, high]`` are clipped into the edge buckets; ``high``
      itself falls in the last bucket; NaN falls in the first.
    - Choice: a continuous dimension with ``low == high`` gets a single (always active) bucket.

    Complexity
    ----------
    Θ(d) per call to `active_features`; k = d active features.

    Examples
    --------
    >>> from conjure.core import DomainSpec
    >>> spec = DomainSpec(name="box", low=[0.0, 0.0], high=[1.0, 1.0], is_discrete=[False, False],
    ...                   num_actions=2, discount=0.9, max_episode_steps=10)
    >>> rep = IndependentDiscretization(num_buckets=4).setup(spec, seed=0)
    >>> rep.num_features_
    8
    >>> rep.active_features([0.3, 0.9]).tolist()
    [1, 7]
    """

    parameter_constraints = {"num_buckets": positive_ints()}

    def __init__(self, *, num_buckets: int | list[int] = 20):
        self.num_buckets = num_buckets

    def setup(
        self, spec: DomainSpec, seed: int | np.random.SeedSequence
    ) -> IndependentDiscretization:
        """Validate ``num_buckets`` against ``spec``, build the blocks and return ``self``."""
        self.validate_params()
        as_seed_sequence(seed)  # no randomness; the seed is checked for uniformity
        table, sizes = dimension_table(spec, per_dimension(self, "num_buckets", spec))
        offsets = np.zeros(spec.num_dims, dtype=np.int64)
        offsets[1:] = np.cumsum(sizes)[:-1]
        self._dims = table
        self.spec_ = spec
        self.num_buckets_ = sizes
        self.offsets_ = offsets
        self.num_features_ = int(sizes.sum())
        self.is_set_up_ = True
        return self

    compiled_methods = ("active_features", "encode")

    def compiled_form(self) -> RepresentationKernel:
        """The bucket table and offsets for the compiled loop (`independent_features`)."""
        check_is_set_up(self, "compiled_form")
        offsets = self.offsets_
        return representation_kernel(INDEPENDENT, offsets.shape[0], dims=self._dims, vector=offsets)

    def active_features(self, state: np.ndarray) -> np.ndarray:
        """Return φ(s): the sorted int64 indices of the d active buckets, one per dimension."""
        dims, state = self._dims_and_state(state)
        return independent_features(state, dims, self.offsets_)
