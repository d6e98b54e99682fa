import numpy as np
import pytest

from conjure.agents import SARSA
from conjure.core import InvalidParameterError, NotSetUpError
from conjure.domains import InvertedPendulum
from conjure.representations.sparse_distributed_memory import SparseDistributedMemory
from conjure.representations.weights import grow_weights
from conjure.testing import box_spec, check_component
from conjure.testing.checks import _rollout

LINE = box_spec([0.0], [1.0], name="line")
WIDE_LINE = box_spec([-2.0], [2.0], name="wide")
PENDULUM = box_spec([-np.pi / 2, -2.0], [np.pi / 2, 2.0], name="pendulum")
CUBE = box_spec([0.0, -1.0, 0.0], [1.0, 1.0, 3.0], is_discrete=[False, False, True])
SEVEN = box_spec([0.0] * 7, [1.0] * 6 + [0.0], name="seven")  # last dimension flat


def random_states(spec, num, seed=0, margin=0.2):
    rng = np.random.default_rng(seed)
    span = spec.high - spec.low
    return rng.uniform(spec.low - margin * span, spec.high + margin * span, (num, spec.num_dims))


def brute_force(rep, state):
    span = rep.spec_.high - rep.spec_.low
    u = np.where(span > 0, (state - rep.spec_.low) / np.where(span > 0, span, 1.0), 0.0)
    u = np.clip(u, 0.0, 1.0)
    radius = np.broadcast_to(np.asarray(rep.activation_radius, dtype=float), u.shape)
    inside = np.all(np.abs(rep.centers_ - u) <= radius * (1 + 1e-9), axis=1)
    return np.nonzero(inside)[0]


def check_indices(phi, num_features):
    assert phi.dtype == np.int64 and phi.ndim == 1 and phi.size > 0
    assert np.all(np.diff(phi) > 0), phi
    assert phi[0] >= 0 and phi[-1] < num_features, phi


def drive(rep, states, seed=0):
    """Encode and discover every state; return the expansions."""
    rng = np.random.default_rng(seed)
    expansions = []
    for state in states:
        phi = rep.active_features(state)
        check_indices(phi, rep.num_features_)
        expansion = rep.discover(phi, float(rng.normal()), state)
        if expansion is not None:
            assert expansion.first_new + expansion.num_new == rep.num_features_
            assert np.all(expansion.parents == -1)
            expansions.append(expansion)
    return expansions


# ------------------------------------------------------------------------------ initial memory


def test_initial_grid_covers_the_space():
    rep = SparseDistributedMemory(activation_radius=0.25).setup(LINE, seed=0)
    assert rep.is_adaptive and rep.encode(LINE.low).has_unit_values()
    np.testing.assert_allclose(rep.centers_.ravel(), [0.25, 0.75])
    two = SparseDistributedMemory(activation_radius=[0.25, 0.5]).setup(PENDULUM, seed=0)
    np.testing.assert_allclose(two.centers_, [[0.25, 0.5], [0.75, 0.5]])
    default = SparseDistributedMemory().setup(PENDULUM, seed=0)
    assert default.num_features_ == 25  # ceil(1 / 0.2) = 5 per dimension
    for state in random_states(PENDULUM, 500):
        check_indices(default.active_features(state), default.num_features_)


def test_hand_checked_activation():
    rep = SparseDistributedMemory(activation_radius=0.25).setup(WIDE_LINE, seed=0)
    expected = {-1.0: [0], 0.0: [0, 1], 1.5: [1], -7.0: [0], 9.0: [1], np.nan: [0]}
    for x, phi in expected.items():  # u = (x + 2) / 4, clipped; centres 0.25 and 0.75
        assert rep.active_features(np.array([x])).tolist() == phi, x


