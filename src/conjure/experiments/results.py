"""Experiment and sweep results on disk: one file per run, named by its config hash.

Layout of a results folder (an experiment or a sweep)::

    OUT/config.resolved.yaml        the experiment or sweep, every default filled in
    OUT/run_ids.txt                 the ids of the runs the last command asked for
    OUT/runs/<run_id>.json          one finished run: its resolved config and its curve
    OUT/errors/<run_id>.txt         the traceback of a failed run (its config at the top)
    OUT/errors/<run_id>.partial.csv the curve a diverged run recorded before it stopped
    OUT/results.parquet             every finished run: one row per policy check
    OUT/summary.csv                 per method: final metric, its 95% CI, features, steps/s

A run's id is `run_id` (the `config_hash` of its resolved config), so a run is finished if and
only if ``runs/<run_id>.json`` exists and is intact: resume needs no other bookkeeping, a
changed config gets a new id, and no run can be stored twice. Every file is written atomically
(`conjure.core.files.write_atomic`: temporary file, fsync, ``os.replace``, fsync of the
folder), so killing the process at any moment loses no finished run and never leaves a
half-written file under its real name.

Each run file carries ``checksum``, the SHA-256 of its other fields (`run_checksum`). A run
file whose checksum does not match (edited by hand, damaged on disk, or written before run
files had one) is not a finished run: a resume redoes it and says so (`run_file_problem`),
and `load_results` leaves it out and lists it in ``attrs["damaged_runs"]``.
"""

from __future__ import annotations

import hashlib
import json
import math
import socket
import time
import uuid
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from scipy import stats

from conjure.core.errors import InvalidParameterError
from conjure.core.files import TEMP_MARK as _TEMP_MARK
from conjure.core.files import write_atomic
from conjure.experiments.claims import process_exists
from conjure.experiments.config import config_hash, dump_yaml, load_yaml
from conjure.experiments.metric_ranges import DOMAIN_BOUND_COLUMNS, clip_interval, metric_range
from conjure.experiments.numbers import format_value

__all__ = [
    "ERRORS_DIR",
    "GROUP_COLUMNS",
    "RESOLVED_FILE",
    "RESULTS_FILE",
    "RUNS_DIR",
    "RUN_IDS_FILE",
    "SELECTED_DIR",
    "SUMMARY_FILE",
    "describe_setting",
    "error_path",
    "final_rows",
    "flatten_params",
    "group_columns",
    "has_finite_values",
    "is_run_done",
    "load_results",
    "make_out_dir",
    "missing_runs",
    "read_resolved",
    "read_run",
    "read_run_ids",
    "remove_stale_temporaries",
    "results_name",
    "run_checksum",
    "run_file_problem",
    "run_id",
    "run_path",
    "save_run",
    "save_run_error",
    "summarize",
    "t_confidence",
    "write_atomic",
    "write_planned_runs",
    "write_results",
    "write_run_ids",
]

RUNS_DIR = "runs"
ERRORS_DIR = "errors"
RESOLVED_FILE = "config.resolved.yaml"
RUN_IDS_FILE = "run_ids.txt"
PLANNED_FILE = "planned.csv"
RESULTS_FILE = "results.parquet"
SUMMARY_FILE = "summary.csv"
#: The subfolder of a sweep's rerun of its chosen settings on fresh seeds.
SELECTED_DIR = "selected"
#: The run-config keys that identify a method's setting, in grouping order (when present).
GROUP_COLUMNS = ("domain_label", "label", "setting")
_FOREIGN_TEMP_SECONDS = 3600.0


def make_out_dir(out_dir: str | Path) -> Path:
    """Create the results folder ``out_dir`` (and its parents) and check that files can go there.

    Raises
    ------
    InvalidParameterError
        Naming the folder and the reason (a file of that name, a read-only or virtual file
        system such as /proc, no permission), before any run starts.

    Examples
    --------
    >>> import tempfile
    >>> make_out_dir(Path(tempfile.mkdtemp()) / "a" / "b").is_dir()
    True
    >>> make_out_dir("/proc/results")
    Traceback (most recent call last):
    ...
    conjure.core.errors.InvalidParameterError: Cannot write results to '/proc/results': No such file or directory.
    """  # noqa: E501
    out_dir = Path(out_dir)
    if out_dir.exists() and not out_dir.is_dir():
        raise InvalidParameterError(
            f"Cannot write results to {str(out_dir)!r}: it is a file, not a folder."
        )
    try:
        out_dir.mkdir(parents=True, exist_ok=True)
        probe = out_dir / f"{_TEMP_MARK}{uuid.uuid4().hex[:8]}"
        probe.touch()
        probe.unlink()
    except OSError as exc:
        reason = exc.strerror or type(exc).__name__
        raise InvalidParameterError(
            f"Cannot write results to {str(out_dir)!r}: {reason}."
        ) from None
    return out_dir


