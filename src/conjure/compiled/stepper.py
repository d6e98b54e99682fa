"""The compiled learning stepper: ``advance(n)`` runs n learning steps in one numba call.

`for_combination` returns a `CompiledStepper` when the domain, representation, agent, policy
and step-size schedule all give compiled forms (see `conjure.compiled.combination`), and
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
- Choice: the learner's θ, traces and tile hash table are updated in place, and so is the
  domain's state (``domain.compiled_form()`` holds the domain's own state arrays,
  `conjure.domains.compiled_domain.KeptCompiledForm`); the episode and learning-step counters
  are written back after every ``advance``, so policy checks, `Agent.save` and the Python
  path see the same objects.
- The learner's compiled form is its state (`conjure.agents.linear_td`): the loop reads and
  updates the learner's own ``arrays_`` and ``row_traces_`` in place, so nothing is taken
  back; its act/learn cache is dropped after every call (`forget_cache`: θ changed under it).
  So is a cooperative box's (`conjure.safety.compiled_cooperative.CompiledBox`): its tables,
  T̂'s counts, η̂^p and the planner's switch are the box's and its parts' own arrays.
- Choice (with `OnlineIFDD`, `RandomExpansion` or `ARiFDD`): the representation's tables
  (and ARiFDD's basic tiles) are its own arrays, updated in place; when a discovery would not
  fit, the kernel returns, the representation grows them with its own method and the kernel
  continues. θ (and Actor-Critic's ω, SARSA(λ)'s trace slots) has as many rows as the
  representation can hold features (the learner's ``reserve_rows``, which reallocates and
  replaces its form only when they do not fit); its ``weights_`` are the first n_t rows, grown
  by the same kernel as the Python learner's
  (`conjure.agents.compiled_agent.grow_learner_rows`).
- Choice: ``advance`` calls the kernel in chunks sized in time, not in steps (`next_chunk`):
  the first call of a stepper takes one step, each next one as many as the last call's rate
  fits in `CHUNK_SECONDS`, at most `CHUNK_GROWTH` times the last chunk and `MAX_KERNEL_STEPS`
  (each call pays a fixed cost before its first step, numba typing its arguments, so a run
  of 10⁴ steps takes four calls, not the fourteen that doubling would make), and at most
  `max_chunk` steps when the agent's risk analyser simulates rollouts. Ctrl-C, which
  Python only sees between compiled calls, therefore stops a run within about a second of the
  step in progress ending, however slow a step is (a Monte-Carlo risk analyser of 10⁶
  rollouts), while fast loops reach long chunks after a few calls. The kernel's pausable
  episodes make the split invisible in the results: same seed, same numbers.
- Choice: a stepper picks the loop's compilation for its arguments' types at its first call
  and calls it directly afterwards (`compiled_function`): numba's typing of the nested named
  tuples on every call cost more than the steps of a short call. The arguments that stay the
  same from call to call (the components' forms, which are their state, and the generators)
  are one `LoopArguments`, built once per stepper and again only when a component replaced
  its form; a call passes it and the domain's form (`run_loop`).
- Compilation: one loop, `conjure.compiled.learning_loop.learning_loop`, serves every
  combination (the compiled forms have fixed field types), compiled once per machine and
  cached on disk, with one more compilation for real-valued φ (`RBF`: its form carries the
  Gaussians' arrays instead of None), so binary φ never pays for reading values;
  `compile_seconds` reports the first calls' cost in this process.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any, NamedTuple

import numpy as np
from numba import njit, typeof
from numba.core import types
from numba.experimental import structref

from conjure.compiled import learning_loop as lp
from conjure.compiled.combination import (
    Selection,
    agent_form,
    box_form,
    learner_of,
    representation_form,
    select,
)
from conjure.core.errors import DivergenceError, InvalidParameterError
from conjure.core.interfaces import Agent, Domain
from conjure.domains.compiled_domain import DomainKernel, callback_error
from conjure.safety.cooperative_agent import CooperativeAgent

__all__ = [
    "AdvanceStats",
    "CompiledStepper",
    "LoopArguments",
    "compile_seconds",
    "compiled_function",
    "for_combination",
    "is_warm",
    "next_chunk",
    "representation_type",
    "run_loop",
    "warm_up",
]

#: Seconds one kernel call aims at (`next_chunk`): Ctrl-C waits for the call in progress.
CHUNK_SECONDS = 0.5
#: At most this many times the last call's steps in the next call (`next_chunk`).
CHUNK_GROWTH = 64
#: Transitions of T̂ the risk judgements of one kernel call may simulate (`max_chunk`): about
#: a second of Algorithm 25's rollouts, whatever the steps before them cost.
CHUNK_SIMULATED_STEPS = 10**8
#: Steps per kernel call at most (a fraction of a second on the fastest combinations).
MAX_KERNEL_STEPS = 2**18
#: The first call's seconds (compile or cache load) of each compilation, by `_kernel_name`.
_COMPILE_SECONDS: dict[str, float] = {}
#: No limit on the steps or episodes of one `CompiledStepper._run`.
_NO_LIMIT = 2**62
#: Position of the `LoopArguments` among `run_loop`'s arguments.
_ARGUMENTS_POSITION = 2
#: `AdvanceStats`' five per-episode arrays when no episode ended (read-only, shared).
_NO_EPISODES = tuple(
    np.zeros(0, dtype=dtype) for dtype in (np.float64, np.float64, np.int64, np.int64, np.float64)
)
for _empty in _NO_EPISODES:
    _empty.flags.writeable = False
#: `LoopArguments`' fields: `learning_loop`'s arguments that stay the same from call to call.
_ARGUMENT_FIELDS = (
    "domain_rng", "rep", "agent", "arrays", "row_traces", "agent_rng", "obs", "state", "box",
    "parts",
)  # fmt: skip


@structref.register
class _LoopArgumentsType(types.StructRef):
    """The numba type of `LoopArguments` (one per combination of field types)."""

    def preprocess_fields(self, fields):
        return tuple((name, types.unliteral(kind)) for name, kind in fields)


class LoopArguments(structref.StructRefProxy):
    """`learning_loop`'s arguments that stay the same from call to call, as one reference.

    The components' forms, which are their state (the learner's `LearnerState` parts, the
    representation's, the box's `CompiledBox`), the domain's and the learner's generators,
    and the stepper's observation and `LoopState`: built once per `CompiledStepper` and again
    only when a component replaced its form (`CompiledStepper._arguments`). A compiled call
    then unboxes one value instead of six named tuples and three generators (numba unboxes a
    `numpy.random.Generator` through its ctypes interface on every call, the largest part of
    a short call's fixed cost). Made by `_pack_arguments`; fields `_ARGUMENT_FIELDS`.
    """


structref.define_boxing(_LoopArgumentsType, LoopArguments)


@njit(cache=True)
def _pack_arguments(
    kind, domain_rng, rep, agent, arrays, row_traces, agent_rng, obs, state, box, parts
):  # fmt: skip
    arguments = structref.new(kind)
    arguments.domain_rng = domain_rng
    arguments.rep = rep
    arguments.agent = agent
    arguments.arrays = arrays
    arguments.row_traces = row_traces
    arguments.agent_rng = agent_rng
    arguments.obs = obs
    arguments.state = state
    arguments.box = box
    arguments.parts = parts
    return arguments


@njit(cache=True)
def run_loop(
    num_steps: int,
    domain: DomainKernel,
    arguments: LoopArguments,
    cap: int,
    learn: bool,
    max_episodes: int,
) -> tuple[int, int, int, float, float, np.ndarray, np.ndarray]:
    """`learning_loop` over the domain's form and the stepper's `LoopArguments`."""
    a = arguments
    return lp.learning_loop(
        num_steps, domain, a.domain_rng, a.rep, a.agent, a.arrays, a.row_traces, a.agent_rng,
        cap, a.obs, a.state, a.box, a.parts, learn, max_episodes,
    )  # fmt: skip


class AdvanceStats(NamedTuple):
    """What one ``advance`` did: steps, failures and the learning episodes that ended.

    ``cost`` is Σ c_t (``info["cost"]``) over the call's steps. The five arrays have one entry
    per learning episode that ended during the call, in order (an episode begun in an earlier
    call counts its earlier steps too), like `conjure.experiments.loop.EpisodeStats`: the
    return Σ r_t, the discounted return Σ γ^t r_t, the length, the number of failure steps
    (``info["cost"] > 0``) and the cost Σ c_t.
    """

    num_steps: int
    num_failures: int
    cost: float
    episode_returns: np.ndarray
    discounted_returns: np.ndarray
    episode_lengths: np.ndarray
    episode_failures: np.ndarray
    episode_costs: np.ndarray


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
    selection : Selection
        What `conjure.compiled.combination.select` found for them.
    seed : int or None, default None
        Passed to the first ``domain.reset(seed=...)``.
    learn : bool, default True
        Learning steps (`advance`), or greedy ones (`play_episodes`: a policy check, as the
        Python `Stepper` with ``learn=False``; a box acts by `greedy_box_action` and its
        analyser draws from the agent's ``eval_rng_``).

    Attributes
    ----------
    total_steps, num_episodes, num_failures : int
        Learning steps, episodes started and failure steps so far.
    total_cost : float
        Σ ``info["cost"]`` over the learning steps so far.
    path : str
        ``"compiled"``: the path a run records (`conjure.experiments.loop.Stepper` says
        ``"python: <why>"``).
    """

    path = "compiled"

    def __init__(
        self,
        domain: Domain,
        agent: Agent,
        selection: Selection,
        *,
        seed: int | None = None,
        learn: bool = True,
    ):
        self.domain = domain
        self.learn = learn
        self.agent = agent
        self.selection = selection
        self.total_steps = 0
        self.num_episodes = 0
        self.num_failures = 0
        self.total_cost = 0.0
        self._seed = seed
        self._started = False
        self._obs = np.zeros(domain.domain_spec.num_dims)
        self._state = lp.new_loop_state(domain.domain_spec.num_actions)
        self._chunk = 1  # steps of the next kernel call (`next_chunk`)
        self._max_chunk = max_chunk(agent)  # and never more than these
        self._compiled = None  # the loop's compiled function for these arguments' types
        self._arguments: LoopArguments | None = None
        rep = representation_form(learner_of(agent))
        self._is_ifdd = rep is not None and rep.is_ifdd
        self._sources: tuple = ()  # what the arguments were built from (`_arguments`)

    @property
    def is_mid_episode(self) -> bool:
        """Whether an episode is in progress."""
        return bool(self._state.phase[0] == lp.IN_EPISODE)

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
        Exception
            Whatever a callback domain's ``reset`` or ``step`` raised (KeyboardInterrupt
            included), after the steps before it were counted; the episode cannot be
            continued.
        InvalidParameterError
            When a `HashedTabular` (the learner's, or a cooperative box's index) is full and a
            new state came: its own error, after the steps before it were counted.
        """
        if isinstance(num_steps, bool) or not isinstance(num_steps, (int, np.integer)):
            raise InvalidParameterError(f"`num_steps` must be an int; got {num_steps!r}.")
        if num_steps < 0:
            raise InvalidParameterError(f"`num_steps` must be >= 0; got {num_steps!r}.")
        return self._run(int(num_steps), _NO_LIMIT)

    def play_episodes(self, num_episodes: int) -> AdvanceStats:
        """Step until ``num_episodes`` episodes ended (`Stepper.play_episode`, repeated).

        With ``learn=False`` these are a policy check's greedy episodes: the first one starts
        from ``domain.reset(seed=seed)``, the next ones from resets that continue the
        domain's generator, as ``run_episode(..., seed=seed if k == 0 else None)`` does.
        Raises as `advance`.
        """
        if isinstance(num_episodes, bool) or not isinstance(num_episodes, (int, np.integer)):
            raise InvalidParameterError(f"`num_episodes` must be an int; got {num_episodes!r}.")
        if num_episodes < 1:
            raise InvalidParameterError(f"`num_episodes` must be >= 1; got {num_episodes!r}.")
        return self._run(_NO_LIMIT, int(num_episodes))

    def _run(self, num_steps: int, max_episodes: int) -> AdvanceStats:
        """Kernel calls until ``num_steps`` steps were taken or ``max_episodes`` ended."""
        domain, agent, state = self.domain, learner_of(self.agent), self._state
        if not self._started and num_steps > 0:
            self._obs[:] = domain.reset(seed=self._seed)[0]
            self._started = True
            state.phase[0] = lp.NEEDS_BEGIN
        domain_form = domain.compiled_form()  # over the domain's own state arrays
        state.episode[0] = agent.episode_
        state.learning_steps[0] = agent.num_learning_steps_
        chunks: list[tuple[np.ndarray, np.ndarray]] = []
        done = failures = ended = 0
        cost = 0.0
        diverged: float | None = None
        raised: BaseException | None = None
        try:
            while done < num_steps and ended < max_episodes:
                before = int(state.episode[0]) if self.learn else 0
                started = time.perf_counter()
                status, steps, fails, costs, delta, ep_float, ep_int = self._call(
                    min(num_steps - done, self._chunk, self._max_chunk),
                    domain_form,
                    max_episodes - ended,
                )
                self._chunk = next_chunk(self._chunk, steps, time.perf_counter() - started)
                ended += ep_float.shape[0]
                # learning episodes begun (greedy episodes begin none: counted as they end)
                self.num_episodes += (
                    int(state.episode[0]) - before if self.learn else ep_float.shape[0]
                )
                done += steps
                failures += fails
                cost += costs
                chunks.append((ep_float, ep_int))
                if status == lp.GROW_TRACES:
                    agent.grow_trace_capacity()
                elif status == lp.GROW_REPRESENTATION:
                    agent.representation_.grow_tables()
                elif status == lp.DIVERGED:
                    diverged = delta
                    break
                elif status == lp.DOMAIN_RAISED:
                    raised = callback_error(domain_form)
                    break
                elif status == lp.FULL_INDEX:
                    raised = self._full_index_error()
                    break
        finally:
            agent.episode_ = int(state.episode[0])
            agent.num_learning_steps_ = int(state.learning_steps[0])
            self.total_steps += done
            self.num_failures += failures
            self.total_cost += cost
        if diverged is not None:
            raise _divergence(agent, diverged)
        if raised is not None:  # the domain's own exception, as on the Python path
            raise raised
        if ended == 0:  # the common short call: no episode ended
            return AdvanceStats(done, failures, cost, *_NO_EPISODES)
        if len(chunks) == 1:
            ep_float, ep_int = chunks[0]
        else:
            ep_float = np.concatenate([c[0] for c in chunks])
            ep_int = np.concatenate([c[1] for c in chunks])
        return AdvanceStats(
            num_steps=done,
            num_failures=failures,
            cost=cost,
            episode_returns=ep_float[:, 0],
            discounted_returns=ep_float[:, 1],
            episode_lengths=ep_int[:, 0],
            episode_failures=ep_int[:, 1],
            episode_costs=ep_float[:, 2],
        )

    def _full_index_error(self) -> Exception:
        """The error of the full index that could not store ``self._obs`` (its own message)."""
        candidates = (learner_of(self.agent).representation_, getattr(self.agent, "index_", None))
        for index in candidates:
            is_full = getattr(index, "num_stored_", -1) == getattr(index, "num_features_", 0)
            if is_full and index.index_of(self._obs) < 0:
                try:
                    index.active_features(self._obs)
                except InvalidParameterError as error:
                    return error
        return InvalidParameterError(f"A full index could not store state {self._obs.tolist()}.")

    def _call(self, num_steps: int, domain_form: DomainKernel, max_episodes: int) -> tuple:
        """One call of the loop over the components' compiled forms, their state, in place.

        With iFDD θ first gets a row for every feature the tables hold (`reserve_rows`).
        """
        agent = learner_of(self.agent)
        if self._is_ifdd:
            agent.reserve_rows(agent.representation_.feature_capacity_)
        arguments = self._loop_arguments(agent)
        cap, learn = self.selection.max_episode_steps, self.learn
        compiled = self._compiled
        if compiled is None:
            args = (domain_form, arguments, cap, learn)
            name = _kernel_name(self.selection)
            if name not in _COMPILE_SECONDS:  # a zero-step call: compile (or load the cache)
                started = time.perf_counter()
                run_loop(0, *args, max_episodes)
                _COMPILE_SECONDS[name] = time.perf_counter() - started
            compiled = self._compiled = compiled_function(
                run_loop, (num_steps, *args, max_episodes)
            )
        try:
            return compiled(num_steps, domain_form, arguments, cap, learn, max_episodes)
        finally:
            agent.forget_cache()  # θ changed under ``act``'s cached Q-values

    def _loop_arguments(self, agent: Agent | None = None) -> LoopArguments:
        """The `LoopArguments`, built again only when a component replaced its form.

        Read from the components' own state: the learner's ``state_`` (replaced when θ or its
        traces are reallocated) and ``rng_``, the domain's ``np_random`` (replaced by a seeded
        reset), iFDD's tables (replaced when they grow; ARiFDD's `grow_tables` replaces its
        basic tiles with them) and the box's kept form. A fixed
        representation's form never changes after its ``setup``. ``agent``: the learner
        (`learner_of` the stepper's agent).
        """
        if agent is None:
            agent = learner_of(self.agent)
        tables = agent.representation_.kernel_tables() if self._is_ifdd else None
        box = self.agent.compiled_form() if agent is not self.agent else None
        domain_rng, old = self.domain.np_random, self._sources
        if (
            old
            and old[0] is agent.state_
            and old[1] is agent.rng_
            and old[2] is domain_rng
            and old[3] is tables
            and old[4] is box
        ):
            return self._arguments
        sources = (agent.state_, agent.rng_, domain_rng, tables, box)
        rep = representation_form(agent)
        assert rep is not None  # `select` checked it
        form = box_form(self.agent, rep)
        values = (
            self.domain.np_random, rep, agent_form(agent), agent.arrays_, agent.row_traces_,
            agent.rng_, self._obs, self._state, form.box,
            form.parts if self.learn else form.greedy_parts,
        )  # fmt: skip
        kind = _LoopArgumentsType(
            [(name, typeof(value)) for name, value in zip(_ARGUMENT_FIELDS, values, strict=True)]
        )
        self._arguments = _pack_arguments(kind, *values)
        self._sources = sources
        return self._arguments


def compiled_function(dispatcher: Any, args: tuple) -> Callable[..., Any]:
    """The compiled function ``dispatcher`` runs for ``args``, callable without typing them.

    numba types every argument on every call to pick a compilation, about a millisecond for
    the loop's nested named tuples; a stepper's argument types never change (the forms'
    builders fix every field: C-contiguous arrays of fixed dtypes), so it picks once. The
    returned function does not check its arguments' types.
    Reads numba's table of compilations (``Dispatcher.overloads``, a private numba API); if
    that API changes, the dispatcher itself is returned, which only costs speed.
    """
    try:
        signature = tuple(dispatcher.typeof_pyval(value) for value in args)
        return dispatcher.overloads[signature].entry_point
    except (AttributeError, KeyError, TypeError):
        return dispatcher


def next_chunk(chunk: int, steps: int, seconds: float) -> int:
    """Steps of the next kernel call after one of ``steps`` steps took ``seconds``.

    As many as that rate fits in `CHUNK_SECONDS`, at most `CHUNK_GROWTH` times ``chunk`` and
    `MAX_KERNEL_STEPS`, at least one; ``chunk`` again after a call that took no step.

    Examples
    --------
    >>> next_chunk(1, 1, 4e-4), next_chunk(64, 64, 0.01), next_chunk(64, 64, 2.0)
    (64, 3200, 16)
    >>> next_chunk(1, 1, 30.0), next_chunk(8, 0, 0.0), next_chunk(MAX_KERNEL_STEPS, 5, 1e-6)
    (1, 8, 262144)
    """
    if steps == 0:
        return chunk
    fits = int(steps * CHUNK_SECONDS / max(seconds, 1e-9))
    return max(1, min(CHUNK_GROWTH * chunk, MAX_KERNEL_STEPS, fits))


def max_chunk(agent: Agent) -> int:
    """Steps per kernel call whose risk judgements simulate at most `CHUNK_SIMULATED_STEPS`.

    A cooperative box may run cheap planner steps first and then judge every proposal with 𝓜
    rollouts (Algorithm 25), so the rate of earlier calls cannot bound a later call's length:
    the analyser's own worst case per step does (``RiskAnalyzer.simulated_steps``).
    """
    simulated = agent.risk_.simulated_steps() if isinstance(agent, CooperativeAgent) else 0
    return max(1, CHUNK_SIMULATED_STEPS // max(simulated, 1))


def _kernel_name(selection: Selection) -> str:
    """The loop compilation ``selection`` runs in (the `_COMPILE_SECONDS` key)."""
    return lp.learning_loop.__name__ + ("[real-valued]" if selection.is_real_valued else "")


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
    """Whether ``stepper``'s loop compilation (default: binary φ) runs without compiling.

    Warm means called in this process or found in numba's on-disk cache (the compilation for
    ``stepper``'s binary or real-valued φ). Reads numba's cache index (a private numba API);
    if that API changes the loop is treated as cold, which only costs speed.
    """
    real_valued = stepper is not None and stepper.selection.is_real_valued
    name = lp.learning_loop.__name__ + ("[real-valued]" if real_valued else "")
    if name in _COMPILE_SECONDS:
        return True
    try:
        index = run_loop._cache._cache_file._load_index()
        return any(
            (representation_type(signature).types[0].types[-1] != types.none) == real_valued
            for signature, *_ in index
        )
    except (AttributeError, OSError, EOFError, ValueError, IndexError, KeyError, TypeError):
        return False


def representation_type(signature: tuple) -> types.Type:
    """The numba type of the representation (`IFDDKernel`) in a `run_loop` signature.

    Its base's last field is None for binary φ and RBF's arrays for real-valued φ.
    """
    return signature[_ARGUMENTS_POSITION].field_dict["rep"]


def warm_up(*, cached_only: bool = False) -> float:
    """Compile the loop (or load it from the disk cache) and return `compile_seconds`.

    One compilation serves every combination of binary φ and one every real-valued φ, so a
    parent process can call this once before starting workers, which then load the cached
    code. ``cached_only``: load the compilations found in numba's disk cache and compile
    none (0.0 when none was found).
    """
    from conjure.agents.sarsa import SARSA
    from conjure.domains.chain import ChainMDP
    from conjure.representations import RBF, Tabular

    for representation in (Tabular(), RBF()):
        domain = ChainMDP()
        agent = SARSA(representation=representation).setup(domain.domain_spec, 0)
        stepper = for_combination(domain, agent, seed=0)
        assert stepper is not None  # both combinations are compiled ones
        if not cached_only or is_warm(stepper):
            stepper.advance(1)
    seconds = compile_seconds()
    assert seconds is not None or cached_only  # the advances above called the loop
    return seconds or 0.0


def for_combination(
    domain: Domain, agent: Agent, *, seed: int | None = None, learn: bool = True
) -> CompiledStepper | None:
    """Return a `CompiledStepper` for a set-up ``agent`` on ``domain``, or ``None``.

    ``None`` means some part (domain, representation, agent, policy or schedule) has no
    compiled kernel; the caller then uses the Python path unchanged. ``seed`` is passed to the
    first ``domain.reset``, as `conjure.experiments.loop.LearningLoop` does; ``learn=False``
    gives a stepper of greedy episodes (a policy check).

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
    selection = select(domain, agent)
    if isinstance(selection, str):
        return None
    return CompiledStepper(domain, agent, selection, seed=seed, learn=learn)
