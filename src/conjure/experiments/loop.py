"""The run loop: the only place a domain meets an agent (STYLE §8).

Two entry points share one step order (Algorithm 11, lines 3-8 as an interaction loop):

- `run_episode` plays one whole episode, greedily for a policy check or learning;
- `LearningLoop` is the resumable learning stepper `run` drives: ``advance(num_steps)`` takes
  exactly that many learning steps, ending and starting episodes as needed, and can stop in the
  middle of an episode (for a policy check, or when the budget runs out) and later continue it.

Per step: ``s', r, terminated, truncated, info = domain.step(a)``; ``a' = agent.act(s')``
(skipped on termination, where ``a' = 0``);
``agent.learn(Transition(s, a, r, s', a', terminated, legal'))``; the step is a failure when
``info.get("cost", 0) > 0`` (`Domain.is_constrained`); the episode ends at termination,
truncation or the cap ``domain_spec.max_episode_steps``.

Notes
-----
- Choice: the loop is the library's hot path (target about 20 µs per SARSA + tile-coding step,
  all included), so it binds methods to locals, allocates nothing per step but the
  `Transition` and the observation's copy (below), and never times single steps;
  throughput is measured around whole ``advance`` calls by `conjure.experiments.run`.
  `profile_steps` gives the per-call microseconds of ``step``, ``act`` and ``learn`` (STYLE
  §2) in a separate, slower loop.
- Choice: ``domain.legal_actions`` is called only when ``domain_spec.has_action_constraints``;
  otherwise agents receive ``legal_actions=None`` (every action).
- Choice: on truncation (cap or a Gymnasium ``TimeLimit``) the agent still chooses a' for s' so
  that SARSA bootstraps from it; only termination zeroes the target.
- Choice: the loop copies every observation it receives (about 0.2 µs): a domain or wrapper
  may return one buffer overwritten in place, and s must survive ``domain.step`` for the
  `Transition` (and a batch learner's stored samples) to be right.
"""

from __future__ import annotations

import time
from typing import NamedTuple

import numpy as np

from conjure.core.errors import InvalidParameterError
from conjure.core.interfaces import Agent, Domain, Transition

__all__ = ["EpisodeStats", "LearningLoop", "profile_steps", "run_episode"]


class EpisodeStats(NamedTuple):
    """One episode's return Σ r_t, discounted return Σ γ^t r_t (from t = 0), length and failures.

    ``num_failures`` counts the steps whose ``info["cost"]`` was positive (entering a failure
    state, `Domain.is_constrained`).
    """

    episode_return: float
    discounted_return: float
    num_steps: int
    num_failures: int = 0


def _check_cap(max_steps: int | None, domain: Domain) -> int:
    cap = domain.domain_spec.max_episode_steps if max_steps is None else max_steps
    if isinstance(cap, bool) or not isinstance(cap, (int, np.integer)) or cap < 1:
        raise InvalidParameterError(f"`max_steps` must be an int in [1, inf); got {cap!r}.")
    return int(cap)


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
    cap = _check_cap(max_steps, domain)
    spec = domain.domain_spec
    discount = float(spec.discount)
    is_constrained = spec.has_action_constraints
    greedy = not learn
    step, act, legal_actions = domain.step, agent.act, domain.legal_actions

    state = domain.reset(seed=seed)[0].copy()
    if learn:
        agent.begin_episode()
    legal = legal_actions(state) if is_constrained else None
    action = act(state, greedy, legal)
    total, discounted, weight, num_steps, num_failures = 0.0, 0.0, 1.0, 0, 0
    while num_steps < cap:
        next_state, reward, terminated, truncated, info = step(action)
        next_state = next_state.copy()
        num_steps += 1
        if info.get("cost", 0.0) > 0.0:
            num_failures += 1
        total += reward
        discounted += weight * reward
        weight *= discount
        if terminated:
            next_action, next_legal = 0, None
        else:
            next_legal = legal_actions(next_state) if is_constrained else None
            next_action = act(next_state, greedy, next_legal)
        if learn:
            agent.learn(
                Transition(state, action, reward, next_state, next_action, terminated, next_legal)
            )
        if terminated or truncated:
            break
        state, action = next_state, next_action
    return EpisodeStats(float(total), float(discounted), num_steps, num_failures)


