"""Online iFDD and legal actions on the compiled path: same seed, same learner as Python.

BlocksWorld and Persistent Surveillance (Geramifard 2012, Section 4.1.4) with their initial
features alone or under online iFDD / iFDD+ or ARiFDD, and the pendulum, GridWorld and chain
with online iFDD over tile coding, a table or independent discretization, or ARiFDD
(`conjure.compiled.learning_loop`), learned by SARSA(λ), Q-Learning or Actor-Critic.
"""

import numpy as np
import pytest

from conjure.agents import SARSA, ActorCritic, QLearning
from conjure.compiled import CompiledStepper, for_combination, why_not_compiled
from conjure.compiled import stepper as stepper_module
from conjure.core.schedules import EpisodicDecay, FeatureNormalizedDecay
from conjure.domains import (
    BlocksWorld,
    ChainMDP,
    GridWorld,
    InvertedPendulum,
    PersistentSurveillance,
    RescueMission,
    UAVMission,
)
from conjure.experiments import run
from conjure.experiments.loop import LearningLoop, run_episode
from conjure.policies import EpsilonGreedy, Gibbs
from conjure.representations import (
    ARiFDD,
    BinaryIndicators,
    HashedTabular,
    IndependentDiscretization,
    OnlineIFDD,
    RandomExpansion,
    Tabular,
    TileCoding,
)

DECAY = FeatureNormalizedDecay(alpha_0=0.1, n_0=100)

#: (domain, representation) of Section 4.1.4's runs (smaller ξ than the thesis's, to grow more).
REPRESENTATIONS = {
    "ifdd-plus": lambda: OnlineIFDD(
        base=BinaryIndicators(), relevance="ifdd_plus", discovery_threshold=0.05
    ),
    "ifdd-threshold": lambda: OnlineIFDD(base=BinaryIndicators(), discovery_threshold=0.02),
    "ifdd-plus-signed-unsparsified": lambda: OnlineIFDD(
        base=BinaryIndicators(),
        relevance="ifdd_plus_signed",
        discovery_threshold=0.01,
        sparsify=False,
        max_features=100,
    ),
    "ifdd-fixed-rate": lambda: OnlineIFDD(base=BinaryIndicators(), discovery_rate=0.4),
    "arifdd": lambda: ARiFDD(discovery_threshold=0.5),
    "indicators": BinaryIndicators,
    "ifdd-plus-over-buckets": lambda: OnlineIFDD(
        base=IndependentDiscretization(num_buckets=2),
        relevance="ifdd_plus",
        discovery_threshold=0.05,
    ),
}
PST_REPRESENTATIONS = {
    "pst-ifdd-plus": lambda: OnlineIFDD(
        base=IndependentDiscretization(), relevance="ifdd_plus", discovery_threshold=20.0
    ),
    "pst-ifdd-fixed-rate": lambda: OnlineIFDD(base=IndependentDiscretization(), discovery_rate=2),
    "pst-independent": IndependentDiscretization,
}
#: Every action legal (pendulum, grid world, chain), iFDD over fixed features.
UNCONSTRAINED_REPRESENTATIONS = {
    "pendulum-ifdd-plus-over-tiles": lambda: OnlineIFDD(
        base=TileCoding(), relevance="ifdd_plus", discovery_threshold=0.05
    ),
    "pendulum-ifdd-over-hashed-tiles": lambda: OnlineIFDD(
        base=TileCoding(memory_size=256), discovery_threshold=0.5
    ),
    "pendulum-ifdd-fixed-rate-over-buckets": lambda: OnlineIFDD(
        base=IndependentDiscretization(), discovery_rate=0.4
    ),
    "gridworld-ifdd-plus-over-buckets": lambda: OnlineIFDD(
        base=IndependentDiscretization(), relevance="ifdd_plus", discovery_threshold=0.01
    ),
    "chain-ifdd-over-table": lambda: OnlineIFDD(base=Tabular(), discovery_threshold=0.01),
    # ARiFDD (Algorithm 22): tiles split past their capacity; iFDD+ up to a feature cap
    "pendulum-arifdd": lambda: ARiFDD(initial_tiles_per_dim=2, discovery_threshold=0.5),
    "pendulum-arifdd-plus-capped": lambda: ARiFDD(
        initial_tiles_per_dim=[3, 5],
        relevance="ifdd_plus",
        discovery_threshold=0.2,
        split_threshold=2.0,
        max_features=60,
    ),
    "chain-ifdd-over-hashed-table": lambda: OnlineIFDD(
        base=HashedTabular(capacity=50), discovery_threshold=0.01
    ),
}
#: Rescue Mission and a UAV mission (Sections 4.1.4 and 5.3.5) over their discrete dimensions.
MISSION_REPRESENTATIONS = {
    "rescue-ifdd-plus": lambda: OnlineIFDD(
        base=IndependentDiscretization(), relevance="ifdd_plus", discovery_threshold=0.5
    ),
    "rescue-independent": IndependentDiscretization,
    "uav-ifdd-fixed-rate": lambda: OnlineIFDD(base=IndependentDiscretization(), discovery_rate=1),
}
ALL_REPRESENTATIONS = {
    **REPRESENTATIONS,
    **PST_REPRESENTATIONS,
    **UNCONSTRAINED_REPRESENTATIONS,
    **MISSION_REPRESENTATIONS,
}
AGENTS = {
    "sarsa": lambda rep: SARSA(representation=rep, step_size=DECAY),
    "qlearning": lambda rep: QLearning(
        representation=rep, step_size=EpisodicDecay(alpha_0=0.05, n_0=100)
    ),
}
#: SARSA(λ) with sparse traces; λ = 1 with accumulating traces outgrows the trace arrays.
TRACE_AGENTS = {
    "sarsa-lambda": lambda rep: SARSA(representation=rep, step_size=DECAY, trace_decay=0.8),
    "sarsa-accumulating": lambda rep: SARSA(
        representation=rep,
        step_size=FeatureNormalizedDecay(alpha_0=0.01, n_0=100),
        trace_decay=1.0,
        trace_kind="accumulating",
    ),
}
#: Algorithm 12 with the actor sharing the critic's (growing) features.
ACTOR_CRITIC = {
    "actor-critic": lambda rep: ActorCritic(
        representation=rep, step_size=FeatureNormalizedDecay(alpha_0=0.05, n_0=100)
    ),
}
#: Uneven advances (20,000 steps), with a greedy policy check after each.
CHUNKS = (0, 1, 337, 1500, 5000, 13162)


