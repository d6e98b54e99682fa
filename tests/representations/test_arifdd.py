import numpy as np
import pytest

from conjure.agents import SARSA
from conjure.core import InvalidParameterError, NotSetUpError
from conjure.domains import InvertedPendulum
from conjure.representations.arifdd import ARiFDD
from conjure.representations.independent_discretization import IndependentDiscretization
from conjure.representations.online_ifdd import OnlineIFDD
from conjure.representations.weights import grow_weights
from conjure.testing import box_spec, check_component
from conjure.testing.checks import _rollout

LINE = box_spec([0.0], [1.0], name="line")
SQUARE = box_spec([0.0, 0.0], [1.0, 1.0], name="square")
PENDULUM = box_spec([-np.pi / 2, -2.0], [np.pi / 2, 2.0], name="pendulum")
MIXED = box_spec([0.0, -1.0, 0.0], [1.0, 1.0, 5.0], is_discrete=[False, False, True])


def random_states(spec, num, seed=0):
    rng = np.random.default_rng(seed)
    states = rng.uniform(spec.low, spec.high, (num, spec.num_dims))
    states[:, spec.is_discrete] = np.round(states[:, spec.is_discrete])
    return states


def step(rep, state, delta):
    state = np.asarray(state, dtype=float)
    return rep.discover(rep.active_features(state), delta, state)


def feed(rep, stream):
    """discover() for each (state, δ); return the (step, expansion) pairs that added features."""
    grown = []
    for k, (state, delta) in enumerate(stream):
        expansion = step(rep, state, delta)
        if expansion is not None:
            grown.append((k, expansion))
    return grown


def assert_same_state(rep, other):
    """Equal state arrays (the activation cache's counters are not saved)."""
    mine, theirs = rep.state_arrays(), other.state_arrays()
    assert mine.keys() == theirs.keys()
    for name, value in mine.items():
        np.testing.assert_array_equal(value, theirs[name], err_msg=name)


def check_cover(rep, state):
    """φ̇(s) is sorted, unique, in range, and a disjoint cover of the live tiles φ⁰(s)."""
    phi = rep.active_features(state)
    assert phi.dtype == np.int64 and phi.size > 0
    assert np.all(np.diff(phi) > 0) and phi[0] >= 0 and phi[-1] < rep.num_features_, phi
    basic = rep.base_.active_features(np.asarray(state, dtype=float))
    covered = np.sort(np.concatenate([rep.initial_set(int(f)) for f in phi]))
    np.testing.assert_array_equal(covered, basic)  # disjoint: no id twice
    assert not np.intersect1d(covered, rep.retired_tiles_).size
    return phi


# ------------------------------------------------------------------------------ basic tiles


def test_initial_tiles_are_equal_intervals_numbered_by_dimension():
    rep = ARiFDD(initial_tiles_per_dim=[2, 4]).setup(PENDULUM, seed=0)
    assert rep.num_features_ == 6 and rep.is_adaptive
    assert rep.encode(np.zeros(2)).has_unit_values()
    tiles = rep.basic_tiles_
    assert tiles["feature"].tolist() == [0, 1, 2, 3, 4, 5]
    assert tiles["dim"].tolist() == [0, 0, 1, 1, 1, 1]
    np.testing.assert_allclose(tiles["low"], [-np.pi / 2, 0.0, -2.0, -1.0, 0.0, 1.0])
    assert rep.active_features(np.array([-1.0, 1.5])).tolist() == [0, 5]
    assert rep.active_features(np.array([0.0, -1.0])).tolist() == [1, 3]  # boundary: upper
    assert rep.active_features(np.array([9.0, -9.0])).tolist() == [1, 2]  # clipped
    assert rep.active_features(np.array([np.nan, np.nan])).tolist() == [0, 2]


def test_discrete_dimension_groups_integer_values():
    spec = box_spec([0.0], [5.0], is_discrete=[True])
    rep = ARiFDD(initial_tiles_per_dim=3).setup(spec, seed=0)
    assert [int(rep.active_features([x])[0]) for x in range(6)] == [0, 0, 1, 1, 2, 2]
    assert ARiFDD(initial_tiles_per_dim=50).setup(spec, seed=0).num_features_ == 6


# ------------------------------------------------------------------------------ statistics


