"""The compiled learning stepper: ``advance(n)`` runs n learning steps in one numba call.

`for_combination` returns a `CompiledStepper` when the domain, representation, agent, policy
and step-size schedule all have compiled kernels (see `conjure.compiled.combination`), and
``None`` otherwise, so that the caller keeps the Python path. The stepper is a drop-in for
`conjure.experiments.loop.LearningLoop` (same counters, same pausable episodes) whose
``advance`` also returns the episodes that ended.

Notes
-----
- The same seed gives the same learning curve on both paths: the kernel runs the step order of
  `LearningLoop` (reset, begin episode, a = π(s); s', r = step(a); a' = π(s') unless
  terminal; TD update of Algorithms 10-12), calls the same kernels and draws from the same
  `numpy.random.Generator` objects (the domain's ``np_random`` and the agent's ``rng_``; numba
  shares their state), one uniform per action choice and the domain's own draws per step.
- Choice: the first reset of a stepper runs in Python (``domain.reset(seed=seed)``, which seeds
  the domain's generator); later resets run in the kernel with the same draws.
- Choice: the learner's θ, traces and tile hash table are updated in place, and the episode
  counter, the learning-step counter and the domain's state are written back after every
  ``advance``, so policy checks, `Agent.save` and the Python path see the same objects.
- Choice: a learner's act/learn cache is dropped after every ``advance`` (θ changed under it).
- Choice (with `OnlineIFDD`): the representation's tables are its own arrays, updated in
  place; when a discovery would not fit, the kernel returns, the representation grows them
  with its own method and the kernel continues. θ (and Actor-Critic's ω, SARSA(λ)'s
  ``trace_slots_``) is passed with as many rows as the representation can hold features (a
  buffer that `append_rows` keeps using) and set to its first n_t rows after every call, as
  the Python learner's `grow_weights` / ``append_rows`` would leave it.
- Choice: ``advance`` calls the kernel for at most `MAX_KERNEL_STEPS` steps at a time (the
  kernel's pausable episodes make the split invisible in the results), so Ctrl-C, which
  Python only sees between compiled calls, stops a run within about a second.
- Compilation: two kernels, ``advance_kernel`` (fixed features, every action legal) and
  ``adaptive_kernel`` (legal actions or growing features); each serves all its combinations
  (the arguments have the same types), is compiled once per machine and cached on disk;
  `compile_seconds` reports the first calls' cost in this process. ``advance_kernel`` has
  one more compilation for real-valued φ (`RBF`: its representation tuple carries the
  Gaussians' arrays instead of None), so binary φ never pays for reading values.
"""

from __future__ import annotations

import time
from typing import NamedTuple

import numpy as np
from numba.core import types

from conjure.compiled import _adaptive_kernel as ak
from conjure.compiled import _kernels as k
from conjure.compiled.combination import (
    EMPTY_FLOATS,
    EMPTY_INT_TABLE,
    EMPTY_INTS,
    Combination,
    pack_combination,
)
from conjure.core.errors import DivergenceError, InvalidParameterError
from conjure.core.interfaces import Agent, Domain
from conjure.representations._ifdd_kernels import empty_tables
from conjure.representations.weights import _is_leading_view

__all__ = [
    "AdvanceStats",
    "CompiledStepper",
    "compile_seconds",
    "for_combination",
    "is_warm",
    "warm_up",
]

#: Steps per kernel call at most: a fraction of a second on the fast combinations, a few
#: seconds on the slowest (online iFDD on the UAV missions, about 10⁵ steps/s).
MAX_KERNEL_STEPS = 2**18
#: The first call's seconds (compile or cache load) of each kernel, by `_kernel_name`.
_COMPILE_SECONDS: dict[str, float] = {}
#: Position of the representation tuple among ``advance_kernel``'s arguments.
_REP_ARGUMENT = 8


class AdvanceStats(NamedTuple):
    """What one ``advance`` did: steps, failures and the learning episodes that ended.

    The four arrays have one entry per learning episode that ended during the call, in order
    (an episode begun in an earlier call counts its earlier steps too), like
    `conjure.experiments.loop.EpisodeStats`: the return Σ r_t, the discounted return
    Σ γ^t r_t, the length and the number of failure steps (``info["cost"] > 0``).
    """

    num_steps: int
    num_failures: int
    episode_returns: np.ndarray
    discounted_returns: np.ndarray
    episode_lengths: np.ndarray
    episode_failures: np.ndarray


