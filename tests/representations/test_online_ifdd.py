"""Online iFDD (Geramifard 2012, Section 4.1, Algorithms 19-21, Eq. 4.6)."""

import itertools

import numpy as np
import pytest
from ifdd_oracle import FlagFeatures, OracleIFDD, flags, flags_spec

from conjure.agents import SARSA, ActorCritic, QLearning
from conjure.core import DomainSpec
from conjure.core.errors import IncompatibleComponentsError, InvalidParameterError, NotSetUpError
from conjure.domains import InvertedPendulum
from conjure.experiments.loop import LearningLoop
from conjure.policies import EpsilonGreedy
from conjure.representations import RBF, IndependentDiscretization, TileCoding
from conjure.representations import _ifdd_kernels as kernels
from conjure.representations.online_ifdd import OnlineIFDD
from conjure.representations.weights import grow_weights
from conjure.testing import check_component


def flag_ifdd(num_flags=21, **params):
    rep = OnlineIFDD(base=FlagFeatures(num_flags=num_flags), **params)
    return rep.setup(flags_spec(num_flags), seed=0)


# ------------------------------------------------------------------ the worked example


def test_hand_checked_discovery_scenario():
    rep = flag_ifdd(21, discovery_threshold=1.0)
    phi = rep.active_features(flags(21, [0, 1]))
    assert phi.tolist() == [0, 1]
    expansion = rep.discover(phi, td_error=2.0)  # ψ_{0,1} = |2| > ξ = 1
    assert expansion.first_new == 21
    assert expansion.parents.tolist() == [[0, 1]]
    assert rep.num_features_ == 22 and rep.num_discovered_ == 1
    assert rep.initial_set(21).tolist() == [0, 1]
    assert rep.active_features(flags(21, [0, 1])).tolist() == [21]
    assert rep.active_features(flags(21, [0, 1, 20])).tolist() == [20, 21]
    assert rep.active_features(flags(21, [2, 3])).tolist() == [2, 3]
    assert rep.active_features(flags(21, [0, 2])).tolist() == [0, 2]


def test_below_threshold_nothing_is_discovered_and_relevance_accumulates():
    rep = flag_ifdd(21, discovery_threshold=1.0)
    phi = rep.active_features(flags(21, [0, 1, 5]))
    assert rep.discover(phi, td_error=-0.4) is None
    sets, parents, relevances = rep.potential_features()
    assert [s.tolist() for s in sets] == [[0, 1], [0, 5], [1, 5]]
    assert parents.tolist() == [[0, 1], [0, 5], [1, 5]]
    np.testing.assert_allclose(relevances, 0.4)
    assert rep.discover(phi, td_error=0.5) is None  # ψ = 0.9
    expansion = rep.discover(phi, td_error=0.2)  # ψ = 1.1 > 1 for all three, in pair order
    assert expansion.parents.tolist() == [[0, 1], [0, 5], [1, 5]]
    # equal sizes: the latest discovered ({1, 5}, id 23) is activated first
    assert rep.active_features(flags(21, [0, 1, 5])).tolist() == [0, 23]
    assert rep.relevances_.size == 0


def test_ifdd_plus_relevance_is_mean_over_root_count():
    rep = flag_ifdd(4, discovery_threshold=1.0, relevance="ifdd_plus")
    phi = rep.active_features(flags(4, [0, 1]))
    for delta in (0.8, -0.7, 0.9):
        assert rep.discover(phi, delta) is None
    np.testing.assert_allclose(rep.relevances_, [1.0 / np.sqrt(3)])
    assert rep.discover(phi, 1.5) is not None  # |2.5| / 2 > 1
    signed = flag_ifdd(4, discovery_threshold=1.0, relevance="ifdd_plus_signed")
    for _ in range(5):
        assert signed.discover(phi, -3.0) is None  # Δ/√ν negative: never above ξ
    magnitude = flag_ifdd(4, discovery_threshold=1.0, relevance="ifdd_plus")
    assert magnitude.discover(phi, -3.0) is not None


