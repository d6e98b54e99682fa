import numpy as np

from conjure.core.seeding import make_rng
from conjure.policies import EpsilonGreedy


def test_ties_are_broken_uniformly():
    rng = make_rng(0)
    picks = [EpsilonGreedy(epsilon=0.0).select(np.zeros(3), rng, np.arange(3)) for _ in range(3000)]
    assert np.allclose(np.bincount(picks) / 3000, 1 / 3, atol=0.03)


def test_probabilities_follow_eq_2_27():
    probs = EpsilonGreedy(epsilon=0.3).probabilities(np.array([1.0, 5.0, 2.0]), np.arange(3))
    assert np.allclose(probs, [0.1, 0.8, 0.1])


def test_illegal_actions_never_chosen():
    rng = make_rng(1)
    values = np.array([9.0, 0.0, 1.0])
    picks = {EpsilonGreedy(epsilon=0.5).select(values, rng, np.array([1, 2])) for _ in range(500)}
    assert picks == {1, 2}
