"""The steady-state distribution of a policy's Markov chain (Geramifard 2012, Eq. 2.14)."""

from __future__ import annotations

import warnings

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from conjure.core.errors import InvalidParameterError

__all__ = ["steady_state_distribution"]


def steady_state_distribution(
    transitions: sp.spmatrix | np.ndarray,
    *,
    tolerance: float = 1e-12,
    max_iterations: int = 100_000,
) -> np.ndarray:
    """Return d with dP = d, ‖d‖₁ = 1 and d ≥ 0 (Eq. 2.14), for a row-stochastic P.

    Parameters
    ----------
    transitions : sparse matrix or ndarray, shape (|S|, |S|)
        The chain P^π (rows sum to 1).
    tolerance : float, default 1e-12
        Stopping tolerance (L1 change) of the power-iteration fallback.
    max_iterations : int, default 100000
        Iterations of the power-iteration fallback.

    Notes
    -----
    - Choice: d is the solution of the sparse linear system (Pᵀ − I)d = 0 with one equation
      replaced by Σ d = 1 (exact for an irreducible chain). If that system is singular or gives
      negative entries (several recurrent classes), the power iteration of the lazy chain
      (P + I)/2 (aperiodic, same stationary distributions) from the uniform distribution is
      returned instead.

    Complexity
    ----------
    One sparse LU of an |S| × |S| matrix; the fallback is Θ(nnz(P)) per iteration.

    Examples
    --------
    Figure 2-3's chain:

    >>> steady_state_distribution(np.array([[0.7, 0.3], [0.5, 0.5]])).round(4).tolist()
    [0.625, 0.375]
    """
    matrix = sp.csr_matrix(transitions, dtype=np.float64)
    n = matrix.shape[0]
    if matrix.shape != (n, n) or n == 0:
        raise InvalidParameterError(
            f"steady_state_distribution needs a square, non-empty matrix; got {matrix.shape}."
        )
    system = sp.lil_matrix(matrix.T - sp.identity(n, format="csr"))
    system[n - 1, :] = np.ones(n)
    rhs = np.zeros(n)
    rhs[n - 1] = 1.0
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            d = spla.splu(sp.csc_matrix(system)).solve(rhs)
        if np.all(np.isfinite(d)) and d.min() > -1e-10:
            d = np.clip(d, 0.0, None)
            return d / d.sum()
    except RuntimeError:
        pass
    transposed = sp.csr_matrix(matrix.T)
    current = np.full(n, 1.0 / n)
    for _ in range(max_iterations):
        following = 0.5 * (current + transposed @ current)  # the lazy chain (P + I)/2
        if np.abs(following - current).sum() < tolerance:
            current = following
            break
        current = following
    return current / current.sum()