class LearningLoop:
    """A resumable learning stepper: exact step budgets, pausable in the middle of an episode.

    Parameters
    ----------
    domain : Domain
        The learning domain (used only by this loop, so policy checks never perturb it).
    agent : Agent
        A set-up agent.
    seed : int or None, default None
        Passed to the first ``domain.reset(seed=...)``; later resets continue its RNG.

    Attributes
    ----------
    total_steps : int
        Learning steps taken so far.
    num_episodes : int
        Learning episodes started so far (the current one included).
    num_completed_episodes : int
        Learning episodes finished so far.
    num_failures : int
        Learning steps so far whose ``info["cost"]`` was positive (entering a failure state).
    is_mid_episode : bool
        Whether the next ``advance`` continues an unfinished episode.

    Examples
    --------
    ``loop = LearningLoop(domain, agent, seed=0); loop.advance(1000)`` takes exactly 1000
    learning steps; a second ``loop.advance(500)`` continues where the first stopped.
    """

    def __init__(self, domain: Domain, agent: Agent, *, seed: int | None = None):
        self.domain = domain
        self.agent = agent
        self.total_steps = 0
        self.num_episodes = 0
        self.num_failures = 0
        self._seed = seed
        self._state: np.ndarray | None = None
        self._action = 0
        self._episode_steps = 0
        self._cap = _check_cap(None, domain)

    @property
    def is_mid_episode(self) -> bool:
        """Whether an episode is in progress."""
        return self._state is not None

    @property
    def num_completed_episodes(self) -> int:
        """Learning episodes finished so far (the current unfinished one excluded)."""
        return self.num_episodes - int(self.is_mid_episode)

    def advance(self, num_steps: int) -> int:
        """Take exactly ``num_steps`` learning steps and return ``total_steps``.

        An exception from the agent or domain (e.g. `DivergenceError`) leaves ``total_steps``
        counting the steps completed before the failing one.
        """
        if isinstance(num_steps, bool) or not isinstance(num_steps, (int, np.integer)):
            raise InvalidParameterError(f"`num_steps` must be an int; got {num_steps!r}.")
        if num_steps < 0:
            raise InvalidParameterError(f"`num_steps` must be >= 0; got {num_steps!r}.")
        domain, agent = self.domain, self.agent
        reset, step, legal_actions = domain.reset, domain.step, domain.legal_actions
        begin_episode, act, learn = agent.begin_episode, agent.act, agent.learn
        is_constrained = domain.domain_spec.has_action_constraints
        cap = self._cap
        state, action, episode_steps = self._state, self._action, self._episode_steps
        done = failures = 0
        try:
            while done < num_steps:
                if state is None:
                    state = reset(seed=self._seed)[0].copy()
                    self._seed = None
                    self.num_episodes += 1
                    begin_episode()
                    legal = legal_actions(state) if is_constrained else None
                    action = act(state, False, legal)
                    episode_steps = 0
                next_state, reward, terminated, truncated, info = step(action)
                next_state = next_state.copy()
                episode_steps += 1
                if terminated:
                    next_action, next_legal = 0, None
                else:
                    next_legal = legal_actions(next_state) if is_constrained else None
                    next_action = act(next_state, False, next_legal)
                learn(
                    Transition(
                        state, action, reward, next_state, next_action, terminated, next_legal
                    )
                )
                done += 1
                if info.get("cost", 0.0) > 0.0:
                    failures += 1
                if terminated or truncated or episode_steps >= cap:
                    state = None
                else:
                    state, action = next_state, next_action
        except BaseException:
            # The failing step is not counted; the episode cannot be continued.
            state = None
            raise
        finally:
            self.total_steps += done
            self.num_failures += failures
            self._state, self._action, self._episode_steps = state, action, episode_steps
        return self.total_steps


def profile_steps(
    domain: Domain, agent: Agent, *, num_steps: int = 10_000, seed: int | None = None
) -> dict[str, float]:
    """Learn for ``num_steps`` steps, timing each call; return microseconds per call.

    The same step order as `LearningLoop`, with a timer around every ``domain.step``,
    ``agent.act`` and ``agent.learn`` call (so about 0.2 µs slower per call than the real loop).
    ``agent`` must be set up; it learns during profiling.

    Returns
    -------
    dict
        ``step_us``, ``act_us``, ``learn_us`` (mean microseconds per call), ``loop_us`` (the
        rest of each step) and ``steps_per_second`` (whole loop, timers included).
    """
    if isinstance(num_steps, bool) or not isinstance(num_steps, (int, np.integer)) or num_steps < 1:
        raise InvalidParameterError(f"`num_steps` must be an int in [1, inf); got {num_steps!r}.")
    clock = time.perf_counter
    spec = domain.domain_spec
    is_constrained = spec.has_action_constraints
    cap = spec.max_episode_steps
    step_time = act_time = learn_time = 0.0
    num_acts = 0
    state = None
    action, episode_steps = 0, 0
    started = clock()
    for _ in range(num_steps):
        if state is None:
            state = domain.reset(seed=seed)[0].copy()
            seed = None
            agent.begin_episode()
            legal = domain.legal_actions(state) if is_constrained else None
            t0 = clock()
            action = agent.act(state, False, legal)
            act_time += clock() - t0
            num_acts += 1
            episode_steps = 0
        t0 = clock()
        next_state, reward, terminated, truncated, _ = domain.step(action)
        step_time += clock() - t0
        next_state = next_state.copy()
        episode_steps += 1
        if terminated:
            next_action, next_legal = 0, None
        else:
            next_legal = domain.legal_actions(next_state) if is_constrained else None
            t0 = clock()
            next_action = agent.act(next_state, False, next_legal)
            act_time += clock() - t0
            num_acts += 1
        t0 = clock()
        agent.learn(
            Transition(state, action, reward, next_state, next_action, terminated, next_legal)
        )
        learn_time += clock() - t0
        if terminated or truncated or episode_steps >= cap:
            state = None
        else:
            state, action = next_state, next_action
    total = clock() - started
    return {
        "step_us": step_time / num_steps * 1e6,
        "act_us": act_time / max(num_acts, 1) * 1e6,
        "learn_us": learn_time / num_steps * 1e6,
        "loop_us": (total - step_time - act_time - learn_time) / num_steps * 1e6,
        "steps_per_second": num_steps / total,
    }
