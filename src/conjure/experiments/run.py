"""One experiment run: learn for a step budget, checking the greedy policy along the way.

``run(domain=..., agent=..., budget_steps=..., seed=...)`` is the library's front door (STYLE
§8); `run_config` does the same from a config. A run splits its seed into independent streams
for the learning domain, the evaluation domain and the agent, so policy checks never perturb
learning: the same seed gives the same learning trajectory whatever ``num_policy_checks``.

Notes
-----
- Choice: policy checks run at learning steps ``budget_steps * i // num_policy_checks`` for
  ``i = 0 .. num_policy_checks`` (step 0 included), possibly in the middle of a learning
  episode, which then continues.
- Choice: every policy check replays the same evaluation start states (the evaluation domain is
  reset with the same seed at each check), so differences between checks reflect the policy.
- Choice: ``wall_time_s`` and ``steps_per_second`` count learning time only (not evaluation);
  a batch learner's fit in `Agent.before_policy_check` is learning time.
- Choice: before every policy check the run calls ``agent.before_policy_check()`` (a no-op for
  online learners; batch learners fit there unless they fit every N samples, so their learning
  trajectory then depends on ``num_policy_checks``, by design).
- Choice (safety metrics, Section 5.4): a step is a failure when the domain reports
  ``info["cost"] > 0`` (entering a state with `Domain.is_constrained`). ``learning_failures``
  counts the failures of all learning steps so far; ``failure_rate`` is the fraction of the
  greedy evaluation episodes with a failure. Costs (constrained MDPs, Safety Gym's measures):
  ``learning_cost`` is Σ c_t over all learning steps so far, ``cost_rate`` that sum over the
  learning steps (NaN at step 0) and ``episode_cost`` the greedy episodes' mean Σ c_t.
  ``optimality`` is (mean return − worst) / (best − worst) with (worst, best) =
  ``domain.value_bounds()`` (the undiscounted return, as Figures 5-6b and 5-9 scale it), NaN
  when the domain has no bounds;
  ``value_ratio`` is mean return / best (V/V*, the plain fraction of the optimum), NaN without
  bounds or when best ≤ 0. Both are reported because the worst policy can be far below every
  policy of interest (UAV 7-2: a crash costs −Σ rewards), which squeezes ``optimality`` toward
  1, while V/V* reads as "the fraction of the optimum obtained".
"""

from __future__ import annotations

import functools
import math
import os
import socket
import time
import traceback
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from conjure.core.errors import DivergenceError, InvalidParameterError, raise_if_interrupted
from conjure.core.interfaces import Agent, Domain, check_is_set_up
from conjure.core.seeding import seed_to_int, split_seed
from conjure.experiments.limits import (
    MAX_COMPILE_STEPS,
    MAX_EVAL_EPISODES,
    check_count,
    check_run_counts,
)
from conjure.experiments.loop import CURVE_COLUMNS, greedy_episodes, learning_stepper
from conjure.experiments.memory import explain_memory_error
from conjure.experiments.metric_ranges import domain_bounds
from conjure.experiments.numbers import format_number

if TYPE_CHECKING:
    import pandas as pd

__all__ = [
    "CURVE_COLUMNS",
    "SEED_STREAMS",
    "TIMING_COLUMNS",
    "Result",
    "checked_value_bounds",
    "evaluate",
    "run",
    "run_config",
    "run_resolved",
]

#: The curve columns that depend on the machine, not on the seed.
TIMING_COLUMNS = ("wall_time_s", "steps_per_second")
#: The streams `run` splits its seed into (`conjure.core.seeding.split_seed`), in this order.
SEED_STREAMS = ("domain", "evaluation", "agent")


