import numpy as np
import scipy.sparse as sp

from conjure.core.linalg import brm_system, lstd_system, row_matrix, solve_regularized


def test_row_matrix_places_features_in_action_slots():
    m = row_matrix(np.array([0, 1, 1]), np.array([0, 2, 3]), 6, column_offsets=np.array([0, 3]))
    assert m.toarray().tolist() == [[1, 1, 0, 0, 0, 0], [0, 0, 0, 0, 1, 0]]


def test_identity_features_recover_the_exact_values():
    rng = np.random.default_rng(0)
    p = rng.random((5, 5))
    p /= p.sum(axis=1, keepdims=True)
    r = rng.random(5)
    exact = np.linalg.solve(np.eye(5) - 0.9 * p, r)
    phi = sp.identity(5, format="csr")
    a, b = lstd_system(phi, sp.csr_matrix(p), r, 0.9)
    assert np.allclose(solve_regularized(a, b), exact)
    a, b = brm_system(phi, sp.csr_matrix(p), r, 0.9)
    assert np.allclose(solve_regularized(a, b), exact)


def test_regularisation_reproduces_figure_2_5():
    a = sp.csr_matrix(np.array([[0.5, -0.45], [-0.45, 0.5]]))
    assert solve_regularized(a, np.array([0.5, 0.0]), 1e-4).round(4).tolist() == [5.2532, 4.7269]


def test_singular_without_regularisation_gives_least_squares():
    a = np.zeros((3, 3))
    a[0, 0] = 2.0
    assert solve_regularized(a, np.array([4.0, 0.0, 0.0])).tolist() == [2.0, 0.0, 0.0]


def test_large_systems_use_sparse_solver():
    n = 5000
    a = sp.diags(np.full(n, 2.0), format="csr")
    assert np.allclose(solve_regularized(a, np.ones(n)), 0.5)