def test_pairs_with_the_same_union_share_one_relevance():
    rep = flag_ifdd(6, discovery_threshold=1.5, sparsify=False)
    rep.discover(rep.active_features(flags(6, [0, 1])), 2.0)  # {0,1} = 6
    rep.discover(rep.active_features(flags(6, [1, 2])), 2.0)  # {1,2} = 7
    assert rep.num_features_ == 8
    # φ of {0,1,2} without sparsification: 0, 1, 2, 6, 7; pairs (0,7), (6,2), (6,7) give {0,1,2}
    phi = rep.active_features(flags(6, [0, 1, 2]))
    assert phi.tolist() == [0, 1, 2, 6, 7]
    expansion = rep.discover(phi, 0.6)  # (0,7): .6, (2,6): 1.2, (6,7): 1.8 > 1.5
    assert rep.initial_set(8).tolist() == [0, 1, 2]
    assert expansion.parents.tolist() == [[6, 7]]


def test_max_features_caps_discovery_but_relevance_keeps_counting():
    rep = flag_ifdd(5, discovery_threshold=0.0, max_features=6)
    phi = rep.active_features(flags(5, [0, 1, 2]))
    expansion = rep.discover(phi, 1.0)
    assert expansion.num_new == 1 and rep.num_features_ == 6
    assert rep.discover(rep.active_features(flags(5, [3, 4])), 1.0) is None
    assert rep.num_features_ == 6
    assert len(rep.potential_features()[0]) == 3


def test_fixed_rate_follows_eq_4_6_and_picks_the_most_relevant():
    rep = flag_ifdd(8, discovery_rate=1.0)
    phi = rep.active_features(flags(8, [0, 1, 2]))
    rep.discover(phi, 0.0)  # t = 1: n = 8 + floor(sqrt(1)) = 9
    assert rep.num_features_ == 9
    counts = []
    for t in range(2, 30):
        state = flags(8, [t % 8, (3 * t + 1) % 8, (5 * t + 2) % 8])
        rep.discover(rep.active_features(state), float(t % 3))
        counts.append(rep.num_features_)
    expected = [min(8 + int(np.floor(np.sqrt(t))), 8 + 28) for t in range(2, 30)]
    assert counts == expected
    heavy = flag_ifdd(8, discovery_rate=1.0)
    heavy.discover(heavy.active_features(flags(8, [0, 1])), 0.5)  # t=1: adds {0,1}
    heavy.discover(heavy.active_features(flags(8, [2, 3])), 0.1)  # t=2: 9 >= 8+1
    heavy.discover(heavy.active_features(flags(8, [4, 5])), 0.9)  # t=3: 9 >= 8+1
    heavy.discover(heavy.active_features(flags(8, [6, 7])), 0.0)  # t=4: n=10, most relevant
    assert heavy.initial_set(9).tolist() == [4, 5]


def test_parents_are_features_active_together_and_only_features_are_added():
    rep = flag_ifdd(10, discovery_threshold=0.5)
    rng = np.random.default_rng(0)
    count = rep.num_features_
    for _ in range(300):
        phi = rep.active_features(flags(10, rng.choice(10, size=4, replace=False)))
        expansion = rep.discover(phi, rng.normal())
        if expansion is not None:
            assert expansion.first_new == count
            assert set(expansion.parents.ravel()) <= set(phi.tolist())
            for i, (g, h) in enumerate(expansion.parents):
                union = set(rep.initial_set(g)) | set(rep.initial_set(h))
                assert set(rep.initial_set(count + i)) == union
            count += expansion.num_new
        assert rep.num_features_ == count


# ------------------------------------------------------------------ oracle (Algorithms 19-21)


def random_sequence(seed, num_flags, length):
    rng = np.random.default_rng(seed)
    weights = rng.dirichlet(np.ones(num_flags) * 0.5)  # some flags co-occur far more often
    for _ in range(length):
        k = int(rng.integers(1, 7))
        active = np.sort(rng.choice(num_flags, size=k, replace=False, p=weights))
        yield active, float(rng.normal() * rng.choice([0.1, 1.0, 3.0]))


