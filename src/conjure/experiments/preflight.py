"""Pre-flight: each agent set up on its domain once, before any run starts.

`conjure.experiments.config.parse_config` builds and validates every component on its own,
so parts that cannot work together pass it: a `CBBAPlanner` inside a grid-world iCCA, a
shortest-path goal off the map, a risk analyser whose rollouts would not end, a mission too
large to solve exactly. Each run would then fail with the same error, one after another.
`check_runs` finds them first: for each distinct (domain, agent) pair among the runs it
builds both, asks the domain for its value bounds and sets the agent up on the domain's spec,
as `conjure.experiments.run.run` does before its first step, and raises one error that names
the agent label, the part and what it needs.

Notes
-----
- Choice: only bad input stops the runs, `InvalidParameterError` and
  `IncompatibleComponentsError`. Any other error (a bug, a `MemoryError`) is left to the runs,
  which record it with its traceback and under their memory limit.
- Choice: the checks run where the runs would: in this process when the executor runs tasks
  in the caller, else in one worker process under the executor's ``max_memory`` (as the
  warm-up does), so a set-up that outgrows memory never takes the driver down. There the
  components are rebuilt from the resolved specs; a pair the worker cannot build (a kind that
  only a run function registers, on the workers) is left to its runs.
- Choice: each pair is set up with the agent seed of its first run, and nothing is kept: the
  runs, their ids and their results are those without the check.
"""

from __future__ import annotations

import copy
import json
import re
from collections.abc import Iterator, Mapping, Sequence
from typing import Any

from conjure.core.errors import IncompatibleComponentsError, InvalidParameterError
from conjure.core.seeding import split_seed
from conjure.experiments import registry
from conjure.experiments.executors import Executor, LocalExecutor
from conjure.experiments.results import describe_setting
from conjure.experiments.run import SEED_STREAMS, checked_value_bounds

__all__ = ["check_problem", "check_runs", "distinct_problems"]

#: The errors that mean bad input, by name (a worker sends the name back).
_BAD_INPUT = {cls.__name__: cls for cls in (InvalidParameterError, IncompatibleComponentsError)}


def distinct_problems(runs: Sequence[Mapping[str, Any]]) -> list[Mapping[str, Any]]:
    """Return the first run of each distinct (domain, agent) pair of ``runs``, in run order.

    Examples
    --------
    >>> runs = [{"domain": {"kind": "ChainMDP"}, "agent": {"kind": "SARSA"}, "seed": s}
    ...         for s in range(10)]
    >>> [run["seed"] for run in distinct_problems(runs)]
    [0]
    """
    first: dict[str, Mapping[str, Any]] = {}
    for spec in runs:
        key = json.dumps([spec.get("domain"), spec.get("agent")], sort_keys=True, default=str)
        first.setdefault(key, spec)
    return list(first.values())


def check_problem(spec: Mapping[str, Any]) -> tuple[str, str, str] | None:
    """Set one run's agent up on its domain, without a step; report bad input.

    Parameters
    ----------
    spec : mapping
        A resolved run config (`conjure.experiments.config.resolve_run`).

    Returns
    -------
    tuple of str or None
        ``(error class name, "domain" or "agent", one-line message)`` if the domain's value
        bounds or the agent's ``setup`` raised `InvalidParameterError` or
        `IncompatibleComponentsError`; ``None`` otherwise (other errors are the run's).
    """
    try:
        domain = registry.build("domain", copy.deepcopy(spec["domain"]))
        agent = registry.build("agent", copy.deepcopy(spec["agent"]))
    except InvalidParameterError:  # the driver built them (parse_config); see the Notes
        return None
    part = "domain"
    try:
        checked_value_bounds(domain)
        part = "agent"
        agent.setup(domain.domain_spec, split_seed(spec["seed"], SEED_STREAMS)["agent"])
    except tuple(_BAD_INPUT.values()) as exc:
        return type(exc).__name__, part, " ".join(str(exc).split())
    return None


def check_runs(runs: Sequence[Mapping[str, Any]], executor: Executor) -> int:
    """Check every distinct (domain, agent) pair of ``runs`` before any run starts.

    Parameters
    ----------
    runs : sequence of mapping
        Resolved run configs, all about to run on ``executor``.
    executor : Executor
        Where the runs will run: the checks run in this process if it runs tasks in the
        caller, else in one local worker process under its ``max_memory``.

    Returns
    -------
    int
        The number of pairs checked.

    Raises
    ------
    InvalidParameterError or IncompatibleComponentsError
        One error for the first pair that cannot run, naming the agent label, the part at
        fault (its config path) and what it needs; the other failing labels are listed.
    """
    problems = distinct_problems(runs)
    if not problems:
        return 0
    in_caller = executor.runs_in_caller
    checker = LocalExecutor(
        max_workers=1,
        max_retries=0,
        in_process=in_caller,
        max_memory=None if in_caller else executor.max_memory,
    )
    with checker:
        failures = sorted(
            (index, outcome)
            for index, outcome in checker.map_unordered(check_problem, problems)
            if isinstance(outcome, tuple)
        )
    if not failures:
        return len(problems)
    index, (kind, part, message) = failures[0]
    spec = problems[index]
    others = sorted({f"agents.{problems[i].get('label')}" for i, _ in failures[1:]})
    also = f" Also failing: {', '.join(others)}." if others else ""
    raise _BAD_INPUT[kind](
        f"{_part_path(spec, part, message)}{_context(spec)}: {message} Found before any run "
        f"started: none of the {len(runs)} runs was started.{also}"
    )


def _context(spec: Mapping[str, Any]) -> str:
    """`` (domains.<label>, setting ...)`` for a sweep run; empty for an experiment run."""
    parts = []
    if "domain_label" in spec:
        parts.append(f"domains.{spec['domain_label']}")
    if spec.get("setting"):
        parts.append(f"setting {describe_setting(spec['setting'])}")
    return f" ({', '.join(parts)})" if parts else ""


def _part_path(spec: Mapping[str, Any], part: str, message: str) -> str:
    """The config path of the component the message blames: the one its text names first."""
    label = spec.get("label", "agent")
    if part == "domain":
        domain = spec.get("domain_label")
        path = f"domains.{domain}" if domain else "domain"
        return f"{path} (for agents.{label})"
    root = f"agents.{label}"
    best_start, best_path = len(message), root
    for path, kind in _components(spec["agent"], root):
        try:
            name = registry.find_kind(kind).__name__
        except InvalidParameterError:
            continue
        match = re.search(rf"\b{re.escape(name)}\b", message)
        if match is not None and match.start() < best_start:
            best_start, best_path = match.start(), path
    return best_path


def _components(tree: Any, path: str) -> Iterator[tuple[str, str]]:
    """Every ``{kind, params}`` inside ``tree`` as (config path, kind), outermost first."""
    if isinstance(tree, Mapping) and "kind" in tree:
        yield path, tree["kind"]
        for name, value in (tree.get("params") or {}).items():
            yield from _components(value, f"{path}.params.{name}")
    elif isinstance(tree, list):
        for position, value in enumerate(tree):
            yield from _components(value, f"{path}[{position}]")