def test_hand_checked_weighted_mean_and_variance():
    rep = ARiFDD(split_threshold=float("inf")).setup(LINE, seed=0)
    feed(rep, [([0.9], 0.0), ([0.2], 1.0), ([0.6], -3.0)])  # δ = 0 on a fresh tile: no effect
    tiles = rep.basic_tiles_
    # weights |δ| = 1, 3: Ξ = 4, μ = (0.2 + 3 · 0.6) / 4 = 0.5,
    # σ² = (1 · 0.3² + 3 · 0.1²) / 4 = 0.03
    assert tiles["error_sum"].tolist() == [4.0]
    assert tiles["mean"][0] == pytest.approx(0.5)
    assert tiles["variance"][0] == pytest.approx(0.03)


def test_incremental_statistics_match_the_batch_formula():
    rep = ARiFDD(split_threshold=float("inf"), discovery_threshold=0.0).setup(PENDULUM, seed=0)
    rng = np.random.default_rng(3)
    first = random_states(PENDULUM, 1)[0]
    step(rep, first, 1.0)  # discovers {0, 1}: every later step is a single-feature step
    states = random_states(PENDULUM, 300, seed=4)
    deltas = rng.normal(size=300)
    for state, delta in zip(states, deltas, strict=True):
        assert rep.active_features(state).tolist() == [2]
        step(rep, state, delta)
    tiles = rep.basic_tiles_
    for i in range(2):
        w = np.abs(deltas)
        mean = np.average(states[:, i], weights=w)
        assert tiles["error_sum"][i] == pytest.approx(w.sum())
        assert tiles["mean"][i] == pytest.approx(mean)
        assert tiles["variance"][i] == pytest.approx(
            np.average((states[:, i] - mean) ** 2, weights=w)
        )


# ------------------------------------------------------------------------------ splitting


def conjoined_square(**params):
    """SQUARE with one tile per dimension and their conjunction {0, 1} (feature 2) discovered."""
    rep = ARiFDD(discovery_threshold=0.0, **params).setup(SQUARE, seed=0)
    expansion = step(rep, [0.5, 0.5], 1.0)
    assert expansion.parents.tolist() == [[0, 1]] and rep.active_features([0.1, 0.9]).tolist() == [
        2
    ]
    return rep


def test_least_variance_tile_splits_at_its_weighted_mean():
    rep = conjoined_square(split_threshold=3.0)
    # dimension 0 spread out, dimension 1 concentrated around 0.7 (|δ|-weighted)
    stream = [([0.1, 0.65], 1.0), ([0.9, 0.75], -1.0), ([0.5, 0.7], 2.0)]
    grown = feed(rep, stream)
    ((k, expansion),) = grown
    assert k == 2  # Ξ = 4 > ς = 3 only at the third step
    assert expansion.first_new == 3 and expansion.parents.tolist() == [[1, -1], [1, -1]]
    mean = np.average([0.65, 0.75, 0.7], weights=[1, 1, 2])
    tiles = rep.basic_tiles_
    assert tiles["feature"].tolist() == [0, 3, 4] and tiles["dim"].tolist() == [0, 1, 1]
    assert tiles["high"][1] == pytest.approx(mean) and tiles["low"][2] == pytest.approx(mean)
    assert tiles["error_sum"].tolist() == [4.0, 0.0, 0.0]  # the halves start afresh
    assert rep.retired_tiles_.tolist() == [1] and rep.num_splits_ == 1
    assert rep.active_features([0.2, mean - 1e-9]).tolist() == [0, 3]
    assert rep.active_features([0.2, mean]).tolist() == [0, 4]
    weights = grow_weights(
        np.array([[1.0, 2.0, 3.0], [10.0, 20.0, 30.0], [5.0, 5.0, 5.0]]), expansion
    )
    np.testing.assert_array_equal(weights[3:], [[10.0, 20.0, 30.0], [10.0, 20.0, 30.0]])


def test_the_tile_of_least_variance_splits_as_printed():
    spec = box_spec([0.0, 0.0], [10.0, 1.0])
    rep = ARiFDD(discovery_threshold=0.0, split_threshold=1.5).setup(spec, seed=0)
    step(rep, [5.0, 0.5], 1.0)
    # Algorithm 22 line 12, argmin σ²: dimension 0 has σ² = 1.0, dimension 1 σ² = 0.04, so
    # dimension 1 splits (relative to the ranges, 0.01 vs 0.04, dimension 0 would)
    ((_, expansion),) = feed(rep, [([4.0, 0.3], 1.0), ([6.0, 0.7], 1.0)])
    assert expansion.parents.tolist() == [[1, -1], [1, -1]]
    assert rep.basic_tiles_["high"][1] == pytest.approx(0.5)


