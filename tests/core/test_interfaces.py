import numpy as np
import pytest

from conjure.core import DomainSpec, Expansion, InvalidParameterError


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
