"""RowTraces: the sparse eligibility trace equals the dense z it stands for."""

import numpy as np

from conjure.agents.row_traces import MIN_TRACE, RowTraces
from conjure.core.interfaces import Expansion, SparseFeatures


def phi(*pairs):
    return SparseFeatures(
        np.array([f for f, _ in pairs], dtype=np.int64), np.array([v for _, v in pairs])
    )


def dense(traces: RowTraces, num_features: int, width: int) -> np.ndarray:
    z = np.zeros((num_features, width))
    count = int(traces.count[0])
    z[traces.rows[:count]] = traces.traces[:count]
    return z


def test_steps_match_the_dense_recursion():
    rng = np.random.default_rng(0)
    traces, z = RowTraces(200, 3), np.zeros((200, 3))
    for _ in range(50):
        features = rng.choice(200, size=4, replace=False)
        values = rng.uniform(0.5, 1.0, size=4)
        vector = rng.normal(size=3)
        traces.step(0.9, SparseFeatures(features, values), vector)
        z *= 0.9
        z[np.abs(z).max(axis=1) < MIN_TRACE] = 0.0
        z[features] += values[:, None] * vector
    np.testing.assert_allclose(dense(traces, 200, 3), z, atol=1e-12)
    assert traces.count[0] > 64  # rows grew past the initial block


def test_apply_adds_amount_times_z_to_the_weights():
    traces = RowTraces(4, 2)
    traces.step(0.5, phi((1, 1.0)), np.array([1.0, -1.0]))
    traces.step(0.5, phi((3, 2.0)), np.array([0.0, 1.0]))
    weights = np.zeros((4, 2))
    traces.apply(weights, 2.0)
    np.testing.assert_allclose(weights, [[0, 0], [1.0, -1.0], [0, 0], [0.0, 4.0]])


def test_rows_that_decay_below_the_minimum_are_forgotten():
    traces = RowTraces(3, 1)
    traces.step(1.0, phi((0, 1.0)), np.array([1.0]))
    for _ in range(10):
        traces.step(0.1, phi((2, 1.0)), np.array([0.0]))
    assert traces.slot_of[0] == -1
    assert 0 not in traces.rows[: traces.count[0]]


def test_clear_grow_and_reload_round_trip():
    traces = RowTraces(3, 2)
    traces.step(0.9, phi((0, 1.0), (2, 0.5)), np.array([1.0, 2.0]))
    saved = traces.state_arrays("z_")
    before = dense(traces, 3, 2)
    traces.clear()
    assert traces.count[0] == 0 and (traces.slot_of == -1).all()
    traces.grow(Expansion(3, np.array([[0, 2]])))
    traces.load(saved["z_rows"], saved["z_values"])
    np.testing.assert_allclose(dense(traces, 4, 2)[:3], before)
    traces.step(1.0, phi((3, 1.0)), np.array([1.0, 1.0]))
    assert dense(traces, 4, 2)[3].tolist() == [1.0, 1.0]
