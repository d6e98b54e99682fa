"""Same seed, same curve: the compiled stepper against the Python `LearningLoop`."""

import time

import numpy as np
import pytest
from numba import njit

from conjure.agents import SARSA, ActorCritic, QLearning
from conjure.agents.constraints import Lagrangian, PIDLagrangian, Saute
from conjure.compiled import (
    CompiledStepper,
    compile_seconds,
    for_combination,
    warm_up,
)
from conjure.compiled import stepper as stepper_module
from conjure.core.errors import DivergenceError, InvalidParameterError
from conjure.core.schedules import EpisodicDecay, FeatureNormalizedDecay
from conjure.domains import ChainMDP, GridWorld, InvertedPendulum, UAVMission, from_gymnasium
from conjure.domains.gridworld import open_grid
from conjure.experiments.loop import LearningLoop, run_episode
from conjure.models.approximate_model import ApproximateModel
from conjure.planners import ShortestPathPlanner
from conjure.policies import EpsilonGreedy, Gibbs
from conjure.representations import (
    RBF,
    HashedTabular,
    IndependentDiscretization,
    Tabular,
    TileCoding,
)
from conjure.safety import CooperativeLearner, MonteCarloRiskAnalyzer
from cost_corridor import register as register_corridor

DECAY = FeatureNormalizedDecay(alpha_0=1.0, n_0=100)


def _tiles(**params):
    return TileCoding(num_tilings=8, tiles_per_dim=10, **params)


def _advantage_actor_critic(actor_alpha: float, trace_decay: float) -> ActorCritic:
    return ActorCritic(
        representation=Tabular(),
        step_size=EpisodicDecay(alpha_0=1.0, n_0=100),
        actor_step_size=EpisodicDecay(alpha_0=actor_alpha, n_0=1000),
        critic="v",
        actor_update="log_policy",
        trace_decay=trace_decay,
    )