def _domain(rep: str):
    domains = {
        "pst": PersistentSurveillance,
        "pendulum": lambda: InvertedPendulum(force_noise=10.0, start_noise=0.05),
        "gridworld": GridWorld,
        "chain": lambda: ChainMDP(num_states=6, num_actions=2, slip=0.2),
        "rescue": RescueMission,
        "uav": lambda: UAVMission(traverse_failure=0.1),
    }
    return domains.get(rep.split("-")[0], BlocksWorld)()


def _build(rep: str, agent: str, seed: int):
    domain = _domain(rep)
    make_agent = {**AGENTS, **TRACE_AGENTS, **ACTOR_CRITIC}[agent]
    learner = make_agent(ALL_REPRESENTATIONS[rep]()).setup(domain.domain_spec, seed)
    return domain, learner


def _learn(stepper, agent, seed: int, rep: str) -> list:
    """Advance by `CHUNKS`, checking the greedy policy after each (as a run's policy checks)."""
    checks = []
    for i, n in enumerate(CHUNKS):
        stepper.advance(n)
        checks.append(run_episode(_domain(rep), agent, max_steps=100, seed=seed + i))
    return checks


def _domain_states(domain) -> tuple:
    if isinstance(domain, BlocksWorld):
        return domain._dstate.tolist(), domain._mask.tolist()
    if isinstance(domain, (PersistentSurveillance, RescueMission)):
        return domain._state.tolist(), domain._mask.tolist()
    if isinstance(domain, UAVMission):
        return (domain._state.tolist(),)
    if isinstance(domain, InvertedPendulum):
        return tuple(domain._fstate)
    return (domain._cell,) if isinstance(domain, GridWorld) else (int(domain._position[0]),)


@pytest.mark.parametrize("rep", sorted(ALL_REPRESENTATIONS))
@pytest.mark.parametrize("agent_name", sorted(AGENTS))
@pytest.mark.parametrize("seed", [0, 5])
def test_same_seed_gives_the_same_learner_on_both_paths(rep, agent_name, seed):
    _check_both_paths(rep, agent_name, seed)