@dataclass
class Result:
    """What a run produced: its learning curve, seed and resolved config.

    Attributes
    ----------
    rows : list of dict
        One row per policy check, keys `CURVE_COLUMNS` (`curve` as a table, `columns` as lists).
    seed : int
        The run's seed.
    config : dict or None
        The resolved run config (``None`` for runs built from objects).
    agent : Agent or None
        The trained agent (object runs and `run_config`; not kept by parallel experiments).
    agent_name, domain_name : str
        For `summary`.
    is_complete : bool
        False for the partial result a `DivergenceError` carries.
    domain_bounds : dict
        What the domain declared of its metrics' ranges (its episode cap, value and return bounds,
        `conjure.experiments.metric_ranges.domain_bounds`); recorded with the run.
    path : str
        Which path the learning steps took: ``"compiled"`` or ``"python: <why not
        compiled>"`` (`conjure.experiments.loop.learning_stepper`); recorded with the run.
    """

    rows: list[dict[str, Any]] = field(repr=False)
    seed: int
    config: dict[str, Any] | None = None
    agent: Agent | None = field(default=None, repr=False)
    agent_name: str = ""
    domain_name: str = ""
    is_complete: bool = True
    domain_bounds: dict[str, float] = field(default_factory=dict)
    path: str = ""

    @functools.cached_property
    def curve(self) -> pd.DataFrame:
        """The learning curve: one row per policy check, columns `CURVE_COLUMNS`."""
        import pandas as pd

        frame = pd.DataFrame(self.columns(), columns=list(CURVE_COLUMNS))
        return frame.astype({c: "int64" if c in _INT_COLUMNS else "float64" for c in CURVE_COLUMNS})

    def columns(self) -> dict[str, list[float] | list[int]]:
        """The curve as plain lists by column (integers for the counts), without pandas."""
        return {
            c: [(int if c in _INT_COLUMNS else float)(row[c]) for row in self.rows]
            for c in CURVE_COLUMNS
        }

    def to_frame(self) -> pd.DataFrame:
        """Return the curve with a leading ``seed`` column (and ``label`` if the config has one)."""
        frame = self.curve.copy()
        frame.insert(0, "seed", self.seed)
        if self.config is not None and "label" in self.config:
            frame.insert(0, "label", self.config["label"])
        return frame

    def summary(self) -> str:
        """Return a one-paragraph account of the run."""
        who = f"{self.agent_name or 'agent'} on {self.domain_name or 'domain'}, seed {self.seed}"
        if self.curve.empty:
            return f"{who}: no policy check recorded."
        last = self.curve.iloc[-1]
        best = float(self.curve["return"].max())
        status = "" if self.is_complete else " (stopped early)"
        return (
            f"{who}{status}: {int(last['learning_steps']):,} learning steps in "
            f"{int(last['learning_episodes']):,} episodes; final greedy return "
            f"{format_number(last['return'])} (best {format_number(best)}, discounted "
            f"{format_number(last['discounted_return'])}, episode length "
            f"{format_number(last['episode_length'])}); {int(last['num_features']):,} "
            f"features; {_format_rate(last['steps_per_second'])} learning steps/s"
            + (f" ({self.path} path)." if self.path == "compiled" else f" ({self.path}).")
        )


def _format_rate(value: float) -> str:
    return "n/a" if not math.isfinite(value) else f"{value:,.0f}"


def checked_value_bounds(domain: Domain) -> tuple[float, float] | None:
    """Return the domain's (worst, best) expected returns, checked, or ``None``.

    Raises
    ------
    InvalidParameterError
        If ``domain.value_bounds()`` is not ``None`` nor finite with worst < best.
    """
    bounds = domain.value_bounds()
    if bounds is None:
        return None
    try:
        worst, best = (float(value) for value in bounds)
    except (TypeError, ValueError):
        worst = best = math.nan
    if not (math.isfinite(worst) and math.isfinite(best) and worst < best):
        raise InvalidParameterError(
            f"{type(domain).__name__}.value_bounds() must return finite (worst, best) with "
            f"worst < best, or None; got {bounds!r}."
        )
    return worst, best


def _evaluate(
    domain: Domain,
    agent: Agent,
    num_episodes: int,
    seed: int,
    bounds: tuple[float, float] | None,
) -> dict[str, float]:
    """One policy check: the greedy episodes' means, failure rate and optimality."""
    stats = greedy_episodes(domain, agent, num_episodes, seed=seed)
    mean_return = float(np.mean([s.episode_return for s in stats]))
    return {
        "return": mean_return,
        "discounted_return": float(np.mean([s.discounted_return for s in stats])),
        "episode_length": float(np.mean([s.num_steps for s in stats])),
        "failure_rate": float(np.mean([s.num_failures > 0 for s in stats])),
        "episode_cost": float(np.mean([s.cost for s in stats])),
        "optimality": math.nan
        if bounds is None
        else (mean_return - bounds[0]) / (bounds[1] - bounds[0]),
        "value_ratio": math.nan if bounds is None or bounds[1] <= 0 else mean_return / bounds[1],
    }


