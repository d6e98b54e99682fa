"""``conjure solve CONFIG``: run one planner on one domain and report (and draw) the plan.

The config is YAML with a ``domain`` and a ``planner``, each ``{kind, params}`` as in the
experiment configs::

    domain: {kind: GridWorld, params: {map_name: gridworld1}}
    planner: {kind: ValueIteration, params: {tolerance: 1.0e-8}}

The command prints V(s₀) (the plan's own value of the start state), the greedy policy's
evaluated return (mean over ``--episodes`` episodes of the domain), the planner's iterations
and wall time; ``--render PNG`` draws a GridWorld's value function and policy in the style of
Geramifard (2012), Figure 5-1.

Notes
-----
- Choice: a domain with an exact model is given to the planner as its `TabularModel`
  (sampled planners then sample it, and the plan has a table over the model's states);
  a domain without one is passed as is (sampled planners only).
- Choice: V(s₀) is ``plan.start_value()`` (the start distribution's mean) when the plan has
  a model, else the plan's value of the domain's first reset state.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import click
import numpy as np
import yaml
from rich.console import Console
from rich.table import Table

from conjure.core.errors import ConjureError, IncompatibleComponentsError, InvalidParameterError
from conjure.core.interfaces import Domain
from conjure.experiments.loop import run_episode
from conjure.experiments.registry import build
from conjure.planners.base import Plan, Planner

__all__ = ["render_gridworld", "solve", "solve_command"]

_ARROWS = ("↑", "↓", "←", "→")  # GridWorld actions 0..3: up, down, left, right


def _load(config: Path) -> dict[str, Any]:
    try:
        data = yaml.safe_load(Path(config).read_text())
    except (OSError, yaml.YAMLError) as exc:
        raise InvalidParameterError(f"Cannot read solve config {config}: {exc}") from exc
    if not isinstance(data, dict) or not {"domain", "planner"} <= set(data):
        raise InvalidParameterError(
            f"A solve config needs `domain: {{kind, params}}` and `planner: {{kind, params}}`; "
            f"{config} has {sorted(data) if isinstance(data, dict) else type(data).__name__}."
        )
    extra = set(data) - {"domain", "planner", "episodes", "seed"}
    if extra:
        raise InvalidParameterError(
            f"Unexpected key {sorted(extra)[0]!r} in {config}; known: domain, planner, episodes, "
            f"seed."
        )
    return data


def solve(
    domain: Domain, planner: Planner, *, episodes: int = 10, seed: int = 0
) -> tuple[Plan, dict[str, float]]:
    """Plan on ``domain`` and evaluate the greedy plan; return the plan and a summary row."""
    model = domain.model() if callable(getattr(domain, "model", None)) else None
    plan = planner.plan(model if model is not None else domain)
    if plan.model is not None:
        start_value = plan.start_value()
    else:
        start_value = plan.value(domain.reset(seed=seed)[0])
    agent = plan.as_agent().setup(domain.domain_spec, seed)
    stats = [run_episode(domain, agent, seed=seed + k) for k in range(episodes)]
    summary = {
        "start_value": float(start_value),
        "mean_return": float(np.mean([s.episode_return for s in stats])),
        "mean_discounted_return": float(np.mean([s.discounted_return for s in stats])),
        "mean_episode_length": float(np.mean([s.num_steps for s in stats])),
        "iterations": float(plan.iterations),
        "wall_time_s": float(plan.wall_time_s),
    }
    return plan, summary


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


@click.command("solve")
@click.argument("config", type=click.Path(exists=True, dir_okay=False, path_type=Path))
@click.option(
    "--render",
    type=click.Path(dir_okay=False, path_type=Path),
    default=None,
    help="Draw a GridWorld's value function and policy to this PNG.",
)
@click.option("--episodes", type=click.IntRange(min=1), default=None, help="Evaluation episodes.")
@click.option("--seed", type=click.IntRange(min=0), default=None, help="Evaluation seed.")
def solve_command(
    config: Path, render: Path | None, episodes: int | None, seed: int | None
) -> None:
    """Plan on the domain of CONFIG with its planner; report V(s0), return, iterations, time."""
    data = _load(config)
    domain = build("domain", data["domain"], path="domain")
    planner = build("planner", data["planner"], path="planner")
    if not isinstance(domain, Domain) or not isinstance(planner, Planner):
        raise ConjureError(f"{config}: `domain` must build a Domain and `planner` a Planner.")
    episodes = int(episodes if episodes is not None else data.get("episodes", 10))
    seed = int(seed if seed is not None else data.get("seed", 0))
    if render is not None:
        check_renderable(domain)
    plan, summary = solve(domain, planner, episodes=episodes, seed=seed)
    table = Table(title=f"{type(planner).__name__} on {domain.domain_spec.name}")
    table.add_column("quantity", style="bold")
    table.add_column("value", justify="right")
    table.add_row("V(start)", f"{summary['start_value']:.6f}")
    table.add_row(f"mean return ({episodes} episodes)", f"{summary['mean_return']:.6f}")
    table.add_row("mean discounted return", f"{summary['mean_discounted_return']:.6f}")
    table.add_row("mean episode length", f"{summary['mean_episode_length']:.1f}")
    table.add_row("iterations", f"{plan.iterations:d}")
    table.add_row("wall time (s)", f"{plan.wall_time_s:.4f}")
    console = Console(width=100)
    console.print(table)
    if render is not None:
        console.print(f"Wrote {render_gridworld(domain, plan, render)}")
