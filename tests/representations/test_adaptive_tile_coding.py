import numpy as np
import pytest

from conjure.agents import SARSA
from conjure.core import InvalidParameterError, NotSetUpError
from conjure.domains import InvertedPendulum
from conjure.representations.adaptive_tile_coding import AdaptiveTileCoding
from conjure.representations.weights import grow_weights
from conjure.testing import box_spec, check_component
from conjure.testing.checks import _rollout

LINE = box_spec([0.0], [1.0], name="line")
SQUARE = box_spec([0.0, 0.0], [1.0, 1.0], name="square")
PENDULUM = box_spec([-np.pi / 2, -2.0], [np.pi / 2, 2.0], name="pendulum")
MIXED = box_spec([0.0, -1.0, 0.0], [1.0, 1.0, 3.0], is_discrete=[False, False, True])


def random_states(spec, num, seed=0, margin=0.2):
    rng = np.random.default_rng(seed)
    span = spec.high - spec.low
    return rng.uniform(spec.low - margin * span, spec.high + margin * span, (num, spec.num_dims))


def check_indices(phi, num_features):
    assert phi.dtype == np.int64 and phi.shape == (1,)
    assert 0 <= phi[0] < num_features, phi


def feed(rep, stream):
    """Call discover for each (state, δ); return the non-empty expansions with their step."""
    grown = []
    for step, (state, delta) in enumerate(stream):
        state = np.asarray(state, dtype=float)
        expansion = rep.discover(rep.active_features(state), delta, state)
        if expansion is not None:
            grown.append((step, expansion))
    return grown


def tile_of_box(rep, state):
    """The tile whose box [low, high) holds ``state`` (edge tiles take outside values)."""
    low, high = rep.tile_low_, rep.tile_high_
    inside = np.all(
        ((state >= low) | (low <= rep.spec_.low)) & ((state < high) | (high >= rep.spec_.high)),
        axis=1,
    )
    (tiles,) = np.nonzero(inside)
    return tiles


# ------------------------------------------------------------------------------ initial tiling


def test_starts_with_one_tile_covering_everything():
    rep = AdaptiveTileCoding().setup(PENDULUM, seed=0)
    assert rep.num_features_ == 1 and rep.is_adaptive
    assert rep.encode(np.zeros(2)).has_unit_values()
    for state in random_states(PENDULUM, 50):
        assert rep.active_features(state).tolist() == [0]


def test_initial_grid_is_row_major():
    rep = AdaptiveTileCoding(initial_tiles_per_dim=[2, 3]).setup(SQUARE, seed=0)
    assert rep.num_features_ == 6
    expected = {(0.1, 0.1): 0, (0.1, 0.5): 1, (0.1, 0.9): 2, (0.7, 0.1): 3, (0.7, 0.5): 4}
    for state, tile in expected.items():
        assert rep.active_features(np.array(state)).tolist() == [tile], state
    assert rep.active_features(np.array([5.0, 5.0])).tolist() == [5]  # outside: edge tile
    assert rep.active_features(np.array([-5.0, -5.0])).tolist() == [0]
    np.testing.assert_allclose(rep.tile_low_[4], [0.5, 1 / 3])
    np.testing.assert_allclose(rep.tile_high_[4], [1.0, 2 / 3])


def test_initial_grid_on_a_discrete_dimension_groups_integer_values():
    spec = box_spec([0.0], [3.0], is_discrete=[True])
    rep = AdaptiveTileCoding(initial_tiles_per_dim=2).setup(spec, seed=0)
    assert [int(rep.active_features(np.array([x]))[0]) for x in range(4)] == [0, 0, 1, 1]
    many = AdaptiveTileCoding(initial_tiles_per_dim=10).setup(spec, seed=0)
    assert many.num_features_ == 4  # at most one tile per value


# ------------------------------------------------------------------------------ splitting


def test_hand_checked_split_halves_the_tile_and_copies_the_weight():
    rep = AdaptiveTileCoding(patience=2).setup(LINE, seed=0)
    stream = [([0.2], 1.0), ([0.8], -1.0), ([0.3], 1.0)]
    grown = feed(rep, stream)
    assert len(grown) == 1
    step, expansion = grown[0]
    assert step == 2  # the first δ sets the minimum; 2 updates without improvement
    assert expansion.first_new == 1 and expansion.parents.tolist() == [[0, -1]]
    assert rep.num_features_ == 2
    np.testing.assert_array_equal(rep.tile_low_, [[0.0], [0.5]])
    np.testing.assert_array_equal(rep.tile_high_, [[0.5], [1.0]])
    assert rep.active_features(np.array([0.49])).tolist() == [0]
    assert rep.active_features(np.array([0.5])).tolist() == [1]
    weights = np.array([[3.0, -4.0, 5.0]])
    grown_weights = grow_weights(weights, expansion)
    np.testing.assert_array_equal(grown_weights, [[3.0, -4.0, 5.0], [3.0, -4.0, 5.0]])