@pytest.mark.parametrize(
    "rep",
    [
        "ifdd-fixed-rate",
        "ifdd-threshold",
        "indicators",
        "pst-ifdd-plus",
        "pendulum-ifdd-plus-over-tiles",
        "pendulum-arifdd",
        "gridworld-ifdd-plus-over-buckets",
        "rescue-ifdd-plus",
        "uav-ifdd-fixed-rate",
    ],
)
@pytest.mark.parametrize("agent_name", sorted(TRACE_AGENTS))
def test_sarsa_lambda_gives_the_same_learner_on_both_paths(rep, agent_name):
    _check_both_paths(rep, agent_name, 1)


@pytest.mark.parametrize(
    "rep",
    [
        "ifdd-plus",
        "ifdd-fixed-rate",
        "indicators",
        "pst-ifdd-plus",
        "pendulum-ifdd-plus-over-tiles",
        "pendulum-arifdd",
        "pendulum-ifdd-over-hashed-tiles",
        "gridworld-ifdd-plus-over-buckets",
        "chain-ifdd-over-table",
        "rescue-ifdd-plus",
        "uav-ifdd-fixed-rate",
    ],
)
@pytest.mark.parametrize("seed", [0, 5])
def test_actor_critic_gives_the_same_learner_on_both_paths(rep, seed):
    _check_both_paths(rep, "actor-critic", seed)


def _check_both_paths(rep: str, agent_name: str, seed: int) -> None:
    python_domain, python_agent = _build(rep, agent_name, seed)
    loop = LearningLoop(python_domain, python_agent, seed=seed)
    python_checks = _learn(loop, python_agent, seed, rep)
    domain, agent = _build(rep, agent_name, seed)
    stepper = for_combination(domain, agent, seed=seed)
    assert isinstance(stepper, CompiledStepper)
    assert _learn(stepper, agent, seed, rep) == python_checks
    np.testing.assert_array_equal(agent.weights_, python_agent.weights_)
    if isinstance(agent, ActorCritic):
        np.testing.assert_array_equal(agent.actor_weights_, python_agent.actor_weights_)
    assert agent.num_features == python_agent.num_features
    assert (stepper.total_steps, stepper.num_episodes, stepper.is_mid_episode) == (
        loop.total_steps,
        loop.num_episodes,
        loop.is_mid_episode,
    )
    assert stepper.num_failures == loop.num_failures
    assert stepper.total_cost == loop.total_cost
    assert (agent.episode_, agent.num_learning_steps_) == (
        python_agent.episode_,
        python_agent.num_learning_steps_,
    )
    assert agent.rng_.bit_generator.state == python_agent.rng_.bit_generator.state
    assert domain.np_random.bit_generator.state == python_domain.np_random.bit_generator.state
    assert _domain_states(domain) == _domain_states(python_domain)
    if "ifdd" in rep:
        compiled_rep, python_rep = agent.representation_, python_agent.representation_
        assert compiled_rep.num_discovered_ == python_rep.num_discovered_
        # one active cell has no co-active pair: iFDD over a table never discovers
        assert python_rep.num_discovered_ > 0 or type(python_rep.base_) in (Tabular, HashedTabular)
        np.testing.assert_array_equal(compiled_rep.parents_, python_rep.parents_)
        sets, parents, relevances = compiled_rep.potential_features()
        python_sets, python_parents, python_relevances = python_rep.potential_features()
        assert [s.tolist() for s in sets] == [s.tolist() for s in python_sets]
        np.testing.assert_array_equal(parents, python_parents)
        np.testing.assert_array_equal(relevances, python_relevances)
        assert compiled_rep.num_discover_calls_ == python_rep.num_discover_calls_ == 20_000


