import numpy as np
import pytest

from conjure.core import DomainSpec, InvalidParameterError, NotSetUpError
from conjure.domains import BlocksWorld
from conjure.representations.indicators import BinaryIndicators
from conjure.testing import check_component


def binary_spec(num_dims=5):
    return DomainSpec(
        name="bits",
        low=np.zeros(num_dims),
        high=np.ones(num_dims),
        is_discrete=np.ones(num_dims, dtype=bool),
        num_actions=2,
        discount=1.0,
        max_episode_steps=10,
    )


def test_blocksworld_on_features():
    domain = BlocksWorld()
    rep = BinaryIndicators().setup(domain.domain_spec, seed=0)
    assert rep.num_features_ == 36  # × 36 actions = 1296 initial features (Section 4.1.4)
    obs, _ = domain.reset(seed=0)
    phi = rep.active_features(obs)
    assert phi.tolist() == [0, 7, 14, 21, 28, 35] and phi.dtype == np.int64


def test_features_are_the_nonzero_dimensions():
    rep = BinaryIndicators().setup(binary_spec(), seed=0)
    assert rep.active_features(np.array([0.0, 1.0, 0.0, 0.5, 1.0])).tolist() == [1, 3, 4]
    assert rep.active_features([1, 1, 1, 1, 1]).tolist() == [0, 1, 2, 3, 4]
    empty = rep.active_features(np.zeros(5))
    assert empty.size == 0 and empty.dtype == np.int64


def test_all_shipped_checks_apply_and_pass():
    assert not BinaryIndicators.expected_check_failures
    check_component(BinaryIndicators())


def test_non_binary_spec_is_rejected_naming_the_dimensions():
    spec = DomainSpec(
        name="mixed",
        low=[0.0, -1.0, 0.0],
        high=[1.0, 1.0, 3.0],
        is_discrete=[True, False, True],
        num_actions=2,
        discount=1.0,
        max_episode_steps=10,
    )
    with pytest.raises(InvalidParameterError, match=r"dimensions 1 \[-1, 1\], 2 \[0, 3\]"):
        BinaryIndicators().setup(spec, seed=0)


def test_wrong_shape_and_not_set_up_raise():
    with pytest.raises(NotSetUpError):
        BinaryIndicators().active_features(np.zeros(5))
    rep = BinaryIndicators().setup(binary_spec(), seed=0)
    with pytest.raises(InvalidParameterError, match=r"\(3,\)"):
        rep.active_features(np.zeros(3))
