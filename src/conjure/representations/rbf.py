"""Gaussian radial basis functions: a dense, non-binary φ(s)."""

from __future__ import annotations

import numpy as np

from conjure.core.errors import InvalidParameterError
from conjure.core.interfaces import DomainSpec, Representation, SparseFeatures, check_is_set_up
from conjure.core.params import InstanceOf, Interval, Options, Predicate
from conjure.core.seeding import make_rng
from conjure.representations._kernels import per_dimension, positive_ints, rbf_values
from conjure.representations.compiled_representation import RBF as RBF_KIND
from conjure.representations.compiled_representation import (
    RepresentationKernel,
    representation_kernel,
)

__all__ = ["RBF"]

_POSITIVE_FLOAT = Interval(float, 0, None, closed="neither")


class RBF(Representation):
    """Gaussian RBF φ_i(s) = exp(−Σ_d ((s_d − c_id) / σ_d)² / 2), plus an optional bias.

    Geramifard (2012), Section 4.1.4: the "original Gaussian representation" the pendulum
    experiments compare against (Lagoudakis & Parr, 2003: a 3 × 3 grid of Gaussians plus a
    constant); Section 2.4 (linear φ with real-valued features, φ(s, a) by Eq. 2.11) and
    Section 6.2.3 (Gaussian features). Dense: every feature is non-zero (sparsity 1,
    Section 3.1.2), so `encode` lists every feature with its real value.

    Parameters
    ----------
    num_centers : int or list of int, default 3
        Grid centers per dimension, in [1, inf); a list gives one entry per dimension. With
        ``centers="random"`` it only sets the default width and count.
    width : float or list of float or None, default None
        σ_d as a fraction of the range ``high_d − low_d``, in (0, inf); a list gives one entry
        per dimension. ``None``: the grid spacing 1 / (num_centers_d − 1) (1 if a single
        center); with random centers the spacing of a grid of as many centers,
        num_random_centers^(−1/d).
    centers : {"grid", "random"}, default "grid"
        Centers on a uniform grid including the bounds (a single center sits mid-range), or
        drawn uniformly within the bounds from the setup seed.
    num_random_centers : int or None, default None
        With ``centers="random"``, the number of centers in [1, inf); ``None`` draws as many
        as the grid would have (Π_d num_centers_d). Ignored for the grid.
    include_bias : bool, default True
        Append a constant feature φ = 1 (last index).

    Attributes
    ----------
    spec_ : DomainSpec
        The spec given to `setup`.
    num_features_ : int
        Number of centers, plus one with the bias (pendulum default: 9 + 1).
    centers_ : ndarray of float64, shape (K, d)
        Centers in state units.
    widths_ : ndarray of float64, shape (d,)
        σ_d in state units.
    is_set_up_ : bool
        Whether `setup` has run.

    Notes
    -----
    - Symbols: φ(s) ``encode`` (dense: ``feature_values``); c_i ``centers_``; σ ``widths_``.
    - States are normalised by the range: u_d = (s_d − low_d) / (high_d − low_d); widths and
      centers are fractions of the range. Choice: a dimension with ``low == high`` uses a
      range of 1.
    - Choice: states outside the bounds are not clipped (the Gaussians just decay).
    - Choice: grid centers are numbered row-major (last dimension fastest); discrete
      dimensions are treated like continuous ones.
    - `active_features` raises `IncompatibleComponentsError`: RBF features are not binary.
    - Choice: `encode` lists all n features, even those whose Gaussian is tiny, so learners
      compute exactly the dense θᵀφ(s).

    Complexity
    ----------
    Θ(K · d) per call to `encode`, K = number of centers.

    Examples
    --------
    >>> from conjure.core import DomainSpec
    >>> spec = DomainSpec(name="box", low=[0.0, 0.0], high=[1.0, 1.0], is_discrete=[False, False],
    ...                   num_actions=2, discount=0.9, max_episode_steps=10)
    >>> rep = RBF(num_centers=3).setup(spec, seed=0)
    >>> rep.num_features_
    10
    >>> indices, values = rep.encode([0.5, 0.5])
    >>> indices.tolist() == list(range(10))
    True
    >>> round(float(values[4]), 3), round(float(values[0]), 3), float(values[-1])
    (1.0, 0.368, 1.0)
    """

    parameter_constraints = {
        "num_centers": positive_ints(),
        "width": InstanceOf(type(None))
        | _POSITIVE_FLOAT
        | Predicate(
            lambda v: (
                isinstance(v, (list, tuple))
                and len(v) > 0
                and all(_POSITIVE_FLOAT.is_satisfied_by(x) for x in v)
            ),
            "a non-empty list of floats in (0, inf)",
        ),
        "centers": Options(("grid", "random")),
        "num_random_centers": InstanceOf(type(None)) | Interval(int, 1, None),
        "include_bias": InstanceOf(bool),
    }

    def __init__(
        self,
        *,
        num_centers: int | list[int] = 3,
        width: float | list[float] | None = None,
        centers: str = "grid",
        num_random_centers: int | None = None,
        include_bias: bool = True,
    ):
        self.num_centers = num_centers
        self.width = width
        self.centers = centers
        self.num_random_centers = num_random_centers
        self.include_bias = include_bias

    def setup(self, spec: DomainSpec, seed: int | np.random.SeedSequence) -> RBF:
        """Validate the parameters, place the centers (random ones from ``seed``), return self."""
        self.validate_params()
        rng = make_rng(seed)
        d = spec.num_dims
        counts = per_dimension(self, "num_centers", spec)
        if self.centers == "grid":
            axes = [np.linspace(0.0, 1.0, n) if n > 1 else np.array([0.5]) for n in counts]
            unit = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, d)
            spacing = np.where(counts > 1, 1.0 / np.maximum(counts - 1, 1), 1.0)
        else:
            num = self.num_random_centers
            num = int(np.prod(counts)) if num is None else int(num)
            unit = rng.random((num, d))
            spacing = np.full(d, num ** (-1.0 / d))
        if self.width is None:
            sigma = spacing
        elif isinstance(self.width, (list, tuple)):
            if len(self.width) != d:
                raise InvalidParameterError(
                    f"`RBF.width` must have one entry per state dimension ({d} for "
                    f"{spec.name!r}); got {self.width!r} (length {len(self.width)}). Pass a "
                    f"single float to use it for every dimension."
                )
            sigma = np.array(self.width, dtype=np.float64)
        else:
            sigma = np.full(d, float(self.width))
        span = np.where(spec.high > spec.low, spec.high - spec.low, 1.0)
        self._set_centers(spec, unit * span + spec.low, sigma * span)
        return self

    def _set_centers(self, spec: DomainSpec, centers: np.ndarray, widths: np.ndarray) -> None:
        self.centers_ = np.ascontiguousarray(centers, dtype=np.float64)
        self.widths_ = np.asarray(widths, dtype=np.float64)
        inv = 1.0 / self.widths_
        self._affine = np.ascontiguousarray(np.stack([inv, -spec.low * inv]))  # u = s/σ − low/σ
        self._scaled_centers = np.ascontiguousarray((self.centers_ - spec.low) * inv)
        self.spec_ = spec
        self.num_features_ = int(self.centers_.shape[0] + (1 if self.include_bias else 0))
        self._indices = np.arange(self.num_features_, dtype=np.int64)
        self._indices.flags.writeable = False
        self.is_set_up_ = True

    compiled_methods = ("encode", "active_features")

    def compiled_form(self) -> RepresentationKernel:
        """The Gaussians for the compiled loop: φ(s) lists every feature with `rbf_values`."""
        check_is_set_up(self, "compiled_form")
        rbf = (self._affine, self._scaled_centers)
        return representation_kernel(
            RBF_KIND, self.num_features_, vector=self._indices.copy(), rbf=rbf
        )

    def encode(self, state: np.ndarray) -> SparseFeatures:
        """Return φ(s) as every index 0 .. n − 1 with a fresh float64 array of values."""
        try:
            affine = self._affine
        except AttributeError:
            check_is_set_up(self, "encode")
            raise
        state = self.check_state(state)
        values = rbf_values(state, affine, self._scaled_centers, self.num_features_)
        return SparseFeatures(self._indices, values)

    def state_arrays(self) -> dict[str, np.ndarray]:
        """Return the centers and widths (random centers depend on the setup seed)."""
        check_is_set_up(self, "state_arrays")
        return {"centers": self.centers_.copy(), "widths": self.widths_.copy()}

    def load_state_arrays(self, arrays: dict[str, np.ndarray]) -> None:
        """Restore the centers and widths into a representation set up with the same spec."""
        check_is_set_up(self, "load_state_arrays")
        centers = np.asarray(arrays.get("centers"), dtype=np.float64)
        widths = np.asarray(arrays.get("widths"), dtype=np.float64)
        d = self.spec_.num_dims
        if centers.ndim != 2 or centers.shape[1] != d or widths.shape != (d,):
            raise InvalidParameterError(
                f"RBF.load_state_arrays: expected 'centers' of shape (K, {d}) and 'widths' of "
                f"shape ({d},); got {centers.shape} and {widths.shape}. Were they saved with "
                f"another spec?"
            )
        self._set_centers(self.spec_, centers, widths)
