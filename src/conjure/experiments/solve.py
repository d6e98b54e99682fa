"""``conjure solve CONFIG``: solve one domain with a planner (or exactly) and report the policy.

The config is YAML with a ``domain`` and a ``planner``, each ``{kind, params}`` as in the
experiment configs; ``planner: exact`` asks the domain to solve itself::

    domain: {kind: GridWorld, params: {map_name: gridworld1}}
    planner: {kind: ValueIteration, params: {tolerance: 1.0e-8}}

    domain: {kind: UAVMission, params: {scenario: uav-7-2}}
    planner: exact

Three kinds of planner fit:

- ``exact``: the domain's own exact solution, ``domain.exact_solution()`` (`UAVMission`:
  backward induction over the reachable states, Section 5.3.5);
- a planner of Algorithms 1-9 and 13 (``conjure list planners``) on the domain's tabular
  model, or by sampling a simulator that can be set to any state (the sampled ones);
- a cooperative planner π^p of iCCA (Section 5.3.1; ``CBBAPlanner`` aggressive or
  conservative, Algorithm 27, on UAV missions) on an `ApproximateModel` of the domain at its
  own noise.

The command prints the policy's value from the start state, the worst value (when the domain
knows it: `Domain.value_bounds`), how the value was computed (exactly, or as the mean return
of ``--episodes`` episodes), and the policy's first moves in one episode; ``--render PNG``
draws a GridWorld's value function and policy in the style of Geramifard (2012), Figure 5-1.
A planner that does not fit the domain is refused before planning, with the planners that do.

Notes
-----
- Choice: a domain with an exact model is given to the planner as its `TabularModel`
  (sampled planners then sample it, and the plan has a table over the model's states);
  a domain without one is passed as is (sampled planners only).
- Choice: a planner's value is ``plan.start_value()`` (the start distribution's mean) when the
  plan has a model, else the plan's value of the domain's first reset state; a cooperative
  planner's value is exact when the domain evaluates policies exactly
  (``domain.evaluate_policy``, `UAVMission`: CBBA replanned at every step), else the mean
  return of the episodes.
- Choice: a domain that solves itself returns an object with ``optimal_return``,
  ``worst_return`` and ``action(state)`` (`UAVMission.exact_solution`'s `MissionSolution`).
- Choice: a cooperative planner whose parameters are planners (``SwitchingPlanner``) is listed
  as fitting a domain when some cooperative planner with default parameters fits it.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import click
import numpy as np
from rich.console import Console
from rich.table import Table

from conjure.core.cooperative import CooperativePlanner, NoisyDomain
from conjure.core.errors import ConjureError, IncompatibleComponentsError, InvalidParameterError
from conjure.core.interfaces import Domain
from conjure.core.params import did_you_mean
from conjure.experiments import registry
from conjure.experiments.config import load_yaml, read_config_text
from conjure.experiments.loop import run_episode
from conjure.models.approximate_model import ApproximateModel
from conjure.models.tabular_model import TabularModel
from conjure.planners.base import Plan, Planner
from conjure.safety.planner_agent import PlannerAgent

__all__ = [
    "EXACT",
    "Solution",
    "fitting_planners",
    "render_gridworld",
    "solve",
    "solve_command",
]

_ARROWS = ("↑", "↓", "←", "→")  # GridWorld actions 0..3: up, down, left, right
#: The ``planner`` of a solve config that asks the domain to solve itself.
EXACT = "exact"
#: How many moves of the policy `conjure solve` prints.
NUM_FIRST_MOVES = 8
_PLANNER_LAYERS = ("planner", "cooperative_planner")


def _load(config: Path) -> dict[str, Any]:
    data = load_yaml(read_config_text(Path(config), "solve config"), source=str(config))
    if not isinstance(data, dict) or not {"domain", "planner"} <= set(data):
        raise InvalidParameterError(
            f"A solve config needs `domain: {{kind, params}}` and `planner: {{kind, params}}` "
            f"(or `planner: exact`); {config} has "
            f"{sorted(data) if isinstance(data, dict) else type(data).__name__}."
        )
    extra = set(data) - {"domain", "planner", "episodes", "seed"}
    if extra:
        raise InvalidParameterError(
            f"Unexpected key {sorted(extra)[0]!r} in {config}; known: domain, planner, episodes, "
            f"seed."
        )
    return data


def build_planner(spec: Any) -> Planner | CooperativePlanner | str:
    """Build a solve config's ``planner``: `EXACT`, a planner or a cooperative planner."""
    if isinstance(spec, str) and spec.lower() == EXACT:
        return EXACT
    kind = spec.get("kind") if isinstance(spec, dict) else None
    if not isinstance(kind, str):
        raise InvalidParameterError(
            f"planner: expected `exact` or {{kind: Name, params: {{...}}}}; got {spec!r}."
        )
    for layer in _PLANNER_LAYERS:
        try:
            registry.find_kind(kind, layer)
        except InvalidParameterError:
            continue
        return registry.build(layer, spec, path="planner")
    known = [EXACT, *(k for layer in _PLANNER_LAYERS for k in registry.LAYERS[layer])]
    other = next((name for name, table in registry.LAYERS.items() if kind in table), None)
    what = f"{kind!r} is in the {other!r} registry, not a planner." if other else (
        f"unknown planner {kind!r}.{did_you_mean(kind, known)}"
    )  # fmt: skip
    raise InvalidParameterError(f"planner.kind: {what} Known: {', '.join(known)}.")


