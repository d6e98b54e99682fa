import numpy as np
import pytest

from conjure.agents import SARSA
from conjure.agents.linear_td import make_schedule
from conjure.core import ConstantStepSize, EpisodicDecay, Expansion, InvalidParameterError
from conjure.core.interfaces import Transition
from conjure.domains import ChainMDP
from conjure.representations import Tabular


def test_make_schedule_wraps_floats_and_validates():
    assert make_schedule(0.3) == ConstantStepSize(alpha_0=0.3)
    assert make_schedule(EpisodicDecay(alpha_0=1.0, n_0=1.0)).value(3, 1) == 0.5
    with pytest.raises(InvalidParameterError, match="alpha_0"):
        make_schedule(EpisodicDecay(alpha_0=-1.0))


def test_grow_adds_rows_as_sum_of_parents_and_drops_caches():
    domain = ChainMDP(num_states=4, num_actions=2)
    agent = SARSA(representation=Tabular()).setup(domain.domain_spec, seed=0)
    agent.weights_[:] = np.arange(8, dtype=float).reshape(4, 2)
    agent.act(np.array([0.0]))
    agent.representation_.num_features_ = 5  # as if the representation discovered one
    agent._grow(Expansion(first_new=4, parents=np.array([[1, 3]])))
    assert agent.weights_.shape == (5, 2)
    assert agent.weights_[4].tolist() == [2 + 6, 3 + 7]  # θ_f = θ_g + θ_h, Section 4.1.1
    assert agent._last[0] is None


def test_cache_serves_learn_with_act_values():
    domain = ChainMDP(num_states=4, num_actions=2)
    agent = SARSA(representation=Tabular()).setup(domain.domain_spec, seed=0)
    state = np.array([1.0])
    agent.act(state)
    assert agent._features(state) is agent._last[1]
    assert agent._features(np.array([1.0])) is agent._last[1]  # equal values, another object


def test_a_state_changed_in_place_after_act_is_encoded_anew():
    # A Gymnasium wrapper may reuse one observation buffer: after act(buffer) the buffer may
    # hold another state, and learn must see that state's features, not the cached ones.
    domain = ChainMDP(num_states=4, num_actions=2)
    agent = SARSA(representation=Tabular(), step_size=1.0).setup(domain.domain_spec, seed=0)
    buffer = np.array([1.0])
    agent.act(buffer)
    buffer[:] = 2.0
    agent.learn(Transition(buffer, 0, 1.0, np.array([3.0]), 0, True))
    assert agent.q_values(np.array([2.0]))[0] == 1.0
    assert agent.q_values(np.array([1.0]))[0] == 0.0


def _random_call_sequence(spec, seed, num_calls=400):
    """Calls a cooperative learner may make on its inner agent, states sometimes in place.

    Acts (exploratory or greedy) happen only on some states; learn gets transitions whose
    states the agent may never have seen in act; one buffer is reused and mutated in place.
    """
    rng = np.random.default_rng(seed)
    buffer = np.zeros(1)
    calls = []
    for _ in range(num_calls):
        kind = rng.choice(["act", "greedy", "learn", "learn", "mutate"])
        if kind == "mutate":
            calls.append(("mutate", float(rng.integers(spec.high[0] + 1))))
            continue
        use_buffer = rng.random() < 0.5
        state = buffer if use_buffer else np.array([float(rng.integers(spec.high[0] + 1))])
        if kind in ("act", "greedy"):
            calls.append((kind, state))
        else:
            following = buffer if rng.random() < 0.3 else np.array([float(rng.integers(4))])
            terminated = bool(following[0] == spec.high[0])
            action, next_action = int(rng.integers(2)), int(rng.integers(2))
            calls.append(
                ("learn", (state, action, float(rng.normal()), following, next_action, terminated))
            )
    return buffer, calls


@pytest.mark.parametrize("kind", ["SARSA", "QLearning", "ActorCritic", "SARSA-traces"])
def test_cache_is_exact_under_any_act_and_learn_interleaving(kind):
    from conjure.agents import ActorCritic, QLearning

    domain = ChainMDP(num_states=4, num_actions=2)
    spec = domain.domain_spec
    make = {
        "SARSA": lambda: SARSA(representation=Tabular(), step_size=0.3),
        "QLearning": lambda: QLearning(representation=Tabular(), step_size=0.3),
        "ActorCritic": lambda: ActorCritic(representation=Tabular(), step_size=0.3),
        "SARSA-traces": lambda: SARSA(representation=Tabular(), step_size=0.3, trace_decay=0.5),
    }[kind]
    buffer, calls = _random_call_sequence(spec, seed=7)
    agent = make().setup(spec, seed=0)
    reference = make().setup(spec, seed=0)  # never acts: its cache is always empty
    for name, payload in calls:
        if name == "mutate":
            buffer[:] = payload
        elif name in ("act", "greedy"):
            agent.act(payload, greedy=name == "greedy")
        else:
            state, action, reward, following, next_action, terminated = payload
            copies = (state.copy(), following.copy())
            agent.learn(Transition(state, action, reward, following, next_action, terminated))
            reference.learn(
                Transition(copies[0], action, reward, copies[1], next_action, terminated)
            )
    np.testing.assert_array_equal(agent.weights_, reference.weights_)
    if kind == "ActorCritic":
        np.testing.assert_array_equal(agent.actor_weights_, reference.actor_weights_)


def test_a_weight_table_too_large_for_memory_is_a_clear_error():
    from conjure.core import IncompatibleComponentsError
    from conjure.domains import BlocksWorld

    with pytest.raises(IncompatibleComponentsError, match="18,432 GiB"):
        SARSA(representation=Tabular()).setup(BlocksWorld().domain_spec, seed=0)