@pytest.mark.parametrize(
    ("spec", "radius"), [(PENDULUM, 0.07), (CUBE, [0.05, 0.2, 0.3]), (SEVEN, 0.3)]
)
def test_grid_search_equals_brute_force(spec, radius):
    rep = SparseDistributedMemory(activation_radius=radius, min_active=4).setup(spec, seed=0)
    drive(rep, random_states(spec, 1500, seed=1))
    assert rep.num_features_ > rep.num_initial_features_
    for state in random_states(spec, 400, seed=2):
        np.testing.assert_array_equal(rep.active_features(state), brute_force(rep, state))


# ------------------------------------------------------------------------------ allocation


def test_hand_checked_allocation_at_the_state():
    rep = SparseDistributedMemory(activation_radius=0.25, min_active=2).setup(LINE, seed=0)
    phi = rep.active_features(np.array([0.1]))
    assert phi.tolist() == [0]
    expansion = rep.discover(phi, 0.3, np.array([0.1]))
    assert expansion.first_new == 2 and expansion.parents.tolist() == [[-1, -1]]
    np.testing.assert_allclose(rep.centers_.ravel(), [0.25, 0.75, 0.1])
    assert rep.active_features(np.array([0.1])).tolist() == [0, 2]
    weights = np.array([[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]])
    np.testing.assert_array_equal(grow_weights(weights, expansion)[2], [0.0, 0.0, 0.0])
    # covered enough now: no further allocation
    assert rep.discover(rep.active_features(np.array([0.1])), 0.3, np.array([0.1])) is None


def test_allocation_fills_up_to_min_active_within_the_box():
    rep = SparseDistributedMemory(activation_radius=0.1, min_active=4).setup(LINE, seed=0)
    phi = rep.active_features(np.array([0.42]))
    expansion = rep.discover(phi, 1.0, np.array([0.42]))
    assert expansion.num_new == 4 - phi.size
    new = rep.centers_[expansion.first_new :].ravel()
    assert new[0] == pytest.approx(0.42)
    assert np.all(np.abs(new - 0.42) <= 0.1)
    assert rep.active_features(np.array([0.42])).size == 4


def test_covered_state_allocates_nothing_and_a_missing_state_raises():
    rep = SparseDistributedMemory(activation_radius=0.25, min_active=2).setup(LINE, seed=0)
    middle = np.array([0.5])
    assert rep.discover(rep.active_features(middle), 1.0, middle) is None  # 2 active
    assert rep.num_features_ == 2
    with pytest.raises(InvalidParameterError, match="state=None"):
        rep.discover(rep.active_features(np.array([0.1])), 1.0)
    with pytest.raises(InvalidParameterError, match=r"\(3,\)"):
        rep.discover(np.array([0]), 1.0, state=np.zeros(3))
    assert rep.num_features_ == 2


def test_memory_grown_since_phi_is_rechecked():
    rep = SparseDistributedMemory(activation_radius=0.25, min_active=2).setup(LINE, seed=0)
    stale = rep.active_features(np.array([0.1]))
    near = np.array([0.12])
    rep.discover(rep.active_features(near), 1.0, near)  # adds 0.12, which covers 0.1
    assert rep.discover(stale, 1.0, np.array([0.1])) is None
    assert rep.num_features_ == 3


def test_max_features_caps_allocation():
    rep = SparseDistributedMemory(activation_radius=0.1, min_active=5, max_features=7)
    rep.setup(LINE, seed=0)
    drive(rep, random_states(LINE, 200))
    assert rep.num_features_ == 7
    with pytest.raises(InvalidParameterError, match="max_features"):
        SparseDistributedMemory(activation_radius=0.1, max_features=4).setup(LINE, seed=0)


def test_deterministic_for_a_seed():
    states = random_states(PENDULUM, 800, seed=5)
    a = SparseDistributedMemory(min_active=5).setup(PENDULUM, seed=3)
    b = SparseDistributedMemory(min_active=5).setup(PENDULUM, seed=3)
    c = SparseDistributedMemory(min_active=5).setup(PENDULUM, seed=4)
    for rep in (a, b, c):
        drive(rep, states)
    np.testing.assert_array_equal(a.centers_, b.centers_)
    assert a.centers_.shape != c.centers_.shape or not np.array_equal(a.centers_, c.centers_)


