"""Random expansion at the fixed rate of Eq. 4.6 (Geramifard 2012, Section 4.1.4, Fig. 4-7)."""

import numpy as np
import pytest
from ifdd_oracle import FlagFeatures, OracleIFDD, flags, flags_spec

from conjure.agents import SARSA
from conjure.core.errors import InvalidParameterError
from conjure.domains import InvertedPendulum
from conjure.experiments.loop import LearningLoop
from conjure.representations import IndependentDiscretization
from conjure.representations import _ifdd_kernels as kernels
from conjure.representations.online_ifdd import OnlineIFDD
from conjure.representations.random_expansion import RandomExpansion
from conjure.testing import check_component


def flag_random(num_flags, seed=0, **params):
    rep = RandomExpansion(base=FlagFeatures(num_flags=num_flags), **params)
    return rep.setup(flags_spec(num_flags), seed=seed)


def sequence(seed, num_flags, length):
    rng = np.random.default_rng(seed)
    for _ in range(length):
        active = np.sort(rng.choice(num_flags, size=int(rng.integers(1, 6)), replace=False))
        yield active, float(rng.normal())


def random_word(rep):
    """The seed word of the representation's random draws, as saved."""
    return int(rep.state_arrays()["ints"][kernels.COUNTERS.index("random_word")])


@pytest.mark.parametrize("sparsify", [True, False])
def test_matches_the_oracle_and_follows_eq_4_6(sparsify):
    rep = flag_random(12, discovery_rate=3.0, sparsify=sparsify)
    oracle = OracleIFDD(12, rate=3.0, selection="random", sparsify=sparsify,
                        random_word=random_word(rep))  # fmt: skip
    for t, (active, delta) in enumerate(sequence(2, 12, 1500), start=1):
        phi = rep.active_features(flags(12, active))
        assert phi.tolist() == oracle.activate(active)
        expansion = rep.discover(phi, delta)
        got = [] if expansion is None else [tuple(p) for p in expansion.parents.tolist()]
        assert got == oracle.discover(phi.tolist(), delta), f"differs at t={t}"
        if oracle.potentials:  # the pool never ran dry: n_t = n_0 + floor(sqrt(C t))
            assert rep.num_features_ == 12 + int(np.floor(np.sqrt(3.0 * t)))
    assert [set(s.tolist()) for s in rep.initial_sets_] == [set(s) for s in oracle.sets]
    assert rep.num_discovered_ > 20


def test_draws_are_uniform_over_the_potential_features():
    counts = np.zeros(3)
    for seed in range(600):
        rep = flag_random(3, seed=seed, discovery_rate=1.0)
        rep.discover(np.array([0, 1, 2]), 0.0)  # 3 potential features; n_1 = 3 + 1
        counts[{(0, 1): 0, (0, 2): 1, (1, 2): 2}[tuple(rep.initial_set(3).tolist())]] += 1
    np.testing.assert_allclose(counts / 600, 1 / 3, atol=0.06)


def test_ignores_relevance_unlike_fixed_rate_ifdd():
    """iFDD takes the most relevant potential feature; random expansion need not."""
    picks = set()
    for seed in range(20):
        for cls, params in ((OnlineIFDD, {}), (RandomExpansion, {})):
            rep = cls(base=FlagFeatures(num_flags=6), discovery_rate=1.0, **params)
            rep.setup(flags_spec(6), seed=seed)
            rep.discover(np.array([0, 1]), 5.0)  # t = 1: {0,1} is the only potential
            rep.discover(np.array([2, 3, 4, 5]), 0.01)  # t = 2, 3: below n_t = 7, no pick
            rep.discover(np.array([2, 3]), 9.0)  # t = 3: still n_t = 7
            rep.discover(np.array([4, 5]), 0.0)  # t = 4: n_4 = 8, pick one
            if cls is OnlineIFDD:
                assert rep.initial_set(7).tolist() == [2, 3]  # ψ = 9.01, the largest
            else:
                picks.add(tuple(rep.initial_set(7).tolist()))
    assert len(picks) > 2


def test_deterministic_for_a_seed_and_seed_dependent():
    def run(seed):
        rep = flag_random(10, seed=seed, discovery_rate=2.0)
        for active, delta in sequence(4, 10, 300):
            rep.discover(rep.active_features(flags(10, active)), delta)
        return [tuple(s.tolist()) for s in rep.initial_sets_]

    assert run(1) == run(1)
    assert run(1) != run(2)


def test_with_sarsa_save_restore_continues(tmp_path):
    def agent():
        rep = RandomExpansion(base=IndependentDiscretization(num_buckets=20), discovery_rate=2.0)
        return SARSA(representation=rep, step_size=0.1)

    def start(num_steps):
        learner, domain = agent(), InvertedPendulum()
        learner.setup(domain.domain_spec, seed=3)
        loop = LearningLoop(domain, learner, seed=3)
        loop.advance(num_steps)
        return learner, loop

    straight, _ = start(3000)
    assert straight.representation_.num_discovered_ > 10
    assert straight.weights_.shape[0] == straight.representation_.num_features_
    half, loop = start(1500)
    half.save(tmp_path / "agent")
    loop.agent = SARSA.restore(tmp_path / "agent")
    loop.advance(1500)
    np.testing.assert_array_equal(loop.agent.weights_, straight.weights_)
    np.testing.assert_array_equal(
        loop.agent.representation_.parents_, straight.representation_.parents_
    )


def test_common_checks():
    check_component(RandomExpansion(base=IndependentDiscretization(num_buckets=5)))


def test_is_online_ifdd_with_random_expansion():
    # the variant is OnlineIFDD's `expansion` parameter: same seed, same features
    named = flag_random(10, discovery_rate=2.0)
    plain = OnlineIFDD(base=FlagFeatures(num_flags=10), discovery_rate=2.0, expansion="random")
    plain.setup(flags_spec(10), seed=0)
    for active, delta in sequence(4, 10, 400):
        for rep in (named, plain):
            rep.discover(rep.active_features(flags(10, active)), delta)
    assert named.num_discovered_ > 10
    assert named.parents_.tolist() == plain.parents_.tolist()
    assert named.get_params()["expansion"] == "random"


def test_random_expansion_needs_a_rate():
    rep = OnlineIFDD(base=FlagFeatures(num_flags=4), expansion="random")
    with pytest.raises(InvalidParameterError, match="discovery_rate"):
        rep.setup(flags_spec(4), seed=0)
