"""The ``conjure`` command line: ``run``, ``list``, ``plot``, and the lazily loaded rest.

``sweep``, ``tune``, ``report``, ``solve`` and ``reproduce`` live beside their machinery and
are imported only when they run.

Examples
--------
::

    conjure run examples/pendulum.yaml --seeds 4 --set agents.tile_coding.params.step_size=0.05
    conjure run examples/pendulum.yaml --max-workers 2 --max-memory 2GiB
    conjure list
    conjure list planners
    conjure list --search cbba
    conjure plot results/pendulum --metric num_features
    conjure reproduce --list
    conjure reproduce fig_5_8 --scale quick

Any `ConjureError` (a bad config, an unknown kind, a full disk, ...) prints one clean line and
exits with status 2; failed runs inside an experiment are reported and give status 1; Ctrl-C
says how many runs are saved and exits with status 130.

Notes
-----
- Choice: start-up imports only click (``conjure --help`` must be quick): each command imports
  what it needs when it runs, and the commands that live in other modules are listed in
  `LAZY_COMMANDS` with their one-line help, loaded by name on use.
"""

from __future__ import annotations

import importlib
import inspect
from pathlib import Path
from typing import Any

import click

from conjure.core.errors import ConjureError, InvalidParameterError, RunsInterruptedError
from conjure.experiments.options import (
    max_memory_option,
    max_workers_option,
    out_dir_option,
    overrides_option,
)

__all__ = ["LAZY_COMMANDS", "main"]

#: Commands defined beside their machinery: name -> (module, attribute, one-line help).
LAZY_COMMANDS = {
    "sweep": (
        "conjure.sweeps.sweep",
        "sweep_command",
        "Run the sweep CONFIG (YAML); rerunning the same command resumes it.",
    ),
    "tune": (
        "conjure.sweeps.tune",
        "tune_command",
        "Tune the methods of CONFIG (a sweep YAML with a `search` section) with Optuna.",
    ),
    "report": (
        "conjure.reporting.report",
        "report_command",
        "Collect the runs in RESULTS_DIR into results.parquet and write report.md with figures.",
    ),
    "reproduce": (
        "conjure.cli.reproduce",
        "reproduce_command",
        "Rerun thesis figures and compare them with the thesis.",
    ),
    "solve": (
        "conjure.experiments.solve",
        "solve_command",
        "Solve the domain of CONFIG (a planner, or `exact`); print values and first moves.",
    ),
}


class _Group(click.Group):
    """A click group with lazily imported commands that turns a `ConjureError` into one line.

    The line goes to stderr; the exit status is the error's ``exit_status`` (2 for a bad
    config or a result that could not be written, 130 for Ctrl-C, as a shell reports it).
    """

    def list_commands(self, ctx: click.Context) -> list[str]:
        return sorted([*super().list_commands(ctx), *LAZY_COMMANDS])

    def get_command(self, ctx: click.Context, cmd_name: str) -> click.Command | None:
        if cmd_name in LAZY_COMMANDS and cmd_name not in self.commands:
            module, attribute, _ = LAZY_COMMANDS[cmd_name]
            self.add_command(getattr(importlib.import_module(module), attribute), cmd_name)
        return super().get_command(ctx, cmd_name)

    def format_commands(self, ctx: click.Context, formatter: click.HelpFormatter) -> None:
        rows = [(name, command.get_short_help_str()) for name, command in self.commands.items()]
        for name, (*_, text) in LAZY_COMMANDS.items():  # a stub formats help as click does
            if name not in self.commands:
                rows.append((name, click.Command(name, help=text).get_short_help_str()))
        if rows:
            with formatter.section("Commands"):
                formatter.write_dl(sorted(rows))

    def invoke(self, ctx: click.Context) -> Any:
        try:
            return super().invoke(ctx)
        except ConjureError as exc:
            message = " ".join(str(exc).split())
            prefix = "" if isinstance(exc, RunsInterruptedError) else "Error: "
            click.echo(f"{prefix}{message}", err=True)
            ctx.exit(getattr(exc, "exit_status", 2))
        except KeyboardInterrupt:  # outside any run (loading, reporting): nothing to save
            click.echo("Interrupted.", err=True)
            ctx.exit(130)


@click.group(cls=_Group)
@click.version_option(package_name="conjure")
def main() -> None:
    """Conjure: reinforcement learning after Geramifard (2012), from the command line."""


