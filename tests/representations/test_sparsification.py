"""The thesis's worked examples of Sections 3.2.1 and 3.4 (Theorems 3.4.3-3.4.4, Remark)."""

import itertools

import numpy as np
import pytest
from ifdd_oracle import FlagFeatures, flags_spec

from conjure.core import DomainSpec
from conjure.representations import IndependentDiscretization
from conjure.representations.online_ifdd import OnlineIFDD
from conjure.representations.weights import grow_weights


def matrix(rep, states):
    """Φ with one row per state (given as initial active sets) and one column per feature."""
    phi = np.zeros((len(states), rep.num_features_))
    for row, active in enumerate(states):
        phi[row, rep.activate_initial(np.array(active, dtype=np.int64))] = 1.0
    return phi


def in_span(phi, v):
    theta = np.linalg.lstsq(phi, v, rcond=None)[0]
    return np.allclose(phi @ theta, v)


# ------------------------------------------------------------------ Section 3.2.1, Fig. 3-6


def grid_rep(sparsify):
    spec = DomainSpec(name="xy", low=[0, 0], high=[1, 1], is_discrete=[True, True],
                      num_actions=1, discount=0.9, max_episode_steps=10)  # fmt: skip
    rep = OnlineIFDD(base=IndependentDiscretization(), sparsify=sparsify)
    return rep.setup(spec, seed=0)  # features: x=0, x=1, y=0, y=1 (f1..f4)


STATES_XY = [(0, 0), (0, 1), (1, 0), (1, 1)]
V1 = np.array([0.0, 2.0, 2.0, 4.0])
V2 = np.array([0.0, 2.0, 2.0, 0.0])


@pytest.mark.parametrize("sparsify", [False, True])
def test_section_3_2_1_v1_linear_v2_needs_the_conjunction(sparsify):
    rep = grid_rep(sparsify)
    phi = np.array([rep.feature_values(np.array(s, dtype=float)) for s in STATES_XY])
    expected = [[1, 0, 1, 0], [1, 0, 0, 1], [0, 1, 1, 0], [0, 1, 0, 1]]
    np.testing.assert_array_equal(phi, expected)
    np.testing.assert_allclose(phi @ [0, 2, 0, 2], V1)
    assert in_span(phi, V1) and not in_span(phi, V2)
    rep.discover(rep.active_features(np.array([1.0, 1.0])), td_error=2.0)  # f5 = x=1 ∧ y=1
    assert rep.initial_set(4).tolist() == [1, 3]
    phi = np.array([rep.feature_values(np.array(s, dtype=float)) for s in STATES_XY])
    assert in_span(phi, V2)
    if not sparsify:  # the thesis's matrix and weights (0, 2, 0, 2, −4)
        np.testing.assert_array_equal(phi[3], [0, 1, 0, 1, 1])
        np.testing.assert_allclose(phi @ [0, 2, 0, 2, -4], V2)
    else:  # sparsified: (1,1) activates f5 alone, which then carries V2(1,1) = 0 by itself
        np.testing.assert_array_equal(phi[3], [0, 0, 0, 0, 1])
        np.testing.assert_allclose(phi @ [0, 2, 0, 2, 0], V2)


# ------------------------------------------------------------------ Section 3.4


def flag_rep(n):
    rep = OnlineIFDD(base=FlagFeatures(num_flags=n), discovery_threshold=1.0)
    return rep.setup(flags_spec(n), seed=0)


def add(rep, *initial):
    expansion = rep.discover(rep.activate_initial(np.array(initial)), td_error=2.0)
    assert expansion is not None and expansion.num_new == 1
    return expansion


def with_empty_column(rep, states):
    """Prepend the ∅ feature of B_n (active only where no index is)."""
    empty = np.array([[1.0 if len(s) == 0 else 0.0] for s in states])
    return np.hstack([empty, matrix(rep, states)])


def test_theorem_3_4_3_base_case_matrices():
    rep = flag_rep(2)
    states = [(0, 1), (0,), (1,), ()]  # rows of the proof: {1,2}, {1}, {2}, ∅
    add(rep, 0, 1)  # E_2 = {{1, 2}}
    raw = OnlineIFDD(base=FlagFeatures(num_flags=2), sparsify=False, discovery_threshold=1.0)
    raw.setup(flags_spec(2), seed=0)
    add(raw, 0, 1)
    np.testing.assert_array_equal(
        with_empty_column(raw, states), [[0, 1, 1, 1], [0, 1, 0, 0], [0, 0, 1, 0], [1, 0, 0, 0]]
    )
    sparse = with_empty_column(rep, states)
    np.testing.assert_array_equal(sparse, [[0, 0, 0, 1], [0, 1, 0, 0], [0, 0, 1, 0], [1, 0, 0, 0]])
    assert np.linalg.matrix_rank(sparse) == 4


