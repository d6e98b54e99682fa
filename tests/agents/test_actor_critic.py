import numpy as np
import pytest

from conjure.agents import ActorCritic
from conjure.core import Transition
from conjure.core.errors import IncompatibleComponentsError
from conjure.domains import ChainMDP, InvertedPendulum
from conjure.policies import Gibbs
from conjure.representations import RBF, IndependentDiscretization, Tabular
from conjure.testing.checks import _rollout


def test_one_update_moves_critic_and_actor_by_alpha_delta():
    domain = ChainMDP(num_states=4, num_actions=2)
    agent = ActorCritic(representation=Tabular(), step_size=0.5, actor_step_size=0.25)
    agent.setup(domain.domain_spec, seed=0)
    agent.begin_episode()
    s = np.array([2.0])
    delta = agent.learn(Transition(s, 0, 1.0, np.array([3.0]), 0, True))
    assert delta == pytest.approx(1.0)
    assert agent.q_values(s)[0] == pytest.approx(0.5)  # θ += α δ φ(s, a), line 8
    assert agent.preferences(s)[0] == pytest.approx(0.25)  # ω += α δ ψ(s, a), line 9
    assert agent.preferences(s)[1] == 0.0


def test_the_state_value_critic_moves_v_and_the_actor_by_the_advantage():
    # critic "v" (Sutton & Barto 1998, Section 6.6): δ = r + γV(s') − V(s); θ_s += αδ and
    # ρ(s, a) += α'δ for the action taken only.
    domain = ChainMDP(num_states=4, num_actions=2)
    agent = ActorCritic(representation=Tabular(), step_size=0.5, actor_step_size=0.25, critic="v")
    agent.setup(domain.domain_spec, seed=0)
    agent.begin_episode()
    s, s_next = np.array([1.0]), np.array([2.0])
    agent.weights_[2, 0] = 2.0  # V(s') = 2
    delta = agent.learn(Transition(s, 1, 1.0, s_next, 0, False))
    gamma = domain.domain_spec.discount
    assert delta == pytest.approx(1.0 + gamma * 2.0)
    assert agent.weights_.shape == (4, 1)
    assert agent.weights_[1, 0] == pytest.approx(0.5 * delta)
    assert agent.preferences(s).tolist() == pytest.approx([0.0, 0.25 * delta])
    # The next visit sees V(s) already raised: δ shrinks (an advantage, not a value).
    second = agent.learn(Transition(s, 1, 1.0, s_next, 0, False))
    assert second == pytest.approx(delta * 0.5)
    with pytest.raises(IncompatibleComponentsError, match="critic='v'"):
        agent.q_values(s)


def test_the_state_value_actor_critic_saves_restores_and_learns_the_chain(tmp_path):
    domain = ChainMDP(num_states=4, num_actions=2)
    agent = ActorCritic(representation=Tabular(), step_size=0.2, critic="v")
    agent.setup(domain.domain_spec, seed=1)
    _rollout(domain, agent, 3000, seed=1)
    for s in range(3):
        assert agent.act(np.array([float(s)]), greedy=True) == 0  # moving right pays
    agent.save(tmp_path / "agent")
    restored = ActorCritic.restore(tmp_path / "agent")
    np.testing.assert_array_equal(restored.weights_, agent.weights_)
    np.testing.assert_array_equal(restored.actor_weights_, agent.actor_weights_)


def test_actor_learns_to_prefer_moving_right():
    domain = ChainMDP(num_states=4, num_actions=2)
    agent = ActorCritic(representation=Tabular(), policy=Gibbs(temperature=0.5), step_size=0.2)
    agent.setup(domain.domain_spec, seed=1)
    _rollout(domain, agent, 5000, seed=1)
    for s in range(3):
        assert agent.act(np.array([float(s)]), greedy=True) == 0
        assert np.argmax(agent.preferences(np.array([float(s)]))) == 0


def test_separate_dense_actor_features_work():
    domain = InvertedPendulum()
    agent = ActorCritic(
        representation=IndependentDiscretization(), actor_representation=RBF(), step_size=0.05
    ).setup(domain.domain_spec, seed=0)
    _rollout(domain, agent, 300, seed=0)
    assert agent.actor_weights_.shape == (agent.actor_representation_.num_features_, 3)
    assert np.all(np.isfinite(agent.actor_weights_)) and np.abs(agent.actor_weights_).sum() > 0


def test_shared_adaptive_features_grow_both_weight_tables():
    from conjure.representations.online_ifdd import OnlineIFDD

    domain = InvertedPendulum()
    agent = ActorCritic(
        representation=OnlineIFDD(base=IndependentDiscretization(), discovery_threshold=0.05),
        step_size=0.1,
    ).setup(domain.domain_spec, seed=0)
    _rollout(domain, agent, 3000, seed=0)
    n = agent.representation_.num_features_
    assert n > agent.representation_.num_initial_features_
    assert agent.weights_.shape[0] == agent.actor_weights_.shape[0] == n


@pytest.mark.parametrize("actor", [None, RBF()])
def test_shift_preference_moves_exactly_one_preference(actor):
    # Section 5.3.2's bias: ρ(s, a) += λ, through ω += λψ(s)/‖ψ(s)‖².
    domain = InvertedPendulum()
    agent = ActorCritic(representation=Tabular(), actor_representation=actor)
    agent.setup(domain.domain_spec, seed=0)
    state = np.array([0.1, -0.2])
    before = agent.preferences(state).copy()
    agent.shift_preference(state, 2, 100.0)
    assert agent.preferences(state) - before == pytest.approx([0.0, 0.0, 100.0])