ORACLE_CASES = [
    {"relevance": "ifdd", "discovery_threshold": 2.0},
    {"relevance": "ifdd", "discovery_threshold": 2.0, "sparsify": False},
    {"relevance": "ifdd_plus", "discovery_threshold": 0.8},
    {"relevance": "ifdd_plus", "discovery_threshold": 0.8, "sparsify": False},
    {"relevance": "ifdd_plus_signed", "discovery_threshold": 0.5},
    {"relevance": "ifdd", "discovery_threshold": 1.0, "max_features": 40},
    {"relevance": "ifdd", "discovery_rate": 2.0},
    {"relevance": "ifdd_plus", "discovery_rate": 0.5, "sparsify": False},
]


@pytest.mark.parametrize("params", ORACLE_CASES, ids=lambda p: repr(p))
def test_compiled_matches_the_plain_python_oracle(params):
    num_flags = 14
    rep = flag_ifdd(num_flags, **params)
    oracle = OracleIFDD(
        num_flags,
        threshold=params["discovery_threshold"] if "discovery_threshold" in params else 1.0,
        relevance=params["relevance"],
        sparsify=params.get("sparsify", True),
        max_features=params.get("max_features"),
        rate=params.get("discovery_rate"),
    )
    for step, (active, delta) in enumerate(random_sequence(1, num_flags, 3000)):
        phi = rep.active_features(flags(num_flags, active))
        assert phi.tolist() == oracle.activate(active), f"φ̇ differs at step {step}"
        expansion = rep.discover(phi, delta)
        expected = oracle.discover(phi.tolist(), delta)
        got = [] if expansion is None else [tuple(p) for p in expansion.parents.tolist()]
        assert got == expected, f"discoveries differ at step {step}"
    assert rep.num_features_ == oracle.num_features > num_flags + 10
    assert [set(s.tolist()) for s in rep.initial_sets_] == [set(s) for s in oracle.sets]
    sets, _, relevances = rep.potential_features()
    oracle_sets, oracle_relevances = oracle.potential_features()
    assert [frozenset(s.tolist()) for s in sets] == oracle_sets
    assert relevances.tolist() == oracle_relevances  # bit for bit
    for size in (1, 2, 3, 4, 6):  # φ̇ of every state with up to `size` flags on 8 flags
        for active in itertools.combinations(range(8), size):
            assert rep.activate_initial(np.array(active)).tolist() == oracle.activate(active)


def test_capacity_growth_keeps_everything():
    rep = flag_ifdd(40, discovery_threshold=3.0)
    oracle = OracleIFDD(40, threshold=3.0)
    rng = np.random.default_rng(3)
    for _ in range(800):  # many potential features: node arrays and the pool grow
        active = np.sort(rng.choice(40, size=10, replace=False))
        phi = rep.active_features(flags(40, active))
        assert phi.tolist() == oracle.activate(active)
        rep.discover(phi, 1.0)
        oracle.discover(phi.tolist(), 1.0)
    assert rep._arrays["node_key"].shape[0] > 1024
    assert rep.num_features_ == oracle.num_features


def test_activation_cache_is_refreshed_by_discovery():
    rep = flag_ifdd(6, discovery_threshold=0.5)
    state = flags(6, [0, 1, 2])
    assert rep.active_features(state).tolist() == [0, 1, 2]
    rep.discover(rep.active_features(flags(6, [1, 2])), 1.0)  # {1,2} = 6
    assert rep.active_features(state).tolist() == [0, 6]
    for _ in range(kernels.PATCH_LIMIT + 3):  # many unrelated discoveries, then revisit
        rep.discover(rep.active_features(flags(6, [3, 4, 5])), 1.0)
    rep.discover(rep.active_features(flags(6, [0, 1])), 1.0)  # {0,1}: 6 -> {0,1} and {2}
    assert rep.active_features(state).tolist() == OracleActivation.of(rep, [0, 1, 2])


