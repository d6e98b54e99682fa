import numpy as np
import pytest

from conjure.agents import SARSA
from conjure.core import (
    DivergenceError,
    FeatureNormalizedDecay,
    InvalidParameterError,
    Representation,
    SparseFeatures,
    Transition,
)
from conjure.domains import ChainMDP, InvertedPendulum
from conjure.representations import RBF, Tabular, TileCoding
from conjure.testing.checks import _rollout


def test_td_converges_to_chain_values():
    # One action: SARSA is TD(0) policy evaluation; V = [2.71, 1.9, 1, 0] for γ = 0.9.
    domain = ChainMDP(num_states=4, num_actions=1)
    agent = SARSA(representation=Tabular(), step_size=0.2).setup(domain.domain_spec, seed=0)
    _rollout(domain, agent, 2000, seed=0)
    values = [agent.q_values(np.array([s]))[0] for s in range(4)]
    assert np.allclose(values, [2.71, 1.9, 1.0, 0.0], atol=1e-3)


@pytest.mark.parametrize("trace_kind", ["replacing", "accumulating"])
def test_sarsa_lambda_converges_to_chain_values(trace_kind):
    domain = ChainMDP(num_states=4, num_actions=1, slip=0.2)
    agent = SARSA(
        representation=Tabular(), step_size=0.05, trace_decay=0.8, trace_kind=trace_kind
    ).setup(domain.domain_spec, seed=1)
    _rollout(domain, agent, 20_000, seed=1)
    values = np.array([agent.q_values(np.array([s]))[0] for s in range(4)])
    assert values[-1] == 0.0
    assert np.allclose(values, domain.optimal_values(), atol=0.1)


class DenseTabular(Representation):
    """Tabular one-hot features encoded densely (every index, zeros included): must learn
    exactly what the binary encoding learns."""

    def __init__(self, *, num_buckets: int = 20):
        self.num_buckets = num_buckets

    def setup(self, spec, seed):
        self.inner_ = Tabular(num_buckets=self.num_buckets).setup(spec, seed)
        self.spec_ = spec
        self.num_features_ = self.inner_.num_features_
        self.is_set_up_ = True
        return self

    def encode(self, state):
        phi = np.zeros(self.num_features_)
        phi[self.inner_.active_features(state)] = 1.0
        return SparseFeatures(np.arange(self.num_features_), phi)


@pytest.mark.parametrize("trace_decay", [0.0, 0.7])
def test_dense_and_binary_paths_agree(trace_decay):
    domain = ChainMDP(num_states=4, num_actions=2, slip=0.3)
    common = dict(
        step_size=0.1, trace_decay=trace_decay, trace_kind="accumulating", min_trace=1e-12
    )
    binary = SARSA(representation=Tabular(), **common).setup(domain.domain_spec, seed=3)
    dense = SARSA(representation=DenseTabular(), **common).setup(domain.domain_spec, seed=3)
    _rollout(domain, binary, 500, seed=3)
    _rollout(domain, dense, 500, seed=3)
    assert np.allclose(binary.weights_, dense.weights_, atol=1e-9)
    assert np.abs(binary.weights_).sum() > 0


def test_feature_normalized_step_size_hand_checked():
    # From θ = 0, a terminal transition with r = 1 and α_t = α_0 / k (episode 1) moves
    # Q(s, a) = Σ_k θ from 0 to exactly α_0, whatever the number k of active tiles.
    domain = InvertedPendulum()
    schedule = FeatureNormalizedDecay(alpha_0=0.3, n_0=100)
    agent = SARSA(representation=TileCoding(num_tilings=8, tiles_per_dim=6), step_size=schedule)
    agent.setup(domain.domain_spec, seed=0)
    agent.begin_episode()
    state = np.array([0.1, -0.2])
    delta = agent.learn(Transition(state, 2, 1.0, state, 0, True))
    assert delta == pytest.approx(1.0)
    assert agent.q_values(state)[2] == pytest.approx(0.3)
    assert agent.q_values(state)[0] == 0.0


def test_divergence_stops_with_clear_error():
    # The largest step size accepted (an absurd one such as 1e300 is refused before any run).
    domain = ChainMDP(num_states=4, num_actions=1)
    agent = SARSA(representation=Tabular(), step_size=10.0, initial_weight=1e300)
    agent.setup(domain.domain_spec, seed=0)
    with pytest.raises(DivergenceError, match="step size"):
        _rollout(domain, agent, 100, seed=0)


