"""The compiled learner's update is the Python learner's: same α_t, δ and θ, bit for bit."""

import numpy as np
import pytest

from conjure.agents import SARSA, ActorCritic, QLearning
from conjure.agents.compiled_agent import MULTIPLIER, learn_step, step_size
from conjure.agents.constraints import Lagrangian, PIDLagrangian
from conjure.core.interfaces import Transition
from conjure.core.schedules import ConstantStepSize, EpisodicDecay, FeatureNormalizedDecay
from conjure.domains import ChainMDP
from conjure.policies import Gibbs
from conjure.representations import Tabular
from conjure.testing.checks import _rollout


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
    "sarsa-lagrangian": lambda: SARSA(
        representation=Tabular(), step_size=0.3, constraint=Lagrangian(cost_limit=0.2)
    ),
    "qlearning-pid-lagrangian": lambda: QLearning(
        representation=Tabular(), step_size=0.3, constraint=PIDLagrangian(cost_limit=0.2)
    ),
    "advantage-actor-critic-traces-lagrangian": lambda: ActorCritic(
        representation=Tabular(),
        step_size=0.3,
        critic="v",
        actor_update="log_policy",
        trace_decay=0.8,
        constraint=Lagrangian(cost_limit=0.2),
    ),
}


@pytest.mark.parametrize("name", list(AGENTS))
def test_learn_step_from_the_loops_values_updates_as_learn(name):
    """The loop's learn slot passes `learn_step` the values at s' it reads from its arrays."""
    domain = ChainMDP(num_states=5, num_actions=2)
    python = AGENTS[name]().setup(domain.domain_spec, 0)
    compiled = AGENTS[name]().setup(domain.domain_spec, 0)
    form, arrays, traces = compiled.compiled_form(), compiled.arrays_, compiled.row_traces_
    rng = np.random.default_rng(1)
    python.begin_episode()
    compiled.begin_episode()
    python.arrays_.constraint_state[MULTIPLIER] = 0.7  # λ, read only with a constraint
    arrays.constraint_state[MULTIPLIER] = 0.7
    for _ in range(40):
        s, a = float(rng.integers(0, 4)), int(rng.integers(0, 2))
        s_next, a_next, reward = s + 1.0, int(rng.integers(0, 2)), float(rng.normal())
        terminated, cost = s_next == 4.0, float(rng.random() < 0.3)
        delta = python.learn(
            Transition(np.array([s]), a, reward, np.array([s_next]), a_next, terminated, cost=cost)
        )
        phi = compiled.representation_.active_features(np.array([s]))
        q = critic_q = cost_q = np.zeros(2)  # not read at a terminal s'
        if not terminated:
            next_phi = compiled.representation_.active_features(np.array([s_next]))
            q = arrays.actor_weights[next_phi[0]].copy()  # the chooser's values at s'
            critic_q = arrays.weights[next_phi[0]].copy()
            cost_q = arrays.cost_weights[next_phi[0]].copy() if form.constraint.kind else q
        # π(s, ·) of the log-policy actor: learn met s without act, so over all actions now.
        drawn = Gibbs().probabilities(arrays.actor_weights[phi[0]], np.arange(2))
        step = (
            form, arrays, traces, phi, None, phi, None, a, reward, terminated, q, critic_q,
            cost_q, a_next, np.arange(2), 1, np.zeros(2), drawn, True, cost, 0.0, 0.0,
        )  # fmt: skip
        assert learn_step(*step) == delta
    np.testing.assert_array_equal(arrays.weights, python.weights_)
    actor = getattr(python, "actor_weights_", python.weights_)
    np.testing.assert_array_equal(arrays.actor_weights, actor)
    np.testing.assert_array_equal(arrays.cost_weights, python.arrays_.cost_weights)
    np.testing.assert_array_equal(arrays.constraint_state, python.arrays_.constraint_state)


