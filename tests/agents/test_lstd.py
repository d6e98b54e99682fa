import numpy as np
import pytest

from conjure.agents.lstd import LSTD
from conjure.core.errors import InvalidParameterError, NotSetUpError
from conjure.core.interfaces import DomainSpec, Transition
from conjure.models import ModelSampler
from conjure.representations import Tabular
from conjure.testing.planner_checks import chain_walk_model


def _spec(n, discount=0.9):
    return DomainSpec(
        name="s",
        low=[0.0],
        high=[n - 1.0],
        is_discrete=[True],
        num_actions=1,
        discount=discount,
        max_episode_steps=10,
    )


def test_tabular_lstd_on_the_exact_chain_gives_i_minus_gamma_p_inverse_r():
    # Every state sampled with its exact next-state frequencies: Φ = I gives (I − γP)⁻¹R.
    p = np.array([[0.7, 0.3], [0.5, 0.5]])
    r = np.array([1.0, -1.0])
    batch = []
    for s in range(2):
        for s2, count in ((0, int(p[s, 0] * 10)), (1, int(p[s, 1] * 10))):
            batch += [
                Transition(np.array([float(s)]), 0, r[s], np.array([float(s2)]), 0, False)
            ] * count
    lstd = LSTD(representation=Tabular(), regularization=0.0).setup(_spec(2), 0).fit(batch)
    assert np.allclose(lstd.weights_, np.linalg.solve(np.eye(2) - 0.9 * p, r))
    assert lstd.value(np.array([1.0])) == pytest.approx(lstd.weights_[1])


def test_matches_the_model_value_of_a_policy_with_many_samples():
    model = chain_walk_model(4)
    sampler = ModelSampler(model)
    rng = np.random.default_rng(0)
    batch, state = [], model.states[0]
    for _ in range(20000):
        nxt, reward, _ = sampler.sample(state, 1, rng)  # always "right"
        batch.append(Transition(state, 1, reward, nxt, 1, False))
        state = nxt if rng.random() > 0.2 else model.states[rng.integers(4)]
    lstd = LSTD(representation=Tabular()).setup(model.domain_spec, 0).fit(batch)
    p = model.transitions[1].toarray()
    exact = np.linalg.solve(np.eye(4) - 0.9 * p, model.rewards[:, 1])
    assert np.allclose(lstd.weights_, exact, atol=0.3)
    assert lstd.iterations_ == 1 and lstd.wall_time_s_ > 0


def test_terminal_transitions_do_not_bootstrap():
    batch = [Transition(np.array([0.0]), 0, 2.0, np.array([1.0]), 0, True)]
    lstd = LSTD(representation=Tabular(), regularization=0.0).setup(_spec(2), 0).fit(batch)
    assert lstd.weights_[0] == pytest.approx(2.0)


def test_lifecycle_errors():
    with pytest.raises(NotSetUpError):
        LSTD(representation=Tabular()).fit([])
    with pytest.raises(InvalidParameterError, match=r"LSTD\.regularization"):
        LSTD(representation=Tabular(), regularization=-1.0).setup(_spec(2), 0)