def sorted_power_set_activation(sets, active, sparsify=True):
    """Algorithm 19 by brute force: walk SortedPowerSet(φ⁰) and keep the features of χ.

    Subsets go largest first and, within a size, the latest discovered first (the documented
    tie rule); a feature is activated only if none of its initial features is covered yet.
    """
    ids = {frozenset(s): f for f, s in enumerate(sets)}
    candidates = [
        ids[frozenset(c)]
        for size in range(len(active), 0, -1)
        for c in itertools.combinations(active, size)
        if frozenset(c) in ids
    ]
    if not sparsify:
        return sorted(candidates)
    candidates.sort(key=lambda f: (-len(sets[f]), -f))
    remaining, phi = set(active), []
    for f in candidates:
        if sets[f] <= remaining:
            remaining -= sets[f]
            phi.append(f)
    return sorted(phi)


@pytest.mark.parametrize("sparsify", [True, False])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_activation_equals_the_sorted_power_set_walk_on_random_features(seed, sparsify):
    num_flags = 12
    rep = flag_ifdd(num_flags, discovery_threshold=0.0, sparsify=sparsify)
    rng = np.random.default_rng(seed)
    for _ in range(60):  # every co-active pair becomes a feature: many sizes and overlaps
        active = np.sort(rng.choice(num_flags, size=int(rng.integers(2, 9)), replace=False))
        rep.discover(rep.active_features(flags(num_flags, active)), 1.0)
    sets = [frozenset(s.tolist()) for s in rep.initial_sets_]
    assert rep.num_discovered_ > 100 and max(len(s) for s in sets) >= 4
    for _ in range(300):
        active = sorted(rng.choice(num_flags, size=int(rng.integers(1, 11)), replace=False))
        expected = sorted_power_set_activation(sets, active, sparsify)
        assert rep.activate_initial(np.array(active)).tolist() == expected
        assert rep.activate_initial(np.array(active)).tolist() == expected  # from the cache


def rows_allocated(count):
    """Rows a block of ``count`` children takes without compaction: 4, 8, 16, ... rows."""
    total, block = 4, 4
    while block < count:
        block *= 2
        total += block
    return total


def test_parent_index_blocks_hold_every_child_after_compaction():
    # 30 initial features, 170 discovered ones on a skewed choice of parents: blocks move as
    # they fill, and the doublings need more rows than `children` has, so it is compacted
    n0, capacity = 30, 200
    rng = np.random.default_rng(0)
    feat_len = np.ones(capacity, dtype=np.int64)
    feat_parents = np.full((capacity, 2), -1, dtype=np.int64)
    for f in range(n0, capacity):
        g = int(rng.integers(0, 3)) if rng.random() < 0.8 else int(rng.integers(0, f))
        h = int(rng.integers(0, f))
        while h == g:
            h = int(rng.integers(0, f))
        feat_parents[f] = g, h
        feat_len[f] = 2
    counts = np.bincount(feat_parents[n0:].ravel(), minlength=capacity)
    doubled = sum(rows_allocated(int(c)) for c in counts if c)
    links = np.zeros((capacity, kernels.NUM_L), dtype=np.int64)
    children = np.empty((4 * capacity + 8, 2), dtype=np.int64)
    assert doubled > children.shape[0]  # so compaction must have run
    pair_table = np.full((1024, 3), -1, dtype=np.int64)
    arrays = {
        name: np.zeros((1,) * kind.ndim, dtype=np.float64 if name == "node_stats" else np.int64)
        for name, kind in kernels.TABLES
    }  # the tables link_children does not read: stand-ins
    arrays.update(feat_len=feat_len, feat_parents=feat_parents, links=links, children=children,
                  pair_table=pair_table)  # fmt: skip
    ints = np.zeros(kernels.NUM_INTS, dtype=np.int64)
    tables = kernels.new_tables(arrays, ints, np.zeros(len(kernels.SETTINGS)))
    for n in range(n0 + 10, capacity + 1, 10):  # linked in batches, as discoveries arrive
        ints[kernels.COUNTERS.index("num_features")] = n
        kernels.link_children(tables)
    for p in range(capacity):
        start, count = links[p, kernels.L_START], links[p, kernels.L_COUNT]
        rows = sorted(map(tuple, children[start : start + count].tolist()))
        expected = sorted(
            (f, int(feat_parents[f, 1 - side]))
            for f in range(n0, capacity)
            for side in range(2)
            if feat_parents[f, side] == p
        )
        assert rows == expected, f"feature {p}'s children"


