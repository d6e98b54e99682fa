"""Tests of the run loop (the Stepper, run_episode, profile_steps), with tiny fake components.

The fakes defined here (`FakeWalk`, `FakeAgent`) are reused by the other experiments tests.
"""

from __future__ import annotations

import itertools
import re
from typing import Any, ClassVar

import numpy as np
import pytest
from gymnasium import spaces

import conjure
from conjure.core.errors import DivergenceError, InvalidParameterError
from conjure.core.interfaces import Agent, Domain, DomainSpec, Transition
from conjure.core.params import InstanceOf, Interval
from conjure.core.seeding import make_rng
from conjure.experiments.loop import (
    BINARY,
    COMPILE_WORTH_STEPS,
    PYTHON_STEP_SECONDS,
    LearningLoop,
    Stepper,
    cold_kernel,
    compile_pays,
    learning_stepper,
    profile_steps,
    run_episode,
)


class FakeWalk(Domain):
    """Walk on 0..length; action 1 moves right, 0 left; reaching ``length`` terminates.

    The start state (0, 1 or 2) is drawn from ``np_random``; reward -1 per step. With
    ``wall_cost`` every step that ends at 0 is a failure (``info["cost"] = 1``); ``bounds`` is
    what ``value_bounds`` returns.
    """

    parameter_constraints: ClassVar = {"length": Interval(int, 1, None)}

    def __init__(
        self,
        *,
        length: int = 5,
        max_episode_steps: int = 50,
        has_action_constraints: bool = False,
        truncate_at: int | None = None,
        wall_cost: bool = False,
        bounds: tuple[float, float] | None = None,
    ):
        self.wall_cost = wall_cost
        self.bounds = bounds
        self.length = length
        self.max_episode_steps = max_episode_steps
        self.has_action_constraints = has_action_constraints
        self.truncate_at = truncate_at
        self.observation_space = spaces.Box(0.0, float(length), shape=(1,), dtype=np.float64)
        self.action_space = spaces.Discrete(2)
        self.domain_spec = DomainSpec(
            name="FakeWalk",
            low=[0.0],
            high=[float(length)],
            is_discrete=[True],
            num_actions=2,
            discount=0.9,
            max_episode_steps=max_episode_steps,
            has_action_constraints=has_action_constraints,
        )
        self.num_legal_calls = 0

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        super().reset(seed=seed)
        self._x = int(self.np_random.integers(3)) if self.length > 3 else 0
        self._t = 0
        return np.array([float(self._x)]), {}

    def step(self, action: int):
        self._x = min(self.length, self._x + 1) if action == 1 else max(0, self._x - 1)
        self._t += 1
        terminated = self._x == self.length
        truncated = self.truncate_at is not None and self._t >= self.truncate_at
        info = {"cost": float(self._x == 0)} if self.wall_cost else {}
        return np.array([float(self._x)]), -1.0, terminated, truncated, info

    def value_bounds(self) -> tuple[float, float] | None:
        return self.bounds

    def legal_actions(self, state: np.ndarray) -> np.ndarray:
        self.num_legal_calls += 1
        if state[0] == 0:
            return np.array([1], dtype=np.int64)
        return np.array([0, 1], dtype=np.int64)


