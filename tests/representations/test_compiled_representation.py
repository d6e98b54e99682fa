"""A fixed representation's compiled form gives its own φ(s), indices and values."""

import numpy as np
import pytest

from conjure.representations import (
    RBF,
    BinaryIndicators,
    IndependentDiscretization,
    Tabular,
    TileCoding,
)
from conjure.representations.compiled_representation import encode_into, values_of
from conjure.testing.checks import box_spec, sample_states

REPRESENTATIONS = {
    "tiles": lambda: TileCoding(num_tilings=4, tiles_per_dim=5),
    "hashed-tiles": lambda: TileCoding(num_tilings=4, tiles_per_dim=5, memory_size=64),
    "table": lambda: Tabular(num_buckets=7),
    "buckets": lambda: IndependentDiscretization(num_buckets=6),
    "rbf": lambda: RBF(num_centers=3),
}


@pytest.mark.parametrize("name", list(REPRESENTATIONS))
def test_encode_into_gives_the_representations_phi(name):
    spec = box_spec([0.0, -1.0], [1.0, 1.0])
    rep = REPRESENTATIONS[name]().setup(spec, 0)
    form = rep.compiled_form()
    quanta = np.empty(2, dtype=np.int64)
    out = np.empty(max(form.max_active, 1), dtype=np.int64)
    for state in sample_states(spec, 50, seed=1):
        expected = rep.encode(state)
        np.testing.assert_array_equal(encode_into(form, state, quanta, out), expected.indices)
        values = values_of(form, state)
        if name == "rbf":
            np.testing.assert_array_equal(values, expected.values)
        else:
            assert values is None  # binary φ: the loop reads no values


def test_indicators_are_the_nonzero_dimensions():
    spec = box_spec([0.0] * 4, [1.0] * 4, is_discrete=[True] * 4)
    form = BinaryIndicators().setup(spec, 0).compiled_form()
    state = np.array([1.0, 0.0, 1.0, 1.0])
    empty = np.empty(0, dtype=np.int64)
    assert encode_into(form, state, empty, empty).tolist() == [0, 2, 3]
