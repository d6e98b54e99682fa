"""Least-squares helpers shared by planners and batch learners (Geramifard 2012, Section 2.5).

Sparse feature matrices are assembled from the active features of each sample (Eq. 2.11 puts
φ(s) in the slot of action a, column ``a * n + f``), the LSTD and BRM systems of Eqs. 2.23-2.26,
2.38-2.39 and 2.43-2.44 are formed with sparse products, and θ = A⁻¹b is solved "with
regularisation where the inverse does not exist" (Algorithms 3-6, 13-16).

Notes
-----
- Choice: regularisation is ridge regularisation, θ = (A + λI)⁻¹ b, applied always (λ ≥ 0 is a
  parameter of each algorithm). Figure 2-5's numbers (Q = [5.2532, ..., 4.7269]) are
  reproduced with λ = 10⁻⁴.
- Choice: with λ = 0 and a singular A, the minimum-norm least-squares solution is returned.
- Choice: systems with at most `DENSE_SOLVE_LIMIT` unknowns are solved densely (LAPACK),
  larger ones with warm-started BiCGSTAB, falling back to SuperLU (LSPI's Ã with 10⁴
  unknowns and 3·10⁶ non-zeros fills in badly under LU); no |S| × |S| dense matrix is formed.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from conjure.core.interfaces import Representation

__all__ = [
    "DENSE_SOLVE_LIMIT",
    "brm_system",
    "lstd_system",
    "row_matrix",
    "solve_regularized",
]

#: Systems with at most this many unknowns are solved with dense LAPACK.
DENSE_SOLVE_LIMIT = 3000


def row_matrix(
    indices: np.ndarray,
    indptr: np.ndarray,
    num_columns: int,
    values: np.ndarray | None = None,
    column_offsets: np.ndarray | None = None,
) -> sp.csr_matrix:
    """Return the sparse matrix whose row i holds ``values[indptr[i]:indptr[i+1]]``.

    Parameters
    ----------
    indices : ndarray of int64
        The concatenated active feature indices of every row.
    indptr : ndarray of int64, shape (num_rows + 1,)
        Row boundaries in ``indices``.
    num_columns : int
        Number of columns.
    values : ndarray of float or None, default None
        Feature values (``None``: binary features, all 1).
    column_offsets : ndarray of int64, shape (num_rows,), or None
        Added to every index of a row: ``a_i * n`` places φ(s_i) in action a_i's slot (Eq. 2.11).

    Examples
    --------
    >>> row_matrix(np.array([0, 2, 1]), np.array([0, 2, 3]), 3).toarray().tolist()
    [[1.0, 0.0, 1.0], [0.0, 1.0, 0.0]]
    """
    indices = np.asarray(indices, dtype=np.int64)
    indptr = np.asarray(indptr, dtype=np.int64)
    if column_offsets is not None:
        lengths = np.diff(indptr)
        indices = indices + np.repeat(np.asarray(column_offsets, dtype=np.int64), lengths)
    data = np.ones(indices.shape[0]) if values is None else np.asarray(values, dtype=np.float64)
    num_rows = indptr.shape[0] - 1
    matrix = sp.csr_matrix((data, indices, indptr), shape=(num_rows, int(num_columns)))
    matrix.sum_duplicates()
    return matrix


def feature_matrix(representation: Representation, states: Sequence[np.ndarray]) -> sp.csr_matrix:
    """Return the sparse Φ̃ whose row i is φ(s_i)ᵀ, from the representation's `encode` (Eq. 2.10)."""
    rows = [representation.encode(np.asarray(s, dtype=np.float64)) for s in states]
    lengths = np.fromiter((r.indices.shape[0] for r in rows), dtype=np.int64, count=len(rows))
    indptr = np.concatenate([[0], np.cumsum(lengths)])
    if not rows:
        return row_matrix(np.zeros(0, dtype=np.int64), indptr, representation.num_features_)
    indices = np.concatenate([r.indices for r in rows])
    values = np.concatenate([r.values for r in rows])
    return row_matrix(indices, indptr, representation.num_features_, values=values)