def test_episode_returns_are_the_python_paths():
    # The compiled stepper's episode statistics equal the Python loop's last episodes.
    domain, agent = _build("ifdd-plus", "sarsa", 2)
    stats = for_combination(domain, agent, seed=2).advance(6000)
    python_domain, python_agent = _build("ifdd-plus", "sarsa", 2)
    loop = LearningLoop(python_domain, python_agent, seed=2)
    lengths = []
    while len(lengths) < len(stats.episode_lengths):
        before = loop.num_completed_episodes
        loop.advance(1)
        if loop.num_completed_episodes > before:
            lengths.append(loop.last_episode.num_steps)
            assert loop.last_episode.episode_return == stats.episode_returns[len(lengths) - 1]
    assert lengths == stats.episode_lengths.tolist()
    assert stats.num_failures == 0 and not stats.episode_failures.any()
    # a finished tower earns +1 and every move before it -0.001 (Section 4.1.4)
    finished = stats.episode_lengths < 1000
    expected = 1.0 - 0.001 * (stats.episode_lengths[finished] - 1)
    np.testing.assert_allclose(stats.episode_returns[finished], expected)


@pytest.mark.parametrize(
    ("rep", "agent_name"),
    [("ifdd-threshold", "sarsa"), ("pendulum-ifdd-plus-over-tiles", "actor-critic")],
)
def test_the_representation_and_weights_grow_between_kernel_calls(rep, agent_name):
    domain, agent = _build(rep, agent_name, 1)
    nodes = agent.representation_._arrays["node_key"].shape[0]
    for_combination(domain, agent, seed=1).advance(20_000)
    assert agent.representation_._arrays["node_key"].shape[0] > nodes  # `_grow` ran
    rep = agent.representation_
    num_actions = domain.domain_spec.num_actions
    weights = [agent.weights_, *([agent.actor_weights_] if agent_name == "actor-critic" else [])]
    for w in weights:
        assert w.shape == (rep.num_features_, num_actions)
        # θ_f of a discovered feature started at θ_g + θ_h: its rows are the buffer's own rows
        assert w.base is not None and w.base.shape[0] >= rep.num_features_


def test_one_compilation_serves_every_adaptive_combination():
    for rep in ALL_REPRESENTATIONS:
        for agent_name in [*AGENTS, *ACTOR_CRITIC]:
            domain, agent = _build(rep, agent_name, 3)
            for_combination(domain, agent, seed=3).advance(30)
    binary = [
        s
        for s in stepper_module.run_loop.overloads
        if str(stepper_module.representation_type(s).types[0].types[-1]) == "none"
    ]
    assert len(binary) == 1


@pytest.mark.parametrize(
    ("domain", "agent"),
    [
        (
            BlocksWorld(),
            ActorCritic(representation=BinaryIndicators(), actor_representation=BinaryIndicators()),
        ),  # separate actor features
        (
            InvertedPendulum(),
            ActorCritic(
                representation=OnlineIFDD(base=TileCoding()), actor_representation=TileCoding()
            ),
        ),
    ],
)
def test_adaptive_combinations_the_kernel_does_not_cover(domain, agent):
    assert why_not_compiled(domain, agent.setup(domain.domain_spec, 0)) is not None


#: Pairs the components' kernels compose into without a line of their own in the loop.
COMPOSED = {
    "random-expansion": lambda: RandomExpansion(base=BinaryIndicators(), discovery_rate=0.4),
    "pst-hashed-tiles": lambda: TileCoding(memory_size=64),
    "rescue-hashed-tiles": lambda: TileCoding(memory_size=64),
    "uav-ifdd-over-hashed-tiles": lambda: OnlineIFDD(
        base=TileCoding(memory_size=64), discovery_threshold=0.5
    ),
}


@pytest.mark.parametrize("rep", list(COMPOSED))
def test_composed_pairs_give_the_same_learner_on_both_paths(rep, monkeypatch):
    monkeypatch.setitem(ALL_REPRESENTATIONS, rep, COMPOSED[rep])
    _check_both_paths(rep, "sarsa", 4)


def test_persistent_surveillance_counts_crashes_as_python_does():
    # Section 4.1.4: running out of fuel outside REFUEL ends the episode, the domain's failure.
    domain, agent = _build("pst-independent", "sarsa", 8)
    stats = for_combination(domain, agent, seed=8).advance(5000)
    crashed = stats.episode_lengths < 1000
    assert crashed.any() and stats.num_failures == int(stats.episode_failures.sum())
    assert stats.episode_failures[crashed].tolist() == [1] * int(crashed.sum())


