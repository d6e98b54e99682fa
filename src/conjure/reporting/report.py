"""``conjure report DIR``: a sweep's table (Parquet) and a markdown report with PNG figures.

The report holds, per domain: learning curves per method (mean over seeds with a 95%
Student-t band), the number of features over learning (as Figs. 4-4 and 4-9 of Geramifard
(2012)), a final-performance table (mean with a 95% t-interval, and the interquartile mean
(IQM) with a 95% stratified-bootstrap interval, by rliable), and wall time and learning steps
per second per method. With a grid selection it adds the chosen settings and the report of
their fresh-seed rerun (``selected/report.md``).

Notes
-----
- Choice: the IQM and its interval are `conjure.reporting.statistics.iqm_interval` (rliable:
  the mean of the middle 50% of runs, robust to a few outlying seeds, with the percentile
  interval of a bootstrap over runs, `DEFAULT_REPS` resamples, seed 0), over the runs whose
  value is finite, as the mean's t-interval is; a method with one such run has no interval.
- Choice: a method is an agent label plus its grid setting, so every grid point is one line.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import click
import numpy as np
import pandas as pd

from conjure.core.errors import InvalidParameterError, write_failure
from conjure.experiments.metric_ranges import metric_range
from conjure.experiments.numbers import (
    format_estimate,
    format_interval,
    format_number,
    readable_setting,
)
from conjure.experiments.options import out_dir_option
from conjure.experiments.results import (
    ERRORS_DIR,
    RESULTS_FILE,
    RUNS_DIR,
    SELECTED_DIR,
    final_rows,
    has_finite_values,
    load_results,
    make_out_dir,
    missing_runs,
    read_resolved,
    read_run,
    results_name,
    t_confidence,
    write_atomic,
)
from conjure.reporting.plots import method_labels, plot_learning_curves
from conjure.reporting.statistics import iqm_interval

__all__ = [
    "collect",
    "report_command",
    "write_report",
]

REPORT_FILE = "report.md"


def collect(results_dir: str | Path) -> pd.DataFrame:
    """Combine the runs of ``results_dir`` into ``results.parquet`` and return the table."""
    results_dir = Path(results_dir)
    if not (results_dir / RUNS_DIR).is_dir():
        raise InvalidParameterError(
            f"No runs in {str(results_dir)!r}; run `conjure sweep CONFIG --out "
            f"{results_dir}` (or `conjure run`) first."
        )
    table = load_results(results_dir)
    write_atomic(results_dir / RESULTS_FILE, table.to_parquet(index=False))
    return table


def damaged_runs(results_dir: Path, present: set[str]) -> list[str]:
    """The ids of run files in ``results_dir`` that `collect` left out (failed checksum)."""
    absent = [p for p in sorted((results_dir / RUNS_DIR).glob("*.json")) if p.stem not in present]
    return [p.stem for p in absent if not _reads(p)]


def _reads(path: Path) -> bool:
    try:
        read_run(path)
    except InvalidParameterError:
        return False
    return True


def completeness(results_dir: Path, results: pd.DataFrame) -> tuple[str, pd.DataFrame | None]:
    """``"6 of 12 runs present"`` and the methods still missing runs (``planned.csv``)."""
    present = set(results["run_id"])
    missing = missing_runs(results_dir, present)
    if missing is None:
        return "", None
    total = len(present) + int(missing["missing"].sum())
    return f"{len(present)} of {total} runs present", (missing if len(missing) else None)


def _missing_lines(results_dir: Path, results: pd.DataFrame) -> list[str]:
    """The report's warning when the sweep is still running or was cut."""
    count, missing = completeness(results_dir, results)
    if missing is None:
        return []
    lines = [f"**Incomplete: {count}** (the sweep is running or was cut; rerun it to resume)."]
    lines += ["", "Methods with missing runs:", ""]
    lines += [f"- {_incomplete(row)}" for row in missing.to_dict("records")]
    return [*lines, ""]