#: Every compiled combination, with the parameters that take each branch of the kernel.
COMBINATIONS = {
    "pendulum-tiles-sarsa": (
        InvertedPendulum,
        lambda: SARSA(representation=_tiles(), step_size=DECAY),
    ),
    "pendulum-tiles-sarsa-lambda": (
        InvertedPendulum,
        lambda: SARSA(representation=_tiles(), step_size=DECAY, trace_decay=0.9),
    ),
    "open-gridworld-tiles-sarsa-lambda-grows-traces": (
        lambda: GridWorld.from_grid(open_grid(30, 30, seed=1), discount=1.0),
        lambda: SARSA(
            representation=TileCoding(num_tilings=4, tiles_per_dim=30),
            step_size=0.01,
            trace_decay=1.0,
            trace_kind="accumulating",
        ),
    ),
    "pendulum-start-noise-tiles-qlearning": (
        lambda: InvertedPendulum(start_noise=0.2),
        lambda: QLearning(representation=_tiles(), step_size=0.05),
    ),
    "pendulum-hashed-tiles-sarsa": (
        InvertedPendulum,
        lambda: SARSA(representation=_tiles(memory_size=300), step_size=DECAY),
    ),
    "pendulum-independent-sarsa": (
        InvertedPendulum,
        lambda: SARSA(representation=IndependentDiscretization(num_buckets=20), step_size=DECAY),
    ),
    "gridworld-tabular-sarsa": (
        GridWorld.gridworld_1,
        lambda: SARSA(representation=Tabular(), step_size=0.5),
    ),
    "gridworld-tabular-qlearning": (
        GridWorld.gridworld_2,
        lambda: QLearning(representation=Tabular(), step_size=0.5),
    ),
    "gridworld-windy-independent-sarsa-lambda": (
        GridWorld.gridworld_3,
        lambda: SARSA(
            representation=IndependentDiscretization(),
            step_size=EpisodicDecay(alpha_0=0.3, n_0=10),
            trace_decay=0.5,
        ),
    ),
    "chain-tabular-qlearning": (
        lambda: ChainMDP(num_states=6, num_actions=2, slip=0.3),
        lambda: QLearning(
            representation=Tabular(), step_size=0.2, policy=EpsilonGreedy(epsilon=0.3)
        ),
    ),
    "chain-tabular-actor-critic": (
        lambda: ChainMDP(num_states=6, num_actions=2, slip=0.1),
        lambda: ActorCritic(representation=Tabular(), step_size=0.2),
    ),
    "gridworld-tabular-actor-critic": (
        GridWorld.gridworld_1,
        lambda: ActorCritic(
            representation=Tabular(),
            step_size=0.3,
            actor_step_size=EpisodicDecay(alpha_0=0.5, n_0=100),
            policy=Gibbs(temperature=0.5),
        ),
    ),
    # The advantage actor-critic of iCCA's learner (Fig. 5-5): V critic, log-policy actor;
    # with eligibility traces of θ and ω by feature row (Figs. 5-6 and 5-7's).
    "gridworld-tabular-advantage-actor-critic": (
        GridWorld.gridworld_1,
        lambda: _advantage_actor_critic(actor_alpha=1.0, trace_decay=0.0),
    ),
    "gridworld-tabular-advantage-actor-critic-traces": (
        GridWorld.gridworld_1,
        lambda: _advantage_actor_critic(actor_alpha=0.1, trace_decay=0.9),
    ),
    "open-gridworld-tiles-actor-critic-traces-grows-rows": (
        lambda: GridWorld.from_grid(open_grid(30, 30, seed=1), discount=1.0),
        lambda: ActorCritic(
            representation=TileCoding(num_tilings=4, tiles_per_dim=30),
            step_size=0.01,
            trace_decay=1.0,
        ),
    ),
    "pendulum-rbf-actor-critic-traces": (
        InvertedPendulum,
        lambda: ActorCritic(
            representation=RBF(num_centers=4), step_size=0.05, policy=Gibbs(), trace_decay=0.7
        ),
    ),
    "chain-tabular-state-value-actor-critic": (
        lambda: ChainMDP(num_states=6, num_actions=2, slip=0.2),
        lambda: ActorCritic(representation=Tabular(), step_size=0.2, critic="v"),
    ),
    "pendulum-tiles-log-policy-actor-critic": (
        InvertedPendulum,
        lambda: ActorCritic(
            representation=_tiles(),
            step_size=0.05,
            actor_update="log_policy",
            policy=Gibbs(temperature=0.5),
        ),
    ),
    # Real-valued φ (Gaussian RBF): the same kernels with the values; the exact same sums in the
    # same order, so weights agree to the bit. k_t = |φ(s)|₁ under the decaying schedule;
    # replacing traces fall back to accumulating for values other than 1, on both paths.
    "pendulum-rbf-sarsa": (
        lambda: InvertedPendulum(start_noise=0.2),
        lambda: SARSA(representation=RBF(), step_size=DECAY),
    ),
    "pendulum-rbf-sarsa-lambda-replacing": (
        InvertedPendulum,
        lambda: SARSA(representation=RBF(num_centers=4), step_size=0.05, trace_decay=0.9),
    ),
    "gridworld-rbf-sarsa-lambda-accumulating": (
        GridWorld.gridworld_1,
        lambda: SARSA(
            representation=RBF(width=0.3),
            step_size=DECAY,
            trace_decay=0.7,
            trace_kind="accumulating",
        ),
    ),
    "chain-rbf-qlearning": (
        lambda: ChainMDP(num_states=8, num_actions=2, slip=0.2),
        lambda: QLearning(
            representation=RBF(num_centers=5, include_bias=False),
            step_size=EpisodicDecay(alpha_0=0.3, n_0=10),
        ),
    ),
    "pendulum-rbf-actor-critic": (
        InvertedPendulum,
        lambda: ActorCritic(
            representation=RBF(), step_size=0.1, actor_step_size=DECAY, policy=Gibbs()
        ),
    ),
    # The lazily indexed table: cells stored in first-seen order by the loop itself.
    "uav-7-2-hashed-tabular-sarsa-lambda": (
        lambda: UAVMission(scenario="uav-7-2", traverse_failure=0.05),
        lambda: SARSA(
            representation=HashedTabular(capacity=5000), step_size=DECAY, trace_decay=1.0
        ),
    ),
    "gridworld-hashed-tabular-q": (
        GridWorld.gridworld_1,
        lambda: QLearning(representation=HashedTabular(capacity=100), step_size=0.5),
    ),
    # Cost constraints (`conjure.agents.constraints`): θ_C, λ and acting on Q − λQ_C.
    "gridworld-tabular-sarsa-lagrangian": (
        GridWorld.gridworld_1,
        lambda: SARSA(
            representation=Tabular(),
            step_size=0.5,
            constraint=Lagrangian(cost_limit=0.1, multiplier_step_size=0.2),
        ),
    ),
    "gridworld-tabular-qlearning-pid-lagrangian": (
        GridWorld.gridworld_2,
        lambda: QLearning(
            representation=Tabular(),
            step_size=0.5,
            constraint=PIDLagrangian(cost_limit=0.1, kp=0.5, ki=0.2, kd=0.1),
        ),
    ),
    "pendulum-tiles-sarsa-lambda-lagrangian": (
        InvertedPendulum,
        lambda: SARSA(
            representation=_tiles(),
            step_size=DECAY,
            trace_decay=0.9,
            constraint=Lagrangian(cost_limit=0.5),
        ),
    ),
    "gridworld-tabular-advantage-actor-critic-traces-pid-lagrangian": (
        GridWorld.gridworld_1,
        lambda: _advantage_actor_critic(actor_alpha=0.1, trace_decay=0.9).set_params(
            constraint=PIDLagrangian(cost_limit=0.1, kp=0.5, ki=0.2)
        ),
    ),
    # Sauté (`conjure.agents.constraints.Saute`): θ's budget blocks and the reshaped reward,
    # on GridWorld (a pit's cost ends the episode) and on a corridor whose cost does not.
    "gridworld-tabular-sarsa-saute": (
        GridWorld.gridworld_1,
        lambda: SARSA(
            representation=Tabular(),
            step_size=0.5,
            constraint=Saute(cost_limit=0.5, unsafe_reward=-2.0, num_budget_bins=2),
        ),
    ),
    "gridworld-tabular-qlearning-saute": (
        GridWorld.gridworld_2,
        lambda: QLearning(
            representation=Tabular(), step_size=0.5, constraint=Saute(cost_limit=1.0)
        ),
    ),
    "corridor-tabular-qlearning-saute": (
        lambda: from_gymnasium(register_corridor(), discount=0.95),
        lambda: QLearning(
            representation=Tabular(),
            step_size=0.5,
            policy=EpsilonGreedy(epsilon=0.5),
            constraint=Saute(cost_limit=2.0, unsafe_reward=-0.5, num_budget_bins=2),
        ),
    ),
    "corridor-tabular-advantage-actor-critic-saute": (
        lambda: from_gymnasium(register_corridor(), discount=0.95),
        lambda: _advantage_actor_critic(actor_alpha=0.1, trace_decay=0.0).set_params(
            constraint=Saute(cost_limit=2.0, num_budget_bins=3)
        ),
    ),
    # A Gymnasium environment: the loop calls the domain's own reset and step back.
    "mountaincar-gymnasium-tiles-sarsa": (
        lambda: from_gymnasium("MountainCar-v0", discount=1.0),
        lambda: SARSA(representation=TileCoding(num_tilings=4, tiles_per_dim=8), step_size=0.05),
    ),
    "cartpole-gymnasium-tiles-sarsa-lambda": (
        lambda: from_gymnasium("CartPole-v1"),
        lambda: SARSA(representation=_tiles(), step_size=DECAY, trace_decay=0.9),
    ),
}