class CompiledStepper:
    """A resumable learning stepper whose steps run inside one compiled function.

    Build it with `for_combination`. Counters and pausing behave as in
    `conjure.experiments.loop.LearningLoop`: ``advance(n)`` takes exactly n learning steps,
    ending and starting episodes as needed, and may stop in the middle of an episode.

    Parameters
    ----------
    domain : Domain
        The learning domain.
    agent : Agent
        The set-up learner.
    combination : Combination
        Its packed constants (`conjure.compiled.combination.pack_combination`).
    seed : int or None, default None
        Passed to the first ``domain.reset(seed=...)``.

    Attributes
    ----------
    total_steps, num_episodes, num_failures : int
        Learning steps, episodes started and failure steps so far.
    path : str
        ``"compiled"``: the path a run records (`conjure.experiments.loop.Stepper` says
        ``"python: <why>"``).
    """

    path = "compiled"

    def __init__(
        self, domain: Domain, agent: Agent, combination: Combination, *, seed: int | None = None
    ):
        self.domain = domain
        self.agent = agent
        self.combination = combination
        self.total_steps = 0
        self.num_episodes = 0
        self.num_failures = 0
        self._seed = seed
        self._started = False
        spec = domain.domain_spec
        self._obs = np.zeros(spec.num_dims)
        self._loop = np.zeros(6, dtype=np.int64)
        self._loop_f = np.zeros(3)

    @property
    def is_mid_episode(self) -> bool:
        """Whether an episode is in progress."""
        return bool(self._loop[k.L_PHASE] == k.IN_EPISODE)

    @property
    def num_completed_episodes(self) -> int:
        """Learning episodes finished so far (the current unfinished one excluded)."""
        return self.num_episodes - int(self.is_mid_episode)

    def advance(self, num_steps: int) -> AdvanceStats:
        """Take exactly ``num_steps`` learning steps in compiled code; see `AdvanceStats`.

        Raises
        ------
        DivergenceError
            When δ stops being finite (as the Python learners); the failing step is not
            counted and the episode cannot be continued.
        """
        if isinstance(num_steps, bool) or not isinstance(num_steps, (int, np.integer)):
            raise InvalidParameterError(f"`num_steps` must be an int; got {num_steps!r}.")
        if num_steps < 0:
            raise InvalidParameterError(f"`num_steps` must be >= 0; got {num_steps!r}.")
        combo, domain, agent, loop = self.combination, self.domain, self.agent, self._loop
        if not self._started and num_steps > 0:
            self._obs[:] = domain.reset(seed=self._seed)[0]
            self._started = True
            loop[k.L_PHASE] = k.NEEDS_BEGIN
        dstate = combo.read_domain(domain)
        loop[k.L_EPISODE] = agent.episode_
        loop[k.L_LEARNING_STEPS] = agent.num_learning_steps_
        chunks: list[tuple[np.ndarray, np.ndarray]] = []
        done = failures = 0
        diverged: float | None = None
        try:
            while done < num_steps:
                before = int(loop[k.L_EPISODE])
                status, steps, fails, delta, ep_float, ep_int = _call_kernel(
                    min(num_steps - done, MAX_KERNEL_STEPS),
                    combo,
                    dstate,
                    domain,
                    agent,
                    self._obs,
                    loop,
                    self._loop_f,
                )
                self.num_episodes += int(loop[k.L_EPISODE]) - before
                done += steps
                failures += fails
                chunks.append((ep_float, ep_int))
                if status == k.GROW_TRACES:
                    agent._grow_trace_capacity()
                elif combo.is_adaptive and status == ak.GROW_REPRESENTATION:
                    agent.representation_.grow_tables()
                elif status == k.DIVERGED:
                    diverged = delta
                    break
        finally:
            combo.write_domain(domain, dstate)
            agent.episode_ = int(loop[k.L_EPISODE])
            agent.num_learning_steps_ = int(loop[k.L_LEARNING_STEPS])
            agent._forget_cache()
            self.total_steps += done
            self.num_failures += failures
        if diverged is not None:
            raise _divergence(agent, diverged)
        ep_float = np.concatenate([c[0] for c in chunks]) if chunks else np.zeros((0, 2))
        ep_int = np.concatenate([c[1] for c in chunks]) if chunks else np.zeros((0, 2), np.int64)
        return AdvanceStats(
            done, failures, ep_float[:, 0], ep_float[:, 1], ep_int[:, 0], ep_int[:, 1]
        )