def _damaged_lines(results: pd.DataFrame) -> list[str]:
    """The report's warning on run files left out because they fail their checksum."""
    damaged = results.attrs.get("damaged_runs") or []
    if not damaged:
        return []
    return [
        f"**{len(damaged)} run file(s) fail their checksum and are left out** "
        f"({', '.join(damaged)}); run the command that wrote these results again to redo them.",
        "",
    ]


def _incomplete(row: dict[str, Any]) -> str:
    """``"long sarsa [step_size=0.1]: 2 of 4 missing"``: a method setting that misses runs."""
    method = " ".join(str(row[k]) for k in ("domain_label", "label") if row.get(k))
    setting = f" [{row['setting']}]" if row.get("setting") else ""
    return f"{method}{setting}: {row['missing']} of {row['planned']} missing"


def _markdown_table(frame: pd.DataFrame) -> str:
    header = "| " + " | ".join(str(c) for c in frame.columns) + " |"
    rule = "|" + "|".join("---" for _ in frame.columns) + "|"
    body = ["| " + " | ".join(str(v) for v in row) + " |" for row in frame.itertuples(False)]
    return "\n".join([header, rule, *body])


def _rate(value: float) -> str:
    return "n/a" if not math.isfinite(value) else f"{value:,.0f}"


#: The safety columns of the final table (Section 5.4), shown when they have a finite value.
SAFETY_COLUMNS = {
    "failure_rate": "failure rate",
    "optimality": "optimality",
    "value_ratio": "V/V*",
}


def _mean_interval(group: pd.DataFrame, column: str) -> str:
    """The mean of ``column`` over ``group``'s runs with its 95% t-interval, cut at its range."""
    mean, half = t_confidence(group[column].to_numpy(dtype=float))
    return format_interval(mean, half, metric_range(group, column))


def _finite_mean(values: pd.Series) -> float:
    """The mean of the finite values (NaN, without a warning, when there is none)."""
    return t_confidence(values.to_numpy(dtype=float))[0]


def _iqm_text(values: np.ndarray) -> str:
    """``IQM [low, high]`` of the finite ``values``, each to 4 significant digits."""
    finite = values[np.isfinite(values)]
    if finite.size == 0:
        return "n/a"
    point, low, high = iqm_interval(finite)
    return format_estimate(point, low, high)


def _final_table(finals: pd.DataFrame, metric: str) -> pd.DataFrame:
    safety = [c for c in SAFETY_COLUMNS if c != metric and has_finite_values(finals, c)]
    has_failures = has_finite_values(finals, "learning_failures")
    rows = []
    for method, group in finals.groupby("method", sort=False):
        values = group[metric].to_numpy(dtype=float)
        row = {
            "method": method,
            "runs": len(values),
            f"mean {metric} ± 95% t": _mean_interval(group, metric),
            f"IQM {metric} [95% bootstrap]": _iqm_text(values),
            "final features": f"{group['num_features'].mean():,.0f}",
        }
        for column in safety:
            row[f"final {SAFETY_COLUMNS[column]} ± 95% t"] = _mean_interval(group, column)
        if has_failures:
            row["learning failures"] = format_number(_finite_mean(group["learning_failures"]))
        rows.append(row)
    return pd.DataFrame(rows)


def _timing_table(finals: pd.DataFrame) -> pd.DataFrame:
    rows = []
    for method, group in finals.groupby("method", sort=False):
        rows.append(
            {
                "method": method,
                "runs": len(group),
                "run wall time (s)": format_number(_finite_mean(group["run_seconds"])),
                "learning wall time (s)": format_number(float(group["wall_time_s"].mean())),
                "learning steps/s": _rate(_finite_mean(group["steps_per_second"])),
            }
        )
    return pd.DataFrame(rows)


def _file_name(text: str) -> str:
    return "".join(c if c.isalnum() or c in "-_." else "_" for c in text)


