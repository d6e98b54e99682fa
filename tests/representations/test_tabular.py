import numpy as np
import pytest

from conjure.core import InvalidParameterError, NotSetUpError
from conjure.representations import Tabular
from conjure.testing import box_spec

PENDULUM = box_spec([-np.pi / 2, -2.0], [np.pi / 2, 2.0], name="pendulum")


def random_states(spec, num, seed=0, margin=0.2):
    rng = np.random.default_rng(seed)
    span = spec.high - spec.low
    return rng.uniform(spec.low - margin * span, spec.high + margin * span, (num, spec.num_dims))


def test_pendulum_has_400_features():
    rep = Tabular().setup(PENDULUM, seed=0)
    assert rep.num_features_ == 400


def test_one_sorted_int64_index_in_range():
    rep = Tabular(num_buckets=[7, 5]).setup(PENDULUM, seed=0)
    for state in random_states(PENDULUM, 500):
        phi = rep.active_features(state)
        assert phi.dtype == np.int64
        assert phi.shape == (1,)
        assert 0 <= phi[0] < rep.num_features_


def test_same_state_same_features():
    rep = Tabular(num_buckets=6).setup(PENDULUM, seed=0)
    for state in random_states(PENDULUM, 50):
        np.testing.assert_array_equal(rep.active_features(state), rep.active_features(state.copy()))


def test_grid_cells_biject_with_features():
    spec = box_spec([0.0, -1.0], [4.0, 2.0])
    rep = Tabular(num_buckets=[4, 3]).setup(spec, seed=0)
    xs = np.linspace(0.0, 4.0, 161)
    ys = np.linspace(-1.0, 2.0, 121)
    cell_to_feature = {}
    feature_to_cell = {}
    for x in xs:
        for y in ys:
            cell = (min(int(x), 3), min(int(y + 1.0), 2))
            (feature,) = rep.active_features(np.array([x, y])).tolist()
            assert cell_to_feature.setdefault(cell, feature) == feature
            assert feature_to_cell.setdefault(feature, cell) == cell
    assert len(feature_to_cell) == 4 * 3 == rep.num_features_


def test_discrete_dimensions_bucket_by_value():
    spec = box_spec([0.0, 2.0], [1.0, 6.0], is_discrete=[False, True])
    rep = Tabular(num_buckets=[2, 99]).setup(spec, seed=0)  # entry of a discrete dim ignored
    assert rep.num_features_ == 2 * 5
    features = {int(rep.active_features(np.array([0.2, v]))[0]) for v in range(2, 7)}
    assert len(features) == 5
    # integer values are identified even when slightly off
    for v in range(2, 7):
        np.testing.assert_array_equal(
            rep.active_features(np.array([0.2, v + 0.3])),
            rep.active_features(np.array([0.2, float(v)])),
        )


def test_out_of_bounds_states_are_clipped_into_edge_cells():
    spec = box_spec([0.0], [1.0])
    rep = Tabular(num_buckets=4).setup(spec, seed=0)
    assert rep.active_features(np.array([-3.0])).tolist() == [0]
    assert rep.active_features(np.array([1.0])).tolist() == [3]
    assert rep.active_features(np.array([7.0])).tolist() == [3]


def test_lists_and_int_states_are_accepted():
    rep = Tabular(num_buckets=4).setup(box_spec([0.0, 0.0], [4.0, 4.0]), seed=0)
    assert (
        rep.active_features([1, 2]).tolist() == rep.active_features(np.array([1.0, 2.0])).tolist()
    )


def test_wrong_state_shape_is_a_clear_error():
    rep = Tabular().setup(PENDULUM, seed=0)
    with pytest.raises(InvalidParameterError, match=r"\(3,\)"):
        rep.active_features(np.zeros(3))
    with pytest.raises(InvalidParameterError, match=r"\(2, 1\)"):
        rep.active_features(np.zeros((2, 1)))


@pytest.mark.parametrize("num_buckets", [0, -3, 2.5, [4, 0], [], "20", True])
def test_bad_num_buckets(num_buckets):
    with pytest.raises(InvalidParameterError, match=r"`Tabular.num_buckets`"):
        Tabular(num_buckets=num_buckets).setup(PENDULUM, seed=0)


def test_wrong_length_list_names_param_value_and_length():
    with pytest.raises(InvalidParameterError, match=r"`Tabular.num_buckets`.*2.*\[4, 4, 4\]"):
        Tabular(num_buckets=[4, 4, 4]).setup(PENDULUM, seed=0)


def test_not_set_up():
    with pytest.raises(NotSetUpError):
        Tabular().active_features(np.zeros(2))


def test_state_arrays_round_trip():
    rep = Tabular(num_buckets=[9, 4]).setup(PENDULUM, seed=0)
    other = Tabular(num_buckets=[9, 4]).setup(PENDULUM, seed=1)
    other.load_state_arrays(rep.state_arrays())
    for state in random_states(PENDULUM, 300, seed=3):
        np.testing.assert_array_equal(rep.active_features(state), other.active_features(state))


def test_clone_is_not_set_up():
    rep = Tabular(num_buckets=5).setup(PENDULUM, seed=0)
    with pytest.raises(NotSetUpError):
        rep.clone().active_features(np.zeros(2))
