"""The batch learners' run protocol (BatchAgent): store, fit at checks or every N, act on Q."""

import numpy as np
import pytest

from conjure.agents import FDLSTD, LSPI, LSPIBRM, LSTD
from conjure.agents.batch import q_system
from conjure.core.errors import IncompatibleComponentsError, InvalidParameterError
from conjure.core.interfaces import Transition
from conjure.domains import ChainMDP
from conjure.experiments import run
from conjure.experiments.loop import LearningLoop
from conjure.representations import Tabular
from conjure.testing.checks import box_spec

#: Moving right costs 1 and staying is free: θ = 0's greedy policy (action 0, right) is worst.
COSTLY_CHAIN = {"num_states": 6, "num_actions": 2, "step_reward": -1.0}


def _agent(cls, **params):
    return cls(representation=Tabular(), **params)


def _count_fits(agent, monkeypatch):
    fits = []
    original = agent._fit_samples
    monkeypatch.setattr(
        agent, "_fit_samples", lambda batch: (fits.append(len(batch)), original(batch))
    )
    return fits


def test_learn_stores_owned_copies_and_never_fits(monkeypatch):
    domain = ChainMDP(**COSTLY_CHAIN)
    agent = _agent(LSPI).setup(domain.domain_spec, seed=0)
    fits = _count_fits(agent, monkeypatch)
    buffer = np.array([0.0])
    assert agent.learn(Transition(buffer, 0, -1.0, buffer, 1, False)) == 0.0
    buffer[:] = 3.0
    assert agent.samples_[0].state.tolist() == [0.0] and agent.num_new_samples_ == 1
    assert fits == [] and not agent.weights_.any()


@pytest.mark.parametrize("cls", [LSPI, LSPIBRM, LSTD, FDLSTD])
def test_fits_at_policy_checks_only_on_new_samples(cls, monkeypatch):
    domain = ChainMDP(**COSTLY_CHAIN)
    agent = _agent(cls).setup(domain.domain_spec, seed=0)
    fits = _count_fits(agent, monkeypatch)
    agent.before_policy_check()  # no sample yet: nothing to fit
    loop = LearningLoop(domain, agent, seed=0)
    loop.advance(60)
    agent.before_policy_check()
    agent.before_policy_check()  # no new sample: no refit
    loop.advance(40)
    agent.before_policy_check()
    # LSPI reuses every sample; LSTD and FDLSTD evaluate each policy on its own samples.
    assert fits == ([60, 100] if cls.reuses_samples else [60, 40])
    assert len(agent.samples_) == (100 if cls.reuses_samples else 0)
    assert agent.num_new_samples_ == 0


@pytest.mark.parametrize("cls", [LSPI, LSTD, FDLSTD])
def test_fit_every_fits_after_every_n_samples_whatever_the_checks(cls):
    def trajectory(num_policy_checks):
        result = run(
            domain=ChainMDP(**COSTLY_CHAIN),
            agent=_agent(cls, fit_every=25),
            budget_steps=200,
            num_policy_checks=num_policy_checks,
            seed=3,
        )
        agent = result.agent
        return [t.action for t in agent.samples_], agent.q_values(np.array([2.0])).tolist()

    assert trajectory(1) == trajectory(7)


@pytest.mark.parametrize("cls", [LSPI, LSPIBRM, LSTD, FDLSTD])
def test_every_batch_learner_improves_on_theta_zero_through_run(cls):
    # θ = 0 walks right (first of tied actions): 5 steps at -1; staying put is optimal (0).
    result = run(
        domain=ChainMDP(**COSTLY_CHAIN),
        agent=_agent(cls),
        budget_steps=300,
        seed=0,
        num_policy_checks=3,
    )
    returns = result.curve["return"].tolist()
    assert returns[0] == -5.0 and returns[1] == 0.0, returns


def test_lstd_agent_evaluates_q_of_the_sampling_policy():
    # Samples of "stay forever" in state 0 and of one "right" move: LSTD-Q with the sampled
    # a' gives Q(0, stay) = 0 + γ·Q(0, stay) = 0 and Q(0, right) = −1 + γ·Q(1, stay) = −1.
    domain = ChainMDP(**COSTLY_CHAIN)
    agent = LSTD(representation=Tabular(), regularization=0.0).setup(domain.domain_spec, 0)
    s0, s1 = np.array([0.0]), np.array([1.0])
    for t in [Transition(s0, 1, 0.0, s0, 1, False)] * 3 + [
        Transition(s0, 0, -1.0, s1, 1, False),
        Transition(s1, 1, 0.0, s1, 1, False),
    ]:
        agent.learn(t)
    agent.before_policy_check()
    np.testing.assert_allclose(agent.q_values(s0), [-1.0, 0.0], atol=1e-9)
    assert agent.act(s0, greedy=True) == 1
    # V of the same samples (Eqs. 2.37-2.39) mixes them: V(0) = (3·γV(0) − 1 + γV(1)) / 4.
    np.testing.assert_allclose(agent.value(s0), -1 / 1.3, atol=1e-9)