def evaluate(*, domain: Domain, agent: Agent, seed: int, num_episodes: int = 1) -> dict[str, float]:
    """Evaluate a set-up agent's greedy policy as a policy check does, without learning.

    For a restored agent (``SARSA.restore(path)``) or one a `run` trained: ``agent`` is used as
    it is (never set up again, its weights untouched); ``domain`` is reset with ``seed`` before
    each of ``num_episodes`` greedy episodes. Returns the policy-check columns of
    `CURVE_COLUMNS`: ``return``, ``discounted_return``, ``episode_length``, ``failure_rate``,
    ``episode_cost``, ``optimality`` and ``value_ratio``.
    """
    check_is_set_up(agent, "evaluate")
    num_episodes = check_count("evaluate.num_episodes", num_episodes, 1, MAX_EVAL_EPISODES)
    return _evaluate(domain, agent, num_episodes, seed, checked_value_bounds(domain))


def run(
    *,
    domain: Domain,
    agent: Agent,
    budget_steps: int,
    seed: int,
    num_policy_checks: int = 10,
    eval_episodes: int = 1,
    config: dict[str, Any] | None = None,
    compile_steps: int | None = None,
    continue_learning: bool = False,
) -> Result:
    """Set up ``agent``, learn on ``domain`` for ``budget_steps`` steps and record a curve.

    Parameters
    ----------
    domain : Domain
        The learning domain (reset and stepped in place); a clone serves the policy checks.
    agent : Agent
        The learner; ``setup`` is called here, so it is trained in place.
    budget_steps : int
        Learning steps in [1, 10^12] (exact, even if the last episode is cut short).
    seed : int
        Split into domain, evaluation and agent seeds (`conjure.core.seeding.split_seed`).
    num_policy_checks : int, default 10
        Greedy evaluations after the first one at step 0, evenly spaced in steps; at most
        ``budget_steps`` and 10^6 (`conjure.experiments.limits`).
    eval_episodes : int, default 1
        Greedy episodes per policy check (their mean is recorded).
    config : dict or None
        The resolved config to record in the result.
    compile_steps : int or None
        The learning steps a cold compile of the loop is weighed against
        (`conjure.experiments.loop.learning_stepper`); None: ``budget_steps``. A command's
        warm-up passes the maximum to the tiny run that compiles for all its runs
        (`conjure.experiments.parallel.warm_up`); an int in [1, 2^62].
    continue_learning : bool, default False
        Learn on from the agent's current state (a restored or already trained agent: its
        weights, features and random stream) instead of setting it up afresh; the seed then
        drives the domains only, and the curve's steps count from 0. With False, an agent
        that is already set up is set up again, discarding what it learned, with a warning.

    Returns
    -------
    Result

    Raises
    ------
    DivergenceError
        If the agent diverges; its ``partial_result`` holds the curve recorded so far.
    """
    budget_steps, num_policy_checks, eval_episodes = check_run_counts(
        budget_steps, num_policy_checks, eval_episodes, prefix="run."
    )
    if compile_steps is not None:
        compile_steps = check_count("run.compile_steps", compile_steps, 1, MAX_COMPILE_STEPS)
    bounds = checked_value_bounds(domain)
    seeds = split_seed(seed, SEED_STREAMS)
    if continue_learning:
        check_is_set_up(agent, "run(continue_learning=True)")
    else:
        if getattr(agent, "is_set_up_", False):
            warnings.warn(
                f"run() sets {type(agent).__name__} up afresh, discarding its learned state; "
                "pass continue_learning=True to learn on from it, or call evaluate() to "
                "evaluate it as it is.",
                UserWarning,
                stacklevel=2,
            )
        agent.setup(domain.domain_spec, seeds["agent"])
    eval_domain = domain.clone()
    eval_seed = seed_to_int(seeds["evaluation"])
    loop = learning_stepper(
        domain,
        agent,
        seed=seed_to_int(seeds["domain"]),
        budget_steps=budget_steps if compile_steps is None else compile_steps,
    )
    names = {
        "agent_name": type(agent).__name__,
        "domain_name": domain.domain_spec.name,
        "path": loop.path,
    }
    declared = domain_bounds(domain.domain_spec.max_episode_steps, bounds, domain.return_bounds())
    int_seed = int(seed) if isinstance(seed, (int, np.integer)) else -1

    rows: list[dict[str, Any]] = []
    wall_time = 0.0
    for i in range(num_policy_checks + 1):
        target = budget_steps * i // num_policy_checks
        started = time.perf_counter()
        try:
            loop.advance(target - loop.total_steps)
            agent.before_policy_check()
            wall_time += time.perf_counter() - started
            checked = _evaluate(eval_domain, agent, eval_episodes, eval_seed, bounds)
        except DivergenceError as exc:
            partial = Result(
                rows, int_seed, config, agent, **names, is_complete=False, domain_bounds=declared
            )
            last = int(rows[-1]["learning_steps"]) if rows else 0
            error = DivergenceError(
                f"Learning diverged at learning step {loop.total_steps + 1:,} of "
                f"{budget_steps:,} ({names['agent_name']} on {names['domain_name']}, seed "
                f"{seed}): {exc} The likely fix is a lower step size (e.g. halve `step_size` "
                f"or the schedule's `alpha_0`). The curve up to step {last:,} is in "
                f"`.partial_result`."
            )
            error.partial_result = partial  # type: ignore[attr-defined]
            raise error from exc
        rows.append(
            {
                "learning_steps": loop.total_steps,
                "learning_episodes": loop.num_completed_episodes,
                "learning_failures": loop.num_failures,
                "learning_cost": loop.total_cost,
                "cost_rate": loop.total_cost / loop.total_steps if loop.total_steps else math.nan,
                **checked,
                "num_features": int(agent.num_features),
                "wall_time_s": wall_time,
                "steps_per_second": loop.total_steps / wall_time
                if loop.total_steps > 0
                else math.nan,
            }
        )
    return Result(rows, int_seed, config, agent, **names, domain_bounds=declared)


