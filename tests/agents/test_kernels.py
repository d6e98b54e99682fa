"""The one sparse kernel family of the linear TD learners, on hand-checked numbers.

φ(s) lists features 0 and 2 of n = 3 with values 0.5 and 2.0; θ has |A| = 2 columns. Every
expected number below is exact in binary floating point.
"""

import numpy as np
import pytest

from conjure.agents import _kernels

INDICES = np.array([0, 2], dtype=np.int64)
VALUES = np.array([0.5, 2.0])
ONES = np.ones(2)


def empty_traces(num_features=3, num_actions=2, capacity=64):
    return (
        np.zeros((num_features, num_actions), dtype=np.int64),  # 1 + slot; 0: no trace
        np.zeros(capacity, dtype=np.int64),
        np.zeros(capacity, dtype=np.int64),
        np.zeros(capacity),
        np.zeros(1, dtype=np.int64),
    )


def traced_step(weights, values, traces, *, is_replacing, action=0, min_trace=1e-3):
    # α = 0.25, γλ = 0.5, target 1.
    return _kernels.td_step_traces(
        weights, INDICES, values, action, 1.0, 0.25, 0.5, is_replacing, min_trace, *traces
    )


def trace_table(traces):
    _, features, actions, values, count = traces
    table = np.zeros((3, 2))
    table[features[: count[0]], actions[: count[0]]] = values[: count[0]]
    return table


def test_q_values_weigh_each_feature_by_its_value():
    weights = np.array([[1.0, 0.0], [7.0, 7.0], [2.0, 1.0]])
    # Q(s, 0) = 0.5·1 + 2·2 = 4.5; Q(s, 1) = 0.5·0 + 2·1 = 2 (feature 1 is not listed).
    assert _kernels.q_values(weights, INDICES, VALUES).tolist() == [4.5, 2.0]
    assert _kernels.q_values(weights, INDICES, None).tolist() == [3.0, 1.0]


def test_td_step_moves_each_weight_by_alpha_delta_value():
    weights = np.array([[1.0, 0.0], [7.0, 7.0], [2.0, 1.0]])
    # δ = 5.5 − 4.5 = 1; θ_0,0 += 0.25·1·0.5, θ_2,0 += 0.25·1·2; action 1 untouched.
    delta = _kernels.td_step(weights, INDICES, VALUES, 0, 5.5, 0.25)
    assert delta == 1.0
    assert weights.tolist() == [[1.125, 0.0], [7.0, 7.0], [2.5, 1.0]]


def test_accumulating_traces_add_the_feature_values():
    weights, traces = np.zeros((3, 2)), empty_traces()
    # Step 1: δ = 1, e = (0.5, 2); θ_0,0 = 0.125, θ_2,0 = 0.5.
    assert traced_step(weights, VALUES, traces, is_replacing=False) == 1.0
    assert trace_table(traces)[:, 0].tolist() == [0.5, 0.0, 2.0]
    # Step 2: Q = 0.5·0.125 + 2·0.5 = 1.0625, δ = −0.0625; e = 0.5 e + φ = (0.75, 3).
    assert traced_step(weights, VALUES, traces, is_replacing=False) == -0.0625
    assert trace_table(traces)[:, 0].tolist() == [0.75, 0.0, 3.0]
    # θ += 0.25·(−0.0625)·e.
    assert weights[:, 0].tolist() == [0.11328125, 0.0, 0.453125]
    assert weights[:, 1].tolist() == [0.0, 0.0, 0.0]


def test_replacing_traces_reset_binary_features_to_one():
    replaced, replaced_traces = np.zeros((3, 2)), empty_traces()
    summed, summed_traces = np.zeros((3, 2)), empty_traces()
    for _ in range(2):
        traced_step(replaced, ONES, replaced_traces, is_replacing=True, action=1)
        traced_step(summed, ONES, summed_traces, is_replacing=False, action=1)
    # Step 1: δ = 1, e = 1, θ = 0.25. Step 2: δ = 0.5; replacing e = 1 (θ = 0.375),
    # accumulating e = 0.5 + 1 = 1.5 (θ = 0.25 + 0.125·1.5 = 0.4375).
    assert trace_table(replaced_traces)[:, 1].tolist() == [1.0, 0.0, 1.0]
    assert replaced[:, 1].tolist() == [0.375, 0.0, 0.375]
    assert trace_table(summed_traces)[:, 1].tolist() == [1.5, 0.0, 1.5]
    assert summed[:, 1].tolist() == [0.4375, 0.0, 0.4375]


def test_replacing_traces_accumulate_when_values_are_not_one():
    # Replacing traces are defined for binary features; real values accumulate (SARSA Choice).
    replacing, accumulating = np.zeros((3, 2)), np.zeros((3, 2))
    traces_r, traces_a = empty_traces(), empty_traces()
    for _ in range(2):
        traced_step(replacing, VALUES, traces_r, is_replacing=True)
        traced_step(accumulating, VALUES, traces_a, is_replacing=False)
    assert np.array_equal(replacing, accumulating)
    assert np.array_equal(trace_table(traces_r), trace_table(traces_a))


def test_traces_below_min_trace_are_dropped():
    weights, traces = np.zeros((3, 2)), empty_traces()
    traced_step(weights, VALUES, traces, is_replacing=False, min_trace=0.3)
    other = np.array([1], dtype=np.int64)
    # Decayed to (0.25, 1): trace (0, 0) falls below 0.3 and its slot is freed.
    _kernels.td_step_traces(weights, other, ONES[:1], 1, 1.0, 0.25, 0.5, False, 0.3, *traces)
    assert trace_table(traces).tolist() == [[0.0, 0.0], [0.0, 1.0], [1.0, 0.0]]
    assert traces[0][0, 0] == 0 and traces[4][0] == 2


def test_actor_add_and_norms():
    weights = np.zeros((3, 2))
    _kernels.add(weights, INDICES, VALUES, 1, 0.5)
    assert weights[:, 1].tolist() == [0.25, 0.0, 1.0]
    assert _kernels.l1_norm(np.array([0.5, -2.0])) == 2.5
    assert _kernels.squared_norm(np.array([0.5, -2.0])) == 4.25
    assert _kernels.l1_norm(ONES) == _kernels.squared_norm(ONES) == 2.0  # k for binary φ


@pytest.mark.parametrize("seed", [0, 1])
def test_values_none_equals_unit_values_bit_for_bit(seed):
    rng = np.random.default_rng(seed)
    active = np.sort(rng.choice(50, size=6, replace=False)).astype(np.int64)
    start = rng.normal(size=(50, 3))
    ones = np.ones(6)
    for replacing in (True, False):
        with_values, with_none = start.copy(), start.copy()
        traces_v, traces_n = empty_traces(50, 3), empty_traces(50, 3)
        for step in range(5):
            target = float(rng.normal())
            a = _kernels.td_step_traces(
                with_values, active, ones, step % 3, target, 0.1, 0.9, replacing, 1e-3, *traces_v
            )
            b = _kernels.td_step_traces(
                with_none, active, None, step % 3, target, 0.1, 0.9, replacing, 1e-3, *traces_n
            )
            assert a == b
        assert np.array_equal(with_values, with_none)
    q = np.empty(3)
    _kernels.q_values_into(start, active, None, q)
    assert np.array_equal(q, _kernels.q_values(start, active, ones))
