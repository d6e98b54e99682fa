import numpy as np
import pytest

from conjure.core import InvalidParameterError
from conjure.core.seeding import make_rng, rng_from_state, rng_state, split_seed


def test_split_children_are_independent_and_reproducible():
    first = split_seed(3, ("domain", "agent"))
    again = split_seed(3, ("domain", "agent"))
    draws = make_rng(first["domain"]).random(4)
    assert np.array_equal(draws, make_rng(again["domain"]).random(4))
    assert not np.array_equal(draws, make_rng(first["agent"]).random(4))


def test_rng_state_round_trip_continues_stream():
    rng = make_rng(9)
    rng.random(5)
    copy = rng_from_state(rng_state(rng))
    assert np.array_equal(rng.random(3), copy.random(3))


@pytest.mark.parametrize("bad", [-1, 1.5, "7", None, True])
def test_bad_seeds_are_rejected(bad):
    with pytest.raises(InvalidParameterError, match="seed"):
        make_rng(bad)