#: Uneven advances: episodes are paused and resumed across calls.
CHUNKS = (0, 1, 337, 1500, 2162)


def _episodes(rewards: list, cap: int) -> tuple[list, list]:
    """Split the recorded (reward, terminated) steps into finished episodes' returns, lengths."""
    returns, lengths = [], []
    total, length = 0.0, 0
    for reward, terminated in rewards:
        total += reward
        length += 1
        if terminated or length >= cap:
            returns.append(total)
            lengths.append(length)
            total, length = 0.0, 0
    return returns, lengths


def _build(name: str, seed: int):
    make_domain, make_agent = COMBINATIONS[name]
    domain = make_domain()
    agent = make_agent().setup(domain.domain_spec, seed)
    return domain, agent


def _python_path(name: str, seed: int):
    domain, agent = _build(name, seed)
    rewards = []
    step = domain.step

    def recording_step(action):
        out = step(action)
        rewards.append((out[1], out[2]))
        return out

    domain.step = recording_step
    loop = LearningLoop(domain, agent, seed=seed)
    for n in CHUNKS:
        loop.advance(n)
    return loop, agent, _episodes(rewards, domain.domain_spec.max_episode_steps)


def _compiled_path(name: str, seed: int):
    domain, agent = _build(name, seed)
    stepper = for_combination(domain, agent, seed=seed)
    assert isinstance(stepper, CompiledStepper)
    stats = [stepper.advance(n) for n in CHUNKS]
    returns = np.concatenate([s.episode_returns for s in stats]).tolist()
    lengths = np.concatenate([s.episode_lengths for s in stats]).tolist()
    assert sum(s.num_steps for s in stats) == sum(CHUNKS)
    return stepper, agent, (returns, lengths)