def test_a_tile_the_floor_blocks_is_skipped_for_the_next_least_variance():
    spec = box_spec([0.0, 0.0], [10.0, 10.0])
    rep = ARiFDD(initial_tiles_per_dim=[10, 1], discovery_threshold=0.0, split_threshold=1.5).setup(
        spec, seed=0
    )
    step(rep, [0.4, 5.0], 1.0)  # conjoins tiles 0 and 10: one active feature from now on
    # tile 0 = [0, 1): σ² = 0.01 at μ = 0.4, but a 0.4-wide half is below the floor of 0.5;
    # tile 10 = [0, 10): σ² = 4 at μ = 5 splits instead
    ((_, expansion),) = feed(rep, [([0.3, 3.0], 1.0), ([0.5, 7.0], 1.0)])
    assert expansion.parents.tolist() == [[10, -1], [10, -1]]
    assert rep.num_rejected_splits_ == 0
    assert rep.active_features([0.3, 4.9]).tolist() != rep.active_features([0.3, 5.0]).tolist()


def test_conjunctions_on_a_split_tile_are_never_activated_again():
    rep = conjoined_square(split_threshold=1.5)
    feed(rep, [([0.2, 0.3], 1.0), ([0.4, 0.5], 1.0)])
    assert rep.num_splits_ == 1
    (tile,) = rep.retired_tiles_
    dead = [f for f in range(rep.num_features_) if tile in rep.initial_set(f)]
    assert 2 in dead
    for state in random_states(SQUARE, 500, seed=1):
        phi = check_cover(rep, state)
        assert not np.isin(phi, dead).any()
    # iFDD conjoins the new tiles again: a fresh conjunction, built on the halves
    expansion = step(rep, [0.2, 0.2], 1.0)
    (new,) = range(expansion.first_new, expansion.first_new + expansion.num_new)
    assert tile not in rep.initial_set(new)
    assert rep.active_features([0.2, 0.2]).tolist() == [new]


def test_a_split_needs_a_single_active_feature():
    rep = ARiFDD(split_threshold=0.0, discovery_threshold=100.0).setup(SQUARE, seed=0)
    for state in random_states(SQUARE, 50):
        assert step(rep, state, 1.0) is None  # two active tiles: only iFDD runs (line 20)
    assert rep.num_splits_ == 0 and rep.basic_tiles_["error_sum"].tolist() == [0.0, 0.0]
    assert rep.num_discover_calls_ == 50


def test_split_threshold_infinity_recovers_online_ifdd():
    stream = [
        (s, float(np.sin(5 * s[0]) * np.cos(3 * s[1]))) for s in random_states(PENDULUM, 3000)
    ]
    ari = ARiFDD(initial_tiles_per_dim=3, split_threshold=float("inf")).setup(PENDULUM, seed=7)
    base = IndependentDiscretization(num_buckets=3)
    ifdd = OnlineIFDD(base=base, discovery_threshold=1.0).setup(PENDULUM, seed=7)
    for state, delta in stream:
        phi = ari.active_features(state)
        np.testing.assert_array_equal(phi, ifdd.active_features(state))
        a, b = ari.discover(phi, delta, state), ifdd.discover(phi, delta, state)
        assert (a is None) == (b is None)
        if a is not None:
            assert a.first_new == b.first_new and a.parents.tolist() == b.parents.tolist()
    assert ari.num_features_ == ifdd.num_features_ > 6 and ari.num_splits_ == 0


# ------------------------------------------------------------------------------ coverage floor


def test_coverage_floor_rejects_an_off_centre_split_and_accepts_the_midpoint():
    spec = box_spec([0.0], [10.0])
    rep = ARiFDD(initial_tiles_per_dim=10, split_threshold=1.5).setup(spec, seed=0)
    # tile [0, 1): μ = 0.4 leaves a 0.4 < 10 / 20 half: rejected, no feature added
    assert feed(rep, [([0.3], 1.0), ([0.5], 1.0), ([0.4], 1.0)]) == []
    assert rep.num_rejected_splits_ == 2 and rep.num_features_ == 10
    # tile [1, 2): μ = 1.5 exactly, halves of exactly 1/20 (Section 4.2.1, footnote 7)
    ((_, expansion),) = feed(rep, [([1.25], 1.0), ([1.75], 1.0)])
    assert expansion.parents.tolist() == [[1, -1], [1, -1]]
    # the halves cannot split again
    assert feed(rep, [([1.1], 1.0), ([1.4], 1.0)] * 5) == []