def remove_stale_temporaries(out_dir: str | Path) -> int:
    """Delete temporary files a killed process left behind; return how many.

    A temporary names its writer (``<host>-<pid>-<nonce>``): one of a live process on this
    host, or younger than an hour from another host, is another driver's write in progress
    and is kept.
    """
    removed = 0
    host = socket.gethostname()
    for temp in Path(out_dir).rglob(f".*{_TEMP_MARK}*"):
        writer, _, _ = temp.name.split(_TEMP_MARK, 1)[1].rpartition("-")
        writer_host, _, pid = writer.rpartition("-")
        if writer_host == host and pid.isdigit():
            if process_exists(int(pid)):
                continue
        elif _age_seconds(temp) < _FOREIGN_TEMP_SECONDS:
            continue
        temp.unlink(missing_ok=True)
        removed += 1
    return removed


def _age_seconds(path: Path) -> float:
    """Seconds since ``path`` was last written (infinite if it is gone)."""
    try:
        return time.time() - path.stat().st_mtime
    except FileNotFoundError:
        return math.inf


def run_id(run_spec: Mapping[str, Any]) -> str:
    """Return the id of a run: the `config_hash` of its resolved config."""
    return config_hash(dict(run_spec))


def run_path(out_dir: str | Path, identifier: str) -> Path:
    """Return the result file of run ``identifier``: ``OUT/runs/<id>.json``."""
    return Path(out_dir) / RUNS_DIR / f"{identifier}.json"


def error_path(out_dir: str | Path, identifier: str) -> Path:
    """Return the error file of run ``identifier``: ``OUT/errors/<id>.txt``."""
    return Path(out_dir) / ERRORS_DIR / f"{identifier}.txt"


def run_checksum(record: Mapping[str, Any]) -> str:
    """The SHA-256 of a run record's fields other than ``checksum`` (canonical JSON)."""
    fields = {key: value for key, value in record.items() if key != "checksum"}
    text = json.dumps(fields, sort_keys=True, default=_jsonable)
    return hashlib.sha256(text.encode()).hexdigest()


def read_run(path: str | Path) -> dict[str, Any]:
    """Read a run file: ``{"run_id", "config", "curve" (DataFrame), "meta"}``.

    Raises
    ------
    InvalidParameterError
        If the file is not a complete run record or its checksum does not match its content.
    """
    path = Path(path)
    try:
        record = json.loads(path.read_text())
        if not isinstance(record, dict) or record.get("checksum") != run_checksum(record):
            problem = "checksum missing" if "checksum" not in record else "checksum mismatch"
            raise InvalidParameterError(
                f"{str(path)!r} fails its checksum ({problem}): its content was changed after "
                f"the run wrote it."
            )
        curve = pd.DataFrame(record["curve"])
        return {
            "run_id": record["run_id"],
            "config": record["config"],
            "curve": curve,
            "meta": record.get("meta", {}),
        }
    except (OSError, ValueError, KeyError, TypeError, RecursionError) as exc:
        if isinstance(exc, InvalidParameterError):
            raise
        raise InvalidParameterError(f"{str(path)!r} is not a run record: {exc}.") from None


def run_file_problem(out_dir: str | Path, run_spec: Mapping[str, Any]) -> str | None:
    """Why ``out_dir`` holds no intact finished run of ``run_spec``: "missing", a reason, or None.

    A present but unusable run file (checksum mismatch, not a run record, another run's
    config) gets a one-line reason; the run is then redone.
    """
    identifier = run_id(run_spec)
    path = run_path(out_dir, identifier)
    if not path.is_file():
        return "missing"
    try:
        record = read_run(path)
    except InvalidParameterError as exc:
        return "checksum mismatch" if "checksum" in str(exc) else "not a run record"
    if run_id(record["config"]) != identifier:
        return "another run's config"
    return None