@pytest.mark.parametrize("name", sorted(COMBINATIONS))
@pytest.mark.parametrize("seed", [0, 7])
def test_same_seed_gives_the_same_curve_on_both_paths(name, seed):
    loop, python_agent, (py_returns, py_lengths) = _python_path(name, seed)
    stepper, agent, (returns, lengths) = _compiled_path(name, seed)
    assert len(py_returns) > 2  # the runs span several episodes
    assert returns == py_returns
    assert lengths == py_lengths
    np.testing.assert_array_equal(agent.weights_, python_agent.weights_)
    np.testing.assert_array_equal(agent.cost_weights_, python_agent.cost_weights_)
    assert agent.multiplier_ == python_agent.multiplier_
    if isinstance(agent.constraint, Saute):  # no cost critic; blocks of θ by budget bin
        assert agent.multiplier_ == 0.0 and agent.cost_weights_.size == 0
        blocks = np.split(agent.weights_, agent.constraint.num_budget_bins + 1)
        # The corridor's costs do not end its episodes: the spent block z ≤ 0 learned too.
        assert blocks[-1].any() and (blocks[0].any() or not name.startswith("corridor"))
    elif agent.constraint is not None:  # λ moved: the runs exceeded the limit
        assert agent.multiplier_ > 0.0 and agent.cost_weights_.any()
    if isinstance(agent, ActorCritic):
        np.testing.assert_array_equal(agent.actor_weights_, python_agent.actor_weights_)
        if agent.trace_decay > 0:  # the same live rows of z^θ and z^ω
            for name in ("critic_traces_", "actor_traces_"):
                traces, python_traces = getattr(agent, name), getattr(python_agent, name)
                np.testing.assert_array_equal(traces.slot_of, python_traces.slot_of)
    assert (stepper.total_steps, stepper.num_completed_episodes, stepper.num_failures) == (
        loop.total_steps,
        loop.num_completed_episodes,
        loop.num_failures,
    )
    assert stepper.num_episodes == loop.num_episodes == agent.episode_ == python_agent.episode_
    assert stepper.is_mid_episode == loop.is_mid_episode
    assert agent.num_learning_steps_ == python_agent.num_learning_steps_
    assert agent.rng_.bit_generator.state == python_agent.rng_.bit_generator.state
    state = stepper.domain.np_random.bit_generator.state
    assert state == loop.domain.np_random.bit_generator.state
    # The next greedy action agrees too (the Python agent reads the compiled θ).
    obs = np.zeros(stepper.domain.domain_spec.num_dims)
    assert agent.act(obs, greedy=True) == python_agent.act(obs, greedy=True)


def _learner_state(agent) -> dict[str, np.ndarray]:
    """θ and the representation's stored arrays (cells, hashed tiles): a check must keep them."""
    arrays = agent.representation_.state_arrays()
    return {"weights": agent.weights_.copy(), **{k: v.copy() for k, v in arrays.items()}}


