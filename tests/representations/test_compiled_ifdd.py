"""Online iFDD's compiled form: the loop's φ̇(s) and discoveries are `OnlineIFDD`'s own."""

import numpy as np

from conjure.representations import BinaryIndicators, OnlineIFDD, Tabular
from conjure.representations.compiled_ifdd import discover_from, fixed, room_for, sparsify
from conjure.representations.compiled_representation import encode_into
from conjure.testing.checks import box_spec


def _ifdd():
    spec = box_spec([0.0] * 5, [1.0] * 5, is_discrete=[True] * 5)
    return OnlineIFDD(base=BinaryIndicators(), discovery_threshold=0.5).setup(spec, 0)


def test_sparsify_and_discover_match_the_python_methods():
    python, compiled = _ifdd(), _ifdd()
    form = compiled.compiled_form()
    rng = np.random.default_rng(0)
    empty = np.empty(0, dtype=np.int64)
    for _ in range(200):
        state = (rng.random(5) < 0.5).astype(np.float64)
        delta = float(rng.normal())
        phi = python.active_features(state)
        np.testing.assert_array_equal(
            sparsify(form, encode_into(form.base, state, empty, empty)), phi
        )
        expansion = python.discover(phi, delta)
        room = room_for(form, phi)
        assert room >= 0
        first, added, parents = discover_from(form, phi, delta, room)
        assert added == (0 if expansion is None else expansion.num_new)
        if added:
            np.testing.assert_array_equal(parents[first : first + added], expansion.parents)
        assert compiled.num_features_ == python.num_features_
    assert python.num_features_ > 5  # something was discovered


def test_a_fixed_representation_fills_the_slot_without_ifdd():
    spec = box_spec([0.0], [1.0])
    form = fixed(Tabular(num_buckets=3).setup(spec, 0).compiled_form())
    assert not form.is_ifdd and form.base.max_active == 1