REMARK_STATES = [(0, 1, 2), (0, 1), (0, 2), (0,), (1, 2), (1,), (2,), ()]


def test_remark_counterexample_det_is_3():
    rep = flag_rep(3)
    add(rep, 0, 1)  # E_3 = {{1, 2}}
    before = with_empty_column(rep, REMARK_STATES)
    np.testing.assert_array_equal(before, [
        [0, 0, 0, 1, 1], [0, 0, 0, 0, 1], [0, 1, 0, 1, 0], [0, 1, 0, 0, 0],
        [0, 0, 1, 1, 0], [0, 0, 1, 0, 0], [0, 0, 0, 1, 0], [1, 0, 0, 0, 0],
    ])  # fmt: skip
    add(rep, 0, 2)  # f = {1, 3}
    after = with_empty_column(rep, REMARK_STATES)
    np.testing.assert_array_equal(after, [
        [0, 0, 1, 0, 0, 1], [0, 0, 0, 0, 1, 0], [0, 0, 0, 0, 0, 1], [0, 1, 0, 0, 0, 0],
        [0, 0, 1, 1, 0, 0], [0, 0, 1, 0, 0, 0], [0, 0, 0, 1, 0, 0], [1, 0, 0, 0, 0, 0],
    ])  # fmt: skip
    a = np.hstack([after, before[:, [1]]])  # A = [℧(χ ∪ {f})  ℧(χ) e_2]
    assert round(np.linalg.det(a.T @ a)) == 3
    assert not in_span(after, before[:, 1])  # span(℧(χ)) ⊄ span(℧(χ ∪ {f}))
    assert np.linalg.matrix_rank(after) == after.shape[1]  # Theorem 3.4.3: full rank


def mho(rep, states):
    """Algorithm 18 (℧) on Φ_χ, columns ordered by size then discovery (the order of χ)."""
    sets = [set(s.tolist()) for s in rep.initial_sets_]
    order = sorted(range(len(sets)), key=lambda f: (len(sets[f]), f))
    phi = np.array([[1.0 if sets[f] <= set(s) else 0.0 for f in order] for s in states])
    for i in range(len(order) - 1, 0, -1):
        for j in range(i - 1, -1, -1):
            if sets[order[i]] & sets[order[j]]:
                phi[:, j] = phi[:, j] * (1.0 - phi[:, i])  # Φe_j ← Φe_j ↛ Φe_i
    out = np.zeros_like(phi)
    out[:, order] = phi
    return out


def test_algorithm_19_equals_algorithm_18_on_random_feature_sets():
    rng = np.random.default_rng(0)
    n = 6
    states = [s for k in range(n + 1) for s in itertools.combinations(range(n), k)]
    for _ in range(5):
        rep = flag_rep(n)
        for _ in range(25):
            active = rep.activate_initial(
                rng.choice(n, size=int(rng.integers(2, 5)), replace=False)
            )
            if active.shape[0] >= 2:
                pair = rng.choice(active, size=2, replace=False)
                rep.discover(np.sort(pair), td_error=2.0)
            np.testing.assert_array_equal(matrix(rep, states), mho(rep, states))


def test_theorem_3_4_4_values_kept_where_both_parents_were_active_or_h_is_off():
    rng = np.random.default_rng(1)
    n = 7
    states = [s for k in range(n + 1) for s in itertools.combinations(range(n), k)]
    checked = 0
    for _ in range(120):
        rep = flag_rep(n)
        for _ in range(int(rng.integers(0, 12))):  # some earlier conjunctions
            active = rep.activate_initial(rng.choice(n, size=4, replace=False))
            if active.shape[0] >= 2:
                rep.discover(np.sort(rng.choice(active, size=2, replace=False)), td_error=2.0)
        active = rep.activate_initial(rng.choice(n, size=int(rng.integers(2, 6)), replace=False))
        if active.shape[0] < 2:
            continue
        f, g = np.sort(rng.choice(active, size=2, replace=False))
        old = matrix(rep, states)
        theta = rng.normal(size=(rep.num_features_, 1))
        expansion = rep.discover(np.array([f, g]), td_error=2.0)
        if expansion is None:
            continue  # f ∪ g was already a feature
        theta_new = grow_weights(theta.copy(), expansion)  # θ_h = θ_f + θ_g
        new = matrix(rep, states)
        h = expansion.first_new
        keep = ((old[:, f] == 1) & (old[:, g] == 1)) | (new[:, h] == 0)
        np.testing.assert_allclose((new @ theta_new)[keep], (old @ theta)[keep])
        # Corollary 3.4.5: the values differ on at most a 2^-|h| fraction of the states
        differ = ~np.isclose(new @ theta_new, old @ theta)[:, 0]
        assert differ.mean() <= 2.0 ** -rep.initial_set(h).shape[0]
        checked += 1
    assert checked > 50