@pytest.mark.parametrize(
    "name",
    [
        "gridworld-hashed-tabular-q",
        "pendulum-hashed-tiles-sarsa",
        "uav-7-2-hashed-tabular-sarsa-lambda",
    ],
)
def test_a_policy_check_leaves_a_lazily_indexed_learner_as_it_was_on_both_paths(name):
    # Greedy acting reads φ(s) without storing new cells or tiles (`Representation.peek`):
    # the compiled loop's greedy steps and `act(s, greedy=True)` play the same episodes and
    # leave θ, the index and its feature count exactly as they were.
    played = []
    for is_compiled in (False, True):
        domain, agent = _build(name, 3)
        (
            for_combination(domain, agent, seed=3)
            if is_compiled
            else LearningLoop(domain, agent, seed=3)
        ).advance(400)
        before, num_features = _learner_state(agent), agent.num_features
        check_domain = COMBINATIONS[name][0]()
        if is_compiled:
            stats = for_combination(check_domain, agent, seed=11, learn=False).play_episodes(6)
            returns, lengths = stats.episode_returns.tolist(), stats.episode_lengths.tolist()
            episodes = list(zip(returns, lengths, strict=True))
        else:
            episodes = [
                (e.episode_return, e.num_steps)
                for e in (
                    run_episode(check_domain, agent, seed=11 if k == 0 else None) for k in range(6)
                )
            ]
        after = _learner_state(agent)
        assert after.keys() == before.keys()
        for key in before:
            np.testing.assert_array_equal(after[key], before[key])
        assert agent.num_features == num_features
        played.append((episodes, num_features))
    assert played[0] == played[1]
    assert sum(length for _, length in played[0][0]) > 6  # the checks visited states


def test_trace_growth_is_exercised():
    domain, agent = _build("open-gridworld-tiles-sarsa-lambda-grows-traces", 0)
    for_combination(domain, agent, seed=0).advance(3000)
    assert agent.trace_values_.shape[0] > 1024  # grew past the initial capacity


def test_actor_critic_trace_rows_grow_in_the_loop():
    domain, agent = _build("open-gridworld-tiles-actor-critic-traces-grows-rows", 0)
    for_combination(domain, agent, seed=0).advance(3000)
    assert agent.critic_traces_.rows.shape[0] > 64 < agent.actor_traces_.rows.shape[0]


def test_episode_statistics_are_hand_checkable_on_the_chain():
    # Deterministic chain of 4 states, one action: every episode is 3 steps earning 1 each.
    domain = ChainMDP()
    agent = QLearning(representation=Tabular()).setup(domain.domain_spec, 0)
    stepper = for_combination(domain, agent, seed=0)
    stats = stepper.advance(10)
    assert stats.episode_lengths.tolist() == [3, 3, 3]
    assert stats.episode_returns.tolist() == [3.0, 3.0, 3.0]
    assert stats.discounted_returns.tolist() == pytest.approx([1 + 0.9 + 0.81] * 3)
    assert stats.episode_failures.tolist() == [0, 0, 0]
    assert stepper.is_mid_episode and stepper.num_completed_episodes == 3
    assert stepper.advance(2).episode_lengths.tolist() == [3]  # the paused episode ends
    assert compile_seconds() is not None and compile_seconds() > 0.0


def test_failures_are_counted_like_the_python_path():
    domain = InvertedPendulum()
    agent = SARSA(representation=_tiles()).setup(domain.domain_spec, 3)
    stats = for_combination(domain, agent, seed=3).advance(500)
    # Every pendulum episode that ends before the cap ends with a fall (one failure).
    assert stats.num_failures == int(stats.episode_failures.sum()) == len(stats.episode_lengths)
    assert stats.cost == stats.episode_costs.sum() == stats.num_failures  # c_t = 1 per fall
    assert stats.episode_returns.tolist() == [-1.0] * len(stats.episode_lengths)


def test_divergence_raises_at_the_same_step_on_both_paths():
    def build():
        domain = ChainMDP(num_states=5, discount=1.0)
        agent = QLearning(representation=Tabular(), step_size=10.0, initial_weight=1e300)
        return domain, agent.setup(domain.domain_spec, 0)

    domain, agent = build()
    loop = LearningLoop(domain, agent, seed=0)
    with pytest.raises(DivergenceError) as python_error:
        loop.advance(100)
    domain, agent = build()
    stepper = for_combination(domain, agent, seed=0)
    with pytest.raises(DivergenceError) as compiled_error:
        stepper.advance(100)
    assert str(compiled_error.value) == str(python_error.value)
    assert stepper.total_steps == loop.total_steps


