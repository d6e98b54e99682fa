"""The compiled learner's update is the Python learner's: same α_t, δ and θ, bit for bit."""

import numpy as np
import pytest

from conjure.agents import SARSA, ActorCritic, QLearning
from conjure.agents.compiled_agent import bootstrap, clear_learner_traces, step_size, td_learn
from conjure.core.interfaces import Transition
from conjure.core.schedules import ConstantStepSize, EpisodicDecay, FeatureNormalizedDecay
from conjure.domains import ChainMDP
from conjure.policies import Gibbs
from conjure.representations import Tabular


@pytest.mark.parametrize(
    "schedule",
    [ConstantStepSize(alpha_0=0.3), FeatureNormalizedDecay(alpha_0=1.0, n_0=10), EpisodicDecay()],
)
def test_step_size_is_the_schedules_value(schedule):
    form = schedule.compiled_form()
    for episode, k in ((1, 1.0), (7, 3.0), (1000, 12.0)):
        assert step_size(form, episode, k) == schedule.value(episode, k)


AGENTS = {
    "sarsa": lambda: SARSA(representation=Tabular(), step_size=0.3),
    "sarsa-lambda": lambda: SARSA(representation=Tabular(), step_size=0.3, trace_decay=0.7),
    "qlearning": lambda: QLearning(representation=Tabular(), step_size=0.3),
    "actor-critic": lambda: ActorCritic(representation=Tabular(), step_size=0.3),
    "advantage-actor-critic": lambda: ActorCritic(
        representation=Tabular(), step_size=0.3, critic="v", actor_update="log_policy"
    ),
    "advantage-actor-critic-traces": lambda: ActorCritic(
        representation=Tabular(),
        step_size=0.3,
        critic="v",
        actor_update="log_policy",
        trace_decay=0.8,
    ),
    "actor-critic-traces": lambda: ActorCritic(
        representation=Tabular(), step_size=0.3, trace_decay=1.0
    ),
}


@pytest.mark.parametrize("name", list(AGENTS))
def test_td_learn_updates_as_learn(name):
    domain = ChainMDP(num_states=5, num_actions=2)
    python = AGENTS[name]().setup(domain.domain_spec, 0)
    compiled = AGENTS[name]().setup(domain.domain_spec, 0)
    form, arrays = compiled.compiled_form(), compiled.compiled_arrays()
    traces = compiled.compiled_row_traces()
    rng = np.random.default_rng(1)
    python.begin_episode()
    compiled.begin_episode()
    for _ in range(40):
        s, a = float(rng.integers(0, 4)), int(rng.integers(0, 2))
        s_next, a_next, reward = s + 1.0, int(rng.integers(0, 2)), float(rng.normal())
        terminated = s_next == 4.0
        delta = python.learn(
            Transition(np.array([s]), a, reward, np.array([s_next]), a_next, terminated)
        )
        phi = compiled.representation_.active_features(np.array([s]))
        target = reward
        if not terminated:
            next_phi = compiled.representation_.active_features(np.array([s_next]))
            chooser = arrays.actor_weights
            q = chooser[next_phi[0]].copy()
            critic_q = arrays.weights[next_phi[0]].copy()
            target = bootstrap(form, reward, q, a_next, np.arange(2), critic_q)
        # π(s, ·) of the log-policy actor: learn met s without act, so over all actions now.
        drawn = Gibbs().probabilities(arrays.actor_weights[phi[0]], np.arange(2))
        assert td_learn(form, arrays, traces, phi, None, a, target, 1, drawn) == delta
        if terminated and not isinstance(compiled, ActorCritic):  # SARSA(λ)'s episode end
            clear_learner_traces(form, arrays, traces)
    np.testing.assert_array_equal(arrays.weights, python.weights_)
    actor = getattr(python, "actor_weights_", python.weights_)
    np.testing.assert_array_equal(arrays.actor_weights, actor)
