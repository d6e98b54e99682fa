import numpy as np
import pytest

from conjure.core import Expansion, InvalidParameterError
from conjure.representations import grow_weights


def test_new_rows_are_sums_of_parents():
    theta = np.array([[1.0, -1.0], [2.0, 0.5], [4.0, 3.0]])
    expansion = Expansion(first_new=3, parents=np.array([[0, 1], [1, 2], [0, 2]]))
    grown = grow_weights(theta, expansion)
    expected = [[1.0, -1.0], [2.0, 0.5], [4.0, 3.0], [3.0, -0.5], [6.0, 3.5], [5.0, 2.0]]
    assert grown.tolist() == expected
    assert theta.shape == (3, 2)  # input untouched


def test_parent_added_earlier_in_the_same_expansion():
    theta = np.array([1.0, 10.0])
    grown = grow_weights(theta, Expansion(first_new=2, parents=np.array([[0, 1], [2, 0]])))
    assert grown.tolist() == [1.0, 10.0, 11.0, 12.0]


def test_nothing_to_add_returns_the_same_array():
    theta = np.zeros((4, 3))
    assert grow_weights(theta, None) is theta
    assert grow_weights(theta, Expansion(first_new=4)) is theta


def test_mismatched_first_new():
    theta = np.zeros((4, 3))
    with pytest.raises(InvalidParameterError, match="4 rows"):
        grow_weights(theta, Expansion(first_new=5, parents=np.array([[0, 1]])))
    with pytest.raises(InvalidParameterError, match="4 rows"):
        grow_weights(theta, Expansion(first_new=3))


@pytest.mark.parametrize("parents", [[[0, 4]], [[-2, 0]], [[0, 1], [0, 5]]])
def test_parents_must_exist(parents):
    with pytest.raises(InvalidParameterError, match="parents"):
        grow_weights(np.zeros((4, 2)), Expansion(first_new=4, parents=np.array(parents)))


def test_dtype_kept():
    theta = np.ones((2, 2), dtype=np.float32)
    grown = grow_weights(theta, Expansion(first_new=2, parents=np.array([[0, 1]])))
    assert grown.dtype == np.float32
    assert grown[2].tolist() == [2.0, 2.0]


def test_missing_parents_copy_or_zero():
    theta = np.array([[1.0, 2.0], [3.0, 4.0]])
    parents = np.array([[1, -1], [-1, -1]])  # a split copy of feature 1, a fresh feature
    grown = grow_weights(theta, Expansion(first_new=2, parents=parents))
    assert grown.tolist() == [[1.0, 2.0], [3.0, 4.0], [3.0, 4.0], [0.0, 0.0]]


def test_growth_one_feature_at_a_time_reuses_the_buffer():
    theta = np.zeros((1000, 3))
    buffers = set()
    for n in range(1000, 1100):
        theta = grow_weights(theta, Expansion(first_new=n, parents=np.array([[0, n - 1]])))
        buffers.add(id(theta.base))
    assert theta.shape == (1100, 3)
    assert len(buffers) == 1  # one reallocation (to 2000 rows) for 100 additions
