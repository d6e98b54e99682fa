"""The run loop: the only place a domain meets an agent (STYLE §8).

One stepper, `Stepper`, holds the step order (Algorithm 11, lines 3-8 as an interaction loop);
every caller uses it:

- learning (`run`): ``Stepper(domain, agent, seed=...)``, resumable: ``advance(num_steps)``
  takes exactly that many learning steps, ending and starting episodes as needed, and can stop
  in the middle of an episode (for a policy check, or when the budget runs out) and continue
  it later; `learning_stepper` picks the compiled path when there is one (below);
- policy checks: `greedy_episodes` (the compiled loop's greedy episodes when the learning
  path is compiled, else `run_episode` repeated);
- planners' episodes: `run_episode` (``Stepper(..., learn=False)``, one episode with
  ``play_episode``);
- profiling: `profile_steps` (``Stepper(..., timed=True)``, a timer around every call).

Per step: ``s', r, terminated, truncated, info = domain.step(a)``; ``a' = agent.act(s')``
(skipped on termination, where ``a' = 0``); when learning,
``agent.learn(Transition(s, a, r, s', a', terminated, legal', cost=c))`` with
c = ``info.get("cost", 0)``; the step is a failure when c > 0 (`Domain.is_constrained`); the
episode ends at termination, truncation or the cap ``domain_spec.max_episode_steps``. A
learning episode starts with ``agent.begin_episode()`` after the reset and acts with
exploration; a greedy one does neither.

The compiled path
-----------------
`learning_stepper` asks ``conjure.compiled.for_combination(domain, agent, seed=seed)`` for a
stepper whose ``advance(n)`` runs the n steps in one compiled function (same counters, same
step order, same seeded draws); it answers ``None`` unless the domain, representation and
agent all have compiled kernels, and then (or when ``conjure.compiled`` is absent) the Python
`Stepper` runs. This is the one place the choice is made.

Notes
-----
- Choice: the loop is the library's hot path (target about 20 µs per SARSA + tile-coding step,
  all included), so it binds methods to locals, allocates nothing per step but the
  `Transition` and the observation's copy (below), and never times single steps unless
  ``timed``; throughput is measured around whole ``advance`` calls by `conjure.experiments.run`.
  A timed stepper (`profile_steps`) gives the per-call microseconds of ``step``, ``act`` and
  ``learn`` (STYLE §2) and is slower by the timers.
- Choice: ``domain.legal_actions`` is called only when ``domain_spec.has_action_constraints``;
  otherwise agents receive ``legal_actions=None`` (every action).
- Choice: on truncation (cap or a Gymnasium ``TimeLimit``) the agent still chooses a' for s' so
  that SARSA bootstraps from it; only termination zeroes the target.
- Choice: the loop copies every observation it receives: a domain or wrapper
  may return one buffer overwritten in place, and s must survive ``domain.step`` for the
  `Transition` (and a batch learner's stored samples) to be right.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from typing import Any, NamedTuple

import numpy as np

from conjure.core.errors import InvalidParameterError
from conjure.core.interfaces import Agent, Domain, Transition

__all__ = [
    "BINARY",
    "COMPILED_SHARE",
    "COMPILE_SECONDS",
    "COMPILE_WORTH_STEPS",
    "CURVE_COLUMNS",
    "PYTHON_STEP_SECONDS",
    "REAL_VALUED",
    "EpisodeStats",
    "LearningLoop",
    "Stepper",
    "cold_kernel",
    "compile_pays",
    "compile_seconds_estimate",
    "greedy_episodes",
    "learning_stepper",
    "profile_steps",
    "run_episode",
]

#: The columns of a learning curve, one row per policy check.
CURVE_COLUMNS = (
    "learning_steps",
    "learning_episodes",
    "learning_failures",
    "learning_cost",
    "cost_rate",
    "return",
    "discounted_return",
    "episode_length",
    "failure_rate",
    "episode_cost",
    "optimality",
    "value_ratio",
    "num_features",
    "wall_time_s",
    "steps_per_second",
)


class EpisodeStats(NamedTuple):
    """One episode's return Σ r_t, discounted return Σ γ^t r_t (from t = 0), length and costs.

    ``num_failures`` counts the steps whose ``info["cost"]`` was positive (entering a failure
    state, `Domain.is_constrained`); ``cost`` is Σ_t c_t, the sum of ``info["cost"]``.
    """

    episode_return: float
    discounted_return: float
    num_steps: int
    num_failures: int = 0
    cost: float = 0.0


def _check_cap(max_steps: int | None, domain: Domain) -> int:
    cap = domain.domain_spec.max_episode_steps if max_steps is None else max_steps
    if isinstance(cap, bool) or not isinstance(cap, (int, np.integer)) or cap < 1:
        raise InvalidParameterError(f"`max_steps` must be an int in [1, inf); got {cap!r}.")
    return int(cap)


class Stepper:
    """The interaction loop: resumable, exact step counts, pausable in the middle of an episode.

    Parameters
    ----------
    domain : Domain
        The domain (used only by this stepper: policy checks run on their own domain).
    agent : Agent
        A set-up agent.
    learn : bool, default True
        Learning (``agent.begin_episode`` after each reset, exploring ``act``, ``agent.learn``
        on every transition) or greedy (a policy check: greedy ``act``, nothing learned).
    seed : int or None, default None
        Passed to the first ``domain.reset(seed=...)``; later resets continue its RNG.
    max_episode_steps : int or None, default None
        The episode cap, in [1, inf); ``None`` uses ``domain.domain_spec.max_episode_steps``.
    timed : bool, default False
        Time every ``domain.step``, ``agent.act`` and ``agent.learn`` call (see `timings`).
    path : str, default "python"
        Which path the steps take, as a run records it (`learning_stepper` adds why the
        compiled path was not taken).

    Notes
    -----
    ``domain`` and ``agent`` are read at every ``advance``: assigning a restored agent to
    ``stepper.agent`` continues the same episode with it.

    Attributes
    ----------
    total_steps : int
        Steps taken so far.
    num_episodes : int
        Episodes started so far (the current one included).
    num_completed_episodes : int
        Episodes finished so far.
    num_failures : int
        Steps so far whose ``info["cost"]`` was positive (entering a failure state).
    total_cost : float
        Σ ``info["cost"]`` over the steps so far (the cost while learning).
    is_mid_episode : bool
        Whether the next ``advance`` continues an unfinished episode.
    last_episode : EpisodeStats or None
        The statistics of the last episode that ended.
    timings : dict
        With ``timed``: total seconds in ``step``, ``act`` and ``learn`` and their call counts
        (``step_calls`` ...); empty otherwise.

    Examples
    --------
    >>> from conjure.agents import SARSA
    >>> from conjure.domains import ChainMDP
    >>> from conjure.representations import Tabular
    >>> domain = ChainMDP(num_states=4)
    >>> agent = SARSA(representation=Tabular()).setup(domain.domain_spec, seed=0)
    >>> stepper = Stepper(domain, agent, seed=0)
    >>> stepper.advance(30), stepper.advance(20)
    (30, 50)
    >>> Stepper(domain.clone(), agent, learn=False, seed=1).play_episode().num_steps <= 100
    True
    """

    def __init__(
        self,
        domain: Domain,
        agent: Agent,
        *,
        learn: bool = True,
        seed: int | None = None,
        max_episode_steps: int | None = None,
        timed: bool = False,
        path: str = "python",
    ):
        self.domain = domain
        self.agent = agent
        self.learn = learn
        self.path = path
        self.total_steps = 0
        self.num_episodes = 0
        self.num_failures = 0
        self.total_cost = 0.0
        self.last_episode: EpisodeStats | None = None
        self.timings: dict[str, float] = {}
        self._seed = seed
        self._cap = _check_cap(max_episode_steps, domain)
        self.timed = timed
        self._state: np.ndarray | None = None
        self._action = 0
        # steps, return, discounted return, γ^t, failures, cost of the episode in progress
        self._episode = (0, 0.0, 0.0, 1.0, 0, 0.0)

    @property
    def is_mid_episode(self) -> bool:
        """Whether an episode is in progress."""
        return self._state is not None

    @property
    def num_completed_episodes(self) -> int:
        """Episodes finished so far (the current unfinished one excluded)."""
        return self.num_episodes - int(self.is_mid_episode)

    def advance(self, num_steps: int) -> int:
        """Take exactly ``num_steps`` steps and return ``total_steps``.

        An exception from the agent or domain (e.g. `DivergenceError`) leaves ``total_steps``
        counting the steps completed before the failing one; the episode cannot be continued.
        """
        if isinstance(num_steps, bool) or not isinstance(num_steps, (int, np.integer)):
            raise InvalidParameterError(f"`num_steps` must be an int; got {num_steps!r}.")
        if num_steps < 0:
            raise InvalidParameterError(f"`num_steps` must be >= 0; got {num_steps!r}.")
        self._steps(int(num_steps), stop_at_episode_end=False)
        return self.total_steps

    def play_episode(self) -> EpisodeStats:
        """Step until the current episode (a new one if none is in progress) ends; return it."""
        self._steps(self._cap, stop_at_episode_end=True)
        assert self.last_episode is not None  # an episode ends within the cap
        return self.last_episode

    def _steps(self, num_steps: int, *, stop_at_episode_end: bool) -> None:
        domain, agent, learning = self.domain, self.agent, self.learn
        reset, legal_actions = domain.reset, domain.legal_actions
        begin_episode = agent.begin_episode
        calls = (domain.step, agent.act, agent.learn)
        step, act, learn = self._timed_calls() if self.timed else calls
        is_constrained = domain.domain_spec.has_action_constraints
        discount = float(domain.domain_spec.discount)
        greedy, cap = not learning, self._cap
        state, action = self._state, self._action
        episode_steps, total, discounted, weight, episode_failures, episode_cost = self._episode
        done = failures = 0
        costs = 0.0
        try:
            while done < num_steps:
                if state is None:
                    state = reset(seed=self._seed)[0].copy()
                    self._seed = None
                    self.num_episodes += 1
                    if learning:
                        begin_episode()
                    legal = legal_actions(state) if is_constrained else None
                    action = act(state, greedy, legal)
                    episode_steps, total, discounted, weight = 0, 0.0, 0.0, 1.0
                    episode_failures, episode_cost = 0, 0.0
                next_state, reward, terminated, truncated, info = step(action)
                next_state = next_state.copy()
                episode_steps += 1
                total += reward
                discounted += weight * reward
                weight *= discount
                if terminated:
                    next_action, next_legal = 0, None
                else:
                    next_legal = legal_actions(next_state) if is_constrained else None
                    next_action = act(next_state, greedy, next_legal)
                cost = info.get("cost", 0.0)
                if learning:
                    learn(
                        Transition(
                            state, action, reward, next_state, next_action, terminated, next_legal,
                            False, cost,
                        )
                    )  # fmt: skip
                done += 1
                if cost > 0.0:
                    failures += 1
                    episode_failures += 1
                    costs += cost
                    episode_cost += cost
                if terminated or truncated or episode_steps >= cap:
                    state = None
                    self.last_episode = EpisodeStats(
                        episode_return=float(total),
                        discounted_return=float(discounted),
                        num_steps=episode_steps,
                        num_failures=episode_failures,
                        cost=float(episode_cost),
                    )
                    if stop_at_episode_end:
                        break
                else:
                    state, action = next_state, next_action
        except BaseException:
            state = None  # the failing step is not counted; the episode cannot be continued
            raise
        finally:
            self.total_steps += done
            self.num_failures += failures
            self.total_cost += costs
            self._state, self._action = state, action
            self._episode = (
                episode_steps, total, discounted, weight, episode_failures, episode_cost
            )  # fmt: skip

    def _timed_calls(self) -> tuple[Callable[..., Any], ...]:
        """``domain.step``, ``agent.act`` and ``agent.learn`` adding their time to `timings`."""
        clock, timings = time.perf_counter, self.timings

        def timed(name: str, call: Callable[..., Any]) -> Callable[..., Any]:
            timings.setdefault(f"{name}_s", 0.0)
            timings.setdefault(f"{name}_calls", 0)

            def timed_call(*args: Any) -> Any:
                started = clock()
                out = call(*args)
                timings[f"{name}_s"] += clock() - started
                timings[f"{name}_calls"] += 1
                return out

            return timed_call

        domain, agent = self.domain, self.agent
        return timed("step", domain.step), timed("act", agent.act), timed("learn", agent.learn)


#: The learning stepper under its earlier name (`run` and the benchmarks learn with it).
LearningLoop = Stepper


#: Estimates behind `compile_pays`, measured by ``benchmarks/compile_cost.py`` (in a fresh
#: process with an empty numba cache, on the shipped examples' methods): the loop's cold
#: compile in seconds, by compilation (binary φ, real-valued φ: one function with one type
#: changed, taken equal), the largest measured, rounded up; a compiled step's seconds as a
#: share of the same Python step's (the largest share measured, rounded up); and the Python
#: step a run is assumed to take when its own cost has not been measured (the fastest
#: measured).
COMPILE_SECONDS = {False: 120.0, True: 120.0}
COMPILED_SHARE = 0.17
PYTHON_STEP_SECONDS = 24e-6


def compile_seconds_estimate(real_valued: bool = False) -> float:
    """The expected seconds of a cold compile of the loop (`COMPILE_SECONDS`)."""
    return COMPILE_SECONDS[bool(real_valued)]


def compile_pays(
    steps: int, python_step_seconds: float = PYTHON_STEP_SECONDS, *, real_valued: bool = False
) -> bool:
    """Whether compiling the loop costs less than the Python steps it replaces.

    Choice: compile when ``steps`` Python steps (``python_step_seconds`` each) would take
    longer than the cold compile plus the same steps compiled (`COMPILED_SHARE` of the
    Python step): ``steps · python · (1 - COMPILED_SHARE) > COMPILE_SECONDS``. ``steps`` are
    all the steps that will run on that compilation: a command's warm-up passes all its runs'
    steps and each method's measured Python step (`conjure.experiments.parallel.warm_up`);
    alone, a run weighs its own steps at the fastest Python step measured
    (`PYTHON_STEP_SECONDS`), so a short cold run never waits for a compile it would not earn
    back.
    """
    saved = python_step_seconds * (1.0 - COMPILED_SHARE)
    return saved > 0 and steps * saved > compile_seconds_estimate(real_valued)


#: The steps a run of unmeasured Python cost needs for a cold compile to pay (`compile_pays`
#: at `PYTHON_STEP_SECONDS`).
COMPILE_WORTH_STEPS = (
    math.floor(COMPILE_SECONDS[False] / (PYTHON_STEP_SECONDS * (1.0 - COMPILED_SHARE))) + 1
)

#: The loop's two compilations, as a Python path's reason names a cold one.
BINARY, REAL_VALUED = "binary φ", "real-valued φ"
_COLD = "its kernel is not compiled yet ({kernel})"


def cold_kernel(path: str) -> str | None:
    """The compilation (`BINARY` or `REAL_VALUED`) a run's ``path`` says was cold, or None."""
    for kernel in (BINARY, REAL_VALUED):
        if _COLD.format(kernel=kernel) in path:
            return kernel
    return None