def test_coverage_floor_stops_splitting():
    rep = ARiFDD(split_threshold=0.5).setup(LINE, seed=0)
    rng = np.random.default_rng(0)
    states = rng.beta(2.0, 5.0, size=(6000, 1))
    grown = feed(rep, [(s, float(rng.normal())) for s in states])
    tiles = rep.basic_tiles_
    widths = tiles["high"] - tiles["low"]
    assert rep.num_splits_ > 5 and np.all(widths >= 0.05 * (1 - 1e-9))
    assert len(widths) <= 20 and rep.num_features_ == 1 + 2 * rep.num_splits_
    assert grown and rep.num_rejected_splits_ > 0


def test_smaller_floor_allows_more_splits():
    rng = np.random.default_rng(1)
    stream = [(s, float(rng.normal())) for s in rng.uniform(0, 1, size=(3000, 1))]
    coarse = ARiFDD(split_threshold=0.5, min_tile_fraction=0.2).setup(LINE, seed=0)
    fine = ARiFDD(split_threshold=0.5, min_tile_fraction=0.02).setup(LINE, seed=0)
    feed(coarse, stream)
    feed(fine, stream)
    assert coarse.num_splits_ <= 4 < fine.num_splits_
    assert np.all(np.diff(np.append(coarse.basic_tiles_["low"], 1.0)) >= 0.2 * (1 - 1e-9))


def test_discrete_dimension_splits_between_values():
    spec = box_spec([0.0], [5.0], is_discrete=[True])
    rep = ARiFDD(split_threshold=1.5).setup(spec, seed=0)
    feed(rep, [([1.0], 1.0), ([2.0], 1.0)])  # μ = 1.5: split at ⌊1.5⌋ + 1/2 = 1.5
    assert [int(rep.active_features([x])[0]) for x in range(6)] == [1, 1, 2, 2, 2, 2]
    feed(rep, [([4.0], 1.0), ([4.0], 1.0)])  # μ = 4: split at 4.5, between 4 and 5
    assert [int(rep.active_features([x])[0]) for x in range(6)] == [1, 1, 3, 3, 3, 4]


# ------------------------------------------------------------------------------ validity, caps


def test_random_stream_keeps_features_valid():
    rep = ARiFDD(initial_tiles_per_dim=[1, 2, 2], split_threshold=0.5, discovery_threshold=0.5)
    rep.setup(MIXED, seed=0)
    rng = np.random.default_rng(2)
    num = rep.num_features_
    for state in random_states(MIXED, 3000, seed=5):
        phi = check_cover(rep, state)
        expansion = rep.discover(phi, float(np.sin(4 * state[0]) + rng.normal()), state)
        if expansion is not None:
            assert expansion.first_new == num
            num += expansion.num_new
        assert rep.num_features_ == num
    assert rep.num_splits_ > 3 and rep.num_features_ > rep.num_initial_features_ + 10
    for state in random_states(MIXED, 300, seed=6):
        check_cover(rep, state)


def test_split_parents_are_active_tiles():
    rep = ARiFDD(split_threshold=0.5, discovery_threshold=0.5).setup(SQUARE, seed=0)
    rng = np.random.default_rng(3)
    for state in random_states(SQUARE, 2000, seed=7):
        phi = rep.active_features(state)
        basic = rep.base_.active_features(state)
        expansion = rep.discover(phi, float(rng.normal()), state)
        if expansion is None:
            continue
        for g, h in expansion.parents:
            if h == -1:
                assert g in basic and phi.size == 1  # a split of a tile of s, at a 1-feature s
            else:
                assert g in phi and h in phi
    assert rep.num_splits_ > 2


def test_max_features_caps_splits_and_conjunctions():
    rng = np.random.default_rng(4)
    stream = [(s, float(rng.normal())) for s in random_states(SQUARE, 2000, seed=8)]
    rep = ARiFDD(split_threshold=0.5, discovery_threshold=0.5, max_features=9).setup(SQUARE, 0)
    feed(rep, stream)
    assert 8 <= rep.num_features_ <= 9