# ------------------------------------------------------------------ which planners fit


def _tabular_model(domain: Domain) -> TabularModel | None:
    model = domain.model() if callable(getattr(domain, "model", None)) else None
    return model if isinstance(model, TabularModel) else None


def _has_exact_solution(domain: Domain) -> bool:
    return callable(getattr(domain, "exact_solution", None))


def _misfit(domain: Domain, planner: Planner | CooperativePlanner | str) -> str | None:
    """Why ``planner`` cannot solve ``domain``, or ``None`` if it can."""
    name = type(domain).__name__
    if planner == EXACT:
        if _has_exact_solution(domain):
            return None
        reason = f"`exact` needs a domain that solves itself (`exact_solution()`); {name} does not"
        if _tabular_model(domain) is not None:
            reason += " (PolicyIteration and ValueIteration solve its tabular model exactly)"
        return reason
    if isinstance(planner, CooperativePlanner):
        return _cooperative_misfit(domain, planner)
    kind = type(planner).__name__
    if _tabular_model(domain) is not None:
        return None
    if not planner.is_sampled:
        return f"{kind} needs the domain's tabular model (`model()`), which {name} does not have"
    if callable(getattr(domain, "set_state", None)):
        return None
    return (
        f"{kind} samples a tabular model (`model()`) or a simulator set to any state "
        f"(`set_state()`); {name} has neither"
    )


def _cooperative_misfit(domain: Domain, planner: CooperativePlanner) -> str | None:
    kind = type(planner).__name__
    if not isinstance(domain, NoisyDomain):
        return (
            f"{kind} plans on an ApproximateModel of a NoisyDomain (Section 5.5); "
            f"{type(domain).__name__} is not one"
        )
    try:
        planner.clone().setup(_approximate_model(domain), seed=0)
    except IncompatibleComponentsError as exc:
        return str(exc).rstrip(".")
    return None


def _approximate_model(domain: NoisyDomain) -> ApproximateModel:
    """T̂ of ``domain`` at its own noise, set up (what a cooperative planner plans on)."""
    return ApproximateModel(domain=domain.clone()).setup(domain.domain_spec, seed=0)


def fitting_planners(domain: Domain) -> list[str]:
    """The planner kinds `solve` accepts for ``domain`` (``"exact"`` first when it fits).

    Examples
    --------
    >>> from conjure.domains import UAVMission
    >>> fitting_planners(UAVMission())
    ['exact', 'CBBAPlanner', 'SwitchingPlanner']
    """
    fits = [EXACT] if _has_exact_solution(domain) else []
    fits += [k for k in registry.PLANNERS if _misfit(domain, registry.PLANNERS[k]()) is None]
    cooperative = []
    composite = []
    for kind in registry.COOPERATIVE_PLANNERS:
        try:
            planner = registry.COOPERATIVE_PLANNERS[kind]()
        except TypeError:  # its parameters are planners: it fits where they do
            composite.append(kind)
            continue
        if _misfit(domain, planner) is None:
            cooperative.append(kind)
    return fits + cooperative + (composite if cooperative else [])


