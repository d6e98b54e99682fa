"""Experiment results on disk: one folder per run, a combined table and a summary.

Layout of an experiment folder::

    OUT/config.resolved.yaml                 the experiment, every default filled in
    OUT/runs/<label>/seed_<k>/config.resolved.yaml
    OUT/runs/<label>/seed_<k>/curve.csv      written last: its presence marks a finished run
    OUT/runs/<label>/seed_<k>/error.txt      the traceback of a failed run
    OUT/results.parquet                      label, seed, curve columns, agent parameters
    OUT/summary.csv                          per label: final return ± 95% CI, features, steps/s

Every file is written atomically (temporary file, fsync, ``os.replace``), so killing an
experiment loses no finished run and never leaves a half-written file under its real name.
"""

from __future__ import annotations

import math
import os
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import yaml
from scipy import stats

from conjure.core.errors import InvalidParameterError
from conjure.experiments.config import config_hash, dump_yaml
from conjure.experiments.run import Result

__all__ = [
    "CURVE_FILE",
    "ERROR_FILE",
    "PARTIAL_CURVE_FILE",
    "RESOLVED_FILE",
    "RESULTS_FILE",
    "SUMMARY_FILE",
    "flatten_params",
    "is_run_done",
    "load_results",
    "remove_stale_temporaries",
    "run_dir",
    "save_run",
    "save_run_error",
    "summarize",
    "t_confidence",
    "write_atomic",
    "write_results",
]

CURVE_FILE = "curve.csv"
PARTIAL_CURVE_FILE = "curve.partial.csv"
ERROR_FILE = "error.txt"
RESOLVED_FILE = "config.resolved.yaml"
RESULTS_FILE = "results.parquet"
SUMMARY_FILE = "summary.csv"
_TEMP_MARK = ".tmp-"