@main.command("run")
@click.argument("config", type=click.Path(dir_okay=False, path_type=Path))
@click.option(
    "--seeds",
    type=click.IntRange(min=1),
    default=None,
    help="Run seeds 0..N-1 (default: the config's seeds).",
)
@out_dir_option("Experiment folder (default results/<config name>).")
@overrides_option(
    "Override a config value, e.g. agents.sarsa.params.step_size=0.05 (repeatable; default: none)."
)
@max_workers_option
@max_memory_option
@click.option("--quiet", is_flag=True, help="No progress bar or summary table (default: shown).")
def run_command(
    config: Path,
    seeds: int | None,
    out_dir: Path | None,
    overrides: tuple[str, ...],
    max_workers: int | None,
    max_memory: int | None,
    quiet: bool,
) -> None:
    """Run the experiment CONFIG (a YAML file); finished runs in the folder are reused.

    CONFIG that names no file is looked up among the shipped examples (e.g. `pendulum`).
    """
    from rich.console import Console

    from conjure.experiments.display import phase

    console = Console()
    shown = None if quiet else console
    with phase(shown, "loading conjure and the config", keep=False):  # an error: one line
        from conjure.experiments.config import load_config
        from conjure.experiments.parallel import run_experiment
        from conjure.experiments.shipped import find_config
        from conjure.reporting.plots import curve_file_name, plot_learning_curves

        overrides = (*overrides, *((f"seeds={seeds}",) if seeds is not None else ()))
        experiment = load_config(find_config(config), overrides)
    out_dir = out_dir or Path("results") / experiment.name
    outcome = run_experiment(
        experiment,
        out_dir,
        max_workers=max_workers,
        max_memory=max_memory,
        progress=not quiet,
        console=console,
    )
    if not outcome.results.empty:
        with phase(shown, "plotting the learning curves"):
            figure = plot_learning_curves(
                outcome.results,
                out_dir / curve_file_name(experiment.metric),
                metric=experiment.metric,
                title=experiment.name,
            )
        console.print(f"Results in {out_dir}; learning curves in {figure}.")
    if outcome.errors:
        raise click.exceptions.Exit(1)


@main.command("list")
@click.argument("layer", required=False)
@click.option(
    "--search",
    default=None,
    help="Only kinds or parameters containing this text (default: all).",
)
def list_command(layer: str | None, search: str | None) -> None:
    """List the components: layers with their kinds, or one LAYER's (or --search's) parameters."""
    from rich.console import Console

    from conjure.experiments import registry

    console = Console()
    if layer is None and search is None:
        console.print(_layers_table(registry.LAYERS))
        console.print(
            "Parameters: conjure list LAYER (e.g. conjure list planners), or conjure list "
            "--search TEXT (e.g. --search cbba).",
            markup=False,
        )
        return
    layers = registry.LAYERS if layer is None else {_layer_name(layer): None}
    rows = [
        (name, kind, cls)
        for name in layers
        for kind, cls in registry.LAYERS[name].items()
        if search is None or _matches(search, kind, cls)
    ]
    if not rows:
        where = f" in layer {layer!r}" if layer is not None else ""
        raise InvalidParameterError(
            f"No component{where} matches --search {search!r}; `conjure list` shows every kind."
        )
    console.print(_components_table(rows))


def _layer_name(name: str) -> str:
    """The `registry.LAYERS` key of ``name`` (singular or plural, ``-`` or ``_``)."""
    from conjure.core.params import did_you_mean
    from conjure.experiments import registry

    key = name.lower().replace("-", "_")
    aliases = {layer: layer for layer in registry.LAYERS}
    aliases.update({f"{layer}s": layer for layer in registry.LAYERS})
    aliases.update({"policies": "policy", "risks": "risk", "risk_analyzers": "risk"})
    if key not in aliases:
        raise InvalidParameterError(
            f"Unknown layer {name!r}.{did_you_mean(key, list(aliases))} Known: "
            f"{', '.join(registry.LAYERS)} (or their plurals)."
        )
    return aliases[key]


def _matches(text: str, kind: str, cls: Any) -> bool:
    """Whether ``text`` occurs (any case) in ``kind`` or in one of its parameter names."""
    needle = text.lower()
    return needle in kind.lower() or any(needle in name.lower() for name in cls.param_defaults())


def _layers_table(layers: dict[str, Any]) -> Any:
    from rich.table import Table

    table = Table(title="conjure components (use a kind in configs as {kind, params})")
    table.add_column("layer", style="bold")
    table.add_column("count", justify="right")
    table.add_column("kinds", style="cyan")
    for name, components in layers.items():
        table.add_row(name, str(len(components)), ", ".join(components))
    return table


def _components_table(rows: list[tuple[str, str, Any]]) -> Any:
    from rich.table import Table

    table = Table(title="conjure components (kind: use in configs as {kind, params})")
    table.add_column("layer", style="bold")
    table.add_column("kind", style="cyan")
    table.add_column("parameters (default)")
    previous = None
    for layer, kind, cls in rows:
        if previous is not None and layer != previous:
            table.add_section()
        lines = []
        for name, default in cls.param_defaults().items():
            shown = "required" if default is inspect.Parameter.empty else repr(default)
            constraint = cls.parameter_constraints.get(name)
            rule = f" — {constraint.describe()}" if constraint is not None else ""
            lines.append(f"{name} = {shown}{rule}")
        table.add_row(layer if layer != previous else "", kind, "\n".join(lines) or "(none)")
        previous = layer
    return table


@main.command("plot")
@click.argument("results_dir", type=click.Path(file_okay=False, path_type=Path))
@click.option(
    "--metric",
    default=None,
    help="Curve column to plot (default: the metric the experiment's config chose).",
)
@click.option(
    "--panels",
    is_flag=True,
    help="One panel per method, for overlapping bands (default: off, one axes).",
)
def plot_command(results_dir: Path, metric: str | None, panels: bool) -> None:
    """Plot learning curves of the experiment in RESULTS_DIR (mean ± 95% CI over seeds)."""
    from conjure.reporting.plots import plot_results_dir

    click.echo(f"Wrote {plot_results_dir(results_dir, metric=metric, panels=panels)}")