def _call_kernel(
    num_steps: int,
    combo: Combination,
    dstate: np.ndarray,
    domain: Domain,
    agent: Agent,
    obs: np.ndarray,
    loop: np.ndarray,
    loop_f: np.ndarray,
) -> tuple:
    """One call of the combination's kernel with the agent's current arrays (they may grow)."""
    if combo.is_adaptive:
        kernel, buffers, middle = ak.adaptive_kernel, *_adaptive_arguments(combo, agent)
        states = (EMPTY_INTS, dstate) if dstate.dtype == np.float64 else (dstate, EMPTY_FLOATS)
        middle = (*combo.domain_arrays, *states, domain.np_random, *middle)
    else:
        kernel, buffers, middle = k.advance_kernel, None, _fixed_arguments(combo, agent)
        middle = (*combo.domain_arrays, dstate, domain.np_random, *middle)
    args = (combo.ints, combo.floats, *middle, agent.rng_, obs, loop, loop_f)
    name = _kernel_name(combo)
    if name not in _COMPILE_SECONDS:  # a zero-step call: compile (or load the cache) alone
        started = time.perf_counter()
        kernel(0, *args)
        _COMPILE_SECONDS[name] = time.perf_counter() - started
    try:
        return kernel(num_steps, *args)
    finally:
        if buffers is not None:  # θ, ω, slots: the first n_t rows of the buffers it grew
            weights, actor, slots = buffers
            rep = agent.representation_
            agent.weights_ = weights[: rep.num_features_]
            if actor is not weights:
                agent.actor_weights_ = actor[: rep.num_features_]
            if slots is not None:
                agent.trace_slots_ = slots[: rep.num_features_]


def _is_real_valued(combo: Combination) -> bool:
    """Whether φ has real values (`RBF`): ``advance_kernel``'s second compilation."""
    return not combo.is_adaptive and combo.representation_arrays[-1] is not None


def _kernel_name(combo: Combination) -> str:
    """The kernel compilation ``combo`` runs in (the `_COMPILE_SECONDS` key)."""
    if combo.is_adaptive:
        return ak.adaptive_kernel.__name__
    return k.advance_kernel.__name__ + ("[real-valued]" if _is_real_valued(combo) else "")


def _fixed_arguments(combo: Combination, agent: Agent) -> tuple:
    """``advance_kernel``'s representation, weight and trace arguments."""
    return (
        combo.representation_arrays,
        agent.weights_,
        _actor(combo, agent),
        *_traces(combo, agent),
    )


def _actor(combo: Combination, agent: Agent) -> np.ndarray:
    """Actor-Critic's ω, or θ for the other learners (the kernels' ``actor_weights``)."""
    return agent.actor_weights_ if combo.ints[k.I_AGENT] == k.ACTOR_CRITIC else agent.weights_


def _traces(combo: Combination, agent: Agent, slots: np.ndarray | None = None) -> tuple:
    """The sparse trace arguments (``slots`` replaces ``trace_slots_``), or stand-ins."""
    if combo.ints[k.I_TRACES] == k.NO_TRACES:
        return (EMPTY_INT_TABLE, EMPTY_INTS, EMPTY_INTS, EMPTY_FLOATS, EMPTY_INTS)
    return (
        agent.trace_slots_ if slots is None else slots,
        agent.trace_features_,
        agent.trace_actions_,
        agent.trace_values_,
        agent.trace_count_,
    )


def _adaptive_arguments(combo: Combination, agent: Agent) -> tuple:
    """(buffers if iFDD may grow them else None, ``adaptive_kernel``'s tables).

    The buffers (θ, ω, trace slots; ω is θ itself but for Actor-Critic) get room for every
    feature the iFDD tables can hold, so no discovery outgrows them.
    """
    base = combo.representation_arrays
    if not combo.ints[k.I_IFDD]:
        weights = (agent.weights_, _actor(combo, agent))
        # a stand-in of the iFDD tables (same type): both run in one compilation
        return None, (base, empty_tables(), *weights, *_traces(combo, agent))
    rep = agent.representation_
    capacity = rep.feature_capacity_  # the most features its tables hold
    weights = _row_buffer(agent.weights_, capacity)
    actor = _actor(combo, agent)
    actor = weights if actor is agent.weights_ else _row_buffer(actor, capacity)
    has_traces = combo.ints[k.I_TRACES] != k.NO_TRACES
    slots = _row_buffer(agent.trace_slots_, capacity) if has_traces else None
    traces = _traces(combo, agent, slots)
    tables = (rep.kernel_tables(), weights, actor, *traces)
    return (weights, actor, slots), (base, *tables)