class FakeAgent(Agent):
    """Explores uniformly with its own RNG, acts 'right' greedily, records what it sees."""

    parameter_constraints: ClassVar = {
        "step_size": Interval(float, 0.0, 1.0, closed="right"),
        "diverge_at": Interval(int, 1, None) | InstanceOf(type(None)),
    }

    def __init__(
        self,
        *,
        step_size: float = 0.5,
        diverge_at: int | None = None,
        fail_in_setup: bool = False,
        greedy_action: int = 1,
    ):
        self.step_size = step_size
        self.diverge_at = diverge_at
        self.fail_in_setup = fail_in_setup
        self.greedy_action = greedy_action

    def setup(self, spec: DomainSpec, seed: Any) -> FakeAgent:
        self.validate_params()
        if self.fail_in_setup:
            raise RuntimeError("fake setup failure")
        self.rng_ = make_rng(seed)
        self.num_actions_ = spec.num_actions
        self.transitions_: list[Transition] = []
        self.events_: list[str] = []
        self.steps_at_check_: list[int] = []
        self.value_ = 0.0
        self.num_greedy_acts_ = 0
        return self

    def begin_episode(self) -> None:
        self.events_.append("begin")

    def before_policy_check(self) -> None:
        self.events_.append("check")
        self.steps_at_check_.append(len(self.transitions_))

    def act(self, state, greedy=False, legal_actions=None) -> int:
        if greedy:
            self.num_greedy_acts_ += 1
            return self.greedy_action
        legal = np.arange(self.num_actions_) if legal_actions is None else legal_actions
        return int(legal[self.rng_.integers(len(legal))])

    def learn(self, transition: Transition) -> float:
        self.transitions_.append(transition)
        if self.diverge_at is not None and len(self.transitions_) >= self.diverge_at:
            raise DivergenceError("fake TD error is nan")
        td_error = transition.reward - self.value_
        self.value_ += self.step_size * td_error
        return td_error

    @property
    def num_features(self) -> int:
        return 1 + len(self.transitions_) // 100


def make_agent(spec: DomainSpec, seed: int = 0, **params: Any) -> FakeAgent:
    return FakeAgent(**params).setup(spec, seed)


# ---------------------------------------------------------------------------------------------


def test_greedy_episode_stops_at_termination_with_returns():
    domain = FakeWalk(length=5)
    agent = make_agent(domain.domain_spec)
    stats = run_episode(domain, agent, seed=0)
    start = 5 - stats.num_steps
    assert 0 <= start <= 2
    assert stats.episode_return == -stats.num_steps
    expected = -sum(0.9**t for t in range(stats.num_steps))
    assert stats.discounted_return == pytest.approx(expected)
    assert agent.transitions_ == []  # a policy check never learns


def test_episode_stops_at_the_cap():
    domain = FakeWalk(length=5, max_episode_steps=7)
    agent = make_agent(domain.domain_spec, greedy_action=0)  # walks left forever
    assert run_episode(domain, agent, seed=0).num_steps == 7
    assert run_episode(domain, agent, seed=0, max_steps=3).num_steps == 3


def test_episode_stops_at_truncation():
    domain = FakeWalk(length=5, truncate_at=2)
    agent = make_agent(domain.domain_spec, greedy_action=0)
    assert run_episode(domain, agent, seed=0).num_steps == 2


def test_learning_episode_calls_begin_episode_and_learns_each_step():
    domain = FakeWalk(length=5, max_episode_steps=20)
    agent = make_agent(domain.domain_spec)
    stats = run_episode(domain, agent, learn=True, seed=1)
    assert agent.events_ == ["begin"]
    assert len(agent.transitions_) == stats.num_steps
    last = agent.transitions_[-1]
    if last.terminated:
        assert last.next_action == 0


def test_transitions_chain_state_and_action():
    domain = FakeWalk(length=5, max_episode_steps=20)
    agent = make_agent(domain.domain_spec)
    loop = LearningLoop(domain, agent, seed=3)
    loop.advance(200)
    transitions = agent.transitions_
    for before, after in itertools.pairwise(transitions):
        if not before.terminated and before.next_state[0] == after.state[0]:
            assert after.action == before.next_action


def test_learning_budget_is_exact_and_resumable():
    domain = FakeWalk(length=5, max_episode_steps=6)
    agent = make_agent(domain.domain_spec)
    loop = LearningLoop(domain, agent, seed=0)
    assert loop.advance(0) == 0
    assert loop.advance(37) == 37
    assert loop.advance(5) == 42
    assert len(agent.transitions_) == 42
    assert loop.num_episodes == agent.events_.count("begin")


def test_pausing_mid_episode_changes_nothing():
    def trajectory(chunks: list[int]) -> list[tuple]:
        domain = FakeWalk(length=6, max_episode_steps=9)
        agent = make_agent(domain.domain_spec, seed=11)
        loop = LearningLoop(domain, agent, seed=5)
        for chunk in chunks:
            loop.advance(chunk)
            assert loop.total_steps <= sum(chunks)
        return [
            (float(t.state[0]), t.action, t.next_action, t.terminated) for t in agent.transitions_
        ]

    straight = trajectory([100])
    assert trajectory([1, 2, 3, 94]) == straight
    assert trajectory([33, 33, 34]) == straight