def test_a_full_hashed_table_raises_its_own_error_at_the_same_step_on_both_paths():
    errors, steps = [], []
    for make_stepper in (LearningLoop, for_combination):
        domain = UAVMission(scenario="uav-7-2")
        agent = SARSA(representation=HashedTabular(capacity=40)).setup(domain.domain_spec, 1)
        stepper = make_stepper(domain, agent, seed=1)
        with pytest.raises(InvalidParameterError, match="HashedTabular is full") as raised:
            stepper.advance(10_000)
        errors.append(str(raised.value))
        steps.append((stepper.total_steps, agent.representation_.num_stored_))
    assert errors[0] == errors[1]
    assert steps[0] == steps[1] and steps[0][1] == 40


class _Raising:
    """A domain's ``step`` that raises ``error`` on its ``after``-th call (counted per run)."""

    def __init__(self, step, error: BaseException, after: int):
        self.step, self.error, self.calls, self.after = step, error, 0, after

    def __call__(self, action):
        self.calls += 1
        if self.calls == self.after:
            raise self.error
        return self.step(action)


@pytest.mark.parametrize("error", [RuntimeError("the simulator crashed"), KeyboardInterrupt()])
def test_a_callback_domains_exception_leaves_both_paths_at_the_same_step(error):
    # The compiled loop calls a Gymnasium domain's own step back; what it raises comes out of
    # `advance` unchanged (Ctrl-C included), after the steps before it were counted.
    counts = []
    for make_stepper in (LearningLoop, for_combination):
        domain, agent = _build("cartpole-gymnasium-tiles-sarsa-lambda", 2)
        domain.step = _Raising(domain.step, error, after=700)
        stepper = make_stepper(domain, agent, seed=2)
        with pytest.raises(type(error)) as raised:
            stepper.advance(1000)
        assert raised.value is error
        counts.append((stepper.total_steps, stepper.num_episodes, agent.num_learning_steps_))
        assert not stepper.is_mid_episode  # the cut episode is not continued
    assert counts[0] == counts[1] and counts[0][0] == 699


@pytest.mark.parametrize("bad", [-1, 2.5, True])
def test_advance_rejects_bad_step_counts(bad):
    domain = ChainMDP()
    agent = SARSA(representation=Tabular()).setup(domain.domain_spec, 0)
    with pytest.raises(InvalidParameterError, match="num_steps"):
        for_combination(domain, agent).advance(bad)


def test_one_compilation_serves_every_binary_combination_and_one_every_rbf_one():
    assert warm_up() > 0.0
    for name in COMBINATIONS:
        domain, agent = _build(name, 1)
        for_combination(domain, agent, seed=1).advance(50)
    # The representation's base ends with None (binary φ) or RBF's arrays (real-valued φ).
    last = sorted(
        str(stepper_module.representation_type(sig).types[0].types[-1])
        for sig in stepper_module.run_loop.overloads
    )
    assert len(last) == 2 and last[1] == "none" and last[0].startswith("UniTuple")


@pytest.mark.parametrize("limit", [("MAX_KERNEL_STEPS", 7), ("CHUNK_SECONDS", 0.0)])
@pytest.mark.parametrize(
    "name", ["pendulum-rbf-actor-critic", "gridworld-rbf-sarsa-lambda-accumulating"]
)
def test_kernel_calls_in_bounded_chunks_change_nothing(name, limit, monkeypatch):
    # Ctrl-C is seen between kernel calls only, so `advance` splits its steps into calls of
    # about CHUNK_SECONDS (issue 20); the split (here 7 steps, or one step, a call) must not
    # show in the results.
    reference, reference_agent, reference_episodes = _compiled_path(name, 5)
    monkeypatch.setattr(stepper_module, *limit)
    stepper, agent, episodes = _compiled_path(name, 5)
    assert episodes == reference_episodes
    np.testing.assert_array_equal(agent.weights_, reference_agent.weights_)
    assert stepper.num_episodes == reference.num_episodes
    assert agent.rng_.bit_generator.state == reference_agent.rng_.bit_generator.state