def test_split_waits_for_patience_and_resets_on_improvement():
    rep = AdaptiveTileCoding(patience=3).setup(LINE, seed=0)
    stream = [([0.1], 1.0), ([0.9], -1.0), ([0.1], 1.0)]  # min 1, then 2 stalls
    stream += [([0.9], -0.5)]  # improvement: count restarts
    stream += [([0.1], 1.0), ([0.9], -1.0)]  # 2 stalls: still no split
    assert feed(rep, stream) == []
    ((step, expansion),) = feed(rep, [([0.1], 0.7)])  # third stall
    assert step == 0 and expansion.parents.tolist() == [[0, -1]]


def test_value_criterion_picks_the_dimension_whose_halves_disagree():
    rep = AdaptiveTileCoding(patience=3).setup(SQUARE, seed=0)
    # δ depends on dimension 1 only: the halves along dimension 0 agree
    stream = [([0.2, 0.2], 1.0), ([0.8, 0.2], 1.0), ([0.2, 0.8], -1.0), ([0.8, 0.8], -1.0)]
    ((_, expansion),) = feed(rep, stream)
    assert expansion.parents.tolist() == [[0, -1]]
    np.testing.assert_array_equal(rep.tile_high_[0], [1.0, 0.5])
    np.testing.assert_array_equal(rep.tile_low_[1], [0.0, 0.5])
    assert rep.active_features(np.array([0.9, 0.1])).tolist() == [0]
    assert rep.active_features(np.array([0.3, 0.7])).tolist() == [1]


def test_split_children_are_split_again_with_fresh_statistics():
    rep = AdaptiveTileCoding(patience=1).setup(LINE, seed=0)
    feed(rep, [([0.1], 1.0), ([0.9], -1.0)])  # split at 0.5
    assert rep.num_features_ == 2
    # the new tile 1 = [0.5, 1) starts afresh: first δ sets its minimum, the next one stalls
    ((_, expansion),) = feed(rep, [([0.6], 1.0), ([0.95], -1.0)])
    assert expansion.first_new == 2 and expansion.parents.tolist() == [[1, -1]]
    np.testing.assert_array_equal(rep.tile_low_.ravel(), [0.0, 0.5, 0.75])
    np.testing.assert_array_equal(rep.tile_high_.ravel(), [0.5, 0.75, 1.0])
    assert rep.active_features(np.array([0.8])).tolist() == [2]


def test_discrete_dimension_splits_between_integer_values():
    spec = box_spec([0.0], [3.0], is_discrete=[True])
    rep = AdaptiveTileCoding(patience=1).setup(spec, seed=0)
    feed(rep, [([0.0], 1.0), ([3.0], -1.0)])
    assert [int(rep.active_features(np.array([x]))[0]) for x in range(4)] == [0, 0, 1, 1]
    feed(rep, [([0.0], 1.0), ([1.0], -1.0)])
    assert [int(rep.active_features(np.array([x]))[0]) for x in range(4)] == [0, 2, 1, 1]
    before = rep.num_features_
    feed(rep, [([0.0], 1.0), ([0.0], -1.0), ([0.0], 1.0)])  # a one-value tile never splits
    assert rep.num_features_ == before


def test_min_tile_width_and_max_features_are_respected():
    rng = np.random.default_rng(0)
    stream = [([x], float(np.sign(x - 0.37) + 0.1 * rng.normal())) for x in rng.uniform(0, 1, 3000)]
    narrow = AdaptiveTileCoding(patience=2, min_tile_width=0.25).setup(LINE, seed=0)
    feed(narrow, stream)
    widths = (narrow.tile_high_ - narrow.tile_low_).ravel()
    assert narrow.num_features_ == 4 and np.all(widths >= 0.25)
    capped = AdaptiveTileCoding(patience=2, max_features=3).setup(LINE, seed=0)
    feed(capped, stream)
    assert capped.num_features_ == 3


def test_random_stream_keeps_features_valid_and_consistent_with_the_boxes():
    rep = AdaptiveTileCoding(patience=5, initial_tiles_per_dim=[1, 2, 1]).setup(MIXED, seed=0)
    rng = np.random.default_rng(1)
    states = random_states(MIXED, 4000, seed=2)
    states[:, 2] = np.round(states[:, 2])
    seen = rep.num_features_
    for state in states:
        phi = rep.active_features(state)
        check_indices(phi, rep.num_features_)
        expansion = rep.discover(phi, float(np.sin(3 * state[0]) + rng.normal()), state)
        if expansion is not None:
            assert expansion.first_new == seen and expansion.parents.tolist() == [[phi[0], -1]]
            seen += expansion.num_new
        assert rep.num_features_ == seen
    assert seen > 10
    for state in random_states(MIXED, 300, seed=3):
        state[2] = np.round(state[2])
        assert tile_of_box(rep, state).tolist() == rep.active_features(state).tolist(), state


