"""The compiled loop on a hand-checkable chain: episodes, returns and the resumable state."""

import numpy as np

from conjure.agents import SARSA
from conjure.compiled import learning_loop as lp
from conjure.compiled.combination import agent_form, box_form, representation_form
from conjure.domains import ChainMDP
from conjure.representations import Tabular


def _loop_arguments(*, learn: bool = True, max_episodes: int = 10**6):
    domain = ChainMDP(num_states=4, step_reward=1.0)  # one action: 0 → 1 → 2 → 3 (terminal)
    agent = SARSA(representation=Tabular(), step_size=0.5).setup(domain.domain_spec, 0)
    obs = domain.reset(seed=0)[0].copy()
    state = lp.new_loop_state(domain.domain_spec.num_actions)
    state.phase[0] = lp.NEEDS_BEGIN
    arrays = agent.arrays_
    rep = representation_form(agent)
    box = box_form(agent, rep)
    args = (domain.compiled_form(), domain.np_random, rep, agent_form(agent), arrays,
            agent.row_traces_, agent.rng_, 100, obs, state, box.box,
            box.parts, learn, max_episodes)  # fmt: skip
    return args, arrays, state


def test_every_chain_episode_takes_three_steps_and_earns_three():
    args, arrays, state = _loop_arguments()
    status, done, failures, _, _, ep_float, ep_int = lp.learning_loop(9, *args)
    assert (status, done, failures) == (lp.DONE, 9, 0)
    assert ep_int[:, 0].tolist() == [3, 3, 3] and ep_float[:, 0].tolist() == [3.0, 3.0, 3.0]
    np.testing.assert_allclose(ep_float[:, 1], 1 + 0.9 + 0.81)  # Σ γ^t r_t
    assert state.phase[0] == lp.NEEDS_RESET and state.episode[0] == 3
    # θ(s, a) after SARSA's updates with α = 0.5 from 0: the last state before the end
    # has seen r = 1 three times: 0.5, 0.75, 0.875.
    assert arrays.weights[2, 0] == 0.875


def test_greedy_steps_learn_nothing_and_stop_after_the_episodes_asked_for():
    # A policy check: three-step episodes, no update, no learning episode begun.
    args, arrays, state = _loop_arguments(learn=False, max_episodes=2)
    status, done, failures, _, _, ep_float, ep_int = lp.learning_loop(100, *args)
    assert (status, done, failures) == (lp.DONE, 6, 0)
    assert ep_int[:, 0].tolist() == [3, 3] and ep_float[:, 0].tolist() == [3.0, 3.0]
    assert not arrays.weights.any() and state.episode[0] == state.learning_steps[0] == 0


def test_an_episode_continues_across_calls():
    args, _, state = _loop_arguments()
    first = lp.learning_loop(2, *args)
    assert first[1] == 2 and first[5].shape[0] == 0 and state.phase[0] == lp.IN_EPISODE
    second = lp.learning_loop(1, *args)
    assert second[5][:, 0].tolist() == [3]  # the episode begun in the first call ends here