def test_q_system_is_lstd_on_action_slots():
    phi = Tabular().setup(box_spec([0.0], [1.0], [True]), 0)
    rows = np.array([[1.0, 0.0], [0.0, 1.0]])
    import scipy.sparse as sp

    a, b = q_system(
        sp.csr_matrix(rows),
        sp.csr_matrix(rows[::-1]),
        np.array([1, 0]),
        np.array([0, 1]),
        np.array([2.0, 0.0]),
        np.array([1.0, 0.0]),
        2,
        0.5,
    )
    assert phi.num_features_ == 2
    # Row 0: φ(s0, a=1) is column 1·2 + 0 = 2; its successor φ(s1, a'=0) is column 1.
    expected = np.zeros((4, 4))
    expected[2, 2], expected[2, 1], expected[1, 1] = 0.5, -0.25, 0.5
    np.testing.assert_allclose(a.toarray(), expected)
    np.testing.assert_allclose(b, [0.0, 0.0, 1.0, 0.0])


def test_brm_waits_for_a_repeated_pair_on_discrete_domains_only():
    domain = ChainMDP(**COSTLY_CHAIN)
    agent = _agent(LSPIBRM).setup(domain.domain_spec, seed=0)
    agent.learn(Transition(np.array([0.0]), 0, -1.0, np.array([1.0]), 0, False))
    agent.before_policy_check()  # one sample, no pair: θ stays 0
    assert not agent.weights_.any() and len(agent.samples_) == 1
    continuous = _agent(LSPIBRM).setup(box_spec([0.0], [1.0]), seed=0)
    continuous.learn(Transition(np.array([0.5]), 0, 1.0, np.array([0.6]), 0, False))
    with pytest.raises(IncompatibleComponentsError, match="sampled twice"):
        continuous.before_policy_check()


@pytest.mark.parametrize("cls", [LSPI, LSTD, FDLSTD])
def test_save_and_restore_keep_samples_with_legal_actions(cls, tmp_path):
    domain = ChainMDP(**COSTLY_CHAIN)
    agent = _agent(cls).setup(domain.domain_spec, seed=0)
    LearningLoop(domain, agent, seed=0).advance(30)
    agent.before_policy_check()
    legal = np.array([1], dtype=np.int64)
    agent.learn(Transition(np.array([2.0]), 1, 0.0, np.array([2.0]), 1, False, legal))
    agent.learn(Transition(np.array([5.0]), 0, 0.0, np.array([5.0]), 0, True))
    restored = cls.restore(agent.save(tmp_path))
    assert len(restored.samples_) == len(agent.samples_)
    for mine, theirs in zip(agent.samples_, restored.samples_, strict=True):
        assert mine.state.tolist() == theirs.state.tolist() and mine[1:3] == theirs[1:3]
        assert mine.terminated == theirs.terminated
        assert (mine.next_legal_actions is None) == (theirs.next_legal_actions is None)
    assert restored.samples_[-2].next_legal_actions.tolist() == [1]
    assert restored.num_new_samples_ == 2
    for s in range(6):
        state = np.array([float(s)])
        assert restored.q_values(state).tolist() == agent.q_values(state).tolist()


def test_damaged_samples_are_refused(tmp_path):
    domain = ChainMDP(**COSTLY_CHAIN)
    agent = _agent(LSPI).setup(domain.domain_spec, seed=0)
    LearningLoop(domain, agent, seed=0).advance(10)
    directory = agent.save(tmp_path)
    with np.load(directory / "arrays.npz") as data:
        arrays = {name: data[name] for name in data.files}
    bad_actions = {**arrays, "samples.actions": np.full(10, 7, dtype=np.int64)}
    np.savez(directory / "arrays.npz", **bad_actions)
    with pytest.raises(InvalidParameterError, match=r"samples.actions.*outside \[0, 2\)"):
        LSPI.restore(directory)
    short = {**arrays, "samples.rewards": np.zeros(9)}
    np.savez(directory / "arrays.npz", **short)
    with pytest.raises(InvalidParameterError, match=r"samples.rewards.*shape \(10,\)"):
        LSPI.restore(directory)