def test_the_log_policy_actor_steps_along_the_gibbs_log_gradient():
    # Bhatnagar et al.'s actor: ω_b += αδ(𝟙[b = a] − π(s, b)); here π = (1/2, 1/2), δ = 1.
    domain = ChainMDP(num_states=4, num_actions=2)
    agent = ActorCritic(
        representation=Tabular(), step_size=0.5, critic="v", actor_update="log_policy"
    ).setup(domain.domain_spec, seed=0)
    agent.begin_episode()
    s = np.array([2.0])
    action = agent.act(s)
    delta = agent.learn(Transition(s, action, 1.0, np.array([3.0]), 0, True))
    assert delta == pytest.approx(1.0)
    expected = np.full(2, -0.25)
    expected[action] = 0.25
    np.testing.assert_allclose(agent.preferences(s), expected)


def test_the_log_policy_step_uses_the_policy_that_chose_the_action_when_a_state_repeats():
    # The run loop's order with s0 = s1 = s2 = s (a move into a wall, twice) and s2's step
    # terminal: act(s0), act(s1), learn(s0), act(s2), learn(s1), learn(s2). learn(s2) must
    # use π(s, ·) as act(s2) drew it (after learn(s0) moved ω), not act(s1)'s older one.
    domain = ChainMDP(num_states=4, num_actions=2)
    agent = ActorCritic(
        representation=Tabular(),
        step_size=0.5,
        critic="v",
        actor_update="log_policy",
    ).setup(domain.domain_spec, seed=0)
    agent.begin_episode()
    s = np.array([1.0])
    a0 = agent.act(s)
    a1 = agent.act(s)
    agent.learn(Transition(s, a0, 1.0, s, a1, False))
    preferences = agent.preferences(s)
    drawn = np.exp(preferences - preferences.max())
    drawn /= drawn.sum()  # π(s, ·) of act(s2), τ = 1
    a2 = agent.act(s)
    agent.learn(Transition(s, a1, 0.0, s, a2, False))
    before = agent.preferences(s)
    value = float(agent.weights_[1, 0])
    delta = agent.learn(Transition(s, a2, 1.0, np.array([3.0]), 0, True))
    assert delta == pytest.approx(1.0 - value)
    expected = before + 0.5 * delta * (np.eye(2)[a2] - drawn)  # ω_b += αδ(𝟙[b = a2] − π(s, b))
    np.testing.assert_allclose(agent.preferences(s), expected)


def test_the_log_policy_step_leaves_the_sum_of_the_preferences_unchanged():
    # Σ_b (𝟙[b = a] − π(b)) = 0: the taken action's gain is paid by the others, which is why
    # a constant error in δ cancels in expectation (the "features" actor's sum grows by αδ).
    domain = ChainMDP(num_states=4, num_actions=2)
    agent = ActorCritic(representation=Tabular(), step_size=0.5, actor_update="log_policy")
    agent.setup(domain.domain_spec, seed=3)
    s = np.array([1.0])
    agent.act(s)
    agent.learn(Transition(s, 1, 2.0, np.array([0.0]), 0, True))
    assert agent.preferences(s).sum() == pytest.approx(0.0)


def test_lambda_one_traces_carry_the_episode_return_back_to_the_first_state():
    domain = ChainMDP(num_states=4, num_actions=2)
    agent = ActorCritic(
        representation=Tabular(), step_size=0.5, actor_step_size=0.25, critic="v", trace_decay=1.0
    ).setup(domain.domain_spec, seed=0)
    agent.begin_episode()
    s0, s1, end = np.array([0.0]), np.array([1.0]), np.array([2.0])
    gamma = domain.domain_spec.discount
    agent.act(s0)
    assert agent.learn(Transition(s0, 0, 0.0, s1, 0, False)) == 0.0  # V = 0 everywhere
    agent.act(s1)
    assert agent.learn(Transition(s1, 0, 1.0, end, 0, True)) == pytest.approx(1.0)
    assert agent.weights_[1, 0] == pytest.approx(0.5)  # z(s1) = 1
    assert agent.weights_[0, 0] == pytest.approx(0.5 * gamma)  # z(s0) = γλ·1
    assert agent.preferences(s0)[0] == pytest.approx(0.25 * gamma)
    agent.begin_episode()  # a new episode clears the traces
    assert agent.critic_traces_.count[0] == agent.actor_traces_.count[0] == 0


def test_the_traced_log_policy_actor_critic_restores_mid_episode_and_grows_with_ifdd():
    from conjure.representations.online_ifdd import OnlineIFDD
    from conjure.testing.checks import check_save_restore_continues

    check_save_restore_continues(
        ActorCritic(
            representation=Tabular(), critic="v", actor_update="log_policy", trace_decay=0.9
        )
    )
    domain = InvertedPendulum()
    agent = ActorCritic(
        representation=OnlineIFDD(base=IndependentDiscretization(), discovery_threshold=0.05),
        step_size=0.1,
        trace_decay=0.5,
        actor_update="log_policy",
    ).setup(domain.domain_spec, seed=0)
    _rollout(domain, agent, 3000, seed=0)
    n = agent.representation_.num_features_
    assert n > agent.representation_.num_initial_features_
    assert agent.critic_traces_.slot_of.shape[0] == agent.actor_traces_.slot_of.shape[0] == n


def test_the_log_policy_actor_needs_a_gibbs_policy():
    from conjure.policies import EpsilonGreedy

    agent = ActorCritic(representation=Tabular(), policy=EpsilonGreedy(), actor_update="log_policy")
    with pytest.raises(IncompatibleComponentsError, match="Gibbs"):
        agent.setup(ChainMDP().domain_spec, seed=0)
