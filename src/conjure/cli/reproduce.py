"""``conjure reproduce``: run a thesis figure's shipped config and compare it with the thesis.

::

    conjure reproduce --list
    conjure reproduce fig_5_8 --scale quick
    conjure reproduce fig_5_5 fig_5_8 --scale thesis --out runs/chapter5 --max-workers 2
    conjure reproduce --all --scale quick

Each figure runs through `conjure.sweeps.sweep.run_sweep` (so a rerun resumes: finished runs
are never run again) at the scale `conjure.sweeps.reproduction` defines, and its folder gets,
beside the sweep's own files, the figure's plots (``FIG_<metric>.png``), ``summary.csv`` (per
method, each final metric's mean, 95% t half-width and interval) and ``comparison.md`` (each
claim: the thesis's value, the measured value with its 95% interval, and whether it holds).

Notes
-----
- Choice: the command exits 0 once a figure's claims are computed, even where runs failed
  (grid settings that diverge, listed one line per setting; their tracebacks are in the
  ``errors`` folders); a figure with no finished run is an error (exit status 2).
- Choice: the default folder is ``runs/reproduce/FIG`` at the thesis scale and
  ``runs/reproduce/FIG_quick`` at the quick scale, so the two scales never share a
  ``summary.csv``; ``--out DIR`` is the figure's folder for one figure and holds one folder per
  figure (``DIR/FIG``) for several.
- Choice: at the thesis scale the comparison uses the fresh-seed rerun of the selected settings
  (``DIR/selected``), as the reproduction pages of the docs do; ``DIR/summary.csv`` then
  replaces the sweep's per-setting search summary (the choice is in ``DIR/selection.csv``).
- Choice: the configs are looked up under the current folder's ``examples/reproduction``,
  else among the configs shipped in the package (`conjure.experiments.shipped`).
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import click

from conjure.core.errors import InvalidParameterError
from conjure.experiments.options import (
    max_memory_option,
    max_workers_option,
    out_dir_option,
    overrides_option,
)
from conjure.sweeps.reproduction import SCALES

if TYPE_CHECKING:
    from rich.console import Console

__all__ = ["default_out_dir", "reproduce_command", "reproduction_root"]

#: Where the shipped configs live, relative to a checkout.
CONFIG_DIR = Path("examples") / "reproduction"


def reproduction_root() -> Path:
    """The folder that holds ``examples/reproduction``: the current one, else the package's."""
    from conjure.experiments.shipped import EXAMPLES_DIR

    return Path.cwd() if (Path.cwd() / CONFIG_DIR).is_dir() else EXAMPLES_DIR.parent


def default_out_dir(name: str, scale: str) -> Path:
    """``runs/reproduce/FIG`` (thesis scale) or ``runs/reproduce/FIG_quick``."""
    return Path("runs") / "reproduce" / (name if scale == "thesis" else f"{name}_{scale}")


@click.command("reproduce")
@click.argument("figures", nargs=-1)
@click.option(
    "--list", "show_list", is_flag=True, help="List the figures, configs and costs (default: off)."
)
@click.option("--all", "run_all", is_flag=True, help="Run every figure (default: off).")
@click.option(
    "--scale",
    type=click.Choice(SCALES),
    default="quick",
    show_default=True,
    help="quick (3 seeds, the selected settings) or thesis (the config as shipped).",
)
@out_dir_option("Results folder (default runs/reproduce/FIG, or FIG_quick at the quick scale).")
@max_workers_option
@max_memory_option
@overrides_option(
    "Override a config value after the scale, as `conjure sweep --set` (repeatable; default: none)."
)
@click.option("--quiet", is_flag=True, help="No progress bar or summary table (default: shown).")
def reproduce_command(
    figures: tuple[str, ...],
    show_list: bool,
    run_all: bool,
    scale: str,
    out_dir: Path | None,
    max_workers: int | None,
    max_memory: int | None,
    overrides: tuple[str, ...],
    quiet: bool,
) -> None:
    """Rerun thesis figures and compare them with the thesis.

    Runs each FIGURE's shipped config at --scale; writes its plots, summary.csv and
    comparison.md. `conjure reproduce --list` names the figures.
    """
    from rich.console import Console

    from conjure.sweeps.reproduction import FIGURES, figure_names

    console = Console()
    if show_list:
        console.print(_figures_table())
        console.print(_list_notes(), markup=False)
        return
    if run_all == bool(figures):
        raise InvalidParameterError(
            "Name the figures to reproduce (e.g. fig_5_8) or give --all; `conjure reproduce "
            "--list` shows them."
        )
    names = list(FIGURES) if run_all else figure_names(figures)
    for name in names:
        out = default_out_dir(name, scale) if out_dir is None else out_dir
        if out_dir is not None and len(names) > 1:
            out = out_dir / name
        _reproduce(
            name, scale, out, overrides, max_workers, max_memory, quiet=quiet, console=console
        )