def test_errors():
    rep = ARiFDD().setup(SQUARE, seed=0)
    with pytest.raises(InvalidParameterError, match="state=None"):
        rep.discover(rep.active_features([0.5, 0.5]), 1.0)
    with pytest.raises(InvalidParameterError, match=r"\(3,\)"):
        rep.active_features(np.zeros(3))
    with pytest.raises(InvalidParameterError, match=r"ARiFDD.initial_tiles_per_dim"):
        ARiFDD(initial_tiles_per_dim=[2, 2, 2]).setup(SQUARE, seed=0)
    with pytest.raises(InvalidParameterError, match="min_tile_fraction"):
        ARiFDD(min_tile_fraction=0.0).setup(SQUARE, seed=0)
    with pytest.raises(InvalidParameterError, match="split_threshold"):
        ARiFDD(split_threshold=-1.0).setup(SQUARE, seed=0)
    with pytest.raises(NotSetUpError):
        ARiFDD().active_features(np.zeros(2))
    with pytest.raises(NotSetUpError):
        ARiFDD().discover(np.array([0]), 1.0, np.zeros(2))
    with pytest.raises(InvalidParameterError, match="load_state_arrays"):
        rep.load_state_arrays({})
    other = ARiFDD(initial_tiles_per_dim=3).setup(SQUARE, seed=0)
    with pytest.raises(InvalidParameterError, match="initial_tiles_per_dim"):
        other.load_state_arrays(rep.state_arrays())


# ------------------------------------------------------------------------------ state, seeds


def test_state_arrays_round_trip_continues_identically():
    rng = np.random.default_rng(5)
    stream = [
        (s, float(np.cos(3 * s[0]) - s[1] + rng.normal())) for s in random_states(PENDULUM, 3000, 9)
    ]
    params = dict(initial_tiles_per_dim=2, split_threshold=1.0, discovery_threshold=1.0)
    rep = ARiFDD(**params).setup(PENDULUM, seed=0)
    feed(rep, stream[:1500])
    twin = ARiFDD(**params).setup(PENDULUM, seed=1)
    twin.load_state_arrays(rep.state_arrays())
    assert twin.num_features_ == rep.num_features_ and rep.num_splits_ > 0
    first = [(k, e.first_new, e.parents.tolist()) for k, e in feed(rep, stream[1500:])]
    second = [(k, e.first_new, e.parents.tolist()) for k, e in feed(twin, stream[1500:])]
    assert first == second and first
    assert_same_state(rep, twin)


def test_deterministic_for_a_seed():
    rng = np.random.default_rng(6)
    stream = [(s, float(rng.normal())) for s in random_states(PENDULUM, 1500, seed=10)]
    a, b = (ARiFDD(split_threshold=0.5).setup(PENDULUM, seed=3) for _ in range(2))
    grown_a = [(k, e.parents.tolist()) for k, e in feed(a, stream)]
    grown_b = [(k, e.parents.tolist()) for k, e in feed(b, stream)]
    assert grown_a == grown_b and grown_a
    assert_same_state(a, b)


# ------------------------------------------------------------------------------ with learners


def test_sarsa_on_pendulum_grows_features_and_weights():
    domain = InvertedPendulum()
    agent = SARSA(representation=ARiFDD(initial_tiles_per_dim=2), step_size=0.1)
    agent.setup(domain.domain_spec, seed=0)
    _rollout(domain, agent, 5000, seed=0)
    rep = agent.representation_
    assert agent.num_features > rep.num_initial_features_ + 10 and rep.num_splits_ > 0
    assert agent.weights_.shape == (rep.num_features_, domain.domain_spec.num_actions)
    assert np.all(np.isfinite(agent.weights_))
    for state in random_states(domain.domain_spec, 200):
        assert np.all(np.isfinite(agent.q_values(state)))
        check_cover(rep, state)


def test_sarsa_save_restore_continues_exactly(tmp_path):
    domain = InvertedPendulum()
    params = dict(representation=ARiFDD(initial_tiles_per_dim=2), step_size=0.1)
    straight = SARSA(**params).setup(domain.domain_spec, seed=3)
    _rollout(domain, straight, 1500, seed=3)
    _rollout(domain, straight, 1500, seed=4)
    first = SARSA(**params).setup(domain.domain_spec, seed=3)
    _rollout(domain, first, 1500, seed=3)
    grown_before = first.num_features
    first.save(tmp_path / "agent")
    resumed = SARSA.restore(tmp_path / "agent")
    _rollout(domain, resumed, 1500, seed=4)
    assert straight.num_features > grown_before > first.representation_.num_initial_features_
    assert resumed.num_features == straight.num_features
    assert resumed.representation_.num_splits_ == straight.representation_.num_splits_ > 0
    np.testing.assert_array_equal(resumed.weights_, straight.weights_)
    assert_same_state(straight.representation_, resumed.representation_)


def test_common_checks_pass():
    check_component(ARiFDD())
    check_component(
        ARiFDD(initial_tiles_per_dim=[2, 3], split_threshold=0.5, relevance="ifdd_plus")
    )
    check_component(SARSA(representation=ARiFDD(split_threshold=0.5)))