def check_fits(domain: Domain, planner: Planner | CooperativePlanner | str) -> None:
    """Raise `IncompatibleComponentsError` naming the planners that fit, if ``planner`` does not."""
    reason = _misfit(domain, planner)
    if reason is None:
        return
    name = type(domain).__name__
    fits = fitting_planners(domain)
    advice = (
        f"planners that fit {name}: {', '.join(fits)}."
        if fits
        else f"no planner fits {name} (no tabular model, no settable simulator, no exact "
        f"solution); learn it with `conjure run`."
    )
    raise IncompatibleComponentsError(f"{reason}; {advice}")


# ------------------------------------------------------------------ solving


@dataclass(frozen=True, eq=False)
class Solution:
    """What `solve` found: the policy, the numbers `conjure solve` prints, and how.

    Parameters
    ----------
    solver : str
        The planner's name (``exact (UAVMission.exact_solution)`` for `EXACT`).
    policy : callable
        π(s): maps a state to the action the solution takes.
    numbers : dict of str to float
        The rows `conjure solve` prints, by key: ``value`` and ``worst_value`` (NaN if
        unknown), then those the method gives (``optimal_value``, ``crash_probability``,
        ``mean_return``, ``iterations``, ``wall_time_s``, ...).
    evaluation : str
        How ``value`` was obtained (``exact`` or ``mean of N episodes``).
    plan : Plan or None
        The plan of a planner of Algorithms 1-9 and 13 (``None`` otherwise).
    """

    solver: str
    policy: Callable[[np.ndarray], int]
    numbers: dict[str, float] = field(default_factory=dict)
    evaluation: str = "exact"
    plan: Plan | None = None


def solve(
    domain: Domain,
    planner: Planner | CooperativePlanner | str,
    *,
    episodes: int = 10,
    seed: int = 0,
) -> Solution:
    """Solve ``domain`` with ``planner`` (`EXACT`: the domain's own exact solution).

    Raises
    ------
    IncompatibleComponentsError
        If ``planner`` does not fit ``domain``, naming the planners that do.
    """
    check_fits(domain, planner)
    if planner == EXACT:
        return _solve_exactly(domain)
    if isinstance(planner, CooperativePlanner):
        return _solve_cooperatively(domain, planner, episodes=episodes, seed=seed)
    return _solve_by_planning(domain, planner, episodes=episodes, seed=seed)


def _worst_value(domain: Domain) -> float:
    bounds = domain.value_bounds()
    return float("nan") if bounds is None else float(bounds[0])


def _solve_exactly(domain: Domain) -> Solution:
    solution = domain.exact_solution()
    numbers = {"value": solution.optimal_return, "worst_value": solution.worst_return}
    if callable(getattr(domain, "evaluate_policy", None)):
        evaluation = domain.evaluate_policy(solution.action)
        numbers["crash_probability"] = evaluation.crash_probability
    numbers["num_states"] = float(solution.num_states)
    return Solution(
        solver=f"exact ({type(domain).__name__}.exact_solution)", policy=solution.action,
        numbers=numbers,
    )  # fmt: skip


def _solve_cooperatively(
    domain: Domain, planner: CooperativePlanner, *, episodes: int, seed: int
) -> Solution:
    agent = PlannerAgent(planner=planner, model=ApproximateModel(domain=domain.clone()))
    agent.setup(domain.domain_spec, seed)
    policy = agent.planner_.action
    numbers = {"value": float("nan"), "worst_value": _worst_value(domain)}
    if callable(getattr(domain, "evaluate_policy", None)):
        evaluation = domain.evaluate_policy(policy)
        numbers["value"] = evaluation.value
        numbers["crash_probability"] = evaluation.crash_probability
        numbers["optimal_value"] = domain.value_bounds()[1]
        return Solution(solver=repr(planner), policy=policy, numbers=numbers)
    numbers.update(_episode_numbers(domain, agent, episodes=episodes, seed=seed))
    numbers["value"] = numbers["mean_return"]
    return Solution(
        solver=repr(planner), policy=policy, numbers=numbers,
        evaluation=f"mean of {episodes} episodes",
    )  # fmt: skip