def learning_stepper(
    domain: Domain,
    agent: Agent,
    *,
    seed: int | None = None,
    budget_steps: int = 0,
    python_step_seconds: float = PYTHON_STEP_SECONDS,
) -> Any:
    """Return the stepper a run learns with: compiled when every part has a kernel, else Python.

    The compiled stepper (``conjure.compiled.for_combination(domain, agent, seed=seed)``) has
    the counters and ``advance(n)`` of `Stepper` and takes the same steps with the same draws.
    Choice: it is used when its kernel is warm (compiled in this process or in numba's disk
    cache, ``conjure.compiled.is_warm(stepper)``; each kernel separately) or when the compile
    pays for ``budget_steps`` steps of ``python_step_seconds`` (`compile_pays`); otherwise, or
    when ``for_combination`` answers ``None`` (some part has no kernel), a learning `Stepper`
    runs, its path naming the cold compilation (`cold_kernel`). Choice: `conjure.compiled` is
    imported here, not at the top, so that importing this module does not load numba's
    compiled loop (about 3 s on a loaded machine) before a run needs it.
    """
    from conjure import compiled

    stepper = compiled.for_combination(domain, agent, seed=seed)  # packing only: no compile
    if stepper is None:
        reason = compiled.why_not_compiled(domain, agent)
        return Stepper(domain, agent, seed=seed, path=f"python: {reason}")
    selection = getattr(stepper, "selection", None)
    real_valued = bool(getattr(selection, "is_real_valued", False))
    pays = compile_pays(budget_steps, python_step_seconds, real_valued=real_valued)
    if not pays and not compiled.is_warm(stepper):
        cold = _COLD.format(kernel=REAL_VALUED if real_valued else BINARY)
        reason = (
            f"{cold} and {budget_steps:,} steps would not earn the compile back (about "
            f"{compile_seconds_estimate(real_valued):.0f} s)"
        )
        return Stepper(domain, agent, seed=seed, path=f"python: {reason}")
    return stepper


