"""Checkpoint tables from the `results.parquet` that `conjure report DIR` writes.

    python docs/reproduction/tables.py DIR [--metric M] [--steps 10000 20000 50000 100000]
        [--by COLUMN ...]

Prints, per method (label and grid setting, or the columns given with --by), the mean metric
with a 95% Student-t half-width at the given learning steps, the mean area under the curve
(the selection criterion) and the mean final feature count, in conjure's number format (an
interval past the metric's range, e.g. the episode cap the runs recorded, cut there and shown
as ``mean [low, high]``). Uses DIR/selected/ (the fresh-seed rerun) when it exists.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import pandas as pd

from conjure.experiments.metric_ranges import metric_range
from conjure.experiments.numbers import format_interval, format_number
from conjure.experiments.results import t_confidence


def t_interval(values: np.ndarray, bounds: tuple[float, float]) -> str:
    """The mean with its 95% Student-t half-width (NaNs ignored), cut at the metric's range."""
    values = values[~np.isnan(values)]
    if not len(values):
        return "n/a"
    return format_interval(*t_confidence(values), bounds)


def table(results_dir: Path, metric: str | None, steps: list[int], by: list[str]) -> str:
    """Return the markdown checkpoint table of one sweep folder."""
    folder = results_dir / "selected" if (results_dir / "selected").is_dir() else results_dir
    frame = pd.read_parquet(folder / "results.parquet")
    if metric is None:
        import yaml

        metric = yaml.safe_load((results_dir / "config.resolved.yaml").read_text())["metric"]
    keys = by or [k for k in ("label", "setting") if k in frame.columns]
    frame = frame.assign(**{k: frame[k].fillna("").astype(str) for k in keys})
    rows = []
    for key, group in frame.groupby(keys, sort=False):
        key = key if isinstance(key, tuple) else (key,)
        row = dict(zip(keys, key, strict=True))
        row["n"] = group["seed"].nunique()
        bounds = metric_range(group, metric)
        for step in steps:
            at = group[group["learning_steps"] == step][metric].to_numpy(dtype=float)
            row[f"{metric} @ {step:,}"] = t_interval(at, bounds)
        auc = group.sort_values("learning_steps").groupby("seed")[metric].mean().to_numpy()
        row["AUC (mean over checks)"] = t_interval(auc, bounds)
        last = group[group["learning_steps"] == group["learning_steps"].max()]
        features = float(last["num_features"].mean())  # a count: whole unless seeds differ
        whole = features.is_integer()
        row["final features"] = f"{features:,.0f}" if whole else format_number(features)
        rows.append(row)
    out = pd.DataFrame(rows)
    header = "| " + " | ".join(out.columns) + " |\n|" + "---|" * len(out.columns) + "\n"
    body = "\n".join("| " + " | ".join(str(v) for v in r) + " |" for r in out.to_numpy())
    return header + body


def main() -> None:
    """Print the checkpoint table of the folder given."""
    parser = argparse.ArgumentParser()
    parser.add_argument("results_dir", type=Path)
    parser.add_argument("--metric", default=None)
    parser.add_argument("--steps", type=int, nargs="+", default=[10000, 20000, 50000, 100000])
    parser.add_argument("--by", nargs="*", default=[])
    args = parser.parse_args()
    print(table(args.results_dir, args.metric, args.steps, args.by))


if __name__ == "__main__":
    main()