def test_kernel_calls_last_about_chunk_seconds_however_slow_a_step_is(monkeypatch):
    # Issue 20 audit: calls of 2**18 steps made Ctrl-C wait for minutes when one step took
    # long (a Monte-Carlo risk analyser of 10**6 rollouts); calls are now sized in time.
    monkeypatch.setattr(stepper_module, "CHUNK_SECONDS", 0.05)
    domain, agent = _build("cartpole-gymnasium-tiles-sarsa-lambda", 2)
    step = domain.step

    def slow_step(action):
        time.sleep(0.01)
        return step(action)

    domain.step = slow_step
    stepper = for_combination(domain, agent, seed=2)
    stepper.advance(1)  # compiled (or loaded from the cache) outside the timed calls
    calls, call = [], stepper._call

    def timed_call(num_steps, *args):
        started = time.perf_counter()
        out = call(num_steps, *args)
        calls.append((num_steps, time.perf_counter() - started))
        return out

    monkeypatch.setattr(stepper, "_call", timed_call)
    stepper.advance(60)
    sizes = [size for size, _ in calls]
    # 0.05 s fits about five steps of 0.01 s: no call takes many more, from the first on
    assert sum(sizes) == 60 and max(sizes) <= 10, sizes
    assert max(seconds for _, seconds in calls) < 0.5, calls


def test_a_call_judges_at_most_chunk_simulated_steps_of_rollouts():
    # Issue 20 probe: a box ran cheap planner steps first, so the calls grew, then judged every
    # proposal with 10**6 rollouts and a Ctrl-C waited 72 s; the analyser's own worst case
    # per step (𝓜𝓗) now bounds a call, whatever the steps before it cost.
    world = GridWorld.gridworld_2()

    def box(num_rollouts):
        return CooperativeLearner(
            learner=SARSA(representation=Tabular()),
            planner=ShortestPathPlanner.conservative(),
            risk=MonteCarloRiskAnalyzer(num_rollouts=num_rollouts, horizon=100),
            model=ApproximateModel(domain=GridWorld.gridworld_2(), initial_noise=0.4),
        ).setup(world.domain_spec, 0)

    assert stepper_module.max_chunk(box(10**6)) == 1
    assert stepper_module.max_chunk(box(5)) == stepper_module.CHUNK_SIMULATED_STEPS // 500
    plain = SARSA(representation=Tabular()).setup(world.domain_spec, 0)
    assert stepper_module.max_chunk(plain) == stepper_module.CHUNK_SIMULATED_STEPS


def test_a_stepper_calls_the_compilation_numba_picked_for_its_argument_types():
    @njit
    def plus_one(x):
        return x + 1

    plus_one(1)
    picked = stepper_module.compiled_function(plus_one, (1,))
    assert picked is not plus_one and picked(41) == 42
    # no compilation for these types yet: the dispatcher itself (it compiles on the call)
    assert stepper_module.compiled_function(plus_one, (1.5,)) is plus_one


def test_a_stepper_packs_its_arguments_once_and_again_when_a_form_is_replaced():
    # The call's unchanging arguments are packed from the components' forms (their state),
    # kept while those are, and packed anew after the learner replaced its form: the steps
    # after it update the new arrays, as if nothing had been replaced.
    weights = []
    for is_replaced in (False, True):
        domain = ChainMDP()
        agent = SARSA(representation=Tabular(), step_size=0.5).setup(domain.domain_spec, 0)
        stepper = for_combination(domain, agent, seed=0)
        stepper.advance(30)
        halfway = agent.weights_.copy()
        packed = stepper._loop_arguments()
        assert stepper._loop_arguments() is packed
        if is_replaced:
            agent.reserve_rows(2 * agent.arrays_.weights.shape[0])  # a new form, θ copied
            assert stepper._loop_arguments() is not packed
        stepper.advance(30)
        assert not np.array_equal(agent.weights_, halfway)
        weights.append(agent.weights_.copy())
    np.testing.assert_array_equal(weights[0], weights[1])


def test_a_cached_only_warm_up_compiles_nothing(monkeypatch):
    def refuse(self, num_steps):
        raise AssertionError("a cold compilation was run")

    monkeypatch.setattr(stepper_module, "is_warm", lambda stepper=None: False)
    monkeypatch.setattr(CompiledStepper, "advance", refuse)
    assert warm_up(cached_only=True) == (compile_seconds() or 0.0)