def is_run_done(out_dir: str | Path, run_spec: Mapping[str, Any]) -> bool:
    """Whether ``out_dir`` holds the intact finished run of exactly ``run_spec``."""
    return run_file_problem(out_dir, run_spec) is None


def save_run(
    out_dir: str | Path,
    run_spec: Mapping[str, Any],
    curve: pd.DataFrame | Mapping[str, Sequence[Any]],
    meta: Mapping[str, Any] | None = None,
) -> Path:
    """Write a finished run to ``OUT/runs/<run_id>.json`` and clear its old error files."""
    identifier = run_id(run_spec)
    columns = curve.to_dict(orient="list") if isinstance(curve, pd.DataFrame) else dict(curve)
    record: dict[str, Any] = {
        "run_id": identifier,
        "config": dict(run_spec),
        "curve": columns,
        "meta": dict(meta or {}),
    }
    # Round-trip through JSON first, so the checksum is of exactly what is read back.
    record = json.loads(json.dumps(record, default=_jsonable))
    record["checksum"] = run_checksum(record)
    path = write_atomic(run_path(out_dir, identifier), json.dumps(record, default=_jsonable))
    error = error_path(out_dir, identifier)
    error.unlink(missing_ok=True)
    error.with_suffix(".partial.csv").unlink(missing_ok=True)
    return path


def _jsonable(value: Any) -> Any:
    if isinstance(value, np.generic):
        return value.item()
    return str(value)


def save_run_error(
    out_dir: str | Path,
    run_spec: Mapping[str, Any],
    traceback_text: str,
    partial: pd.DataFrame | Mapping[str, Sequence[Any]] | None = None,
) -> Path:
    """Record a failed run: ``OUT/errors/<run_id>.txt`` (config, then traceback) and any partial curve."""  # noqa: E501
    identifier = run_id(run_spec)
    path = error_path(out_dir, identifier)
    if partial is not None:
        frame = partial if isinstance(partial, pd.DataFrame) else pd.DataFrame(dict(partial))
        write_atomic(path.with_suffix(".partial.csv"), frame.to_csv(index=False))
    header = "".join(f"# {line}\n" for line in dump_yaml(dict(run_spec)).splitlines())
    return write_atomic(path, f"# run {identifier}\n{header}\n{traceback_text}")


def write_run_ids(out_dir: str | Path, identifiers: Iterable[str]) -> Path:
    """Record which runs the current experiment or sweep consists of (``run_ids.txt``)."""
    return write_atomic(Path(out_dir) / RUN_IDS_FILE, "".join(f"{i}\n" for i in identifiers))


def write_planned_runs(out_dir: str | Path, runs: Iterable[Mapping[str, Any]]) -> Path:
    """Record every run a command will finish (``planned.csv``: id, method, seed), first.

    `conjure report` reads it to say which runs are still missing while a sweep runs or after
    it was cut.
    """
    rows = {}
    for spec in runs:
        row = {"run_id": run_id(spec), **_method_columns(spec), "seed": spec.get("seed")}
        rows.setdefault(row["run_id"], row)
    table = pd.DataFrame(list(rows.values()))
    return write_atomic(Path(out_dir) / PLANNED_FILE, table.to_csv(index=False))


def missing_runs(out_dir: str | Path, present: Iterable[str]) -> pd.DataFrame | None:
    """Per method of ``planned.csv`` with runs not in ``present``: planned and missing counts.

    ``None`` when the folder has no ``planned.csv`` (written by an older version).
    """
    path = Path(out_dir) / PLANNED_FILE
    if not path.is_file():
        return None
    planned = pd.read_csv(path, keep_default_na=False, dtype=str)
    planned["missing"] = ~planned["run_id"].isin(set(present))
    keys = [c for c in GROUP_COLUMNS if c in planned.columns]
    counts = planned.groupby(keys, sort=False)["missing"].agg(planned="size", missing="sum")
    return counts[counts["missing"] > 0].reset_index()


def _method_columns(spec: Mapping[str, Any]) -> dict[str, str]:
    """The `GROUP_COLUMNS` of one run, as `load_results` writes them."""
    columns = {k: str(spec[k]) for k in ("domain_label", "label") if k in spec}
    if "setting" in spec:
        columns["setting"] = describe_setting(spec["setting"])
    return columns