def write_report(
    results_dir: str | Path, *, metric: str | None = None, out_dir: str | Path | None = None
) -> Path:
    """Write ``report.md`` and its figures for the sweep or experiment in ``results_dir``.

    Parameters
    ----------
    results_dir : str or Path
        A folder written by `conjure.sweeps.sweep.run_sweep` (or ``run_experiment``).
    metric : str or None
        The curve column reported; default the sweep's ``metric``, else ``return``.
    out_dir : str or Path or None
        Where to write the report and figures (default ``results_dir``).

    Returns
    -------
    Path
        The markdown report.
    """
    results_dir = Path(results_dir)
    out_dir = make_out_dir(out_dir if out_dir is not None else results_dir)
    resolved = read_resolved(results_dir)
    metric = metric or resolved.get("metric") or "return"
    results = collect(results_dir)
    _check_metric(results, metric, results_dir)
    name = results_name(results_dir)
    errors = sorted((results_dir / ERRORS_DIR).glob("*.txt"))
    lines = [
        f"# Report: {name}",
        "",
        *_missing_lines(results_dir, results),
        *_damaged_lines(results),
        f"{results['run_id'].nunique()} finished runs, "
        + (f"{len(errors)} failed (tracebacks in `{ERRORS_DIR}/`)" if errors else "none failed")
        + "; seeds per method shown as `n`. Curves are means over seeds with 95% confidence "
        "bands (Student t), cut at what each metric can be (a rate within [0, 1], an episode "
        "no longer than the domain's cap, a return within the bounds its domain declares, "
        "if any: `value_bounds`, `return_bounds`; other returns are not cut); in the "
        "tables an interval so cut reads `mean [low, high]`. The final performance is the "
        "last policy check.",
        "",
    ]
    domains = (
        list(results.groupby("domain_label", sort=False))
        if "domain_label" in results.columns
        else [(None, results)]
    )
    for domain, frame in domains:
        lines += _domain_lines(frame, domain, metric, name, out_dir)
    lines += _selection_lines(results_dir, results, metric, resolved)
    if errors:
        lines += ["## Failed runs", ""]
        lines += [f"- `{ERRORS_DIR}/{path.name}`" for path in errors]
        lines.append("")
    return write_atomic(out_dir / REPORT_FILE, "\n".join(lines))


def _check_metric(results: pd.DataFrame, metric: str, results_dir: Path) -> None:
    """Raise `InvalidParameterError` unless ``results`` has finite values of ``metric``."""
    if results.empty:
        raise InvalidParameterError(f"No finished runs in {str(results_dir)!r} to report.")
    if metric not in results.columns:
        raise InvalidParameterError(
            f"Unknown metric {metric!r}; the results have columns {', '.join(results.columns)}."
        )
    if not has_finite_values(results, metric):
        raise InvalidParameterError(
            f"The metric {metric!r} has no finite value in the results of "
            f"{str(results_dir)!r} (optimality needs a domain with value_bounds()); report "
            f"another metric with --metric."
        )


def _domain_lines(
    frame: pd.DataFrame, domain: str | None, metric: str, name: str, out_dir: Path
) -> list[str]:
    """The report's section of one domain: its plots and tables."""
    lines = [] if domain is None else [f"## Domain {domain}", ""]
    if not has_finite_values(frame, metric):
        return [*lines, f"No finite {metric} on this domain (skipped).", ""]
    tag = "" if domain is None else f"_{_file_name(str(domain))}"
    title = name if domain is None else f"{name} / {domain}"
    frame = frame.assign(method=method_labels(frame, abbreviate=False))
    plotted = frame.assign(label=method_labels(frame))
    figures = out_dir / "figures"
    curve = plot_learning_curves(
        plotted, figures / f"learning_curve_{metric}{tag}.png", metric=metric, title=title
    )
    features = plot_learning_curves(
        plotted, figures / f"features{tag}.png", metric="num_features", title=title
    )
    finals = final_rows(frame)
    return [
        *lines,
        f"![learning curves]({curve.relative_to(out_dir).as_posix()})",
        "",
        f"![feature counts]({features.relative_to(out_dir).as_posix()})",
        "",
        "Final performance:",
        "",
        _markdown_table(_final_table(finals, metric)),
        "",
        "Wall time and speed (per run; learning time excludes policy checks):",
        "",
        _markdown_table(_timing_table(finals)),
        "",
    ]


