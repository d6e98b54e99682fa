import numpy as np
import pytest

from conjure.core import (
    DomainSpec,
    Expansion,
    IncompatibleComponentsError,
    InvalidParameterError,
    Representation,
    SparseFeatures,
)
from conjure.core.errors import NotSetUpError
from conjure.core.interfaces import check_binary_features


def spec(**changes):
    params = dict(
        name="t",
        low=[0, -1],
        high=[3, 1],
        is_discrete=[True, False],
        num_actions=2,
        discount=0.9,
        max_episode_steps=10,
    )
    params.update(changes)
    return DomainSpec(**params)


def test_spec_round_trips_through_dict_and_is_read_only():
    original = spec()
    copy = DomainSpec.from_dict(original.to_dict())
    assert copy.to_dict() == original.to_dict() and copy.num_dims == 2
    with pytest.raises(ValueError):
        original.low[0] = 5.0


@pytest.mark.parametrize(
    "changes, message",
    [
        ({"high": [3, np.inf]}, "finite"),
        ({"low": [0]}, "one entry per dimension"),
        ({"discount": 1.5}, "discount"),
    ],
)
def test_spec_rejects_bad_bounds(changes, message):
    with pytest.raises(InvalidParameterError, match=message):
        spec(**changes)


def test_expansion_counts_new_features():
    assert Expansion(first_new=4, parents=np.array([[0, 1], [2, 3]])).num_new == 2
    assert Expansion(first_new=4).num_new == 0


# ------------------------------------------------------------------------------ encode


def test_binary_encode_gives_active_features_with_read_only_ones():
    from conjure.representations import TileCoding

    rep = TileCoding(num_tilings=4, tiles_per_dim=5).setup(spec(), seed=0)
    first, second = rep.encode(np.array([1.0, 0.2])), rep.encode(np.array([2.0, -0.5]))
    assert np.array_equal(first.indices, rep.active_features(np.array([1.0, 0.2])))
    assert first.values.tolist() == [1.0] * 4 and first.has_unit_values()
    assert second.values is first.values  # one buffer, no allocation per call
    with pytest.raises(ValueError):
        first.values[0] = 2.0


class Growing(Representation):
    """Activates features 0 .. s₀ (a varying count), to exercise the ones buffer."""

    def setup(self, spec, seed):
        self.spec_, self.num_features_, self.is_set_up_ = spec, 4, True
        return self

    def active_features(self, state):
        return np.arange(int(state[0]) + 1, dtype=np.int64)


def test_binary_encode_values_follow_a_varying_count():
    rep = Growing().setup(spec(), seed=0)
    for count in (1, 4, 2, 3):
        indices, values = rep.encode(np.array([count - 1.0, 0.0]))
        assert indices.tolist() == list(range(count)) and values.tolist() == [1.0] * count
    assert rep.feature_values(np.array([1.0, 0.0])).tolist() == [1.0, 1.0, 0.0, 0.0]


def test_rbf_encode_lists_every_feature_with_its_value():
    from conjure.representations import RBF

    rep = RBF(num_centers=3).setup(spec(), seed=0)
    state = np.array([1.0, 0.3])
    indices, values = rep.encode(state)
    assert indices.tolist() == list(range(rep.num_features_))
    assert np.array_equal(values, rep.feature_values(state))
    assert not rep.encode(state).has_unit_values() and values[-1] == 1.0  # the bias


def test_sparse_features_dot_and_dense_by_hand():
    phi = SparseFeatures(np.array([0, 2]), np.array([0.5, 2.0]))
    weights = np.array([[1.0, 0.0], [7.0, 7.0], [2.0, 1.0]])
    assert phi.dot(weights).tolist() == [4.5, 2.0]
    assert phi.dense(4).tolist() == [0.5, 0.0, 2.0, 0.0]


def test_check_binary_features_refuses_real_values_by_name():
    from conjure.representations import RBF, Tabular

    check_binary_features(Tabular().setup(spec(), seed=0), "iFDD")
    with pytest.raises(IncompatibleComponentsError, match=r"iFDD conjoins binary.*RBF"):
        check_binary_features(RBF().setup(spec(), seed=0), "iFDD")


def test_check_state_before_setup_raises_not_set_up_naming_the_class():
    class Probe(Representation):
        def active_features(self, state):
            self.check_state(state)
            return np.zeros(0, dtype=np.int64)

    with pytest.raises(NotSetUpError, match="Probe"):
        Probe().encode(np.zeros(2))


def test_the_agent_interface_declares_its_persistence_and_compiled_state_contracts():
    from conjure.agents import SARSA
    from conjure.core.interfaces import Agent

    contract = ("state_metadata", "state_arrays", "load_state")
    compiled = ("reserve_rows",)
    for name in (*contract, *compiled):
        method = vars(Agent)[name]
        assert method.__doc__ and len(method.__doc__.split()) > 10, name
        assert getattr(SARSA, name) is not method, f"SARSA does not implement {name}"