def test_gibbs_over_legal_moves_matches_python():
    def build():
        domain = BlocksWorld(num_blocks=4)
        agent = QLearning(
            representation=OnlineIFDD(base=BinaryIndicators(), discovery_threshold=0.05),
            policy=Gibbs(temperature=0.01),
        )
        return domain, agent.setup(domain.domain_spec, 4)

    python_domain, python_agent = build()
    LearningLoop(python_domain, python_agent, seed=4).advance(3000)
    domain, agent = build()
    for_combination(domain, agent, seed=4).advance(3000)
    np.testing.assert_array_equal(agent.weights_, python_agent.weights_)
    assert agent.rng_.bit_generator.state == python_agent.rng_.bit_generator.state


def test_epsilon_greedy_chooses_only_legal_moves():
    # ε = 1: every action is exploratory; an illegal one would raise in Python and corrupt
    # the compiled state, so the state must stay a valid On vector after many steps.
    domain = BlocksWorld()
    agent = SARSA(representation=BinaryIndicators(), policy=EpsilonGreedy(epsilon=1.0))
    for_combination(domain, agent.setup(domain.domain_spec, 0), seed=0).advance(5000)
    obs = domain._current_observation()
    assert domain.legal_actions(obs).size > 0  # raises on a malformed state
    on = obs.reshape(6, 6).argmax(axis=1).tolist()
    assert obs.sum() == 6 and on == domain.compiled_form().state[36:42].tolist()


def _curve(rows: list) -> list:
    return [{k: v for k, v in row.items() if k not in ("wall_time_s", "steps_per_second")}
            for row in rows]  # fmt: skip


@pytest.mark.parametrize(
    "rep",
    [
        "ifdd-plus",
        "pst-ifdd-plus",
        "pendulum-ifdd-plus-over-tiles",
        "rescue-ifdd-plus",
        "pendulum-arifdd",
    ],
)
def test_a_run_records_the_same_curve_on_both_paths(monkeypatch, rep):
    import conjure.compiled

    offered = []

    def result(compiled: bool):
        domain, _ = _build(rep, "sarsa", 0)
        make_rep = ALL_REPRESENTATIONS[rep]
        warmth = lambda stepper: offered.append(type(stepper)) or compiled  # noqa: E731
        monkeypatch.setattr(conjure.compiled, "is_warm", warmth)
        agent = AGENTS["sarsa"](make_rep())
        return run(domain=domain, agent=agent, budget_steps=8000, seed=11, num_policy_checks=4)

    python_result, compiled_result = result(False), result(True)
    # Each run's learning stepper and its 5 policy checks' greedy steppers were offered; the
    # compiled path ran the second run's.
    assert offered == [CompiledStepper] * 2 * (1 + 5)
    assert _curve(compiled_result.rows) == _curve(python_result.rows)
    np.testing.assert_array_equal(compiled_result.agent.weights_, python_result.agent.weights_)


def test_save_after_compiled_steps_and_continue_from_the_restored_agent(tmp_path):
    domain, agent = _build("ifdd-plus", "qlearning", 6)
    stepper = for_combination(domain, agent, seed=6)
    stepper.advance(4000)
    restored = type(agent).restore(agent.save(tmp_path / "agent"))
    stepper.agent = restored  # the stepper reads its agent at every advance
    stepper.advance(4000)
    straight_domain, straight = _build("ifdd-plus", "qlearning", 6)
    for_combination(straight_domain, straight, seed=6).advance(8000)
    np.testing.assert_array_equal(restored.weights_, straight.weights_)
    np.testing.assert_array_equal(
        restored.representation_.parents_, straight.representation_.parents_
    )
    assert restored.rng_.bit_generator.state == straight.rng_.bit_generator.state


def test_traces_and_their_slots_grow_between_kernel_calls():
    domain, agent = _build("ifdd-fixed-rate", "sarsa-accumulating", 2)
    for_combination(domain, agent, seed=2).advance(20_000)
    assert agent.trace_values_.shape[0] > 1024  # GROW_TRACES: the agent's own growth ran
    n = agent.representation_.num_features_
    assert agent.trace_slots_.shape == (n, 36) and agent.weights_.shape == (n, 36)
    live = agent.trace_count_[0]
    slots = agent.trace_slots_[agent.trace_features_[:live], agent.trace_actions_[:live]]
    assert slots.tolist() == list(range(1, live + 1))  # every live trace: 1 + its slot
    assert (agent.trace_slots_ > 0).sum() == live