def _solve_by_planning(domain: Domain, planner: Planner, *, episodes: int, seed: int) -> Solution:
    model = _tabular_model(domain)
    plan = planner.plan(model if model is not None else domain)
    if plan.model is not None:
        start_value = plan.start_value()
    else:
        start_value = plan.value(domain.reset(seed=seed)[0])
    agent = plan.as_agent().setup(domain.domain_spec, seed)
    numbers = {"value": float(start_value), "worst_value": _worst_value(domain)}
    numbers.update(_episode_numbers(domain, agent, episodes=episodes, seed=seed))
    numbers["iterations"] = float(plan.iterations)
    numbers["wall_time_s"] = float(plan.wall_time_s)
    return Solution(
        solver=repr(planner), policy=plan.action, numbers=numbers,
        evaluation="the plan's V", plan=plan,
    )  # fmt: skip


def _episode_numbers(domain: Domain, agent: Any, *, episodes: int, seed: int) -> dict[str, float]:
    stats = [run_episode(domain, agent, seed=seed + k) for k in range(episodes)]
    return {
        "mean_return": float(np.mean([s.episode_return for s in stats])),
        "mean_discounted_return": float(np.mean([s.discounted_return for s in stats])),
        "mean_episode_length": float(np.mean([s.num_steps for s in stats])),
    }


def first_moves(
    domain: Domain, policy: Callable[[np.ndarray], int], *, seed: int, num_moves: int
) -> list[tuple[int, str, float]]:
    """(t, action, reward) of the first ``num_moves`` steps of ``policy`` in one episode."""
    describe = getattr(domain, "describe_action", None)
    state, _ = domain.reset(seed=seed)
    moves = []
    for t in range(num_moves):
        action = int(policy(state))
        state, reward, terminated, truncated, _ = domain.step(action)
        moves.append((t, describe(action) if callable(describe) else f"action {action}", reward))
        if terminated or truncated:
            break
    return moves


def check_renderable(domain: Domain) -> None:
    """Raise `IncompatibleComponentsError` unless `render_gridworld` can draw ``domain``'s plans.

    ``conjure solve --render`` calls it before planning, so a long solve never ends in it.
    """
    from conjure.domains.gridworld import GridWorld

    if not isinstance(domain, GridWorld):
        raise IncompatibleComponentsError(
            f"--render draws GridWorld plans over a tabular model; got {type(domain).__name__}."
        )


def render_gridworld(domain: Domain, plan: Plan, path: str | Path) -> Path:
    """Draw V (cell colours) and π (arrows) of a GridWorld plan, as Figure 5-1; return path.

    Blocked cells are grey, the start is marked S, goals G (green) and pits P (red).
    """
    from matplotlib import colormaps
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    from conjure.domains.gridworld import BLOCKED, GOAL, PIT, START

    check_renderable(domain)
    grid = domain.grid_
    if plan.model is None:
        raise IncompatibleComponentsError(
            f"--render draws GridWorld plans over a tabular model; {type(domain).__name__}'s "
            f"plan has none."
        )
    rows, cols = grid.shape
    image = np.full((rows, cols), np.nan)
    values = plan.state_values()
    states = np.rint(plan.model.states).astype(int)
    image[states[:, 0], states[:, 1]] = values
    cmap = colormaps["viridis"].with_extremes(bad="0.6")
    figure = Figure(figsize=(0.6 * cols + 1.6, 0.6 * rows + 0.6))
    FigureCanvasAgg(figure)
    axes = figure.add_subplot()
    shown = axes.imshow(np.ma.masked_invalid(image), cmap=cmap)
    figure.colorbar(shown, ax=axes, label="V(s)")
    for index, (r, c) in enumerate(states):
        code = grid[r, c]
        if code == GOAL:
            axes.text(
                c,
                r,
                "G",
                ha="center",
                va="center",
                color="white",
                weight="bold",
                bbox={"facecolor": "green", "edgecolor": "none"},
            )
        elif code == PIT:
            axes.text(
                c,
                r,
                "P",
                ha="center",
                va="center",
                color="white",
                weight="bold",
                bbox={"facecolor": "red", "edgecolor": "none"},
            )
        else:
            label = _ARROWS[int(plan.policy[index])]
            if code == START:
                label = f"S{label}"
            axes.text(c, r, label, ha="center", va="center", color="white", fontsize=12)
    blocked = np.argwhere(grid == BLOCKED)
    axes.set_xticks(range(cols))
    axes.set_yticks(range(rows))
    axes.set_title(f"{domain.domain_spec.name}: V and π ({len(blocked)} blocked cells)")
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    figure.savefig(path, dpi=100, bbox_inches="tight")
    return path