def test_negative_step_size_is_rejected_naming_the_field():
    agent = SARSA(representation=Tabular(), step_size=-0.1)
    with pytest.raises(InvalidParameterError, match=r"`SARSA.step_size` must be .*got -0.1"):
        agent.setup(ChainMDP().domain_spec, seed=0)


def test_legal_actions_are_respected():
    domain = ChainMDP(num_states=4, num_actions=2)
    agent = SARSA(representation=Tabular()).setup(domain.domain_spec, seed=0)
    only = np.array([1])
    assert all(agent.act(np.array([0.0]), legal_actions=only) == 1 for _ in range(50))


def test_rbf_dense_agent_learns_finite_weights_on_pendulum():
    domain = InvertedPendulum()
    agent = SARSA(representation=RBF(), step_size=0.05).setup(domain.domain_spec, seed=0)
    _rollout(domain, agent, 500, seed=0)
    assert np.all(np.isfinite(agent.weights_)) and np.abs(agent.weights_).sum() > 0


def test_save_restore_with_traces_continues_exactly(tmp_path):
    domain = InvertedPendulum()
    params = dict(
        representation=TileCoding(num_tilings=4, tiles_per_dim=5), step_size=0.1, trace_decay=0.9
    )
    straight = SARSA(**params).setup(domain.domain_spec, seed=5)
    _rollout(domain, straight, 300, seed=5)
    _rollout(domain, straight, 300, seed=6)
    first = SARSA(**params).setup(domain.domain_spec, seed=5)
    _rollout(domain, first, 300, seed=5)
    first.save(tmp_path / "agent")
    resumed = SARSA.restore(tmp_path / "agent")
    assert resumed.episode_ == first.episode_
    _rollout(domain, resumed, 300, seed=6)
    assert np.array_equal(resumed.weights_, straight.weights_)
    assert resumed.get_params() == straight.get_params()


def test_traces_grow_with_discovered_features():
    from conjure.core import Expansion

    domain = ChainMDP(num_states=4, num_actions=2)
    agent = SARSA(representation=Tabular(), trace_decay=0.5).setup(domain.domain_spec, seed=0)
    _rollout(domain, agent, 20, seed=0)
    agent.representation_.num_features_ = 5  # as if the representation discovered one
    agent._grow(Expansion(first_new=4, parents=np.array([[0, 1]])))
    assert agent.weights_.shape == (5, 2) and agent.trace_slots_.shape == (5, 2)
    assert np.all(agent.trace_slots_[4] == 0)  # no trace


def test_rbf_sarsa_lambda_matches_dense_accumulating_traces():
    # The dense SARSA(λ) earlier conjure ran for RBF: e ← γλ e + φ(s, a), θ += αδe. The
    # sparse traces differ only by traces dropped below min_trace (here 1e-12: negligible).
    domain = InvertedPendulum()
    spec = domain.domain_spec
    agent = SARSA(representation=RBF(), step_size=0.1, trace_decay=0.8, min_trace=1e-12)
    agent.setup(spec, seed=0)
    rng = np.random.default_rng(0)
    states = rng.uniform(spec.low, spec.high, size=(41, 2))
    actions = rng.integers(spec.num_actions, size=41)
    weights = np.zeros(agent.weights_.shape)
    traces = np.zeros_like(weights)
    decay = spec.discount * 0.8
    for t in range(40):
        reward = float(rng.normal())
        phi = agent.representation_.feature_values(states[t])
        phi_next = agent.representation_.feature_values(states[t + 1])
        delta = reward + spec.discount * phi_next @ weights[:, actions[t + 1]]
        delta -= phi @ weights[:, actions[t]]
        traces *= decay
        traces[:, actions[t]] += phi
        weights += 0.1 * delta * traces
        transition = Transition(states[t], actions[t], reward, states[t + 1], actions[t + 1], False)
        assert agent.learn(transition) == pytest.approx(delta, abs=1e-9)
    np.testing.assert_allclose(agent.weights_, weights, atol=1e-9)
    assert np.abs(weights).sum() > 0