# ------------------------------------------------------------------------------ errors, state


def test_bad_setups_raise():
    with pytest.raises(InvalidParameterError, match="activation_radius"):
        SparseDistributedMemory(activation_radius=[0.1]).setup(PENDULUM, seed=0)
    with pytest.raises(InvalidParameterError, match="activation_radius"):
        SparseDistributedMemory(activation_radius=1.5).setup(PENDULUM, seed=0)
    with pytest.raises(InvalidParameterError, match="min_active"):
        SparseDistributedMemory(min_active=0).setup(PENDULUM, seed=0)
    with pytest.raises(NotSetUpError):
        SparseDistributedMemory().active_features(np.zeros(2))
    with pytest.raises(InvalidParameterError, match="load_state_arrays"):
        SparseDistributedMemory().setup(PENDULUM, seed=0).load_state_arrays({})


def test_state_arrays_round_trip_continues_identically():
    states = random_states(PENDULUM, 1200, seed=6)
    rep = SparseDistributedMemory(min_active=4).setup(PENDULUM, seed=0)
    drive(rep, states[:600])
    twin = SparseDistributedMemory(min_active=4).setup(PENDULUM, seed=99)
    twin.load_state_arrays(rep.state_arrays())
    assert twin.num_features_ == rep.num_features_ > twin.num_initial_features_
    drive(rep, states[600:], seed=1)
    drive(twin, states[600:], seed=1)
    np.testing.assert_array_equal(rep.centers_, twin.centers_)
    for state in states[:100]:
        np.testing.assert_array_equal(rep.active_features(state), twin.active_features(state))


# ------------------------------------------------------------------------------ with learners


def test_sarsa_on_pendulum_grows_prototypes_and_weights():
    domain = InvertedPendulum()
    agent = SARSA(representation=SparseDistributedMemory(), step_size=0.1)
    agent.setup(domain.domain_spec, seed=0)
    _rollout(domain, agent, 3000, seed=0)
    assert agent.num_features > 25
    assert agent.weights_.shape == (agent.num_features, domain.domain_spec.num_actions)
    assert np.all(np.isfinite(agent.weights_))
    assert np.all(np.isfinite(agent.q_values(np.array([0.1, -0.3]))))


def test_sarsa_save_restore_continues_exactly(tmp_path):
    domain = InvertedPendulum()
    params = dict(
        representation=SparseDistributedMemory(min_active=4), step_size=0.1, trace_decay=0.5
    )
    straight = SARSA(**params).setup(domain.domain_spec, seed=3)
    _rollout(domain, straight, 800, seed=3)
    _rollout(domain, straight, 800, seed=4)
    first = SARSA(**params).setup(domain.domain_spec, seed=3)
    _rollout(domain, first, 800, seed=3)
    grown_before = first.num_features
    first.save(tmp_path / "agent")
    resumed = SARSA.restore(tmp_path / "agent")
    _rollout(domain, resumed, 800, seed=4)
    assert straight.num_features > grown_before > 25
    assert resumed.num_features == straight.num_features
    np.testing.assert_array_equal(resumed.weights_, straight.weights_)
    np.testing.assert_array_equal(
        resumed.representation_.centers_, straight.representation_.centers_
    )


def test_common_checks_pass():
    check_component(SparseDistributedMemory())
    check_component(SparseDistributedMemory(activation_radius=[0.3, 0.2], min_active=2))
    check_component(SARSA(representation=SparseDistributedMemory(min_active=2)))


def test_too_many_initial_prototypes_is_a_clear_error_not_a_memory_error():
    from conjure.domains import BlocksWorld, PersistentSurveillance

    with pytest.raises(InvalidParameterError, match="larger activation_radius"):
        SparseDistributedMemory().setup(PersistentSurveillance().domain_spec, seed=0)
    wide = SparseDistributedMemory(activation_radius=0.5).setup(BlocksWorld().domain_spec, seed=0)
    assert wide.num_features_ == 1  # 36 dimensions, beyond numpy's 32-axis meshgrid
