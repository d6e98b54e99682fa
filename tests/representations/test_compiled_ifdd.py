"""Online iFDD's and ARiFDD's compiled form: the loop's φ̇(s) and discoveries are their own."""

import numpy as np

from conjure.representations import ARiFDD, BinaryIndicators, OnlineIFDD, Tabular
from conjure.representations._arifdd_kernels import fits_splits, tile_word
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
        first, added, parents = discover_from(form, phi, delta, room, state)
        assert added == (0 if expansion is None else expansion.num_new)
        if added:
            np.testing.assert_array_equal(parents[first : first + added], expansion.parents)
        assert compiled.num_features_ == python.num_features_
    assert python.num_features_ > 5  # something was discovered


def test_a_fixed_representation_fills_the_slot_without_ifdd():
    spec = box_spec([0.0], [1.0])
    form = fixed(Tabular(num_buckets=3).setup(spec, 0).compiled_form())
    assert not form.is_ifdd and form.base.max_active == 1


def _arifdd():
    spec = box_spec([0.0, -1.0], [1.0, 1.0])
    return ARiFDD(initial_tiles_per_dim=2, discovery_threshold=0.3).setup(spec, 0)


def test_arifdd_encodes_splits_and_discovers_as_its_python_methods():
    python, compiled = _arifdd(), _arifdd()
    rng = np.random.default_rng(1)
    empty = np.empty(0, dtype=np.int64)
    for _ in range(400):
        state = rng.uniform([0.0, -1.0], [1.0, 1.0])
        delta = float(rng.normal())
        phi = python.active_features(state)
        expansion = python.discover(phi, delta, state)
        form = compiled.compiled_form()  # again: growing replaces the tables
        while room_for(form, phi) < 0:
            compiled.grow_tables()
            form = compiled.compiled_form()
        np.testing.assert_array_equal(
            sparsify(form, encode_into(form.base, state, empty, empty)), phi
        )
        first, added, parents = discover_from(form, phi, delta, room_for(form, phi), state)
        assert added == (0 if expansion is None else expansion.num_new)
        if added:
            np.testing.assert_array_equal(parents[first : first + added], expansion.parents)
    assert python.num_splits_ > 8 and python.num_discovered_ > 0  # both kinds of growth ran
    assert compiled.num_splits_ == python.num_splits_
    np.testing.assert_array_equal(compiled.retired_tiles_, python.retired_tiles_)
    for name, value in python.basic_tiles_.items():
        np.testing.assert_array_equal(compiled.basic_tiles_[name], value, err_msg=name)


def test_a_split_needs_room_for_a_tile_in_every_dimension_and_two_features():
    rep = _arifdd()
    tiles, tables = rep.base_.tiles_, rep.kernel_tables()
    free = tiles.tile_feature.shape[1] - int(tiles.num_tiles.max())
    assert fits_splits(tiles, free, 2, tables) and not fits_splits(tiles, free + 1, 2, tables)
    capacity = rep.feature_capacity_
    room = capacity - rep.num_features_
    assert fits_splits(tiles, 1, room, tables) and not fits_splits(tiles, 1, room + 1, tables)
    rep.grow_tables()
    assert rep.base_.tiles_.tile_feature.shape[1] == 2 * tiles.tile_feature.shape[1]
    assert rep.feature_capacity_ > capacity


def test_a_new_tiles_hash_word_is_splitmix64_of_the_seed_word_and_its_id():
    # splitmix64's first two outputs from state 0 (Steele et al. 2014; Vigna's reference code)
    words = [tile_word(0, 0), tile_word(0, 1)]
    assert [w & (2**64 - 1) for w in words] == [0xE220A8397B1DCDAF, 0x6E789E6AA1B965F4]