def test_discover_needs_the_state():
    rep = AdaptiveTileCoding(patience=1).setup(LINE, seed=0)
    with pytest.raises(InvalidParameterError, match="state=None"):
        rep.discover(np.array([0]), 1.0)
    with pytest.raises(InvalidParameterError, match=r"\(2,\)"):
        rep.discover(np.array([0]), 1.0, state=np.zeros(2))
    assert rep.num_features_ == 1


# ------------------------------------------------------------------------------ errors, state


def test_bad_setups_raise():
    with pytest.raises(InvalidParameterError, match="max_features"):
        AdaptiveTileCoding(initial_tiles_per_dim=3, max_features=8).setup(SQUARE, seed=0)
    with pytest.raises(InvalidParameterError, match="initial_tiles_per_dim"):
        AdaptiveTileCoding(initial_tiles_per_dim=[2, 2, 2]).setup(SQUARE, seed=0)
    with pytest.raises(InvalidParameterError, match="min_tile_width"):
        AdaptiveTileCoding(min_tile_width=0.0).setup(SQUARE, seed=0)
    with pytest.raises(NotSetUpError):
        AdaptiveTileCoding().discover(np.array([0]), 1.0)


def test_state_arrays_round_trip_continues_identically():
    stream = [(s, float(np.cos(4 * s[0]) - s[1])) for s in random_states(SQUARE, 1500, seed=4)]
    rep = AdaptiveTileCoding(patience=3).setup(SQUARE, seed=0)
    feed(rep, stream[:700])
    twin = AdaptiveTileCoding(patience=3).setup(SQUARE, seed=1)
    twin.load_state_arrays(rep.state_arrays())
    assert twin.num_features_ == rep.num_features_ > 1
    first = [(k, e.first_new, e.parents.tolist()) for k, e in feed(rep, stream[700:])]
    second = [(k, e.first_new, e.parents.tolist()) for k, e in feed(twin, stream[700:])]
    assert first == second and first
    for name, value in rep.state_arrays().items():
        np.testing.assert_array_equal(value, twin.state_arrays()[name], err_msg=name)
    with pytest.raises(InvalidParameterError, match="load_state_arrays"):
        AdaptiveTileCoding().setup(PENDULUM, seed=0).load_state_arrays({"node_dim": np.zeros(2)})


# ------------------------------------------------------------------------------ with learners


def test_sarsa_on_pendulum_grows_tiles_and_weights():
    domain = InvertedPendulum()
    agent = SARSA(representation=AdaptiveTileCoding(patience=20), step_size=0.1)
    agent.setup(domain.domain_spec, seed=0)
    _rollout(domain, agent, 3000, seed=0)
    assert agent.num_features > 5
    assert agent.weights_.shape == (agent.num_features, domain.domain_spec.num_actions)
    assert np.all(np.isfinite(agent.weights_))
    assert np.all(np.isfinite(agent.q_values(np.array([0.1, -0.3]))))


def test_sarsa_save_restore_continues_exactly(tmp_path):
    domain = InvertedPendulum()
    params = dict(representation=AdaptiveTileCoding(patience=10), step_size=0.1, trace_decay=0.5)
    straight = SARSA(**params).setup(domain.domain_spec, seed=3)
    _rollout(domain, straight, 800, seed=3)
    _rollout(domain, straight, 800, seed=4)
    first = SARSA(**params).setup(domain.domain_spec, seed=3)
    _rollout(domain, first, 800, seed=3)
    grown_before = first.num_features
    first.save(tmp_path / "agent")
    resumed = SARSA.restore(tmp_path / "agent")
    _rollout(domain, resumed, 800, seed=4)
    assert straight.num_features > grown_before > 1
    assert resumed.num_features == straight.num_features
    np.testing.assert_array_equal(resumed.weights_, straight.weights_)
    for name, value in straight.representation_.state_arrays().items():
        np.testing.assert_array_equal(value, resumed.representation_.state_arrays()[name])


def test_common_checks_pass():
    check_component(AdaptiveTileCoding())
    check_component(AdaptiveTileCoding(initial_tiles_per_dim=[2, 3], patience=5))
    check_component(SARSA(representation=AdaptiveTileCoding(patience=5)))