#: The rows `conjure solve` prints: key of `Solution.numbers` -> (label, format); values
#: with 7 significant digits.
_ROWS = {
    "value": ("value V(start)", "{:,.7g}"),
    "worst_value": ("worst value (start)", "{:,.7g}"),
    "optimal_value": ("optimal value V*(start)", "{:,.7g}"),
    "crash_probability": ("crash probability", "{:.4f}"),
    "mean_return": ("mean return ({episodes} episodes)", "{:,.7g}"),
    "mean_discounted_return": ("mean discounted return", "{:,.7g}"),
    "mean_episode_length": ("mean episode length", "{:,.1f}"),
    "num_states": ("states solved", "{:,.0f}"),
    "iterations": ("iterations", "{:,.0f}"),
    "wall_time_s": ("wall time (s)", "{:.4f}"),
}


def _table(solution: Solution, episodes: int) -> Table:
    table = Table()
    table.add_column("quantity", style="bold")
    table.add_column("value", justify="right")
    for key, (label, form) in _ROWS.items():
        if key not in solution.numbers:
            continue
        number = solution.numbers[key]
        shown = form.format(number) if np.isfinite(number) else "unknown"
        if key == "value":
            label = f"{label}, {solution.evaluation}"
        table.add_row(label.format(episodes=episodes), shown)
    return table


def _moves_table(domain: Domain, solution: Solution, seed: int) -> Table:
    table = Table()
    table.add_column("t", justify="right")
    table.add_column("action")
    table.add_column("reward", justify="right")
    for t, action, reward in first_moves(
        domain, solution.policy, seed=seed, num_moves=NUM_FIRST_MOVES
    ):
        table.add_row(str(t), action, f"{reward:,.4g}")
    return table


@click.command("solve")
@click.argument("config", type=click.Path(exists=True, dir_okay=False, path_type=Path))
@click.option(
    "--render",
    type=click.Path(dir_okay=False, path_type=Path),
    default=None,
    help="Draw a GridWorld's value function and policy to this PNG (default: none).",
)
@click.option(
    "--episodes",
    type=click.IntRange(min=1),
    default=None,
    help="Evaluation episodes (default: the config's episodes, else 10).",
)
@click.option(
    "--seed",
    type=click.IntRange(min=0),
    default=None,
    help="Evaluation seed (default: the config's seed, else 0).",
)
def solve_command(
    config: Path, render: Path | None, episodes: int | None, seed: int | None
) -> None:
    """Solve the domain of CONFIG (a planner, or `exact`); print values and first moves."""
    data = _load(config)
    domain = registry.build("domain", data["domain"], path="domain")
    planner = build_planner(data["planner"])
    if not isinstance(domain, Domain):
        raise ConjureError(f"{config}: `domain` must build a Domain; got {type(domain).__name__}.")
    episodes = int(episodes if episodes is not None else data.get("episodes", 10))
    seed = int(seed if seed is not None else data.get("seed", 0))
    if render is not None:
        check_renderable(domain)
    solution = solve(domain, planner, episodes=episodes, seed=seed)
    console = Console(width=100)
    console.print(f"{solution.solver} on {domain.domain_spec.name}", markup=False)
    console.print(_table(solution, episodes))
    console.print(f"First moves of the policy (one episode, seed {seed}):", markup=False)
    console.print(_moves_table(domain, solution, seed))
    if render is not None:
        if solution.plan is None:
            raise IncompatibleComponentsError(
                f"--render draws a plan over a tabular model; {solution.solver} made none."
            )
        console.print(f"Wrote {render_gridworld(domain, solution.plan, render)}")
