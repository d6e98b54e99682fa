import numpy as np
import scipy.sparse as sp

from conjure.models import steady_state_distribution


def test_figure_2_3():
    d = steady_state_distribution(np.array([[0.7, 0.3], [0.5, 0.5]]))
    assert np.allclose(d, [0.625, 0.375])


def test_is_invariant_on_a_random_sparse_chain():
    rng = np.random.default_rng(1)
    p = sp.random(50, 50, density=0.1, random_state=1) + sp.identity(50) * 0.01
    p = sp.csr_matrix(p.multiply(1.0 / p.sum(axis=1)))
    d = steady_state_distribution(p)
    assert np.isclose(d.sum(), 1.0) and np.all(d >= 0)
    assert np.allclose(d @ p.toarray(), d, atol=1e-10)
    del rng


def test_reducible_chain_falls_back_to_power_iteration():
    d = steady_state_distribution(np.eye(2))
    assert np.allclose(d, [0.5, 0.5])