def _reproduce(
    name: str,
    scale: str,
    out: Path,
    overrides: tuple[str, ...],
    max_workers: int | None,
    max_memory: int | None,
    *,
    quiet: bool,
    console: Console,
) -> None:
    """Run one figure into ``out`` and write its outputs.

    Failed runs (e.g. grid settings that diverge) do not fail the figure once its claims are
    computed from the runs that finished: the sweep lists them, one line per setting, and
    their tracebacks are in ``out/errors``. A figure with no finished run raises.
    """
    from conjure.experiments.executors import make_executor
    from conjure.experiments.results import has_finite_values, write_atomic
    from conjure.reporting.plots import plot_learning_curves
    from conjure.sweeps.reproduction import (
        FIGURES,
        comparison_markdown,
        finals_table,
        load_figure_sweep,
        summary_table,
    )
    from conjure.sweeps.sweep import run_sweep

    figure = FIGURES[name]
    sweep = load_figure_sweep(name, scale, reproduction_root(), overrides)
    engine = make_executor(
        "local",
        max_workers=max_workers or sweep.max_workers,
        max_memory=max_memory or sweep.max_memory,
    )
    with engine:
        outcome = run_sweep(sweep, out, executor=engine, progress=not quiet, console=console)
    final = outcome.selected if outcome.selected is not None else outcome
    results = final.results
    if results.empty:
        raise InvalidParameterError(f"{name}: no run finished; see {out}.")
    finals = finals_table(results, sweep.metric)
    write_atomic(out / "summary.csv", summary_table(finals).to_csv(index=False))
    comparison = comparison_markdown(name, finals, scale=scale)
    write_atomic(out / "comparison.md", comparison)
    plots = [
        plot_learning_curves(
            results, out / f"{name}_{metric}.png", metric=metric, title=figure.title
        )
        for metric in figure.plots
        if has_finite_values(results, metric)
    ]
    skipped = outcome.num_skipped + (outcome.selected.num_skipped if outcome.selected else 0)
    ran = len(outcome.runs) + (len(outcome.selected.runs) if outcome.selected else 0) - skipped
    if not quiet:
        from rich.markdown import Markdown

        console.print(Markdown(comparison))
    failed = len(outcome.errors) + (len(outcome.selected.errors) if outcome.selected else 0)
    console.print(
        f"{name} ({scale}): {ran} runs run, {skipped} already finished"
        + (f", {failed} failed (tracebacks in the errors folders under {out})" if failed else "")
        + f"; comparison.md, summary.csv and {len(plots)} plots in {out}.",
        markup=False,
    )


def _figures_table() -> Any:
    from rich.table import Table

    from conjure.sweeps.reproduction import FIGURES, SCALES, figure_cost

    root = reproduction_root()
    table = Table(title=f"Reproduced figures (config: {CONFIG_DIR}/FIGURE.yaml)")
    table.add_column("figure", style="cyan", no_wrap=True)
    table.add_column("claims", justify="right")
    for scale in SCALES:
        table.add_column(f"{scale}\nruns", justify="right")
        table.add_column(f"{scale}\nsteps", justify="right")
    for name, figure in FIGURES.items():
        cells = [name if figure.config == f"{CONFIG_DIR}/{name}.yaml" else figure.config]
        cells.append(str(len(figure.claims)))
        for scale in SCALES:
            runs, steps = figure_cost(name, scale, root)
            cells += [f"{runs:,}", _steps_text(steps)]
        table.add_row(*cells)
    return table


def _steps_text(steps: int) -> str:
    """Learning steps, short: ``2.7M``, ``150k``."""
    if steps >= 1_000_000:
        return f"{steps / 1e6:,.1f}M"
    return f"{steps / 1e3:,.0f}k"


def _list_notes() -> str:
    root = reproduction_root()
    others = sorted(
        path.stem
        for path in (root / CONFIG_DIR).glob("*.yaml")
        if not path.stem.startswith(("fig_", "ifdd_"))
    )
    lines = [
        "Cost: runs = per method, grid settings × search seeds, plus the selection's fresh "
        "seeds; steps = runs × budget_steps (learning steps; policy-check episodes not "
        "counted, no time given: speed per step differs 100x between workloads).",
        "quick: 3 seeds; a config with a selection drops its grid and runs the selected "
        "settings on its first 3 fresh seeds; budget unchanged.",
        "Fig. 3-15 is a batch evaluation, not a sweep: python docs/reproduction/fig_3_15.py.",
    ]
    if others:
        lines.append(
            f"Follow-up sweeps (not figures; `conjure sweep {CONFIG_DIR}/NAME.yaml`): "
            f"{', '.join(others)}."
        )
    return "\n".join(lines)
