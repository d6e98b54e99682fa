import numpy as np
import pytest

from conjure.core import (
    IncompatibleComponentsError,
    InvalidParameterError,
    NotSetUpError,
)
from conjure.representations import RBF
from conjure.testing import box_spec

PENDULUM = box_spec([-np.pi / 2, -2.0], [np.pi / 2, 2.0], name="pendulum")


def random_states(spec, num, seed=0):
    rng = np.random.default_rng(seed)
    return rng.uniform(spec.low, spec.high, (num, spec.num_dims))


def test_lagoudakis_parr_grid_plus_bias():
    rep = RBF().setup(PENDULUM, seed=0)
    assert rep.num_features_ == 10
    assert rep.centers_.shape == (9, 2)
    np.testing.assert_allclose(rep.centers_[0], PENDULUM.low)
    np.testing.assert_allclose(rep.centers_[-1], PENDULUM.high)
    np.testing.assert_allclose(rep.widths_, (PENDULUM.high - PENDULUM.low) / 2)
    phi = rep.feature_values(np.zeros(2))
    assert phi.shape == (10,) and phi.dtype == np.float64
    assert phi[-1] == 1.0


def test_grid_count_and_no_bias():
    spec = box_spec([0.0, 0.0, 0.0], [1.0, 2.0, 3.0])
    rep = RBF(num_centers=[2, 3, 4], include_bias=False).setup(spec, seed=0)
    assert rep.num_features_ == 24
    assert len({tuple(c) for c in rep.centers_.tolist()}) == 24
    assert rep.feature_values(np.zeros(3)).shape == (24,)


def test_value_one_at_each_center():
    rep = RBF(num_centers=[3, 4]).setup(PENDULUM, seed=0)
    for k, center in enumerate(rep.centers_):
        phi = rep.feature_values(center)
        assert phi[k] == pytest.approx(1.0)
        assert np.all(np.delete(phi[:-1], k) < 1.0)


def test_formula():
    spec = box_spec([0.0, 10.0], [2.0, 20.0])
    rep = RBF(num_centers=2, width=[0.25, 0.5], include_bias=False).setup(spec, seed=0)
    state = np.array([0.3, 13.0])
    sigma = np.array([0.5, 5.0])
    expected = [np.exp(-0.5 * np.sum(((state - c) / sigma) ** 2)) for c in rep.centers_]
    np.testing.assert_allclose(rep.feature_values(state), expected)


def test_symmetric_decay():
    rep = RBF(num_centers=3).setup(PENDULUM, seed=0)
    center = rep.centers_[4]
    previous = 1.0
    for step in np.linspace(0.05, 1.0, 10):
        delta = step * rep.widths_ * np.array([1.0, -0.5])
        up = rep.feature_values(center + delta)[4]
        down = rep.feature_values(center - delta)[4]
        assert up == pytest.approx(down)
        assert up < previous
        previous = up


def test_random_centers_from_seed():
    rep = RBF(centers="random", num_random_centers=30).setup(PENDULUM, seed=3)
    assert rep.num_features_ == 31
    assert np.all((rep.centers_ >= PENDULUM.low) & (rep.centers_ <= PENDULUM.high))
    same = RBF(centers="random", num_random_centers=30).setup(PENDULUM, seed=3)
    other = RBF(centers="random", num_random_centers=30).setup(PENDULUM, seed=4)
    np.testing.assert_array_equal(rep.centers_, same.centers_)
    assert not np.allclose(rep.centers_, other.centers_)
    default = RBF(centers="random", num_centers=[2, 5]).setup(PENDULUM, seed=0)
    assert default.centers_.shape == (10, 2)


def test_state_arrays_round_trip_with_random_centers():
    rep = RBF(centers="random", num_random_centers=12).setup(PENDULUM, seed=1)
    other = RBF(centers="random", num_random_centers=12).setup(PENDULUM, seed=2)
    other.load_state_arrays(rep.state_arrays())
    for state in random_states(PENDULUM, 200):
        np.testing.assert_array_equal(rep.feature_values(state), other.feature_values(state))


def test_load_state_arrays_rejects_wrong_shapes():
    rep = RBF().setup(PENDULUM, seed=0)
    with pytest.raises(InvalidParameterError, match="centers"):
        rep.load_state_arrays({"centers": np.zeros((4, 3)), "widths": np.ones(3)})


def test_fresh_array_and_same_state_same_values():
    rep = RBF().setup(PENDULUM, seed=0)
    state = np.array([0.2, -0.4])
    phi = rep.feature_values(state)
    phi[:] = -1.0
    again = rep.feature_values(state)
    assert np.all(again > 0)
    np.testing.assert_array_equal(again, rep.feature_values([0.2, -0.4]))


def test_active_features_is_incompatible():
    rep = RBF().setup(PENDULUM, seed=0)
    assert not rep.encode(np.zeros(2)).has_unit_values()
    with pytest.raises(IncompatibleComponentsError, match="RBF has real-valued features"):
        rep.active_features(np.zeros(2))


def test_wrong_state_shape_is_a_clear_error():
    rep = RBF().setup(PENDULUM, seed=0)
    with pytest.raises(InvalidParameterError, match=r"\(5,\)"):
        rep.feature_values(np.zeros(5))


@pytest.mark.parametrize(
    ("params", "name"),
    [
        ({"num_centers": 0}, "num_centers"),
        ({"num_centers": [3, -1]}, "num_centers"),
        ({"num_centers": [3, 3, 3]}, "num_centers"),
        ({"width": -1.0}, "width"),
        ({"width": 0.0}, "width"),
        ({"width": [0.5]}, "width"),
        ({"centers": "hexagonal"}, "centers"),
        ({"centers": "random", "num_random_centers": 0}, "num_random_centers"),
        ({"include_bias": 1}, "include_bias"),
    ],
)
def test_bad_params_name_the_param(params, name):
    with pytest.raises(InvalidParameterError, match=rf"`RBF.{name}`"):
        RBF(**params).setup(PENDULUM, seed=0)


def test_not_set_up():
    with pytest.raises(NotSetUpError):
        RBF().feature_values(np.zeros(2))
