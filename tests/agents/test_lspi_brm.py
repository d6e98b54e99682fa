import numpy as np
import pytest

from conjure.agents.lspi_brm import LSPIBRM, double_samples
from conjure.core.errors import IncompatibleComponentsError
from conjure.core.interfaces import DomainSpec, Transition
from conjure.models import ModelSampler
from conjure.representations import Tabular
from conjure.testing.planner_checks import chain_walk_model, chain_walk_optimal_policy


def test_filter_pairs_consecutive_samples_of_the_same_state_action():
    s0, s1 = np.array([0.0]), np.array([1.0])
    batch = [
        Transition(s0, 0, 0.0, s1, 0, False),
        Transition(s1, 0, 0.0, s0, 0, False),
        Transition(s0, 1, 0.0, s1, 0, False),
        Transition(s0, 0, 0.0, s0, 0, False),
        Transition(s0, 0, 0.0, s1, 0, False),
    ]
    first, second = double_samples(batch)
    assert first.tolist() == [0] and second.tolist() == [3]


def test_double_sampled_brm_is_unbiased_where_single_sampling_is_not():
    # One state, stochastic reward-free self-loop or exit; exact V = r / (1 − γ p).
    spec = DomainSpec(
        name="one",
        low=[0.0],
        high=[1.0],
        is_discrete=[True],
        num_actions=1,
        discount=0.9,
        max_episode_steps=10,
    )
    s, end = np.array([0.0]), np.array([1.0])
    rng = np.random.default_rng(0)
    batch = []
    for _ in range(20000):
        stays = rng.random() < 0.5
        batch.append(Transition(s, 0, 1.0, s if stays else end, 0, not stays))
    agent = LSPIBRM(representation=Tabular(), regularization=0.0).setup(spec, 0).fit(batch)
    assert agent.weights_[0, 0] == pytest.approx(1 / (1 - 0.45), rel=0.03)


def test_finds_the_chain_walk_optimal_policy():
    model = chain_walk_model(4)
    sampler = ModelSampler(model)
    rng = np.random.default_rng(1)
    batch = []
    for _ in range(4000):
        state = model.states[rng.integers(4)]
        action = int(rng.integers(2))
        nxt, reward, done = sampler.sample(state, action, rng)
        batch.append(Transition(state, action, reward, nxt, int(rng.integers(2)), done))
    agent = LSPIBRM(representation=Tabular()).setup(model.domain_spec, 0).fit(batch)
    assert [agent.act(s, greedy=True) for s in model.states] == chain_walk_optimal_policy(
        4
    ).tolist()
    assert agent.num_pairs_ > 1000


def test_no_repeated_pairs_is_a_clear_error():
    spec = chain_walk_model(4).domain_spec
    batch = [Transition(np.array([0.0]), 0, 0.0, np.array([1.0]), 0, False)]
    with pytest.raises(IncompatibleComponentsError, match="sampled twice"):
        LSPIBRM(representation=Tabular()).setup(spec, 0).fit(batch)