def test_activation_cache_forgets_one_entry_at_a_time():
    rep = flag_ifdd(16, discovery_threshold=0.5)
    rep.discover(rep.active_features(flags(16, [0, 1])), 1.0)
    first = np.array([0, 1, 2])
    rep.activate_initial(first)
    row = int(np.bitwise_xor.reduce(rep._arrays["words"][first])) & (rep._centry.shape[0] - 1)
    rows_used = set()
    rng = np.random.default_rng(0)
    for _ in range(3000):  # more distinct sets than fit: some rows are overwritten
        active = np.sort(rng.choice(np.arange(3, 16), size=5, replace=False))
        key = int(np.bitwise_xor.reduce(rep._arrays["words"][active]))
        rows_used.add(key & (rep._centry.shape[0] - 1))
        rep.activate_initial(active)
    assert row not in rows_used  # its row was never overwritten ...
    assert rep._centry[row, kernels.C_A_LEN] == 3  # ... so its entry is still there
    assert rep.activate_initial(first).tolist() == [2, 16]


class OracleActivation:
    """Algorithm 19 by brute force from the representation's own feature sets."""

    @staticmethod
    def of(rep, active):
        oracle = OracleIFDD(rep.num_initial_features_)
        oracle.sets = [frozenset(s.tolist()) for s in rep.initial_sets_]
        return oracle.activate(active)


# ------------------------------------------------------------------ Section 4.1.2


def discrete_spec(d, q):
    return DomainSpec(
        name="grid",
        low=np.zeros(d),
        high=np.full(d, q - 1.0),
        is_discrete=np.ones(d, dtype=bool),
        num_actions=1,
        discount=0.9,
        max_episode_steps=10,
    )


@pytest.mark.parametrize(("d", "q"), [(3, 2), (2, 3)])
def test_features_explored_are_at_most_q_plus_one_to_the_d_minus_one(d, q):
    """Remark of Section 4.1.2: at most (q + 1)^d − 1 features on d variables of q values."""
    rep = OnlineIFDD(base=IndependentDiscretization(), discovery_threshold=0.0)
    rep.setup(discrete_spec(d, q), seed=0)
    states = [np.array(s, dtype=float) for s in itertools.product(range(q), repeat=d)]
    for _ in range(2 * d):
        for state in states:
            rep.discover(rep.active_features(state), 1.0)
    assert rep.num_features_ == (q + 1) ** d - 1  # every conjunction, and no more
    for state in states:  # fully expanded: one active feature, the full conjunction
        phi = rep.active_features(state)
        assert phi.shape == (1,) and rep.initial_set(int(phi[0])).shape == (d,)


def ifdd_td(rep, transitions, rewards, num_steps, seed, step_size=0.1, discount=0.9):
    """iFDD-TD (policy evaluation, Section 4.1.2) on a Markov chain over the grid states."""
    rng = np.random.default_rng(seed)
    states = rep._test_states
    weights = np.zeros(rep.num_features_)
    s = 0
    errors = []
    for _ in range(num_steps):
        s_next = int(rng.choice(len(states), p=transitions[s]))
        phi = rep.active_features(states[s])
        phi_next = rep.active_features(states[s_next])
        delta = rewards[s] + discount * weights[phi_next].sum() - weights[phi].sum()
        weights[phi] += step_size * delta
        expansion = rep.discover(phi, delta)
        weights = grow_weights(weights[:, None], expansion)[:, 0]
        errors.append(abs(delta))
        s = s_next
    return weights, np.array(errors)


