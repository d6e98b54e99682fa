import numpy as np
import pytest

from conjure.core.errors import IncompatibleComponentsError
from conjure.domains import ChainMDP, GridWorld, InvertedPendulum
from conjure.models import DomainSampler, ModelSampler, generative_model
from conjure.testing.planner_checks import chain_walk_model


def test_model_sampler_frequencies_match_p():
    model = chain_walk_model(4)
    sampler = ModelSampler(model)
    rng = np.random.default_rng(0)
    hits = sum(sampler.sample(np.array([1.0]), 1, rng)[0][0] == 2.0 for _ in range(2000))
    assert abs(hits / 2000 - 0.9) < 0.03


def test_domain_sampler_sets_the_state_and_leaves_the_domain_alone():
    domain = GridWorld(map_name="4x5", noise=0.0)
    domain.reset(seed=0)
    sampler = DomainSampler(domain)
    next_state, reward, terminated = sampler.sample(
        np.array([3.0, 3.0]), 3, np.random.default_rng(0)
    )
    assert next_state.tolist() == [3.0, 4.0] and reward == 1.0 and terminated
    assert domain._cell == 0  # the original was not moved


def test_generative_model_dispatch_and_errors():
    assert isinstance(generative_model(ChainMDP()), DomainSampler)
    assert isinstance(generative_model(chain_walk_model(4)), ModelSampler)
    with pytest.raises(IncompatibleComponentsError, match="set_state"):
        generative_model(InvertedPendulum())
