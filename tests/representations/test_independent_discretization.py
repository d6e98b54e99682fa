import numpy as np
import pytest

from conjure.core import InvalidParameterError, NotSetUpError
from conjure.representations import IndependentDiscretization
from conjure.testing import box_spec

PENDULUM = box_spec([-np.pi / 2, -2.0], [np.pi / 2, 2.0], name="pendulum")
MIXED = box_spec([0.0, -1.0, 0.0], [1.0, 1.0, 3.0], is_discrete=[False, False, True])


def random_states(spec, num, seed=0, margin=0.2):
    rng = np.random.default_rng(seed)
    span = spec.high - spec.low
    return rng.uniform(spec.low - margin * span, spec.high + margin * span, (num, spec.num_dims))


def test_pendulum_initial_features():
    rep = IndependentDiscretization().setup(PENDULUM, seed=0)
    assert rep.num_features_ == 40  # x 3 actions = 120, Section 4.1.4


def test_exactly_one_active_feature_per_dimension_block():
    rep = IndependentDiscretization(num_buckets=[5, 7, 1]).setup(MIXED, seed=0)
    assert rep.num_buckets_.tolist() == [5, 7, 4]
    assert rep.num_features_ == 16
    blocks = np.concatenate([rep.offsets_, [rep.num_features_]])
    for state in random_states(MIXED, 500):
        phi = rep.active_features(state)
        assert phi.dtype == np.int64
        assert phi.shape == (3,)
        assert np.all(np.diff(phi) > 0)
        for d in range(3):
            assert blocks[d] <= phi[d] < blocks[d + 1]


def test_bucket_edges():
    rep = IndependentDiscretization(num_buckets=4).setup(box_spec([0.0], [1.0]), seed=0)
    expected = {-5.0: 0, 0.0: 0, 0.2499: 0, 0.25: 1, 0.4999: 1, 0.5: 2, 0.75: 3, 1.0: 3, 5.0: 3}
    for value, bucket in expected.items():
        assert rep.active_features(np.array([value])).tolist() == [bucket], value


def test_discrete_dimension_by_value():
    rep = IndependentDiscretization(num_buckets=2).setup(MIXED, seed=0)
    third = [int(rep.active_features(np.array([0.5, 0.0, v]))[2]) for v in range(4)]
    assert third == [rep.offsets_[2] + v for v in range(4)]


def test_same_state_same_features():
    rep = IndependentDiscretization().setup(PENDULUM, seed=0)
    for state in random_states(PENDULUM, 50):
        np.testing.assert_array_equal(rep.active_features(state), rep.active_features(state.copy()))


def test_wrong_state_shape_is_a_clear_error():
    rep = IndependentDiscretization().setup(PENDULUM, seed=0)
    with pytest.raises(InvalidParameterError, match=r"\(4,\)"):
        rep.active_features(np.zeros(4))


@pytest.mark.parametrize("num_buckets", [0, -1, [3, -2], None])
def test_bad_num_buckets(num_buckets):
    with pytest.raises(InvalidParameterError, match=r"`IndependentDiscretization.num_buckets`"):
        IndependentDiscretization(num_buckets=num_buckets).setup(PENDULUM, seed=0)


def test_wrong_length_list():
    with pytest.raises(InvalidParameterError, match=r"num_buckets.*\(2 for 'pendulum'\).*\[3\]"):
        IndependentDiscretization(num_buckets=[3]).setup(PENDULUM, seed=0)


def test_not_set_up():
    with pytest.raises(NotSetUpError):
        IndependentDiscretization().active_features(np.zeros(2))


def test_state_arrays_round_trip():
    rep = IndependentDiscretization(num_buckets=[3, 8, 1]).setup(MIXED, seed=0)
    other = IndependentDiscretization(num_buckets=[3, 8, 1]).setup(MIXED, seed=5)
    other.load_state_arrays(rep.state_arrays())
    for state in random_states(MIXED, 300, seed=2):
        np.testing.assert_array_equal(rep.active_features(state), other.active_features(state))