@pytest.mark.parametrize(
    ("name", "flags"),
    [("sarsa", (False, False)), ("sarsa-lambda", (False, True)), ("actor-critic", (True, False))],
)
def test_python_growth_is_the_loops_growth_kernel(name, flags, monkeypatch):
    from conjure.agents import compiled_agent
    from conjure.core import Expansion

    calls = []
    kernel = compiled_agent.grow_learner_rows

    def recording(arrays, first, parents, *grown):
        calls.append((first, parents.tolist(), grown))
        kernel(arrays, first, parents, *grown)

    monkeypatch.setattr(compiled_agent, "grow_learner_rows", recording)
    domain = ChainMDP(num_states=4, num_actions=2)
    agent = AGENTS[name]().setup(domain.domain_spec, seed=0)
    _rollout(domain, agent, 30, seed=0)
    theta = agent.weights_.copy()
    omega = agent.actor_weights_.copy() if name == "actor-critic" else None
    agent.representation_.num_features_ = 6  # as if the representation discovered two
    agent._grow(Expansion(first_new=4, parents=np.array([[0, 1], [4, -1]])))
    assert calls == [(4, [[0, 1], [4, -1]], flags)]
    assert np.array_equal(agent.weights_[4], theta[0] + theta[1])  # θ_f = θ_g + θ_h
    assert np.array_equal(agent.weights_[5], theta[0] + theta[1])  # a parent of −1 adds 0
    if omega is not None:
        assert np.array_equal(agent.actor_weights_[4], omega[0] + omega[1])
    if flags[1]:
        assert np.all(agent.trace_slots_[4:] == 0)


def test_an_actor_with_its_own_features_keeps_its_rows_when_the_critic_grows():
    from conjure.core import Expansion
    from conjure.representations import RBF

    domain = ChainMDP(num_states=4, num_actions=2)
    agent = ActorCritic(representation=Tabular(), actor_representation=RBF()).setup(
        domain.domain_spec, seed=0
    )
    _rollout(domain, agent, 30, seed=0)
    omega = agent.actor_weights_.copy()
    agent.representation_.num_features_ = 5  # as if the critic's representation discovered one
    agent._grow(Expansion(first_new=4, parents=np.array([[0, 1]])))
    assert agent.weights_.shape[0] == 5
    assert np.array_equal(agent.actor_weights_, omega)


class HalvedConstant(ConstantStepSize):
    """A user's schedule with no compiled form (its ``value`` is overridden)."""

    def value(self, episode, num_active):
        return 0.5 * super().value(episode, num_active)


@pytest.mark.parametrize(
    "make",
    [
        lambda step: SARSA(representation=Tabular(), step_size=step, trace_decay=0.7),
        lambda step: ActorCritic(representation=Tabular(), step_size=step, critic="v"),
    ],
)
def test_a_python_schedule_is_read_in_python_and_leaves_the_learner_without_a_form(make):
    domain = ChainMDP(num_states=5, num_actions=2)
    python = make(HalvedConstant(alpha_0=0.6)).setup(domain.domain_spec, 0)
    compiled = make(ConstantStepSize(alpha_0=0.3)).setup(domain.domain_spec, 0)
    assert python.compiled_form() is None and compiled.compiled_form() is not None
    _rollout(domain, python, 60, seed=3)
    _rollout(domain, compiled, 60, seed=3)
    np.testing.assert_array_equal(python.weights_, compiled.weights_)


def test_growing_past_capacity_replaces_the_form_and_learn_updates_the_new_arrays():
    from conjure.core import Expansion

    domain = ChainMDP(num_states=4, num_actions=2)
    agent = SARSA(representation=Tabular(), step_size=0.5, trace_decay=0.5).setup(
        domain.domain_spec, seed=0
    )
    state, arrays = agent.state_, agent.arrays_
    agent.representation_.num_features_ = 5  # as if the representation discovered one
    agent._grow(Expansion(first_new=4, parents=np.array([[0, 1]])))
    assert agent.state_ is not state and agent.arrays_.weights is not arrays.weights
    assert agent.arrays_.weights.shape[0] >= 5 and agent.weights_.shape == (5, 2)
    agent.begin_episode()
    agent.learn(Transition(np.array([0.0]), 1, 1.0, np.array([1.0]), 0, True))
    assert agent.weights_[0, 1] == 0.5  # θ ← θ + αδφ through the new form
    assert agent.arrays_.weights[0, 1] == 0.5 and arrays.weights[0, 1] == 0.0
