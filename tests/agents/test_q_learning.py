import numpy as np

from conjure.agents import QLearning
from conjure.core import Transition
from conjure.domains import ChainMDP, GridWorld
from conjure.representations import Tabular
from conjure.testing.checks import _rollout


def test_q_learning_converges_to_q_star_on_chain():
    domain = ChainMDP(num_states=4, num_actions=2)
    agent = QLearning(representation=Tabular(), step_size=0.2).setup(domain.domain_spec, seed=0)
    _rollout(domain, agent, 5000, seed=0)
    q = np.array([agent.q_values(np.array([s])) for s in range(3)])
    assert np.allclose(q, domain.optimal_q_values()[:3], atol=1e-3)


def test_max_runs_over_legal_next_actions_only():
    domain = ChainMDP(num_states=4, num_actions=2)
    agent = QLearning(representation=Tabular(), step_size=1.0).setup(domain.domain_spec, seed=0)
    s, s_next = np.array([0.0]), np.array([1.0])
    agent.weights_[agent.representation_.active_features(s_next), 0] = 5.0  # illegal in s'
    agent.weights_[agent.representation_.active_features(s_next), 1] = 1.0
    agent.learn(Transition(s, 0, 0.0, s_next, 0, False, np.array([1])))
    assert agent.q_values(s)[0] == np.float64(0.9)  # γ · Q(s', 1), not γ · 5
    agent.learn(Transition(s, 1, 0.0, s_next, 0, False))
    assert agent.q_values(s)[1] == np.float64(4.5)  # no constraint: γ · max = 0.9 · 5


def test_q_learning_finds_the_goal_on_a_small_gridworld():
    domain = GridWorld(map_name="4x5", noise=0.0, step_reward=-0.01)
    agent = QLearning(representation=Tabular(), step_size=0.5).setup(domain.domain_spec, seed=0)
    _rollout(domain, agent, 3000, seed=0)
    state, _ = domain.reset(seed=0)
    total = 0.0
    for _ in range(50):
        state, reward, terminated, _, _ = domain.step(agent.act(state, greedy=True))
        total += reward
        if terminated:
            break
    assert terminated and total > 0.9
