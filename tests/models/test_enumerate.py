import numpy as np
import pytest

from conjure.core.errors import IncompatibleComponentsError
from conjure.domains import ChainMDP, InvertedPendulum
from conjure.models import enumerate_model


def test_chain_model_matches_the_helper():
    domain = ChainMDP(num_states=4, num_actions=2, slip=0.2)
    model = enumerate_model(domain)
    p, r = domain.tabular_model()
    for a in range(2):
        assert np.allclose(model.transitions[a].toarray(), p[a])
    assert np.allclose(model.rewards, r.T)
    assert model.is_terminal.tolist() == [False, False, False, True]


def test_domains_without_outcomes_get_a_clear_error():
    with pytest.raises(IncompatibleComponentsError, match="sampled planner"):
        enumerate_model(InvertedPendulum())
