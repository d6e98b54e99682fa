import numpy as np
import pytest

from conjure.agents import SARSA
from conjure.agents.linear_td import make_schedule
from conjure.core import ConstantStepSize, EpisodicDecay, Expansion, InvalidParameterError
from conjure.domains import ChainMDP
from conjure.representations import Tabular


def test_make_schedule_wraps_floats_and_validates():
    assert make_schedule(0.3) == ConstantStepSize(alpha_0=0.3)
    assert make_schedule(EpisodicDecay(alpha_0=1.0, n_0=1.0)).value(3, 1) == 0.5
    with pytest.raises(InvalidParameterError, match="alpha_0"):
        make_schedule(EpisodicDecay(alpha_0=-1.0))


def test_grow_adds_rows_as_sum_of_parents_and_drops_caches():
    domain = ChainMDP(num_states=4, num_actions=2)
    agent = SARSA(representation=Tabular()).setup(domain.domain_spec, seed=0)
    agent.weights_[:] = np.arange(8, dtype=float).reshape(4, 2)
    agent.act(np.array([0.0]))
    agent._grow(Expansion(first_new=4, parents=np.array([[1, 3]])))
    assert agent.weights_.shape == (5, 2)
    assert agent.weights_[4].tolist() == [2 + 6, 3 + 7]  # θ_f = θ_g + θ_h, Section 4.1.1
    assert agent._last[0] is None


def test_cache_serves_learn_with_act_values():
    domain = ChainMDP(num_states=4, num_actions=2)
    agent = SARSA(representation=Tabular()).setup(domain.domain_spec, seed=0)
    state = np.array([1.0])
    agent.act(state)
    assert agent._features(state) is agent._last[1]
    assert agent._features(np.array([1.0])) is not agent._last[1]  # identity, not equality


def test_a_weight_table_too_large_for_memory_is_a_clear_error():
    from conjure.core import IncompatibleComponentsError
    from conjure.domains import BlocksWorld

    with pytest.raises(IncompatibleComponentsError, match="18,432 GiB"):
        SARSA(representation=Tabular()).setup(BlocksWorld().domain_spec, seed=0)