def _selection_table(selection: pd.DataFrame, results: pd.DataFrame, metric: str) -> pd.DataFrame:
    """``selection.csv`` to read: the score as one interval (cut at the metric's range).

    The setting's whole numbers get separators (`readable_setting`); the file keeps its key.
    """
    bounds = metric_range(results, metric)
    # Read as text (a setting may be empty): an empty half-width (one seed) becomes NaN.
    means, halves = (
        pd.to_numeric(selection[c], errors="coerce") for c in ("score_mean", "score_ci95")
    )
    scores = [format_interval(mean, half, bounds) for mean, half in zip(means, halves, strict=True)]
    table = selection.drop(columns=["score_mean", "score_ci95"])
    table["setting"] = table["setting"].astype(str).map(readable_setting)
    table.insert(table.columns.get_loc("criterion") + 1, "score ± 95% t", scores)
    return table


def _selection_lines(
    results_dir: Path, results: pd.DataFrame, metric: str, resolved: dict[str, Any]
) -> list[str]:
    """The report's section on a grid selection: the chosen settings and their rerun."""
    selection = results_dir / "selection.csv"
    if not selection.is_file():
        return []
    chosen = pd.read_csv(selection, keep_default_na=False)
    lines = ["## Selected settings", "", _markdown_table(_selection_table(chosen, results, metric))]
    selected = results_dir / SELECTED_DIR
    if (selected / RUNS_DIR).is_dir():
        sub = write_report(selected, metric=metric).relative_to(results_dir).as_posix()
        lines += ["", f"Rerun on fresh seeds: [{sub}]({sub})."]
    elif (resolved.get("selection") or {}).get("fresh_seeds") in (0, []):
        lines += [
            "",
            "No rerun on fresh seeds (`fresh_seeds: 0`): the scores are those of the search "
            "seeds, which the choice biases upward.",
        ]
    return [*lines, ""]


@click.command("report")
@click.argument("results_dir", type=click.Path(file_okay=False, path_type=Path))
@click.option("--metric", default=None, help="Curve column to report (default the sweep's).")
@out_dir_option("Where to write report.md and figures/ (default RESULTS_DIR).")
def report_command(results_dir: Path, metric: str | None, out_dir: Path | None) -> None:
    """Collect the runs in RESULTS_DIR into results.parquet and write report.md with figures."""
    try:
        path = write_report(results_dir, metric=metric, out_dir=out_dir)
    except OSError as exc:
        kept = f"the runs in {Path(results_dir) / RUNS_DIR} are untouched."
        raise write_failure(exc, kept) from None
    present = pd.read_parquet(Path(results_dir) / RESULTS_FILE, columns=["run_id"])
    damaged = damaged_runs(Path(results_dir), set(present["run_id"]))
    if damaged:
        click.echo(
            f"Left out {len(damaged)} run file(s) that fail their checksum ("
            f"{', '.join(damaged[:5])}{', ...' if len(damaged) > 5 else ''}); the command that "
            f"wrote {results_dir} redoes them when run again."
        )
    count, missing = completeness(Path(results_dir), present)
    if missing is not None:
        methods = "; ".join(_incomplete(row) for row in missing.to_dict("records"))
        click.echo(f"Incomplete: {count}; runs missing for {methods}.")
    click.echo(f"Wrote {path} and {Path(results_dir) / RESULTS_FILE}")