def read_resolved(results_dir: str | Path) -> dict[str, Any]:
    """Return the folder's ``config.resolved.yaml`` as a dict (empty when there is none)."""
    path = Path(results_dir) / RESOLVED_FILE
    if not path.is_file():
        return {}
    return load_yaml(path.read_text(), source=str(path)) or {}


def results_name(results_dir: str | Path) -> str:
    """Return what a results folder's plots and report are titled by: its config's ``name``.

    A sweep's ``selected/`` rerun, which has no config of its own, is named after the sweep;
    a folder with no config by itself.
    """
    results_dir = Path(results_dir)
    name = read_resolved(results_dir).get("name")
    if name is None and results_dir.name == SELECTED_DIR:
        parent = read_resolved(results_dir.parent).get("name")
        name = None if parent is None else f"{parent} (best settings, fresh seeds)"
    return str(name or results_dir.name)


def read_run_ids(out_dir: str | Path) -> list[str] | None:
    """Return the ids in ``run_ids.txt``, or ``None`` if the folder has none."""
    path = Path(out_dir) / RUN_IDS_FILE
    if not path.is_file():
        return None
    return [line.strip() for line in path.read_text().splitlines() if line.strip()]


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


def describe_setting(setting: Mapping[str, Any] | None) -> str:
    """Return a short text for a grid setting: ``"step_size.alpha_0=0.1, ..."``.

    Values read as YAML (`conjure.experiments.numbers.format_value`), so each ``key=value``
    can go back into ``--set`` or a grid.

    Examples
    --------
    >>> describe_setting({"agents.sarsa.params.step_size.params.alpha_0": 0.05002000000000905,
    ...                   "agents.sarsa.params.step_size.params.n_0": 1000000})
    'step_size.alpha_0=0.05002, step_size.n_0=1000000'
    """
    if not setting:
        return ""
    parts = []
    for path, value in setting.items():
        keys = path.split(".")
        if keys[0] in ("agents", "domains") and len(keys) > 2:
            keys = keys[2:]
        elif keys[0] == "domain":
            keys = keys[1:]
        short = ".".join(k for k in keys if k != "params")
        parts.append(f"{short}={format_value(value)}")
    return ", ".join(parts)


def _normalize_column(column: pd.Series) -> pd.Series:
    values = [v for v in column if v is not None and not (isinstance(v, float) and math.isnan(v))]
    if all(isinstance(v, (bool, np.bool_)) for v in values) and values:
        return column.astype("boolean")
    if all(isinstance(v, (int, float, np.number)) and not isinstance(v, bool) for v in values):
        return pd.to_numeric(column)
    return column.map(lambda v: None if v is None else str(v)).astype("string")