def write_atomic(path: str | Path, data: str | bytes) -> Path:
    """Write ``data`` to ``path`` via a fsynced temporary file and ``os.replace``."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    temp = path.with_name(f".{path.name}{_TEMP_MARK}{os.getpid()}")
    payload = data.encode() if isinstance(data, str) else data
    with open(temp, "wb") as handle:
        handle.write(payload)
        handle.flush()
        os.fsync(handle.fileno())
    os.replace(temp, path)
    return path


def remove_stale_temporaries(out_dir: str | Path) -> int:
    """Delete temporary files a killed experiment left behind; return how many."""
    removed = 0
    for temp in Path(out_dir).rglob(f".*{_TEMP_MARK}*"):
        temp.unlink(missing_ok=True)
        removed += 1
    return removed


def run_dir(out_dir: str | Path, label: str, seed: int) -> Path:
    """Return the folder of run (``label``, ``seed``)."""
    return Path(out_dir) / "runs" / label / f"seed_{seed}"


def is_run_done(directory: str | Path, run_spec: Mapping[str, Any]) -> bool:
    """Whether ``directory`` holds a finished run of exactly ``run_spec`` (same config hash)."""
    directory = Path(directory)
    curve, resolved = directory / CURVE_FILE, directory / RESOLVED_FILE
    if not (curve.is_file() and resolved.is_file()):
        return False
    try:
        stored = yaml.safe_load(resolved.read_text())
    except yaml.YAMLError:
        return False
    return isinstance(stored, dict) and config_hash(stored) == config_hash(dict(run_spec))


def save_run(result: Result, directory: str | Path) -> Path:
    """Write a finished run: its resolved config, then its curve (the 'finished' mark)."""
    directory = Path(directory)
    if result.config is not None:
        write_atomic(directory / RESOLVED_FILE, dump_yaml(result.config))
    write_atomic(directory / CURVE_FILE, result.curve.to_csv(index=False))
    for stale in (ERROR_FILE, PARTIAL_CURVE_FILE):
        (directory / stale).unlink(missing_ok=True)
    return directory


def save_run_error(
    directory: str | Path,
    run_spec: Mapping[str, Any],
    traceback_text: str,
    partial: Result | None = None,
) -> Path:
    """Record a failed run: its config, ``error.txt`` and any partial curve."""
    directory = Path(directory)
    write_atomic(directory / RESOLVED_FILE, dump_yaml(dict(run_spec)))
    if partial is not None:
        write_atomic(directory / PARTIAL_CURVE_FILE, partial.curve.to_csv(index=False))
    (directory / CURVE_FILE).unlink(missing_ok=True)
    return write_atomic(directory / ERROR_FILE, traceback_text)


def flatten_params(spec: Mapping[str, Any], prefix: str) -> dict[str, Any]:
    """Flatten a ``{kind, params}`` tree into ``{prefix: kind, prefix.param: value, ...}``.

    Examples
    --------
    >>> flatten_params({"kind": "SARSA", "params": {"step_size": 0.1,
    ...     "policy": {"kind": "EpsilonGreedy", "params": {"epsilon": 0.1}}}}, "agent")
    {'agent': 'SARSA', 'agent.step_size': 0.1, 'agent.policy': 'EpsilonGreedy', 'agent.policy.epsilon': 0.1}
    """  # noqa: E501
    flat: dict[str, Any] = {prefix: spec.get("kind")}
    for name, value in (spec.get("params") or {}).items():
        key = f"{prefix}.{name}"
        if isinstance(value, Mapping) and "kind" in value:
            flat.update(flatten_params(value, key))
        else:
            flat[key] = value
    return flat


def _normalize_column(column: pd.Series) -> pd.Series:
    values = [v for v in column if v is not None and not (isinstance(v, float) and math.isnan(v))]
    if all(isinstance(v, (bool, np.bool_)) for v in values) and values:
        return column.astype("boolean")
    if all(isinstance(v, (int, float, np.number)) and not isinstance(v, bool) for v in values):
        return pd.to_numeric(column)
    return column.map(lambda v: None if v is None else str(v)).astype("string")


def load_results(
    out_dir: str | Path, runs: Iterable[tuple[str, int]] | None = None
) -> pd.DataFrame:
    """Combine finished runs into one table: label, seed, curve columns, agent parameters.

    Parameters
    ----------
    out_dir : str or Path
        The experiment folder.
    runs : iterable of (label, seed), optional
        Which runs to read; default every finished run under ``out_dir/runs``.
    """
    out_dir = Path(out_dir)
    if runs is None:
        found = sorted(out_dir.glob(f"runs/*/seed_*/{CURVE_FILE}"))
        runs = [(p.parent.parent.name, int(p.parent.name.removeprefix("seed_"))) for p in found]
    frames, param_rows = [], []
    for label, seed in runs:
        directory = run_dir(out_dir, label, seed)
        if not (directory / CURVE_FILE).is_file():
            continue
        curve = pd.read_csv(directory / CURVE_FILE)
        curve.insert(0, "seed", int(seed))
        curve.insert(0, "label", label)
        resolved_path = directory / RESOLVED_FILE
        params: dict[str, Any] = {}
        if resolved_path.is_file():
            resolved = yaml.safe_load(resolved_path.read_text()) or {}
            if isinstance(resolved.get("agent"), Mapping):
                params = flatten_params(resolved["agent"], "agent")
        frames.append(curve)
        param_rows.append((len(curve), params))
    if not frames:
        return pd.DataFrame(columns=["label", "seed"])
    keys: list[str] = []
    for _, params in param_rows:
        keys.extend(k for k in params if k not in keys)
    columns = {key: [params.get(key) for n, params in param_rows for _ in range(n)] for key in keys}
    table = pd.concat(frames, ignore_index=True)
    extra = pd.DataFrame(columns, index=table.index)
    for key in keys:
        extra[key] = _normalize_column(extra[key])
    return pd.concat([table, extra], axis=1)


def t_confidence(values: Iterable[float], level: float = 0.95) -> tuple[float, float]:
    """Return the mean and the Student-t confidence half-width (NaN for fewer than 2 values).

    Examples
    --------
    >>> mean, half = t_confidence([1.0, 2.0, 3.0])
    >>> round(mean, 3), round(half, 3)
    (2.0, 2.484)
    """
    array = np.asarray(list(values), dtype=np.float64)
    array = array[np.isfinite(array)]
    if array.size == 0:
        return math.nan, math.nan
    mean = float(array.mean())
    if array.size < 2:
        return mean, math.nan
    sem = float(array.std(ddof=1)) / math.sqrt(array.size)
    return mean, float(stats.t.ppf(0.5 + level / 2, array.size - 1)) * sem


def summarize(results: pd.DataFrame, metric: str = "return") -> pd.DataFrame:
    """Per label, the final policy check over seeds: mean ``metric`` ± 95% t half-width, etc."""
    columns = [
        "label",
        "num_seeds",
        f"final_{metric}_mean",
        f"final_{metric}_ci95",
        "final_num_features",
        "mean_steps_per_second",
    ]
    if results.empty:
        return pd.DataFrame(columns=columns)
    if metric not in results.columns:
        raise InvalidParameterError(
            f"Unknown metric {metric!r}; the results have columns {', '.join(results.columns)}."
        )
    rows = []
    for label, group in results.groupby("label", sort=False):
        finals = group.loc[group.groupby("seed")["learning_steps"].idxmax()]
        mean, half = t_confidence(finals[metric])
        rows.append(
            (
                label,
                len(finals),
                mean,
                half,
                float(finals["num_features"].mean()),
                float(np.nanmean(finals["steps_per_second"].to_numpy(dtype=float))),
            )
        )
    return pd.DataFrame(rows, columns=columns)


def write_results(out_dir: str | Path, results: pd.DataFrame, summary: pd.DataFrame) -> None:
    """Write ``results.parquet`` and ``summary.csv`` atomically."""
    out_dir = Path(out_dir)
    write_atomic(out_dir / RESULTS_FILE, results.to_parquet(index=False))
    write_atomic(out_dir / SUMMARY_FILE, summary.to_csv(index=False))