def run_episode(
    domain: Domain,
    agent: Agent,
    *,
    learn: bool = False,
    max_steps: int | None = None,
    seed: int | None = None,
) -> EpisodeStats:
    """Play one episode of ``agent`` on ``domain``: greedy (a policy check) or learning.

    Parameters
    ----------
    domain : Domain
        The domain; it is reset first (with ``seed`` if given).
    agent : Agent
        A set-up agent. With ``learn=False`` it acts greedily and never learns.
    learn : bool, default False
        Whether to explore and call ``agent.learn`` on each transition (then
        ``agent.begin_episode`` is called after the reset).
    max_steps : int or None, default None
        The episode cap; ``None`` uses ``domain.domain_spec.max_episode_steps``.
    seed : int or None, default None
        Passed to ``domain.reset(seed=...)``.

    Returns
    -------
    EpisodeStats
        The return, the discounted return (γ from the domain spec), the number of steps and
        the number of failures.
    """
    stepper = Stepper(domain, agent, learn=learn, seed=seed, max_episode_steps=max_steps)
    return stepper.play_episode()


def greedy_episodes(
    domain: Domain, agent: Agent, num_episodes: int, *, seed: int | None = None
) -> list[EpisodeStats]:
    """A policy check: ``num_episodes`` greedy episodes, the first from ``reset(seed=seed)``.

    Same episodes as ``[run_episode(domain, agent, seed=seed if k == 0 else None) for k in
    range(num_episodes)]`` (the later resets continue the domain's generator), played by the
    compiled loop's greedy steps when every part has a kernel and the loop is warm (a
    compiled learning run's is), else by that Python loop. Nothing is learned.
    """
    from conjure import compiled

    stepper = compiled.for_combination(domain, agent, seed=seed, learn=False)
    if stepper is None or not compiled.is_warm(stepper):
        return [
            run_episode(domain, agent, seed=seed if k == 0 else None) for k in range(num_episodes)
        ]
    played = stepper.play_episodes(num_episodes)
    return [
        EpisodeStats(
            episode_return=float(total),
            discounted_return=float(discounted),
            num_steps=int(length),
            num_failures=int(failures),
            cost=float(cost),
        )
        for total, discounted, length, failures, cost in zip(
            played.episode_returns,
            played.discounted_returns,
            played.episode_lengths,
            played.episode_failures,
            played.episode_costs,
            strict=True,
        )
    ]


