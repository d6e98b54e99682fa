import itertools

import numpy as np
import pytest

from conjure.agents import SARSA
from conjure.core import InvalidParameterError, NotSetUpError, Transition
from conjure.domains import BlocksWorld
from conjure.representations import HashedTabular, Tabular
from conjure.representations import _hashed_tabular_kernels as _hk
from conjure.testing import box_spec

BINARY_10 = box_spec([0.0] * 10, [1.0] * 10, is_discrete=[True] * 10)
PENDULUM = box_spec([-np.pi / 2, -2.0], [np.pi / 2, 2.0], name="pendulum")


def all_binary_states(d):
    return np.array(list(itertools.product([0.0, 1.0], repeat=d)))


def test_indices_follow_first_seen_order():
    rep = HashedTabular(capacity=8).setup(BINARY_10, seed=0)
    a, b, c = np.zeros(10), np.ones(10), np.eye(10)[3]
    seen = [int(rep.active_features(s)[0]) for s in (b, a, b, c, a, c)]
    assert seen == [0, 1, 0, 2, 1, 2]
    assert rep.num_stored_ == 3
    np.testing.assert_array_equal(rep.cells_, np.array([b, a, c], dtype=np.int64))


def test_every_binary_state_gets_its_own_index():
    states = all_binary_states(10)
    order = np.random.default_rng(0).permutation(len(states))
    rep = HashedTabular(capacity=len(states)).setup(BINARY_10, seed=0)
    indices = [int(rep.active_features(states[i])[0]) for i in order]
    assert indices == list(range(len(states)))  # a full table of 1,024 distinct states
    again = [int(rep.active_features(states[i])[0]) for i in order]
    assert again == indices


def test_cells_whose_hashes_share_a_slot_are_not_merged():
    rep = HashedTabular(capacity=4).setup(BINARY_10, seed=0)
    mask = rep._slots.shape[0] - 1
    home = {}
    for state in all_binary_states(10):
        slot = int(_hk.cell_hash(state.astype(np.int64)) & np.uint64(mask))
        if slot in home:
            first, second = home[slot], state
            break
        home[slot] = state
    i, j = rep.active_features(first)[0], rep.active_features(second)[0]
    assert (i, j) == (0, 1)
    assert rep.active_features(first)[0] == 0 and rep.active_features(second)[0] == 1


def test_full_table_names_the_capacity_and_suggests_a_larger_one():
    rep = HashedTabular(capacity=2).setup(BINARY_10, seed=0)
    rep.active_features(np.zeros(10))
    rep.active_features(np.ones(10))
    with pytest.raises(InvalidParameterError, match=r"capacity = 2 .*at least 4"):
        rep.active_features(np.eye(10)[0])
    assert rep.active_features(np.ones(10)).tolist() == [1]  # known states still work
    assert rep.num_stored_ == 2


def test_index_of_looks_up_without_storing():
    rep = HashedTabular(capacity=5).setup(BINARY_10, seed=0)
    assert rep.index_of(np.ones(10)) == -1
    assert rep.num_stored_ == 0
    rep.active_features(np.zeros(10))
    rep.active_features(np.ones(10))
    assert rep.index_of(np.ones(10)) == 1
    assert rep.num_stored_ == 2


def test_same_partition_as_tabular():
    rng = np.random.default_rng(1)
    states = rng.uniform(PENDULUM.low - 0.3, PENDULUM.high + 0.3, (3000, 2))
    hashed = HashedTabular(num_buckets=[7, 5]).setup(PENDULUM, seed=0)
    table = Tabular(num_buckets=[7, 5]).setup(PENDULUM, seed=0)
    pairs = {(int(hashed.active_features(s)[0]), int(table.active_features(s)[0])) for s in states}
    assert len(pairs) == len({h for h, _ in pairs}) == len({t for _, t in pairs}) == 35


def test_capacity_never_exceeds_the_number_of_cells():
    assert HashedTabular().setup(PENDULUM, seed=0).num_features_ == 400
    assert HashedTabular(capacity=50).setup(PENDULUM, seed=0).num_features_ == 50
    blocks = BlocksWorld().domain_spec
    assert HashedTabular(capacity=10_231).setup(blocks, seed=0).num_features_ == 10_231


