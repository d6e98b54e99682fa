"""Grid selection as the thesis did it: each method's best setting, then fresh seeds.

Geramifard (2012), §4.3 and §3.4: step sizes were chosen from grids (α₀ ∈ {0.01, 0.1, 1},
N₀ ∈ {100, 1000, 10⁶}; discovery thresholds per domain) by the best performance, and the
chosen settings were reported over many runs. `select_best` scores every setting of every
method (a method is a (domain, agent label) pair) by a stated criterion; `selected_runs`
builds the runs of the chosen settings on seeds that took no part in the choice, so the
reported numbers are not biased upward by the selection.

Notes
-----
- ``criterion="auc"``: the mean over seeds of the area under the learning curve divided by
  its length in steps (trapezoid rule), i.e. the average performance over learning;
  ``criterion="final"``: the mean over seeds of the last policy check.
- Choice: only settings whose every seed finished are eligible; a setting that diverged on
  some seeds is never chosen on the strength of the seeds that survived. Ties go to the first
  setting in grid order.
- ``cost_limit`` d (a constrained MDP's limit on the cost per episode): only settings whose
  mean final ``episode_cost`` over the search seeds is at most d are eligible, as a
  constrained learner's limit asks of its final policy; when no setting meets it, the one
  with the lowest mean final ``episode_cost`` is chosen (the ``num_settings`` column then
  reads ``0/n``).
- Choice: fresh seeds start after the largest seed used in the grid. With ``fresh_seeds: 0``
  there is no rerun, and the chosen settings are shown on the search seeds
  (`selected_results`), whose numbers the choice biases upward.
"""

from __future__ import annotations

import copy
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import pandas as pd

from conjure.core.errors import InvalidParameterError
from conjure.experiments.results import describe_setting, final_rows, t_confidence

__all__ = [
    "CRITERIA",
    "fresh_seeds",
    "score_runs",
    "select_best",
    "selected_results",
    "selected_runs",
]

#: Selection criteria by name.
CRITERIA = ("auc", "final")
_METHOD = ("domain_label", "label")


def score_runs(results: pd.DataFrame, metric: str = "return", criterion: str = "auc") -> pd.Series:
    """Return one score per run (indexed by ``run_id``): its curve's mean area or final value.

    Examples
    --------
    >>> frame = pd.DataFrame({"run_id": ["a"] * 3, "learning_steps": [0, 10, 20],
    ...                       "return": [0.0, 1.0, 1.0]})
    >>> float(score_runs(frame, criterion="auc")["a"]), float(score_runs(frame)["a"])
    (0.75, 0.75)
    """
    if criterion not in CRITERIA:
        raise InvalidParameterError(
            f"Unknown selection criterion {criterion!r}; use one of {', '.join(CRITERIA)}."
        )
    if metric not in results.columns:
        raise InvalidParameterError(
            f"Unknown metric {metric!r}; the results have columns {', '.join(results.columns)}."
        )
    if criterion == "final":
        finals = final_rows(results)
        return pd.Series(finals[metric].to_numpy(dtype=float), index=finals["run_id"])
    scores = {}
    for identifier, curve in results.groupby("run_id", sort=False):
        curve = curve.sort_values("learning_steps")
        steps = curve["learning_steps"].to_numpy(dtype=float)
        values = curve[metric].to_numpy(dtype=float)
        span = steps[-1] - steps[0]
        scores[identifier] = (
            float(np.trapezoid(values, steps) / span) if span > 0 else float(values[-1])
        )
    return pd.Series(scores)


