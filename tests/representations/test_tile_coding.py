import numpy as np
import pytest

from conjure.core import InvalidParameterError, NotSetUpError
from conjure.representations import TileCoding
from conjure.testing import box_spec

PENDULUM = box_spec([-np.pi / 2, -2.0], [np.pi / 2, 2.0], name="pendulum")
LINE = box_spec([0.0], [1.0], name="line")
CUBE = box_spec([0.0, -1.0, 0.0], [1.0, 1.0, 3.0], is_discrete=[False, False, True])


def random_states(spec, num, seed=0, margin=0.2):
    rng = np.random.default_rng(seed)
    span = spec.high - spec.low
    return rng.uniform(spec.low - margin * span, spec.high + margin * span, (num, spec.num_dims))


def check_indices(phi, num_features):
    assert phi.dtype == np.int64
    assert phi.ndim == 1
    assert np.all(np.diff(phi) > 0), phi
    assert np.all((phi >= 0) & (phi < num_features)), phi


def test_exactly_num_tilings_sorted_unique_active():
    rep = TileCoding(num_tilings=8, tiles_per_dim=10).setup(PENDULUM, seed=0)
    assert rep.num_features_ == 8 * 11 * 11
    for state in random_states(PENDULUM, 1000):
        phi = rep.active_features(state)
        check_indices(phi, rep.num_features_)
        assert phi.shape == (8,)
        # one tile per tiling, in tiling order
        assert np.array_equal(phi // 121, np.arange(8))


def test_same_state_same_features():
    rep = TileCoding().setup(PENDULUM, seed=0)
    for state in random_states(PENDULUM, 50):
        np.testing.assert_array_equal(rep.active_features(state), rep.active_features(state.copy()))


def test_hand_checked_one_dimensional_case():
    # 4 tilings of 2 tiles (width 0.5) plus the extra tile; tiling t shifted by t/4 of a tile
    rep = TileCoding(num_tilings=4, tiles_per_dim=2).setup(LINE, seed=0)
    assert rep.num_features_ == 4 * 3
    expected = {
        0.0: [0, 3, 6, 9],
        0.3: [0, 3, 7, 10],
        0.49: [0, 4, 7, 10],
        0.5: [1, 4, 7, 10],
        1.0: [2, 5, 8, 11],
        -2.0: [0, 3, 6, 9],
        3.0: [2, 5, 8, 11],
    }
    for x, indices in expected.items():
        assert rep.active_features(np.array([x])).tolist() == indices, x


def test_asymmetric_offsets_in_two_dimensions():
    # tiling t shifts dim 0 by t/T and dim 1 by 3t/T tile widths (mod one tile)
    spec = box_spec([0.0, 0.0], [1.0, 1.0])
    rep = TileCoding(num_tilings=4, tiles_per_dim=1).setup(spec, seed=0)
    # each tiling has 2 x 2 tiles; a state just above 1 - 1/4 of a tile in dim 1 moves to
    # the upper tile in tilings whose dim-1 shift (3t mod 4)/4 is >= 1/4
    phi = rep.active_features(np.array([0.0, 0.8]))
    upper_in_dim1 = (phi % 4) % 2
    assert upper_in_dim1.tolist() == [0, 1, 1, 1]  # shifts 0, 3/4, 2/4, 1/4
    phi = rep.active_features(np.array([0.6, 0.0]))
    upper_in_dim0 = (phi % 4) // 2
    assert upper_in_dim0.tolist() == [0, 0, 1, 1]  # shifts 0, 1/4, 2/4, 3/4


def test_locality():
    rep = TileCoding(num_tilings=8, tiles_per_dim=10).setup(PENDULUM, seed=0)
    width = (PENDULUM.high - PENDULUM.low) / 10
    rng = np.random.default_rng(1)
    for state in random_states(PENDULUM, 300, margin=0.0):
        phi = set(rep.active_features(state).tolist())
        for d in range(2):
            near = state.copy()
            near[d] += rng.uniform(-1, 1) * 0.99 * width[d] / 8
            assert len(phi & set(rep.active_features(near).tolist())) >= 7
        both = state + rng.uniform(-1, 1, 2) * 0.99 * width / 8
        assert len(phi & set(rep.active_features(both).tolist())) >= 6
        far = state.copy()
        far[0] += 1.01 * width[0] * (1 if state[0] < 0 else -1)
        assert not phi & set(rep.active_features(far).tolist())


def test_discrete_dimension_one_tile_per_value():
    spec = box_spec([0.0, 0.0], [1.0, 3.0], is_discrete=[False, True])
    rep = TileCoding(num_tilings=4, tiles_per_dim=[2, 100]).setup(spec, seed=0)
    assert rep.num_features_ == 4 * 3 * 4
    for x in np.linspace(0, 1, 7):
        phis = [set(rep.active_features(np.array([x, v])).tolist()) for v in range(4)]
        for a in range(4):
            for b in range(a + 1, 4):
                assert not phis[a] & phis[b]
        assert phis[2] == set(rep.active_features(np.array([x, 2.2])).tolist())


def test_dimension_groups():
    groups = [[0], [1], [0, 2], [1, 0, 2]]
    rep = TileCoding(num_tilings=3, tiles_per_dim=4, dimension_groups=groups).setup(CUBE, seed=0)
    # continuous dims: 4 + 1 tiles; the discrete dim: 4 values
    per_tiling = [5, 5, 5 * 4, 5 * 5 * 4]
    assert rep.num_features_ == 3 * sum(per_tiling)
    assert rep.num_active_ == 3 * len(groups)
    bounds = np.cumsum([0] + [3 * n for n in per_tiling])
    for state in random_states(CUBE, 500):
        phi = rep.active_features(state)
        check_indices(phi, rep.num_features_)
        assert phi.shape == (12,)
        for g in range(4):
            assert np.sum((phi >= bounds[g]) & (phi < bounds[g + 1])) == 3


def test_group_over_one_dimension_ignores_the_others():
    rep = TileCoding(num_tilings=4, tiles_per_dim=5, dimension_groups=[[1]]).setup(CUBE, seed=0)
    a = rep.active_features(np.array([0.1, 0.3, 0.0]))
    b = rep.active_features(np.array([0.9, 0.3, 3.0]))
    np.testing.assert_array_equal(a, b)


def test_hashed_with_large_memory_is_the_same_partition():
    plain = TileCoding(num_tilings=8, tiles_per_dim=6).setup(PENDULUM, seed=0)
    hashed = TileCoding(num_tilings=8, tiles_per_dim=6, memory_size=100_000).setup(PENDULUM, 0)
    states = random_states(PENDULUM, 1500, seed=4)
    rng = np.random.default_rng(5)
    nearby = states + rng.normal(0.0, 0.05, states.shape)  # pairs sharing some tiles
    plain_sets, hashed_sets = [], []
    for state in np.concatenate([states, nearby]):
        h = hashed.active_features(state)
        check_indices(h, hashed.num_features_)
        plain_sets.append(set(plain.active_features(state).tolist()))
        hashed_sets.append(set(h.tolist()))
    # every pair of states shares as many hashed indices as tiles
    n = len(states)
    shared = 0
    for a in range(n):
        for b in (a + 1, a + n, int(rng.integers(2 * n))):
            if b < 2 * n:
                overlap = len(plain_sets[a] & plain_sets[b])
                assert overlap == len(hashed_sets[a] & hashed_sets[b])
                shared += overlap
    assert shared > n  # the check compared non-trivial overlaps
    # and as many distinct indices as tiles were seen: the map is a bijection
    assert len(set().union(*plain_sets)) == len(set().union(*hashed_sets)) == hashed.num_stored_
    assert hashed.num_collisions_ == 0


def test_hashed_indices_in_order_of_first_appearance_and_bijective():
    plain = TileCoding(num_tilings=4, tiles_per_dim=5).setup(PENDULUM, seed=0)
    hashed = TileCoding(num_tilings=4, tiles_per_dim=5, memory_size=10_000).setup(PENDULUM, 0)
    seen = {}
    for state in random_states(PENDULUM, 2000, seed=7):
        p = plain.active_features(state).tolist()
        new = [i for i in p if i not in seen]
        h = hashed.active_features(state).tolist()
        # tiles new to the table get the next indices, in tiling order
        for i in new:
            seen[i] = len(seen)
        assert sorted(seen[i] for i in p) == h
    assert hashed.num_stored_ == len(seen)
    assert hashed.num_collisions_ == 0
    assert len(set(seen.values())) == len(seen)  # a bijection between tiles and indices


def test_tiny_memory_counts_collisions_and_stays_in_range():
    rep = TileCoding(num_tilings=8, tiles_per_dim=10, memory_size=5).setup(PENDULUM, seed=0)
    assert rep.num_features_ == 5
    lengths = set()
    for state in random_states(PENDULUM, 500):
        phi = rep.active_features(state)
        check_indices(phi, 5)
        lengths.add(phi.shape[0])
    assert rep.num_stored_ == 5
    assert rep.num_collisions_ > 0
    assert max(lengths) <= 5 and min(lengths) >= 1


def test_hashed_same_state_same_features_after_full():
    rep = TileCoding(num_tilings=8, tiles_per_dim=10, memory_size=50).setup(PENDULUM, seed=0)
    states = random_states(PENDULUM, 200)
    first = [rep.active_features(s) for s in states]
    for s, phi in zip(states, first, strict=True):
        np.testing.assert_array_equal(rep.active_features(s), phi)


def test_unhashed_has_no_collisions():
    rep = TileCoding().setup(PENDULUM, seed=0)
    assert rep.num_collisions_ == 0
    assert rep.state_arrays() == {}


@pytest.mark.parametrize("memory_size", [None, 64, 100_000])
def test_state_arrays_round_trip(memory_size):
    params = dict(num_tilings=8, tiles_per_dim=7, memory_size=memory_size)
    rep = TileCoding(**params).setup(PENDULUM, seed=0)
    for state in random_states(PENDULUM, 300, seed=1):
        rep.active_features(state)
    other = TileCoding(**params).setup(PENDULUM, seed=0)
    other.load_state_arrays(rep.state_arrays())
    for state in random_states(PENDULUM, 500, seed=2):  # seen and unseen tiles alike
        np.testing.assert_array_equal(rep.active_features(state), other.active_features(state))
    assert other.num_collisions_ == rep.num_collisions_


def test_fresh_hashed_table_differs_without_restore():
    # guards the round-trip test: the order of first appearance matters
    params = dict(num_tilings=8, tiles_per_dim=7, memory_size=100_000)
    rep = TileCoding(**params).setup(PENDULUM, seed=0)
    for state in random_states(PENDULUM, 300, seed=1):
        rep.active_features(state)
    fresh = TileCoding(**params).setup(PENDULUM, seed=0)
    states = random_states(PENDULUM, 50, seed=2)
    assert any(not np.array_equal(rep.active_features(s), fresh.active_features(s)) for s in states)


def test_load_state_arrays_rejects_wrong_shapes():
    rep = TileCoding(memory_size=64).setup(PENDULUM, seed=0)
    other = TileCoding(memory_size=4096).setup(PENDULUM, seed=0)
    with pytest.raises(InvalidParameterError, match="hash_table"):
        other.load_state_arrays(rep.state_arrays())


def test_wrong_state_shape_is_a_clear_error():
    rep = TileCoding().setup(PENDULUM, seed=0)
    with pytest.raises(InvalidParameterError, match=r"\(3,\).*another domain's spec"):
        rep.active_features(np.zeros(3))


@pytest.mark.parametrize(
    ("params", "name"),
    [
        ({"num_tilings": 0}, "num_tilings"),
        ({"num_tilings": 2.0}, "num_tilings"),
        ({"tiles_per_dim": -1}, "tiles_per_dim"),
        ({"tiles_per_dim": [10, 0]}, "tiles_per_dim"),
        ({"tiles_per_dim": [10, 10, 10]}, "tiles_per_dim"),
        ({"dimension_groups": [[0, 2]]}, "dimension_groups"),
        ({"dimension_groups": [[0, -1]]}, "dimension_groups"),
        ({"dimension_groups": [[]]}, "dimension_groups"),
        ({"dimension_groups": []}, "dimension_groups"),
        ({"dimension_groups": [[0, 0]]}, "dimension_groups"),
        ({"dimension_groups": [0, 1]}, "dimension_groups"),
        ({"memory_size": 0}, "memory_size"),
    ],
)
def test_bad_params_name_the_param(params, name):
    with pytest.raises(InvalidParameterError, match=rf"`TileCoding.{name}`"):
        TileCoding(**params).setup(PENDULUM, seed=0)


def test_num_tilings_message():
    with pytest.raises(InvalidParameterError) as info:
        TileCoding(num_tilings=0).setup(PENDULUM, seed=0)
    assert str(info.value) == "`TileCoding.num_tilings` must be an int in [1, 2^63); got 0."


def test_out_of_range_group_message_names_value():
    with pytest.raises(InvalidParameterError, match=r"dimension 2.*2 dimensions.*\[\[0, 2\]\]"):
        TileCoding(dimension_groups=[[0, 2]]).setup(PENDULUM, seed=0)


def test_too_many_tiles_is_refused():
    spec = box_spec([0.0] * 20, [1.0] * 20)
    with pytest.raises(InvalidParameterError, match="dimension_groups"):
        TileCoding(tiles_per_dim=10).setup(spec, seed=0)


def test_not_set_up():
    with pytest.raises(NotSetUpError):
        TileCoding().active_features(np.zeros(2))
    with pytest.raises(NotSetUpError):
        TileCoding().state_arrays()


def _stored(rep) -> dict[str, np.ndarray]:
    return {key: value.copy() for key, value in rep.state_arrays().items()}


@pytest.mark.parametrize("memory_size", [None, 50, 100_000])
def test_peek_gives_what_storing_would_give_and_stores_nothing(memory_size):
    # Greedy acting's φ(s): new tiles get the index storing would give them (50: the table
    # fills up after a few states, then new keys fall back to hash % memory_size).
    params = dict(num_tilings=8, tiles_per_dim=10, memory_size=memory_size)
    rep = TileCoding(**params).setup(PENDULUM, seed=0)
    for state in random_states(PENDULUM, 60):
        before = _stored(rep)
        peeked = rep.peek(state)
        after = _stored(rep)
        assert after.keys() == before.keys()
        for key in before:
            np.testing.assert_array_equal(after[key], before[key])
        np.testing.assert_array_equal(peeked.indices, rep.active_features(state))
        np.testing.assert_array_equal(peeked.values, np.ones(len(peeked.indices)))
    assert memory_size != 50 or rep.num_collisions_ > 0  # the fallback was exercised