def _row_buffer(array: np.ndarray, rows: int) -> np.ndarray:
    """``array`` or the buffer it leads (`append_rows`) if it has ``rows`` rows, else a copy."""
    if array.shape[0] >= rows and array.flags.c_contiguous:
        return array
    if _is_leading_view(array) and array.base.shape[0] >= rows:
        return array.base
    buffer = np.empty((max(rows, 2 * array.shape[0]), *array.shape[1:]), dtype=array.dtype)
    buffer[: array.shape[0]] = array
    return buffer


def _divergence(agent: Agent, delta: float) -> DivergenceError:
    return DivergenceError(
        f"{type(agent).__name__}: the TD error became {delta} at learning step "
        f"{agent.num_learning_steps_}; the weights diverged. Lower the step size "
        f"(now {agent.step_size!r}) or use a feature-normalised schedule."
    )


def compile_seconds() -> float | None:
    """Seconds the kernels' first calls in this process took (compile or cache load), or None."""
    return sum(_COMPILE_SECONDS.values()) if _COMPILE_SECONDS else None


def is_warm(stepper: CompiledStepper | None = None) -> bool:
    """Whether ``stepper``'s kernel (default ``advance_kernel``, binary φ) runs without compiling.

    Warm means called in this process or found in numba's on-disk cache (for
    ``advance_kernel``, the compilation of ``stepper``'s binary or real-valued φ). Reads
    numba's cache index (a private numba API); if that API changes the kernel is treated as
    cold, which only costs speed.
    """
    combo = None if stepper is None else stepper.combination
    is_adaptive = combo is not None and combo.is_adaptive
    kernel = ak.adaptive_kernel if is_adaptive else k.advance_kernel
    name = kernel.__name__ if combo is None else _kernel_name(combo)
    if name in _COMPILE_SECONDS:
        return True
    real_valued = combo is not None and _is_real_valued(combo)
    try:
        index = kernel._cache._cache_file._load_index()
        if is_adaptive:
            return bool(index)
        return any(
            (signature[_REP_ARGUMENT].types[-1] != types.none) == real_valued
            for signature, *_ in index
        )
    except (AttributeError, OSError, EOFError, ValueError, IndexError, TypeError):
        return False


def warm_up() -> float:
    """Compile both kernels (or load them from the disk cache) and return `compile_seconds`.

    Each kernel serves all its combinations (``advance_kernel`` in its binary and real-valued
    compilations), so a parent process can call this once before starting workers, which
    then load the cached code.
    """
    from conjure.agents.sarsa import SARSA
    from conjure.domains.blocksworld import BlocksWorld
    from conjure.domains.chain import ChainMDP
    from conjure.representations import RBF, BinaryIndicators, OnlineIFDD, Tabular

    for domain, representation in (
        (ChainMDP(), Tabular()),
        (ChainMDP(), RBF()),
        (BlocksWorld(num_blocks=2), OnlineIFDD(base=BinaryIndicators())),
    ):
        agent = SARSA(representation=representation).setup(domain.domain_spec, 0)
        stepper = for_combination(domain, agent, seed=0)
        assert stepper is not None  # both combinations are compiled ones
        stepper.advance(1)
    seconds = compile_seconds()
    assert seconds is not None  # the advances above called the kernels
    return seconds


def for_combination(
    domain: Domain, agent: Agent, *, seed: int | None = None
) -> CompiledStepper | None:
    """Return a `CompiledStepper` for a set-up ``agent`` on ``domain``, or ``None``.

    ``None`` means some part (domain, representation, agent, policy or schedule) has no
    compiled kernel; the caller then uses the Python path unchanged. ``seed`` is passed to the
    first ``domain.reset``, as `conjure.experiments.loop.LearningLoop` does.

    Examples
    --------
    >>> from conjure.agents import SARSA
    >>> from conjure.domains import InvertedPendulum
    >>> from conjure.representations import TileCoding
    >>> domain = InvertedPendulum()
    >>> agent = SARSA(representation=TileCoding()).setup(domain.domain_spec, seed=0)
    >>> stepper = for_combination(domain, agent, seed=0)
    >>> stats = stepper.advance(1000)
    >>> stepper.total_steps, int(stats.episode_lengths.sum()) <= 1000
    (1000, True)
    """
    combination = pack_combination(domain, agent)
    if combination is None:
        return None
    return CompiledStepper(domain, agent, combination, seed=seed)
