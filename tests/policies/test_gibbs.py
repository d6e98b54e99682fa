import numpy as np

from conjure.policies import Gibbs


def test_probabilities_follow_eq_2_32():
    values = np.array([1.0, 2.0, 0.5])
    expected = np.exp(values / 2.0) / np.exp(values / 2.0).sum()
    assert np.allclose(Gibbs(temperature=2.0).probabilities(values, np.arange(3)), expected)


def test_zero_temperature_is_greedy_and_large_is_uniform():
    values = np.array([1.0, 3.0, 2.0])
    assert Gibbs(temperature=0.0).probabilities(values, np.arange(3)).tolist() == [0, 1, 0]
    assert np.allclose(Gibbs(temperature=1e9).probabilities(values, np.arange(3)), 1 / 3)


def test_no_overflow_for_large_values():
    probs = Gibbs(temperature=1.0).probabilities(np.array([1e4, 1e4 + 1.0]), np.arange(2))
    assert np.all(np.isfinite(probs)) and probs[1] > probs[0]