def test_indices_do_not_depend_on_the_seed():
    states = all_binary_states(10)[::7]
    one = HashedTabular(capacity=200).setup(BINARY_10, seed=0)
    two = HashedTabular(capacity=200).setup(BINARY_10, seed=123)
    for s in states:
        assert one.active_features(s)[0] == two.active_features(s)[0]


def test_restore_continues_the_numbering():
    states = all_binary_states(10)
    rep = HashedTabular(capacity=100).setup(BINARY_10, seed=0)
    for s in states[:40]:
        rep.active_features(s)
    twin = HashedTabular(capacity=100).setup(BINARY_10, seed=1)
    twin.load_state_arrays(rep.state_arrays())
    assert twin.num_stored_ == 40
    for s in states[40:80]:
        assert twin.active_features(s)[0] == rep.active_features(s)[0]
    for s in states[:80]:
        assert twin.index_of(s) == rep.index_of(s)


@pytest.mark.parametrize(
    "cells",
    [np.zeros((3, 9), dtype=np.int64), np.zeros((2, 10), dtype=np.int64), np.full((1, 10), 2)],
)
def test_restore_rejects_foreign_cells(cells):
    rep = HashedTabular(capacity=100).setup(BINARY_10, seed=0)
    with pytest.raises(InvalidParameterError, match="cells"):
        rep.load_state_arrays({"cells": cells})


def test_oversized_index_is_refused_before_allocating():
    spec = box_spec([0.0] * 60, [1.0] * 60, is_discrete=[True] * 60)
    with pytest.raises(InvalidParameterError, match="capacity"):
        HashedTabular(capacity=10**9).setup(spec, seed=0)


def test_not_set_up_raises():
    with pytest.raises(NotSetUpError):
        HashedTabular().active_features(np.zeros(2))
    with pytest.raises(NotSetUpError):
        HashedTabular().index_of(np.zeros(2))


def test_sarsa_learns_with_it_on_blocksworld_unchanged():
    domain = BlocksWorld()
    agent = SARSA(representation=HashedTabular(capacity=10_231)).setup(domain.domain_spec, 0)
    assert agent.weights_.shape == (10_231, 36)
    state, _ = domain.reset(seed=0)
    agent.begin_episode()
    action = agent.act(state, legal_actions=domain.legal_actions(state))
    for _ in range(300):
        next_state, reward, terminated, _, _ = domain.step(action)
        next_action = agent.act(next_state, legal_actions=domain.legal_actions(next_state))
        agent.learn(Transition(state, action, reward, next_state, next_action, terminated))
        state, action = next_state, next_action
    stored = agent.representation_.num_stored_
    assert 1 < stored <= 300
    assert np.count_nonzero(np.any(agent.weights_ != 0.0, axis=1)) <= stored


def test_a_run_reports_the_features_in_use_not_the_capacity():
    from conjure.domains import UAVMission
    from conjure.experiments import run

    agent = SARSA(representation=HashedTabular())  # capacity 100,000
    result = run(domain=UAVMission(), agent=agent, budget_steps=2_000, seed=0)
    representation = result.agent.representation_
    in_use = representation.num_features_in_use_
    assert in_use == representation.num_stored_ == result.agent.num_features
    assert 0 < in_use < representation.num_features_ == 100_000  # the capacity, θ's rows
    assert int(result.curve["num_features"].iloc[-1]) == in_use
    assert f"{in_use:,} features" in result.summary()


def test_peek_gives_the_index_storing_would_give_and_stores_nothing():
    # Greedy acting's φ(s): a seen cell's index, a new cell the next index (a θ row no update
    # has touched), a new cell of a full table no feature; the index never changes.
    rep = HashedTabular(capacity=2).setup(BINARY_10, seed=0)
    a, b, c = np.zeros(10), np.ones(10), np.eye(10)[3]
    assert rep.peek(a).indices.tolist() == [0] and rep.num_stored_ == 0
    rep.active_features(a)
    assert [rep.peek(s).indices.tolist() for s in (a, b, c)] == [[0], [1], [1]]
    assert rep.num_stored_ == 1 and rep.index_of(b) == -1
    rep.active_features(b)
    assert rep.peek(c).indices.tolist() == [] and rep.num_stored_ == 2  # full: no feature
    np.testing.assert_array_equal(rep.peek(b).values, [1.0])