def profile_steps(
    domain: Domain, agent: Agent, *, num_steps: int = 10_000, seed: int | None = None
) -> dict[str, float]:
    """Learn for ``num_steps`` steps, timing each call; return microseconds per call.

    A timed learning `Stepper` (same steps as `run` takes), with a timer around every
    ``domain.step``, ``agent.act`` and ``agent.learn`` call (so slower per call than the real
    loop). ``agent`` must be set up; it learns during profiling.

    Returns
    -------
    dict
        ``step_us``, ``act_us``, ``learn_us`` (mean microseconds per call), ``loop_us`` (the
        rest of each step) and ``steps_per_second`` (whole loop, timers included).
    """
    if isinstance(num_steps, bool) or not isinstance(num_steps, (int, np.integer)) or num_steps < 1:
        raise InvalidParameterError(f"`num_steps` must be an int in [1, inf); got {num_steps!r}.")
    stepper = Stepper(domain, agent, seed=seed, timed=True)
    started = time.perf_counter()
    stepper.advance(num_steps)
    total = time.perf_counter() - started
    t = stepper.timings
    return {
        "step_us": t["step_s"] / num_steps * 1e6,
        "act_us": t["act_s"] / max(t["act_calls"], 1) * 1e6,
        "learn_us": t["learn_s"] / num_steps * 1e6,
        "loop_us": (total - t["step_s"] - t["act_s"] - t["learn_s"]) / num_steps * 1e6,
        "steps_per_second": num_steps / total,
    }