def test_episode_ends_and_restarts_at_the_cap():
    domain = FakeWalk(length=50, max_episode_steps=4)
    agent = make_agent(domain.domain_spec, seed=0)
    loop = LearningLoop(domain, agent, seed=0)
    loop.advance(10)
    assert loop.num_episodes == 3
    assert loop.num_completed_episodes == 2
    assert loop.is_mid_episode


def test_legal_actions_only_when_constrained():
    free = FakeWalk(length=5)
    agent = make_agent(free.domain_spec)
    LearningLoop(free, agent, seed=0).advance(50)
    assert free.num_legal_calls == 0
    assert all(t.next_legal_actions is None for t in agent.transitions_)

    constrained = FakeWalk(length=5, has_action_constraints=True)
    agent = make_agent(constrained.domain_spec)
    LearningLoop(constrained, agent, seed=0).advance(200)
    assert constrained.num_legal_calls > 0
    for t in agent.transitions_:
        if t.state[0] == 0:
            assert t.action == 1  # only the legal action is ever taken in state 0
        if not t.terminated:
            assert t.next_legal_actions is not None


def test_divergence_leaves_a_consistent_step_count():
    domain = FakeWalk(length=5)
    agent = make_agent(domain.domain_spec, diverge_at=13)
    loop = LearningLoop(domain, agent, seed=0)
    with pytest.raises(DivergenceError):
        loop.advance(100)
    assert loop.total_steps == 12


def test_bad_step_counts_are_rejected():
    domain = FakeWalk()
    loop = LearningLoop(domain, make_agent(domain.domain_spec), seed=0)
    with pytest.raises(InvalidParameterError):
        loop.advance(-1)
    with pytest.raises(InvalidParameterError):
        loop.advance(2.5)  # type: ignore[arg-type]


def test_profile_steps_reports_per_call_times_and_learns():
    domain = FakeWalk(length=5)
    agent = make_agent(domain.domain_spec)
    timings = profile_steps(domain, agent, num_steps=300, seed=0)
    assert set(timings) == {"step_us", "act_us", "learn_us", "loop_us", "steps_per_second"}
    assert all(timings[k] > 0 for k in ("step_us", "act_us", "learn_us", "steps_per_second"))
    assert len(agent.transitions_) == 300
    with pytest.raises(InvalidParameterError):
        profile_steps(domain, agent, num_steps=0)


def test_a_domain_that_reuses_its_observation_buffer_gives_correct_transitions():
    # The loop keeps s across domain.step; a domain writing every observation into one
    # buffer must not turn ⟨s, a, r, s'⟩ into ⟨s', a, r, s'⟩ (nor reach a learner's cache).
    from conjure.agents import SARSA
    from conjure.domains import ChainMDP
    from conjure.representations import Tabular
    from conjure.testing.fakes import SharedObservationBuffer

    chain = ChainMDP(num_states=4)
    domain = SharedObservationBuffer(domain=ChainMDP(num_states=4))
    agent = SARSA(representation=Tabular(), step_size=0.5).setup(domain.domain_spec, seed=0)
    LearningLoop(domain, agent, seed=0).advance(300)
    values = [agent.q_values(np.array([float(s)]))[0] for s in range(4)]
    np.testing.assert_allclose(values, chain.optimal_values(), atol=1e-6)

    recorder = make_agent(domain.domain_spec)
    LearningLoop(domain, recorder, seed=0).advance(6)
    assert [t.state[0] for t in recorder.transitions_] == [0, 1, 2, 0, 1, 2]
    assert [t.next_state[0] for t in recorder.transitions_] == [1, 2, 3, 1, 2, 3]
    stats_domain = SharedObservationBuffer(domain=ChainMDP(num_states=4))
    assert run_episode(stats_domain, recorder, learn=True, seed=0).num_steps == 3
    assert [t.state[0] for t in recorder.transitions_[-3:]] == [0, 1, 2]