def test_theorem_4_1_1_adds_every_conjunction_when_the_error_persists():
    """V2 of Section 3.2.1 (not linear in the initial features) on a stochastic ergodic chain."""
    rep = OnlineIFDD(base=IndependentDiscretization(), discovery_threshold=0.5)
    rep.setup(discrete_spec(2, 2), seed=0)
    rep._test_states = [np.array(s, dtype=float) for s in itertools.product(range(2), repeat=2)]
    transitions = np.full((4, 4), 0.25)
    rewards = np.array([0.0, 2.0, 2.0, 0.0])
    ifdd_td(rep, transitions, rewards, 20_000, seed=0)
    assert rep.num_features_ == (2 + 1) ** 2 - 1  # all 4 pairs discovered


def test_theorem_4_1_1_or_drives_the_td_error_to_zero():
    """A deterministic cycle whose value is linear in the initial features: δ → 0."""
    rep = OnlineIFDD(base=IndependentDiscretization(), discovery_threshold=50.0)
    rep.setup(discrete_spec(2, 2), seed=0)
    rep._test_states = [np.array(s, dtype=float) for s in itertools.product(range(2), repeat=2)]
    transitions = np.roll(np.eye(4), 1, axis=1)  # 0 -> 1 -> 2 -> 3 -> 0
    rewards = np.array([1.0, -0.5, 0.3, 0.2])
    _, errors = ifdd_td(rep, transitions, rewards, 20_000, seed=0, step_size=0.2)
    assert errors[-400:].max() < 1e-6
    assert rep.num_features_ < (2 + 1) ** 2 - 1


# ------------------------------------------------------------------ with the learners


def pendulum_agent(cls, **params):
    rep = OnlineIFDD(base=IndependentDiscretization(num_buckets=20), discovery_threshold=0.5)
    if cls is ActorCritic:  # iFDD as the critic's features; the actor keeps its own
        actor = IndependentDiscretization(num_buckets=20)
        return ActorCritic(representation=rep, actor_representation=actor, **params)
    return cls(representation=rep, policy=EpsilonGreedy(epsilon=0.1), step_size=0.1, **params)


def trained(agent, num_steps, seed=0):
    domain = InvertedPendulum()
    agent.setup(domain.domain_spec, seed=seed)
    loop = LearningLoop(domain, agent, seed=seed)
    loop.advance(num_steps)
    return agent, loop


@pytest.mark.parametrize("cls", [SARSA, QLearning, ActorCritic])
def test_end_to_end_on_the_pendulum(cls):
    agent, _ = trained(pendulum_agent(cls), 3000)
    rep = agent.representation_
    assert rep.num_discovered_ > 0
    assert agent.weights_.shape[0] == rep.num_features_
    assert np.all(np.isfinite(agent.weights_))
    for state in (np.array([0.1, -0.2]), np.array([-0.5, 1.0])):
        assert np.all(np.isfinite(agent.q_values(state)))
    twin, _ = trained(pendulum_agent(cls), 3000)
    np.testing.assert_array_equal(twin.weights_, agent.weights_)  # determinism for a seed
    np.testing.assert_array_equal(twin.representation_.parents_, rep.parents_)


@pytest.mark.parametrize("cls", [SARSA, QLearning, ActorCritic])
def test_save_restore_continues_exactly(cls, tmp_path):
    straight, _ = trained(pendulum_agent(cls), 4000)
    first, loop = trained(pendulum_agent(cls), 2000)
    first.save(tmp_path / "agent")
    restored = type(first).restore(tmp_path / "agent")
    assert restored.representation_.num_features_ == first.representation_.num_features_
    loop.agent = restored  # continue the same episode, domain and all, with the restored agent
    loop.advance(2000)
    np.testing.assert_array_equal(restored.weights_, straight.weights_)
    np.testing.assert_array_equal(
        restored.representation_.parents_, straight.representation_.parents_
    )
    assert (
        restored.representation_.relevances_.tolist()
        == straight.representation_.relevances_.tolist()
    )


