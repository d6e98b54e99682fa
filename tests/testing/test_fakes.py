import numpy as np

from conjure.domains import ChainMDP, GridWorld
from conjure.testing.fakes import SharedObservationBuffer


def test_every_observation_is_the_same_array_with_the_wrapped_values():
    inner = ChainMDP(num_states=4, num_actions=2)
    domain = SharedObservationBuffer(domain=inner)
    first, _ = domain.reset(seed=0)
    seen = [first]
    for action in (0, 1, 0):
        seen.append(domain.step(action)[0])
    assert all(obs is first for obs in seen)
    assert first.tolist() == [2.0]
    assert domain.domain_spec is inner.domain_spec


def test_passes_through_model_constraints_and_info():
    grid = GridWorld()
    domain = SharedObservationBuffer(domain=grid)
    state, _ = domain.reset(seed=1)
    assert np.array_equal(domain.legal_actions(state), grid.legal_actions(state))
    assert domain.model().num_states == grid.model().num_states
    assert domain.value_bounds() == grid.value_bounds()
    assert "cost" in domain.step(int(domain.legal_actions(state)[0]))[4]
    twin = domain.clone()
    assert twin.reset(seed=1)[0].tolist() == domain.reset(seed=1)[0].tolist()