def select_best(
    results: pd.DataFrame,
    *,
    metric: str = "return",
    criterion: str = "auc",
    mode: str = "max",
    cost_limit: float | None = None,
) -> pd.DataFrame:
    """Return each method's best setting, one row per (domain, agent label).

    Parameters
    ----------
    results : pandas.DataFrame
        `conjure.experiments.results.load_results`'s table of a sweep.
    metric : str, default "return"
        The curve column scored.
    criterion : {"auc", "final"}, default "auc"
        See the module notes.
    mode : {"max", "min"}, default "max"
        Whether a larger score is better (``min`` for e.g. steps to the goal).
    cost_limit : float or None, default None
        d: only settings whose mean final ``episode_cost`` is at most d (module notes).

    Returns
    -------
    pandas.DataFrame
        Columns: the method columns, ``setting`` (text), ``score_mean``, ``score_ci95``,
        ``num_seeds``, ``num_settings`` (eligible / total) and ``run_id`` (one run of the
        chosen setting, the template for its reruns).
    """
    if mode not in ("max", "min"):
        raise InvalidParameterError(f"Selection mode must be 'max' or 'min'; got {mode!r}.")
    scores = score_runs(results, metric, criterion)
    runs = results.drop_duplicates("run_id").set_index("run_id")
    runs = runs.assign(score=scores.reindex(runs.index))
    if cost_limit is not None:
        costs = score_runs(results, "episode_cost", "final")
        runs = runs.assign(final_cost=costs.reindex(runs.index))
    if "setting" not in runs.columns:
        runs["setting"] = ""
    method = [c for c in _METHOD if c in runs.columns]
    rows = []
    for key, group in runs.groupby(method, sort=False):
        settings = []
        for setting, at_setting in group.groupby("setting", sort=False):
            mean, half = t_confidence(at_setting["score"])
            cost = float(at_setting["final_cost"].mean()) if cost_limit is not None else 0.0
            settings.append((setting, mean, half, len(at_setting), at_setting.index[0], cost))
        most = max(s[3] for s in settings)
        eligible = [s for s in settings if s[3] == most and np.isfinite(s[1])]
        sign = 1.0 if mode == "max" else -1.0
        count = len(eligible)
        if cost_limit is not None:
            feasible = [s for s in eligible if s[5] <= cost_limit]
            count = len(feasible)
            eligible = feasible or [min(eligible, key=lambda s: s[5])]
        best = max(eligible, key=lambda s: sign * s[1])
        keys = key if isinstance(key, tuple) else (key,)
        rows.append(
            (*keys, best[0], best[1], best[2], best[3], f"{count}/{len(settings)}", best[4])
        )
    columns = [
        *method,
        "setting",
        "score_mean",
        "score_ci95",
        "num_seeds",
        "num_settings",
        "run_id",
    ]
    table = pd.DataFrame(rows, columns=columns)
    rule = f"{criterion} of {metric} ({mode})"
    if cost_limit is not None:
        rule += f", final episodic cost ≤ {cost_limit:g}"
    table.insert(len(method) + 2, "criterion", rule)
    return table


def fresh_seeds(used: Sequence[int], count_or_list: int | Sequence[int]) -> list[int]:
    """Return the seeds of the rerun: a list as given, or ``count`` seeds after ``max(used)``.

    Examples
    --------
    >>> fresh_seeds([0, 1, 2], 3)
    [3, 4, 5]
    """
    if isinstance(count_or_list, (int, np.integer)):
        start = max(used, default=-1) + 1
        return list(range(start, start + int(count_or_list)))
    seeds = [int(s) for s in count_or_list]
    reused = sorted(set(seeds) & set(used))
    if reused:
        raise InvalidParameterError(
            f"Fresh seeds must not repeat the grid's seeds; {reused} were used to select."
        )
    return seeds


def selected_runs(
    runs: Sequence[Mapping[str, Any]], best: pd.DataFrame, seeds: Sequence[int]
) -> list[dict[str, Any]]:
    """Return the run configs of each chosen setting on ``seeds``.

    Parameters
    ----------
    runs : sequence of dict
        The sweep's run configs (`conjure.sweeps.sweep.expand_sweep`).
    best : pandas.DataFrame
        `select_best`'s table.
    seeds : sequence of int
        The fresh seeds.
    """
    chosen = []
    for row in best.to_dict("records"):
        template = next(
            (
                spec
                for spec in runs
                if spec.get("label") == row["label"]
                and spec.get("domain_label", None) == row.get("domain_label", None)
                and describe_setting(spec.get("setting")) == row["setting"]
            ),
            None,
        )
        if template is None:
            raise InvalidParameterError(
                f"No run of the sweep matches the selected setting {row['setting']!r} of "
                f"{row['label']!r}; was the sweep changed since it ran?"
            )
        for seed in seeds:
            spec = copy.deepcopy(dict(template))
            spec["seed"] = int(seed)
            chosen.append(spec)
    return chosen


def selected_results(results: pd.DataFrame, best: pd.DataFrame) -> pd.DataFrame:
    """Return the rows of ``results`` (a sweep's search) that belong to a chosen setting.

    Examples
    --------
    >>> search = pd.DataFrame({"label": ["a", "a", "b"], "setting": ["x=1", "x=2", ""],
    ...                        "seed": 0})
    >>> chosen = pd.DataFrame({"label": ["a", "b"], "setting": ["x=2", ""]})
    >>> selected_results(search, chosen)["setting"].tolist()
    ['x=2', '']
    """
    keys = [c for c in (*_METHOD, "setting") if c in results.columns]
    return results.merge(best[keys].drop_duplicates(), on=keys, how="inner")
