"""The ``conjure`` command line: ``run``, ``list`` and ``plot``.

Examples
--------
::

    conjure run examples/pendulum.yaml --seeds 4 --set agents.tile_coding.params.step_size=0.05
    conjure run examples/pendulum.yaml --max-workers 2 --max-memory 2GiB
    conjure list
    conjure plot results/pendulum --metric num_features

Any `ConjureError` (a bad config, an unknown kind, ...) prints one clean line and exits with
status 2; failed runs inside an experiment are reported and give status 1.
"""

from __future__ import annotations

import inspect
from pathlib import Path
from typing import Any

import click
from rich.console import Console
from rich.table import Table

from conjure.core.errors import ConjureError
from conjure.experiments.memory import max_memory_option

__all__ = ["main"]


class _Group(click.Group):
    """A click group that turns a `ConjureError` into one line on stderr and exit status 2."""

    def invoke(self, ctx: click.Context) -> Any:
        try:
            return super().invoke(ctx)
        except ConjureError as exc:
            message = " ".join(str(exc).split())
            click.echo(f"Error: {message}", err=True)
            ctx.exit(2)


@click.group(cls=_Group)
@click.version_option(package_name="conjure")
def main() -> None:
    """Conjure: reinforcement learning after Geramifard (2012), from the command line."""


@main.command("run")
@click.argument("config", type=click.Path(dir_okay=False, path_type=Path))
@click.option("--seeds", type=click.IntRange(min=1), default=None, help="Run seeds 0..N-1.")
@click.option(
    "--out",
    "out_dir",
    type=click.Path(file_okay=False, path_type=Path),
    default=None,
    help="Experiment folder (default results/<config name>).",
)
@click.option(
    "--set",
    "overrides",
    multiple=True,
    metavar="PATH=VALUE",
    help="Override a config value, e.g. agents.sarsa.params.step_size=0.05 (repeatable).",
)
@click.option("--max-workers", type=click.IntRange(min=1), default=None, help="Worker processes.")
@max_memory_option
@click.option("--quiet", is_flag=True, help="No progress bar or summary table.")
def run_command(
    config: Path,
    seeds: int | None,
    out_dir: Path | None,
    overrides: tuple[str, ...],
    max_workers: int | None,
    max_memory: int | None,
    quiet: bool,
) -> None:
    """Run the experiment CONFIG (a YAML file); finished runs in the folder are reused."""
    from conjure.experiments.config import load_config
    from conjure.experiments.parallel import run_experiment
    from conjure.experiments.plots import plot_learning_curves

    overrides = (*overrides, *((f"seeds={seeds}",) if seeds is not None else ()))
    experiment = load_config(config, overrides)
    out_dir = out_dir or Path("results") / experiment.name
    console = Console()
    outcome = run_experiment(
        experiment,
        out_dir,
        max_workers=max_workers,
        max_memory=max_memory,
        progress=not quiet,
        console=console,
    )
    if not outcome.results.empty:
        figure = plot_learning_curves(
            outcome.results,
            out_dir / "learning_curve.png",
            metric=experiment.metric,
            title=experiment.name,
        )
        console.print(f"Results in {out_dir}; learning curves in {figure}.")
    if outcome.errors:
        raise click.exceptions.Exit(1)


@main.command("list")
def list_command() -> None:
    """List every registered component (domains to cooperative planners) with its parameters."""
    from conjure.experiments import registry

    table = Table(title="conjure components (kind: use in configs as {kind, params})")
    table.add_column("layer", style="bold")
    table.add_column("kind", style="cyan")
    table.add_column("parameters (default)")
    for layer, components in registry.LAYERS.items():
        for position, (kind, cls) in enumerate(components.items()):
            lines = []
            for name, default in cls.param_defaults().items():
                shown = "required" if default is inspect.Parameter.empty else repr(default)
                constraint = cls.parameter_constraints.get(name)
                rule = f" — {constraint.describe()}" if constraint is not None else ""
                lines.append(f"{name} = {shown}{rule}")
            table.add_row(layer if position == 0 else "", kind, "\n".join(lines) or "(none)")
        table.add_section()
    Console().print(table)


@main.command("plot")
@click.argument("results_dir", type=click.Path(file_okay=False, path_type=Path))
@click.option("--metric", default="return", show_default=True, help="Curve column to plot.")
def plot_command(results_dir: Path, metric: str) -> None:
    """Plot learning curves of the experiment in RESULTS_DIR (mean ± 95% CI over seeds)."""
    from conjure.experiments.plots import plot_results_dir

    click.echo(f"Wrote {plot_results_dir(results_dir, metric=metric)}")


def _register_commands() -> None:
    """Add the sweep, tune, report and solve commands, which live beside their machinery."""
    from conjure.experiments.report import report_command
    from conjure.experiments.solve import solve_command
    from conjure.experiments.sweep import sweep_command
    from conjure.experiments.tune import tune_command

    for command in (sweep_command, tune_command, report_command, solve_command):
        main.add_command(command)


_register_commands()