def test_state_round_trip_restores_potentials_and_continues():
    params = {"discovery_threshold": 2.5, "relevance": "ifdd_plus"}
    rep = flag_ifdd(12, **params)
    sequence = list(random_sequence(5, 12, 600))
    for active, delta in sequence[:300]:
        rep.discover(rep.active_features(flags(12, active)), delta)
    twin = OnlineIFDD(base=FlagFeatures(num_flags=12), **params).setup(flags_spec(12), seed=9)
    twin.load_state_arrays(rep.state_arrays())
    for active, delta in sequence[300:]:
        phi = rep.active_features(flags(12, active))
        assert twin.active_features(flags(12, active)).tolist() == phi.tolist()
        a, b = rep.discover(phi, delta), twin.discover(phi, delta)
        assert (a is None and b is None) or a.parents.tolist() == b.parents.tolist()
    assert twin.relevances_.tolist() == rep.relevances_.tolist()


# ------------------------------------------------------------------ contract


@pytest.mark.parametrize(
    "base",
    [IndependentDiscretization(num_buckets=5), TileCoding(num_tilings=3, tiles_per_dim=4)],
)
def test_common_checks(base):
    check_component(OnlineIFDD(base=base))
    check_component(OnlineIFDD(base=base, relevance="ifdd_plus", discovery_rate=1.0))


def test_tile_coding_base_discovers_conjunctions_of_tiles():
    spec = InvertedPendulum().domain_spec
    rep = OnlineIFDD(base=TileCoding(num_tilings=4, tiles_per_dim=6), discovery_threshold=0.0)
    rep.setup(spec, seed=0)
    phi = rep.active_features(np.array([0.1, 0.2]))
    assert phi.shape == (4,)
    rep.discover(phi, 1.0)
    assert rep.num_discovered_ == 6  # every pair of the 4 active tiles
    assert rep.active_features(np.array([0.1, 0.2])).shape == (2,)


def test_errors():
    with pytest.raises(NotSetUpError):
        OnlineIFDD(base=IndependentDiscretization()).active_features(np.zeros(2))
    with pytest.raises(IncompatibleComponentsError, match="binary"):
        OnlineIFDD(base=RBF()).setup(InvertedPendulum().domain_spec, seed=0)
    with pytest.raises(InvalidParameterError, match="relevance"):
        OnlineIFDD(base=IndependentDiscretization(), relevance="ifdd+").setup(
            InvertedPendulum().domain_spec, seed=0
        )
    rep = OnlineIFDD(base=IndependentDiscretization()).setup(InvertedPendulum().domain_spec, 0)
    with pytest.raises(InvalidParameterError, match=r"\(3,\)"):
        rep.active_features(np.zeros(3))


def test_max_features_counts_initial_plus_discovered_features():
    # 5 initial flags; a cap of 5 + 2 lets exactly two conjunctions in.
    rep = flag_ifdd(5, discovery_threshold=0.0, max_features=7)
    for active in ([0, 1], [2, 3], [0, 4], [1, 2, 3]):
        rep.discover(rep.active_features(flags(5, active)), 1.0)
    assert rep.num_features_ == 7
    with pytest.raises(InvalidParameterError, match=r"initial plus discovered"):
        OnlineIFDD(base=FlagFeatures(num_flags=5), max_features=0).validate_params()


@pytest.mark.parametrize("cls", ["OnlineIFDD", "RandomExpansion"])
def test_a_cap_below_the_initial_features_is_rejected(cls):
    from conjure.domains import BlocksWorld
    from conjure.representations import BinaryIndicators, RandomExpansion

    kind = {"OnlineIFDD": OnlineIFDD, "RandomExpansion": RandomExpansion}[cls]
    spec = BlocksWorld().domain_spec  # 36 initial On(·,·) features
    rate = {"discovery_rate": 1.0}
    with pytest.raises(InvalidParameterError, match=rf"`{cls}.max_features`.*at least the 36"):
        kind(base=BinaryIndicators(), max_features=10, **rate).setup(spec, seed=0)
    rep = kind(base=BinaryIndicators(), max_features=36, **rate).setup(spec, seed=0)
    assert rep.num_features_ == 36  # a cap equal to n₀ freezes the features