#: The integer curve columns (the others are float64).
_INT_COLUMNS = ("learning_steps", "learning_episodes", "learning_failures", "num_features")


def run_resolved(run_spec: dict[str, Any]) -> Result:
    """Run from one resolved run config (`conjure.experiments.config.resolve_run`'s output)."""
    from conjure.experiments import registry

    label = run_spec.get("label", "agent")
    domain = registry.build("domain", run_spec["domain"], path="domain")
    agent = registry.build("agent", run_spec["agent"], path=f"agents.{label}")
    return run(
        domain=domain,
        agent=agent,
        budget_steps=run_spec["budget_steps"],
        seed=run_spec["seed"],
        num_policy_checks=run_spec["num_policy_checks"],
        eval_episodes=run_spec["eval_episodes"],
        config=run_spec,
        compile_steps=run_spec.get("compile_steps"),
    )


def run_config(config: Any, *, agent_name: str, seed: int) -> Result:
    """Run agent ``agent_name`` of an experiment config (dict or `ExperimentConfig`) once.

    Examples
    --------
    ``run_config(load_config("examples/pendulum.yaml"), agent_name="tile_coding", seed=0)``
    """
    from conjure.experiments.config import parse_config, resolve_run

    parsed = parse_config(config)
    return run_resolved(resolve_run(parsed, agent_name, seed))


#: What a worker runs for one resolved run config (`run_resolved`, or a user's wrapper of it).
RunFunction = Callable[[dict[str, Any]], Any]


def run_task(run_spec: dict[str, Any], run_fn: RunFunction = run_resolved) -> dict[str, Any]:
    """Run one resolved run on a worker; return its curve or its error as plain data.

    It lives here, not beside the executors, so that a worker imports what a run needs and
    not pandas, SciPy's statistics or rich: the parent process writes the results.
    """
    started = time.perf_counter()
    meta = {"host": socket.gethostname(), "pid": os.getpid()}
    try:
        result = run_fn(run_spec)
    except Exception as exc:  # recorded and reported, never fatal to other runs
        raise_if_interrupted(exc)
        partial = getattr(exc, "partial_result", None) if isinstance(exc, DivergenceError) else None
        message = f"{type(exc).__name__}: {exc}".splitlines()[0]
        error = traceback.format_exc()
        if isinstance(exc, MemoryError):
            message = explain_memory_error(message)
            error = f"{message}\n\n{error}"
        return {
            "curve": None,
            "error": error,
            "message": message,
            "partial": None if partial is None else partial.columns(),
            "meta": meta,
        }
    meta["run_seconds"] = time.perf_counter() - started
    meta["path"] = result.path
    meta.update(result.domain_bounds)
    return {"curve": result.columns(), "error": None, "meta": meta}