def load_results(out_dir: str | Path, run_ids: Iterable[str] | None = None) -> pd.DataFrame:
    """Combine finished runs into one table, one row per policy check.

    Columns: ``run_id``, ``label``, ``seed`` (and ``domain_label`` and ``setting`` for sweep
    runs), the curve columns, ``run_seconds``, what the run's domain declared
    (`conjure.experiments.metric_ranges.DOMAIN_BOUND_COLUMNS`, NaN when not recorded), then
    the flattened agent and domain parameters (``agent.step_size``, ``domain.length``, ...).
    A run file that fails its checksum is left out; the ids of those are in
    ``attrs["damaged_runs"]``.

    Parameters
    ----------
    out_dir : str or Path
        The results folder.
    run_ids : iterable of str, optional
        Which runs to read (missing ones are skipped); default the ids in ``run_ids.txt``, or
        every run file if there is none.
    """
    out_dir = Path(out_dir)
    if run_ids is None:
        run_ids = read_run_ids(out_dir)
    if run_ids is None:
        paths = sorted((out_dir / RUNS_DIR).glob("*.json"))
    else:
        paths = [run_path(out_dir, i) for i in dict.fromkeys(run_ids)]
    frames, param_rows, damaged = [], [], []
    for path in paths:
        if not path.is_file():
            continue
        try:
            record = read_run(path)
        except InvalidParameterError:
            damaged.append(path.stem)
            continue
        config, curve = record["config"], record["curve"]
        leading: dict[str, Any] = {"run_id": record["run_id"]}
        if "domain_label" in config:
            leading["domain_label"] = config["domain_label"]
        leading["label"] = config.get("label", "agent")
        if "setting" in config:
            leading["setting"] = describe_setting(config["setting"])
        leading["seed"] = int(config.get("seed", -1))
        for position, (name, value) in enumerate(leading.items()):
            curve.insert(position, name, value)
        curve["run_seconds"] = float(record["meta"].get("run_seconds", math.nan))
        curve["path"] = str(record["meta"].get("path", ""))
        for column in DOMAIN_BOUND_COLUMNS:
            curve[column] = float(record["meta"].get(column, math.nan))
        params: dict[str, Any] = {}
        for key in ("agent", "domain"):
            if isinstance(config.get(key), Mapping):
                params.update(flatten_params(config[key], key))
        frames.append(curve)
        param_rows.append((len(curve), params))
    if not frames:
        empty = pd.DataFrame(columns=["run_id", "label", "seed"])
        empty.attrs["damaged_runs"] = damaged
        return empty
    keys: list[str] = []
    for _, params in param_rows:
        keys.extend(k for k in params if k not in keys)
    columns = {key: [params.get(key) for n, params in param_rows for _ in range(n)] for key in keys}
    table = pd.concat(frames, ignore_index=True)
    if "setting" in table.columns:
        table["setting"] = table["setting"].fillna("")
    extra = pd.DataFrame(columns, index=table.index)
    for key in keys:
        extra[key] = _normalize_column(extra[key])
    combined = pd.concat([table, extra], axis=1)
    combined.attrs["damaged_runs"] = damaged
    return combined


def group_columns(results: pd.DataFrame) -> list[str]:
    """The columns that name a method's setting in ``results`` (`GROUP_COLUMNS` present)."""
    return [c for c in GROUP_COLUMNS if c in results.columns]


def has_finite_values(results: pd.DataFrame, column: str) -> bool:
    """Whether ``results`` has ``column`` with at least one finite value.

    Optional metrics are NaN when they do not apply (``optimality`` without value bounds);
    reports and plots skip such columns.

    Examples
    --------
    >>> has_finite_values(pd.DataFrame({"a": [np.nan], "b": [0.0]}), "a")
    False
    """
    if column not in results.columns:
        return False
    values = pd.to_numeric(results[column], errors="coerce").to_numpy(dtype=np.float64)
    return bool(np.isfinite(values).any())


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


def final_rows(results: pd.DataFrame) -> pd.DataFrame:
    """Return each run's last policy check (its largest ``learning_steps``)."""
    key = "run_id" if "run_id" in results.columns else ["label", "seed"]
    return results.loc[results.groupby(key, sort=False)["learning_steps"].idxmax()]


def summarize(
    results: pd.DataFrame, metric: str = "return", by: Sequence[str] | None = None
) -> pd.DataFrame:
    """Per method, the final policy check over seeds: mean ``metric`` and its 95% t-interval, etc.

    Columns: ``by``, ``num_seeds``, ``final_<metric>_mean``, ``final_<metric>_ci95`` (the
    Student-t half-width), ``final_<metric>_low`` and ``final_<metric>_high`` (the interval's
    ends, cut at the metric's range: `conjure.experiments.metric_ranges`),
    ``final_num_features`` and ``mean_steps_per_second``.

    Parameters
    ----------
    results : pandas.DataFrame
        `load_results`'s table.
    metric : str, default "return"
        The curve column to summarise.
    by : sequence of str, optional
        The grouping columns; default `group_columns` (``label``, plus ``domain_label`` and
        ``setting`` for sweeps).
    """
    by = list(by) if by is not None else group_columns(results) or ["label"]
    columns = [
        *by,
        "num_seeds",
        f"final_{metric}_mean",
        f"final_{metric}_ci95",
        f"final_{metric}_low",
        f"final_{metric}_high",
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
    for name, finals in final_rows(results).groupby(by, sort=False):
        keys = name if isinstance(name, tuple) else (name,)
        mean, half = t_confidence(finals[metric])
        rows.append(
            (
                *keys,
                len(finals),
                mean,
                half,
                *clip_interval(mean, half, metric_range(finals, metric)),
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