def lstd_system(
    phi: sp.spmatrix, phi_next: sp.spmatrix, rewards: np.ndarray, discount: float
) -> tuple[sp.csr_matrix, np.ndarray]:
    """Return Ã = Φ̃ᵀ(Φ̃ − γ P̃Φ̃)/L and b̃ = Φ̃ᵀR̃/L (Eqs. 2.23-2.24, 2.35-2.36, 2.38-2.39).

    Rows of ``phi_next`` of terminal transitions must be empty (V(terminal) = 0).

    Examples
    --------
    >>> phi = sp.csr_matrix(np.array([[1.0, 0.0], [0.0, 1.0]]))
    >>> nxt = sp.csr_matrix(np.array([[0.0, 1.0], [1.0, 0.0]]))
    >>> a, b = lstd_system(phi, nxt, np.array([1.0, 0.0]), 0.9)
    >>> a.toarray().tolist(), b.tolist()
    ([[0.5, -0.45], [-0.45, 0.5]], [0.5, 0.0])
    """
    num_samples = max(phi.shape[0], 1)
    phi_t = sp.csr_matrix(phi.T)
    a = (phi_t @ (phi - discount * phi_next)) / num_samples
    b = phi_t @ np.asarray(rewards, dtype=np.float64) / num_samples
    return sp.csr_matrix(a), np.asarray(b).reshape(-1)


def brm_system(
    phi: sp.spmatrix,
    phi_next: sp.spmatrix,
    rewards: np.ndarray,
    discount: float,
    phi_next_2: sp.spmatrix | None = None,
) -> tuple[sp.csr_matrix, np.ndarray]:
    """Return the BRM system (Eqs. 2.25-2.26; with ``phi_next_2``, double-sampled Eqs. 2.43-2.44).

    Ã = (Φ̃ − γP̃Φ̃₁)ᵀ(Φ̃ − γP̃Φ̃₂)/L and b̃ = (Φ̃ − γP̃Φ̃₁)ᵀR̃/L; without a second sample
    P̃Φ̃₂ = P̃Φ̃₁ (exact expectations, Algorithm 5).
    """
    num_samples = max(phi.shape[0], 1)
    left = sp.csr_matrix((phi - discount * phi_next).T)
    right = phi - discount * (phi_next if phi_next_2 is None else phi_next_2)
    a = (left @ right) / num_samples
    b = left @ np.asarray(rewards, dtype=np.float64) / num_samples
    return sp.csr_matrix(a), np.asarray(b).reshape(-1)


def solve_regularized(
    a: sp.spmatrix | np.ndarray,
    b: np.ndarray,
    regularization: float = 0.0,
    initial: np.ndarray | None = None,
) -> np.ndarray:
    """Return θ = (A + λI)⁻¹ b, "using regularization if the inverse does not exist" (Alg. 3).

    Parameters
    ----------
    a : sparse matrix or ndarray, shape (n, n)
        The system matrix Ã.
    b : ndarray, shape (n,)
        The right-hand side b̃.
    regularization : float, default 0.0
        λ ≥ 0 added to the diagonal. With λ = 0 and a singular A the minimum-norm
        least-squares solution is returned.
    initial : ndarray or None, default None
        A warm start (e.g. the previous θ of LSPI) for large systems, which are first tried
        with BiCGSTAB (relative tolerance 10⁻¹⁰) and fall back to SuperLU.

    Examples
    --------
    >>> a = np.array([[0.5, -0.45], [-0.45, 0.5]])
    >>> solve_regularized(a, np.array([0.5, 0.0]), 1e-4).round(4).tolist()
    [5.2532, 4.7269]
    """
    n = a.shape[0]
    b = np.asarray(b, dtype=np.float64).reshape(-1)
    if n == 0:
        return np.zeros(0)
    if n <= DENSE_SOLVE_LIMIT:
        dense = a.toarray() if sp.issparse(a) else np.array(a, dtype=np.float64)
        if regularization:
            dense[np.diag_indices(n)] += regularization
        try:
            solution = np.linalg.solve(dense, b)
            if np.all(np.isfinite(solution)):
                return solution
        except np.linalg.LinAlgError:
            pass
        return np.linalg.lstsq(dense, b, rcond=None)[0]
    matrix = sp.csc_matrix(a, dtype=np.float64)
    if regularization:
        matrix = (matrix + regularization * sp.identity(n, format="csc")).tocsc()
    solution, info = spla.bicgstab(matrix, b, x0=initial, rtol=1e-10, maxiter=10 * n)
    if info == 0 and np.all(np.isfinite(solution)):
        return solution
    try:
        solution = spla.splu(matrix).solve(b)
        if np.all(np.isfinite(solution)):
            return solution
    except RuntimeError:  # "Factor is exactly singular"
        pass
    return spla.lsqr(matrix, b, atol=1e-12, btol=1e-12)[0]