def test_episode_stats_count_failure_steps():
    domain = FakeWalk(length=5, max_episode_steps=6, wall_cost=True)
    left = make_agent(domain.domain_spec, greedy_action=0)
    stats = run_episode(domain, left, seed=0)
    start = int(domain.reset(seed=0)[0][0])
    assert stats.num_steps == 6 and stats.num_failures == 6 - max(start - 1, 0)
    assert run_episode(domain, make_agent(domain.domain_spec), seed=0).num_failures == 0


def test_learning_loop_counts_failures_of_the_steps_it_took():
    domain = FakeWalk(length=5, max_episode_steps=8, wall_cost=True)
    agent = make_agent(domain.domain_spec)
    loop = LearningLoop(domain, agent, seed=2)
    loop.advance(150)
    at_wall = sum(t.next_state[0] == 0 for t in agent.transitions_)
    assert at_wall > 10 and loop.num_failures == at_wall
    loop.advance(50)
    assert loop.num_failures == sum(t.next_state[0] == 0 for t in agent.transitions_)


@pytest.mark.parametrize(
    ("warm", "budget_steps", "python_step_seconds", "is_compiled"),
    [
        (True, 0, PYTHON_STEP_SECONDS, True),
        (False, COMPILE_WORTH_STEPS, PYTHON_STEP_SECONDS, True),
        (False, COMPILE_WORTH_STEPS - 1, PYTHON_STEP_SECONDS, False),
        # a slow Python step (measured by a command's warm-up) pays for a compile sooner
        (False, COMPILE_WORTH_STEPS // 10, 20 * PYTHON_STEP_SECONDS, True),
    ],
)
def test_learning_stepper_uses_the_compiled_path_only_when_worth_it_and_answered(
    monkeypatch, warm, budget_steps, python_step_seconds, is_compiled
):
    import sys
    import types

    domain = FakeWalk(length=5)
    agent = make_agent(domain.domain_spec)
    asked = []
    compiled = types.ModuleType("conjure.compiled")

    def for_combination(d, a, *, seed=None):
        asked.append((d, a, seed))
        return "compiled stepper" if len(asked) == 1 else None

    compiled.for_combination = for_combination
    compiled.why_not_compiled = lambda d, a: "no kernel in this fake"
    warmth_asked = []
    compiled.is_warm = lambda stepper: warmth_asked.append(stepper) or warm
    monkeypatch.setitem(sys.modules, "conjure.compiled", compiled)
    monkeypatch.setattr(conjure, "compiled", compiled, raising=False)  # `from conjure import`
    options = {"seed": 4, "budget_steps": budget_steps, "python_step_seconds": python_step_seconds}
    first = learning_stepper(domain, agent, **options)
    fallback = learning_stepper(domain, agent, **options)
    assert type(fallback) is Stepper and fallback.learn
    assert fallback.path == "python: no kernel in this fake"
    assert asked == [(domain, agent, 4)] * 2
    assert (first == "compiled stepper") is is_compiled
    # the warmth asked about is that of the stepper's own kernel, and only when a compile
    # would not pay
    pays = compile_pays(budget_steps, python_step_seconds)
    assert warmth_asked == ([] if pays else ["compiled stepper"])
    if not is_compiled:
        assert cold_kernel(first.path) == BINARY  # the warm-up reads which compilation


def test_a_compile_pays_when_the_python_steps_outlast_it(monkeypatch):
    from conjure.experiments import loop

    monkeypatch.setattr(loop, "COMPILE_SECONDS", {False: 30.0, True: 60.0})
    monkeypatch.setattr(loop, "COMPILED_SHARE", 0.5)
    # 10⁶ steps save half their Python time: 20 s at 40 µs, 40 s at 80 µs
    assert not compile_pays(10**6, 40e-6)
    assert compile_pays(10**6, 80e-6)
    assert not compile_pays(10**6, 80e-6, real_valued=True)  # its compilation costs 60 s
    assert compile_pays(2 * 10**6, 80e-6, real_valued=True)
    monkeypatch.setattr(loop, "COMPILED_SHARE", 1.0)
    assert not compile_pays(10**12, 1.0)  # a compiled step no faster never pays
    assert cold_kernel("compiled") is None and cold_kernel("python: no kernel") is None


def test_greedy_and_timed_steppers_take_the_learning_steppers_steps():
    # One step order: a greedy stepper's episode equals run_episode's, and a timed learning
    # stepper learns exactly what an untimed one does from the same seeds.
    domain = FakeWalk(length=6, max_episode_steps=9)
    agent = make_agent(domain.domain_spec)
    episode = Stepper(domain, agent, learn=False, seed=5).play_episode()
    assert episode == run_episode(domain, agent, seed=5)
    results = []
    for timed in (False, True):
        d = FakeWalk(length=6, max_episode_steps=9)
        a = make_agent(d.domain_spec, seed=2)
        stepper = Stepper(d, a, seed=1, timed=timed)
        stepper.advance(40)
        actions = [(t.action, t.reward, t.terminated) for t in a.transitions_]
        results.append((actions, a.events_, stepper.num_episodes, stepper.last_episode))
    assert results[0] == results[1]
    assert stepper.timings["step_calls"] == stepper.timings["learn_calls"] == 40


class BudgetWatcher(FakeAgent):
    """A `FakeAgent` that observes the episode's cost (`Agent.observes_budget`) and logs calls."""

    observes_budget = True

    def setup(self, spec: DomainSpec, seed: Any) -> BudgetWatcher:
        super().setup(spec, seed)
        self.calls_: list[tuple] = []
        return self

    def begin_episode(self) -> None:
        super().begin_episode()
        self.calls_.append(("begin",))

    def observe_episode_cost(self, spent: float, greedy: bool = False) -> None:
        self.calls_.append(("observe", spent, greedy))

    def act(self, state, greedy=False, legal_actions=None) -> int:
        self.calls_.append(("act", float(state[0]), greedy))
        return super().act(state, greedy, legal_actions)

    def learn(self, transition: Transition) -> float:
        self.calls_.append(("learn", transition.cost))
        return super().learn(transition)


def test_an_agent_that_observes_the_budget_is_told_the_cost_so_far_before_every_act():
    domain = FakeWalk(length=5, max_episode_steps=4, wall_cost=True)
    start = int(domain.reset(seed=0)[0][0])
    agent = BudgetWatcher(greedy_action=0).setup(domain.domain_spec, 0)  # greedy: always left
    run_episode(domain, agent, seed=0)
    # x_k = max(0, start − k); entering or staying at 0 costs 1; the cap ends after 4 steps,
    # and a' is still chosen for the last s' (a truncation).
    xs = [max(0, start - k) for k in range(5)]
    spent = np.cumsum([0.0] + [float(x == 0) for x in xs[1:]]).tolist()
    expected = [
        call
        for x, cost in zip(xs, spent, strict=True)
        for call in (("observe", cost, True), ("act", x, True))
    ]
    assert agent.calls_ == expected
    # Learning: after begin the cost so far before every act, each step's learn after the
    # act of its s' (so the observe before act(s') counts the step's cost already).
    learner = BudgetWatcher().setup(domain.domain_spec, 1)
    LearningLoop(domain, learner, seed=3).advance(60)
    letters = {"begin": "B", "observe": "O", "act": "A", "learn": "L"}
    kinds = "".join(letters[call[0]] for call in learner.calls_)
    assert re.fullmatch(r"(BOA(OAL)*L?)+", kinds) and kinds.count("L") == 60
    episodes = kinds.count("B")
    assert episodes > 5
    for episode in re.finditer(r"B[^B]*", kinds):
        calls = learner.calls_[episode.start() : episode.end()]
        costs = [call[1] for call in calls if call[0] == "learn"]
        told = [call[1:] for call in calls if call[0] == "observe"]
        assert told == [(float(spent), False) for spent in np.cumsum([0.0, *costs])[: len(told)]]
    assert sum(call[1] for call in learner.calls_ if call[0] == "learn") > 0
    # An agent that does not observe the budget is never told it.
    silent = BudgetWatcher().set_params(greedy_action=1).setup(domain.domain_spec, 0)
    silent.observes_budget = False
    LearningLoop(domain, silent, seed=3).advance(10)
    assert all(call[0] != "observe" for call in silent.calls_)
