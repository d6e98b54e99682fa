"""The reproduced figures of Geramifard (2012): their shipped configs, scales and claims.

`FIGURES` catalogues every figure with a shipped sweep config under
``examples/reproduction/`` (chapters 4 and 5 and Section 6.2.6; Fig. 3-15 is a batch
evaluation run by ``docs/reproduction/fig_3_15.py``, not a sweep). Each `Figure` names its
config, the curve columns it plots and its claims: a sentence of the thesis, the thesis's
value, and how to measure it from the final policy checks (`finals_table`). ``conjure
reproduce`` (`conjure.cli.reproduce`) runs a figure at a `SCALES` scale and writes
`comparison_markdown`; ``docs/reproduction/figures.py`` renders the stored results
with the same claims.

Scales
------
- ``thesis``: the config as shipped: the grid searched on the search seeds, each method's
  setting selected, then rerun on the fresh seeds (`conjure.sweeps.sweep.run_sweep`).
- ``quick``: `QUICK_SEEDS` seeds and no search. A config with a ``selection`` starts at the
  settings its search selected (tests/test_reproduction_docs.py checks it), so quick drops the
  grid and the selection and runs those settings on the first `QUICK_SEEDS` of the fresh seeds
  (seeds that took no part in the choice). A config without a selection keeps its grid (there
  the grid is the figure's x-axis, e.g. Fig. 4-11's initial cut counts) and runs its first
  `QUICK_SEEDS` seeds. The budget, policy checks and evaluation episodes are unchanged: every
  claim is about the end of the curve, which fewer steps would move.

Notes
-----
- Choice: the cost of a scale is counted in runs and learning steps (runs × ``budget_steps``),
  read from the config without running anything; policy-check episodes are not counted, and no
  time is given, because the speed per step differs by two orders of magnitude between
  workloads (compiled SARSA on a grid world against Monte-Carlo risk analysis on UAV 7-2).
- Choice: each claim follows its thesis sentence's own word (`Claim`, whose ``quote`` names
  the sentence): "ends above" claims need the 95% Welch interval of the difference to lie
  above 0, "level" claims need it to hold 0, "does not end above" claims need it not to lie
  above 0; ``at_most`` and ``ratio_within`` compare means (their text shows the ratio).
- Choice: "optimality" in Section 5.4.1 and 5.5.2's sentences (SARSA below 50%, aggressive
  CBBA above 80%) is the run's ``optimality``, Fig. 5-6b's (V − V_worst)/(V* − V_worst).
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from scipy import stats

from conjure.core.errors import InvalidParameterError
from conjure.core.params import did_you_mean
from conjure.experiments.config import parse_overridden
from conjure.experiments.metric_ranges import DOMAIN_BOUND_COLUMNS, clip_interval, metric_range
from conjure.experiments.numbers import format_interval
from conjure.experiments.results import group_columns, t_confidence
from conjure.sweeps.selection import fresh_seeds, score_runs
from conjure.sweeps.sweep import (
    SweepConfig,
    apply_sweep_overrides,
    grid_keys_for,
    parse_sweep,
    read_sweep_data,
)

__all__ = [
    "FIGURES",
    "GROUPS",
    "METRICS",
    "QUICK_SEEDS",
    "SCALES",
    "Claim",
    "Figure",
    "above",
    "above_best",
    "at_most",
    "cheaper_at_return",
    "check_scale",
    "claim_rows",
    "comparison_markdown",
    "curve_table",
    "every_run_within",
    "figure_cost",
    "figure_names",
    "finals_markdown",
    "finals_table",
    "level",
    "load_figure_sweep",
    "no_better",
    "ratio_within",
    "share_within",
    "summary_table",
    "within",
]

#: The scales of ``conjure reproduce`` (see the module docstring).
SCALES = ("quick", "thesis")
#: Seeds per method at the quick scale.
QUICK_SEEDS = 3

#: The curve columns of the chapter-5 tables, with their headings.
METRICS = {
    "return": "final return",
    "value_ratio": "V/V*",
    "optimality": "optimality",
    "failure_rate": "failure rate",
    "learning_failures": "failures while learning",
    "episode_cost": "episodic cost",
    "learning_cost": "cost while learning",
}

Measure = Callable[[pd.DataFrame], tuple[str, bool]]


# ------------------------------------------------------------------------------------ tables


def finals_table(frame: pd.DataFrame, metric: str = "return") -> pd.DataFrame:
    """One row per run: label, seed, the last policy check's metrics and ``auc_<metric>``.

    The metrics are `METRICS` and ``metric`` (those the results hold); ``auc_<metric>`` is the
    selection's area under the curve (`conjure.sweeps.selection.score_runs`). ``domain_label``
    and ``setting`` are kept where a label has several (a grid that is the figure's x-axis).
    """
    columns = [m for m in dict.fromkeys([*METRICS, metric]) if m in frame.columns]
    per_label = frame.groupby("label")
    keys = [
        c
        for c in group_columns(frame)
        if c != "label" and per_label[c].nunique(dropna=False).max() > 1
    ]
    last = frame.sort_values("learning_steps").groupby("run_id", sort=False).tail(1)
    finals = last[["run_id", "label", *keys, "seed", "learning_steps", *columns]].copy()
    auc = score_runs(frame, metric, "auc")
    finals[f"auc_{metric}"] = finals["run_id"].map(auc).to_numpy(dtype=float)
    order = {label: k for k, label in enumerate(frame["label"].drop_duplicates())}
    finals = finals.assign(_order=finals["label"].map(order)).sort_values(["_order", "seed"])
    return finals.drop(columns=["_order", "run_id"]).reset_index(drop=True)


def curve_table(frame: pd.DataFrame) -> pd.DataFrame:
    """Mean, 95% t half-width and cut interval of every `METRICS` column per label and check."""
    rows = []
    for (label, steps), group in frame.groupby(["label", "learning_steps"], sort=False):
        row = {"label": label, "learning_steps": int(steps), "seeds": group["seed"].nunique()}
        for metric in METRICS:
            mean, half = t_confidence(group[metric])
            row[f"{metric}_mean"], row[f"{metric}_ci95"] = mean, half
            cut = clip_interval(mean, half, metric_range(group, metric))
            row[f"{metric}_low"], row[f"{metric}_high"] = cut
        rows.append(row)
    return pd.DataFrame(rows)


def _parts(name: Any) -> tuple:
    """A groupby key as a tuple."""
    return name if isinstance(name, tuple) else (name,)


def _natural(parts: tuple) -> list:
    """A sort key that orders the numbers inside ``parts`` by value ("x=2" before "x=10")."""
    text = " ".join(str(part) for part in parts)
    return [(0, int(t), "") if t.isdigit() else (1, 0, t) for t in re.split(r"(\d+)", text)]


def finals_markdown(finals: pd.DataFrame) -> str:
    """The markdown table of the final policy check (`finals_table`), one row per method.

    Columns: the metrics with a finite value (`METRICS` headings, else ``final <metric>``)
    and the area under the curve, each as mean ± 95% t half-width, cut at the metric's range
    (`metric_range`: with what the domain declared, the `DOMAIN_BOUND_COLUMNS` of ``finals``
    when given; they are not shown).
    """
    areas = [c for c in finals.columns if c.startswith("auc_")]
    metrics = [
        c
        for c in finals.columns
        if c not in (*areas, "label", "domain_label", "setting", "seed", "learning_steps")
        and c not in DOMAIN_BOUND_COLUMNS
        and np.isfinite(finals[c].to_numpy(dtype=float)).any()
    ]
    heading = [
        "method",
        "seeds",
        *(METRICS.get(m, f"final {m}") for m in metrics),
        *(f"AUC of {a.removeprefix('auc_')}" for a in areas),
    ]
    keys = [c for c in ("label", "domain_label", "setting") if c in finals.columns]
    lines = ["| " + " | ".join(heading) + " |", "|" + "---|" * len(heading)]
    labels = list(dict.fromkeys(finals["label"]))
    groups = sorted(  # methods in order, a method's settings in natural order (2 before 10)
        finals.groupby(keys, sort=False),
        key=lambda item: (labels.index(_parts(item[0])[0]), _natural(_parts(item[0])[1:])),
    )
    for name, group in groups:
        parts = _parts(name)
        cells = [" ".join(str(part) for part in parts), str(group["seed"].nunique())]
        for metric in [*metrics, *areas]:
            mean, half = t_confidence(group[metric])
            cells.append(format_interval(mean, half, metric_range(group, metric)))
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def summary_table(finals: pd.DataFrame) -> pd.DataFrame:
    """Per method (label, and setting where the grid is the figure's), each final metric.

    Columns: the method's keys, ``seeds``, then ``<metric>_mean``, ``<metric>_ci95`` (the
    Student-t half-width) and ``<metric>_low``/``<metric>_high`` (cut at the metric's range)
    for every metric column of ``finals`` (`finals_table`).
    """
    keys = [c for c in ("label", "domain_label", "setting") if c in finals.columns]
    metrics = [c for c in finals.columns if c not in (*keys, "seed", "learning_steps")]
    rows = []
    for name, group in finals.groupby(keys, sort=False, dropna=False):
        row = dict(zip(keys, name if isinstance(name, tuple) else (name,), strict=True))
        row["seeds"] = group["seed"].nunique()
        for metric in metrics:
            mean, half = t_confidence(group[metric])
            low, high = clip_interval(mean, half, metric_range(group, metric))
            row.update(
                {
                    f"{metric}_mean": mean,
                    f"{metric}_ci95": half,
                    f"{metric}_low": low,
                    f"{metric}_high": high,
                }
            )
        rows.append(row)
    return pd.DataFrame(rows)


# ------------------------------------------------------------------------------------ claims


@dataclass(frozen=True)
class Claim:
    """A claim of the thesis: its text, the thesis's value, its measure and the sentence quoted.

    ``quote`` is the thesis's sentence (with its section) whose own word the measure follows:
    "outperformed", "improved", "better", "boost" → significantly above (`above`, `above_best`);
    "could not outperform" → no significant excess (`no_better`); "not statistically
    significant", "reached the same level" → no significant difference (`level`); a number
    ("more than 80%", "about 90%") → the mean against it (`within`, `ratio_within`,
    `at_most`). Empty for a check the thesis does not state ("(not in the thesis)").
    Choice: a margin the thesis does not state is not tested; the thesis's number (+10%,
    +22%) is shown beside the measured difference.
    """

    text: str
    thesis: str
    measure: Measure
    quote: str = ""


def values(finals: pd.DataFrame, label: str, metric: str) -> np.ndarray:
    """The per-seed final ``metric`` of ``label``.

    Raises
    ------
    InvalidParameterError
        When the finals hold no run of ``label``.
    """
    chosen = finals.loc[finals["label"] == label, metric].to_numpy(dtype=float)
    if chosen.size == 0:
        known = ", ".join(finals["label"].drop_duplicates())
        raise InvalidParameterError(f"No results for {label!r}; the labels are {known}.")
    return chosen


def welch(a: np.ndarray, b: np.ndarray) -> tuple[float, float]:
    """mean(a) − mean(b) and its 95% Welch half-width (0 when both have no spread)."""
    difference = float(a.mean() - b.mean())
    va, vb = a.var(ddof=1) / a.size, b.var(ddof=1) / b.size
    if va + vb == 0.0:
        return difference, 0.0
    dof = (va + vb) ** 2 / (va**2 / (a.size - 1) + vb**2 / (b.size - 1))
    return difference, float(stats.t.ppf(0.975, dof) * np.sqrt(va + vb))


def _away_from_zero(values: np.ndarray) -> bool:
    """Whether the 95% t interval of ``values``' mean excludes 0 (so a ratio to it is read).

    Choice: a relative difference is printed only against such a baseline; against one whose
    interval holds 0 (a return near zero) a percentage would be noise ("+2542.5%").

    Examples
    --------
    >>> _away_from_zero(np.array([0.21, 0.25, 0.19])), _away_from_zero(np.array([-0.1, 0.2, 0.0]))
    (True, False)
    """
    mean, half = t_confidence(values)
    return bool(abs(mean) > (0.0 if math.isnan(half) else half))


def above(
    better: str, worse: str, metric: str = "return", *, by: float = 0.0, significant: bool = True
) -> Measure:
    """``better`` ends above ``worse`` by more than ``by`` × |worse|.

    With ``significant`` the 95% Welch interval of the difference must lie above that margin;
    otherwise ("at or above") it must not lie below it: no significant shortfall.
    """

    def measure(finals: pd.DataFrame) -> tuple[str, bool]:
        a, b = values(finals, better, metric), values(finals, worse, metric)
        difference, half = welch(a, b)
        base = abs(b.mean())
        relative = f" ({difference / base:+.1%})" if _away_from_zero(b) else ""
        text = f"{better} − {worse}: {format_interval(difference, half)}{relative}"
        if significant:
            return text, bool(difference - half > by * base)
        return text, bool(difference + half >= by * base)

    return measure


def no_better(label: str, other: str, metric: str = "return") -> Measure:
    """``label`` does not end significantly above ``other`` ("could not outperform").

    The 95% Welch interval of mean(label) − mean(other) does not lie above 0.
    """
    return above(other, label, metric, significant=False)


def level(label: str, other: str, metric: str = "return") -> Measure:
    """``label`` and ``other`` end level: the 95% Welch interval of the difference holds 0."""

    def measure(finals: pd.DataFrame) -> tuple[str, bool]:
        a, b = values(finals, label, metric), values(finals, other, metric)
        difference, half = welch(a, b)
        text = f"{label} − {other}: {format_interval(difference, half)}"
        return text, bool(difference - half <= 0.0 <= difference + half)

    return measure


def above_best(
    label: str, others: tuple[str, ...], metric: str = "return", *, by: float = 0.0
) -> Measure:
    """``label`` ends above the best of ``others`` (by mean) by more than ``by``, significantly."""

    def measure(finals: pd.DataFrame) -> tuple[str, bool]:
        best = max(others, key=lambda other: values(finals, other, metric).mean())
        return above(label, best, metric, by=by)(finals)

    return measure


def ratio_within(
    label: str, other: str, low: float, high: float, metric: str = "return"
) -> Measure:
    """The ratio of the means of ``label`` and ``other``, minus 1, lies in [low, high]."""

    def measure(finals: pd.DataFrame) -> tuple[str, bool]:
        a, b = values(finals, label, metric).mean(), values(finals, other, metric).mean()
        change = a / b - 1.0
        return f"{label} / {other} − 1 = {change:+.1%}", bool(low <= change <= high)

    return measure


def at_most(label: str, other: str, fraction: float, metric: str = "learning_failures") -> Measure:
    """The mean ``metric`` of ``label`` is at most ``fraction`` × that of ``other``."""

    def measure(finals: pd.DataFrame) -> tuple[str, bool]:
        a, b = values(finals, label, metric).mean(), values(finals, other, metric).mean()
        ratio = a / b if b > 0 else np.inf
        return f"{label} / {other}: {a:,.0f} / {b:,.0f} = {ratio:.2f}", bool(ratio <= fraction)

    return measure


def share_within(label: str, metric: str, high: float, share: float) -> Measure:
    """At least ``share`` of ``label``'s runs end with ``metric`` at most ``high`` (a limit)."""

    def measure(finals: pd.DataFrame) -> tuple[str, bool]:
        chosen = values(finals, label, metric)
        inside = int(np.count_nonzero(chosen <= high))
        text = f"{label}: {inside} of {chosen.size} runs ≤ {high:g}"
        return text, inside >= share * chosen.size

    return measure


def cheaper_at_return(
    cooperative: tuple[str, ...], constrained: tuple[str, ...], fraction: float
) -> Measure:
    """The best of ``cooperative`` costs at most ``fraction`` × the best of ``constrained``.

    "Best" is the highest mean final return of each group; the claim holds when the
    cooperative one's mean ``learning_cost`` is at most ``fraction`` × the constrained one's
    and its final return is not significantly below (the 95% Welch interval of the difference
    reaches 0 or above).
    """

    def measure(finals: pd.DataFrame) -> tuple[str, bool]:
        best = {
            group: max(labels, key=lambda label: values(finals, label, "return").mean())
            for group, labels in (("cooperative", cooperative), ("constrained", constrained))
        }
        mine, theirs = best["cooperative"], best["constrained"]
        cost_text, cheaper = at_most(mine, theirs, fraction, "learning_cost")(finals)
        return_text, level_or_above = above(mine, theirs, significant=False)(finals)
        return f"{cost_text}; {return_text}", cheaper and level_or_above

    return measure


def every_run_within(label: str, metric: str, low: float, high: float) -> Measure:
    """Every run's final ``metric`` of ``label`` lies in [low, high] ("always")."""

    def measure(finals: pd.DataFrame) -> tuple[str, bool]:
        chosen = values(finals, label, metric)
        inside = int(np.count_nonzero((chosen >= low) & (chosen <= high)))
        text = f"{label}: {inside} of {chosen.size} runs in [{low:,g}, {high:,g}]"
        return text, inside == chosen.size

    return measure


def within(label: str, metric: str, low: float, high: float) -> Measure:
    """The mean final ``metric`` of ``label`` lies in [low, high]."""

    def measure(finals: pd.DataFrame) -> tuple[str, bool]:
        mean, half = t_confidence(values(finals, label, metric))
        text = format_interval(mean, half, metric_range(finals, metric))
        return f"{label}: {text}", bool(low <= mean <= high)

    return measure


def _means_by_x(finals: pd.DataFrame, label: str, metric: str) -> dict[int, float]:
    """Mean final ``metric`` of ``label`` per x-axis value: the number ending its setting."""
    chosen = finals.loc[finals["label"] == label]
    if chosen.empty or "setting" not in chosen.columns:
        values(finals, label, metric)  # raises, naming the labels there are
        raise InvalidParameterError(f"{label!r} has no grid settings (the figure's x-axis).")
    x = chosen["setting"].str.extract(r"(\d+)$", expand=False).astype(int)
    return chosen.groupby(x)[metric].mean().to_dict()


def best_at_every_x(label: str, others: tuple[str, ...], metric: str) -> Measure:
    """At every x-axis value, ``label``'s mean is at least each of ``others``' means there."""

    def measure(finals: pd.DataFrame) -> tuple[str, bool]:
        mine = _means_by_x(finals, label, metric)
        rivals = {other: _means_by_x(finals, other, metric) for other in others}
        lost = []
        for x, mean in sorted(mine.items()):
            best = max(rivals, key=lambda other: rivals[other].get(x, -np.inf))
            if rivals[best].get(x, -np.inf) > mean:
                lost.append(f"{x} ({best} {rivals[best][x]:,.0f} vs {mean:,.0f})")
        text = f"{label} best at {len(mine) - len(lost)} of {len(mine)}"
        return text + (f"; behind at {', '.join(lost)}" if lost else ""), not lost

    return measure


def worst_above_worst(label: str, others: tuple[str, ...], metric: str) -> Measure:
    """``label``'s worst x-axis value (by mean) is above every one of ``others``' worst."""

    def measure(finals: pd.DataFrame) -> tuple[str, bool]:
        worst = {name: min(_means_by_x(finals, name, metric).values()) for name in (label, *others)}
        text = ", ".join(f"{name} {value:,.0f}" for name, value in worst.items())
        return f"worst over x: {text}", all(worst[label] > worst[o] for o in others)

    return measure


def claim_rows(claims: Sequence[Claim], finals: pd.DataFrame) -> str:
    """The markdown table of ``claims``: thesis, measured (95% interval), holds.

    A claim about a method ``finals`` does not hold is "not measured", naming the method.
    """
    lines = ["| claim | thesis | measured (95% interval) | holds? |", "|---|---|---|---|"]
    for claim in claims:
        try:
            measured, holds = claim.measure(finals)
            verdict = "yes" if holds else "no"
        except InvalidParameterError as exc:  # a method the results do not hold
            measured, verdict = str(exc), "not measured"
        lines.append(f"| {claim.text} | {claim.thesis} | {measured} | {verdict} |")
    return "\n".join(lines)


# ------------------------------------------------------------------------------------ figures


@dataclass(frozen=True)
class Figure:
    """One reproduced figure: its sweep config, the curve columns it plots, and its claims."""

    title: str
    config: str
    plots: tuple[str, ...]
    claims: tuple[Claim, ...] = ()


def _ifdd_beats_random(domain: str, metric: str) -> Figure:
    return Figure(
        f"Fig. 4-7 ({domain}): iFDD vs random expansion at a fixed discovery rate",
        f"examples/reproduction/fig_4_7_{domain}.yaml",
        (metric,),
        (
            Claim(  # "learns significantly faster": the area under the curve
                "iFDD learns faster than random expansion (AUC)",
                "significantly, in all four domains",
                above("ifdd_fixed_rate", "random_fixed_rate", f"auc_{metric}"),
                'Section 4.1.4: "In all domains, the error driven feature discovery used in '
                "iFDD provided a statistically significant boost to the learning rate of the "
                'algorithm compared to the random discovery approach."',
            ),
        ),
    )


def _fig_4_5(domain: str, panel: str, metric: str, claims: tuple[Claim, ...]) -> Figure:
    return Figure(
        f"Fig. 4-5({panel}) ({domain}): SARSA with initial, tabular, iFDD, ATC, SDM",
        f"examples/reproduction/fig_4_5_{domain}.yaml",
        (metric, "num_features"),
        claims,
    )


#: Section 4.1.4 on the Rescue Mission (Fig. 4-5(d)).
#: The constrained learners of every safe-RL comparison (`_safe_rl`).
_CONSTRAINED = ("sarsa_lagrangian", "sarsa_pid_lagrangian")
#: The comparison without a shield (its Monte-Carlo analyser is too slow on the Python path).
_NO_SHIELD = "safe_rl_gridworld_2"


def _safe_rl(
    domain: str,
    name: str,
    cost_limit: float,
    constrained: tuple[str, ...],
    cooperative: tuple[str, ...],
    shielded: bool = True,
) -> Figure:
    """A safe-RL comparison on one domain: constrained learners, a shield and iCCA's boxes."""
    return Figure(
        f"Safe exploration against constrained RL: {domain}, cost limit d = {cost_limit:g}",
        f"examples/reproduction/{name}.yaml",
        ("return", "episode_cost", "learning_cost"),
        (
            *(
                Claim(
                    f"{label} ends within d on at least 80% of the runs",
                    "(issue 34's target)",
                    share_within(label, "episode_cost", cost_limit, 0.8),
                )
                for label in constrained
            ),
            Claim(
                "the best cooperative learner's cost while learning is at most half the best "
                "constrained learner's, at an equal or better final return",
                "(issue 34's target)",
                cheaper_at_return(cooperative, constrained, 0.5),
            ),
            *(
                (
                    Claim(
                        "the shield costs less than SARSA alone while learning",
                        "(not in the thesis)",
                        at_most("shield", "sarsa", 1.0, "learning_cost"),
                    ),
                )
                if shielded
                else ()
            ),
        ),
    )


_RESCUE = (
    "Section 4.1.4: \"after 20,000 steps, iFDD's richer representation allowed it to encode "
    'a policy that outperformed all other methods."'
)
#: Section 5.3.5 on UAV 7-2 (Fig. 5-6).
_ICCA_7_2 = (
    'Section 5.3.5: "It is clear that the Actor-Critic performed much better inside the iCCA '
    'framework and performed better than CBBA alone."'
)
#: Section 5.3.5 on UAV 10-2 (Fig. 5-7).
_ICCA_10_2 = (
    'Section 5.3.5: "Notice that iCCA again could boost the performance of CBBA solution '
    'statistically significantly."'
)
#: Section 5.3.5: the risk analyser's part in iCCA's crashes (Figs. 5-6 and 5-7).
_FILTERED = (
    'Section 5.3.5: "the risk analyzer filtered risky actions of the actor leading to '
    'catastrophic situations."'
)
#: Section 5.5.2 on GridWorld-2 (Fig. 5-12).
_STATIC = (
    'Section 5.5.2: "it is important to see that all learning methods (SARSA, iCCA, '
    'AM-iCCA) improved on the baseline static policies, highlighting their sub-optimality."'
)
_SAME_LEVEL = (
    'Section 5.5.2: "Over time, however, all methods reached the same level of performance."'
)
_TWICE_FASTER = (
    'Section 5.5.2: "AM-iCCA outperformed both iCCA and SARSA, requiring two times less data '
    'compared to other learning methods to reach the asymptotic performance."'
)
#: Section 5.5.2 on UAV 7-2 with noise (Fig. 5-13).
_AM_ICCA_BEST = (
    'Section 5.5.2: "Finally AM-iCCA outperformed all other methods statistically '
    "significantly, obtaining close to 90% optimality. AM-iCCA boosted the best performance "
    'of all other methods by 22% on average."'
)
_AM_ICCA_RISK = (
    'Section 5.5.2: "The risk involved in running AM-iCCA was also close to 20%, matching the '
    'selected ε value."'
)
#: Fig. 5-13's other methods (SARSA, the two CBBAs, iCCA).
_FIG_5_13_OTHERS = ("sarsa", "cbba_aggressive", "cbba_conservative", "icca")
#: Every method of Figs. 5-9 and 5-13 but the fuel-rule variant: the variant is "the best
#: cooperative learner" when it ends above each of them.
_FIG_5_13_ALL_COOPERATIVE = (*_FIG_5_13_OTHERS, "csarsa", "am_icca", "am_icca_tolerant")


FIGURES: dict[str, Figure] = {
    "fig_4_5_pendulum": _fig_4_5(
        "pendulum",
        "a",
        "episode_length",
        (
            Claim(
                "iFDD ends above initial",
                "initial never balances",
                above("ifdd", "initial", "episode_length"),
                'Section 4.1.4: "SDM and iFDD found good policies quickly ... SARSA with the '
                "initial features never learned to balance the pendulum for more than 2,500 "
                'steps"',
            ),
            Claim(
                "iFDD learns earlier than tabular (AUC)",
                "tabular gets there later",
                above("ifdd", "tabular", "auc_episode_length"),
                'Section 4.1.4: "SDM and iFDD found good policies quickly ... The tabular '
                'representation reached near-optimal performance after about 60,000 steps"',
            ),
        ),
    ),
    "fig_4_5_blocksworld": _fig_4_5(
        "blocksworld",
        "b",
        "return",
        (
            Claim(
                "iFDD ends above initial",
                "initial does poorly",
                above("ifdd", "initial"),
                'Section 4.1.4: "As expected, the initial representation does poorly because it '
                "cannot capture correlations between blocks. Our iFDD approach on the other "
                'hand discovered the necessary feature dependencies."',
            ),
            Claim(
                "iFDD learns earlier than tabular (AUC)",
                "tabular slower",
                above("ifdd", "tabular", "auc_return"),
                "Section 4.1.4: \"[tabular's] expressiveness hindered generalization: it needed "
                'three times the data as iFDD to achieve the same performance."',
            ),
        ),
    ),
    "fig_4_5_surveillance": _fig_4_5(
        "surveillance",
        "c",
        "return",
        (
            Claim(
                "iFDD learns more than tabular (AUC)",
                "iFDD far ahead; tabular stuck near 0",
                above("ifdd", "tabular", "auc_return"),
                'Section 4.1.4: "the lack of generalization slowed learning for the tabular '
                "case: even after 10^5 steps, it held all agents in the maintenance area for "
                'the entire mission."',
            ),
        ),
    ),
    "fig_4_5_rescue": _fig_4_5(
        "rescue",
        "d",
        "return",
        (
            Claim(
                "iFDD ends above initial",
                "iFDD outperforms all after 2·10⁴ steps",
                above("ifdd", "initial"),
                _RESCUE,
            ),
            Claim("iFDD ends above tabular", "tabular worst", above("ifdd", "tabular"), _RESCUE),
        ),
    ),
    "fig_4_7_pendulum": _ifdd_beats_random("pendulum", "episode_length"),
    "fig_4_7_blocksworld": _ifdd_beats_random("blocksworld", "return"),
    "fig_4_7_surveillance": _ifdd_beats_random("surveillance", "return"),
    "fig_4_7_rescue": _ifdd_beats_random("rescue", "return"),
    "fig_4_8_pendulum_ifdd_plus": Figure(
        "Fig. 4-8 (pendulum): online iFDD⁺ (Eq. 4.3 as printed)",
        "examples/reproduction/fig_4_8_pendulum_ifdd_plus.yaml",
        ("episode_length", "num_features"),
        (
            Claim(
                "iFDD⁺ balances the pendulum for all 3,000 steps at the end, in every run",
                "always, from 40,000 steps",
                every_run_within("ifdd_plus_signed", "episode_length", 3_000.0, 3_000.0),
                'Section 4.1.4: "after 40,000 steps the resulting policy using online iFDD+ '
                'always balanced the pendulum for 3,000 steps"',
            ),
        ),
    ),
    "fig_4_11": Figure(
        "Fig. 4-11: ARiFDD vs iFDD vs initial vs tabular across initial cut counts",
        "examples/reproduction/fig_4_11.yaml",
        ("episode_length",),
        (
            Claim(
                "ARiFDD ends best (or tied) at every initial cut count",
                "yes, for all cut counts",
                best_at_every_x("arifdd", ("ifdd", "initial", "tabular"), "episode_length"),
                'Section 4.2.1: "For all initial cut values, ARiFDD achieved the best '
                'performance compared to all other methods asymptotically."',
            ),
            Claim(
                "ARiFDD's worst cut count beats the others' worst",
                "odd cut counts cripple iFDD, initial and tabular, not ARiFDD",
                worst_above_worst("arifdd", ("ifdd", "initial", "tabular"), "episode_length"),
                'Section 4.2.1: "Starting with an odd or even number of initial cuts played a '
                'major role in the performance of all methods except ARiFDD."',
            ),
        ),
    ),
    "fig_5_5": Figure(
        "Fig. 5-5: GridWorld-1, Actor-Critic vs iCCA",
        "examples/reproduction/fig_5_5.yaml",
        ("return", "learning_failures"),
        (
            Claim(
                "iCCA ends above the VI planner",
                "yes, from 6,000 steps",
                above("icca", "vi_planner"),
                'Section 5.3.5: "In particular iCCA outperformed the planner (red) after 6,000 '
                'steps by navigating farther from the danger zones."',
            ),
            Claim(
                "iCCA fails at most half as often as Actor-Critic while learning",
                "(not in the thesis)",
                at_most("icca", "actor_critic", 0.5),
            ),
            Claim(
                "iCCA ends above Actor-Critic",
                "yes",
                above("icca", "actor_critic"),
                'Section 5.3.5: "Notice how iCCA outperformed pure learning Actor-Critic."',
            ),
            Claim(
                "Actor-Critic does not end above the planner",
                "yes, at 10⁴ steps",
                no_better("actor_critic", "vi_planner"),
                'Section 5.3.5: "Actor-Critic, on the other hand, could not outperform the '
                'planner by the end of 10,000 steps."',
            ),
            Claim(
                "Algorithm 23 as printed (λ = 100, Q critic) ends above the planner",
                "yes (as iCCA)",
                above("icca_printed", "vi_planner"),
                'Section 5.3.5 (of iCCA, Algorithm 23): "In particular iCCA outperformed the '
                'planner (red) after 6,000 steps"',
            ),
            Claim(
                "the first variant (Algorithm 12's actor step) ends above the planner",
                "(not in the thesis)",
                above("icca_features", "vi_planner"),
            ),
            Claim(
                "iCCA learns earlier than its learner alone (AUC)",
                "(not in the thesis)",
                above("icca", "actor_critic_advantage", "auc_return"),
            ),
            Claim(
                "iCCA fails less than its learner alone while learning",
                "(not in the thesis)",
                at_most("icca", "actor_critic_advantage", 1.0),
            ),
        ),
    ),
    "fig_5_8": Figure(
        "Fig. 5-8: GridWorld-1, SARSA vs CSARSA",
        "examples/reproduction/fig_5_8.yaml",
        ("return", "learning_failures"),
        (
            Claim(
                "CSARSA ends above SARSA",
                "yes",
                above("csarsa", "sarsa"),
                'Section 5.4.1: "Notice how CSARSA outperformed pure learning approaches." '
                '(Fig. 5-8\'s caption: "It is clear that CSARSA outperform SARSA")',
            ),
            Claim(
                "CSARSA ends above the VI planner",
                "yes, given enough interactions",
                above("csarsa", "vi_planner"),
                "Fig. 5-8's caption: \"[CSARSA will] eventually outperform the baseline planner "
                'when given a sufficient number of interactions."',
            ),
            Claim(
                "CSARSA fails less than SARSA while learning",
                "(not in the thesis)",
                at_most("csarsa", "sarsa", 1.0),
            ),
            Claim(
                "Algorithm 24 as printed ends above the VI planner",
                "(as CSARSA)",
                above("csarsa_printed", "vi_planner"),
                "Fig. 5-8's caption (of CSARSA, Algorithm 24): \"eventually outperform the "
                'baseline planner when given a sufficient number of interactions."',
            ),
        ),
    ),
    "fig_5_6": Figure(
        "Fig. 5-6: UAV 7-2 without noise, Actor-Critic vs iCCA vs CBBA",
        "examples/reproduction/fig_5_6.yaml",
        ("return", "value_ratio", "learning_failures"),
        (
            Claim(
                "iCCA ends above CBBA",
                "+10%",
                above("icca", "cbba"),
                _ICCA_7_2 + ' "Notice how the integrated algorithm could on average boost the '
                "best individual optimality performance (i.e., CBBA's result) by %10.\"",
            ),
            Claim(
                "iCCA crashes at most a tenth as often as Actor-Critic while learning",
                "risky actions filtered",
                at_most("icca", "actor_critic", 0.1),
                _FILTERED,
            ),
            Claim(
                "Actor-Critic ends below CBBA",
                "(Fig. 5-6(b) only)",
                above("cbba", "actor_critic"),
            ),
            Claim(
                "Algorithm 23 as printed ends above CBBA",
                "yes (as iCCA)",
                above("icca_printed", "cbba"),
                _ICCA_7_2,
            ),
            Claim(
                "the first variant (Algorithm 12's actor step) ends above CBBA",
                "(not in the thesis)",
                above("icca_features", "cbba"),
            ),
            Claim(
                "iCCA crashes less than its learner alone while learning",
                "(not in the thesis)",
                at_most("icca", "actor_critic_advantage", 0.3),
            ),
        ),
    ),
    "fig_5_7": Figure(
        "Fig. 5-7: UAV 10-2 without noise, Actor-Critic vs iCCA vs CBBA",
        "examples/reproduction/fig_5_7.yaml",
        ("return", "value_ratio", "learning_failures"),
        (
            Claim("iCCA ends above CBBA", "yes, significantly", above("icca", "cbba"), _ICCA_10_2),
            Claim(
                "Actor-Critic ends below CBBA",
                "yes, no sensible policy after 10⁵ steps",
                above("cbba", "actor_critic"),
                'Section 5.3.5: "Actor-Critic method had a hard time to find a sensible policy '
                "even after 10^5 steps. Online CBBA still could find a good policy to the "
                'approximated problem."',
            ),
            Claim(
                "iCCA crashes at most a tenth as often as Actor-Critic while learning",
                "risky actions filtered",
                at_most("icca", "actor_critic", 0.1),
                _FILTERED,
            ),
            Claim(
                "Algorithm 23 as printed ends above CBBA",
                "yes (as iCCA)",
                above("icca_printed", "cbba"),
                _ICCA_10_2,
            ),
        ),
    ),
    "fig_5_9_13": Figure(
        "Figs. 5-9 and 5-13: UAV 7-2 with 5% traverse failures",
        "examples/reproduction/fig_5_9_13.yaml",
        ("return", "value_ratio", "failure_rate", "learning_failures"),
        (
            Claim(
                "SARSA: optimality below 0.5",
                "< 50%",
                within("sarsa", "optimality", -np.inf, 0.5),
                'Section 5.4.1: "SARSA could barely avoid crashing scenarios (about 90%), thus '
                'yielding low performance with less than 50% optimality."',
            ),
            Claim(
                "SARSA: crash probability above 0.8",
                "> 80% (≈ 90%)",
                within("sarsa", "failure_rate", 0.8, 1.0),
                'Section 5.5.2: "SARSA at the end of training yielded 50% optimal performance, '
                'together with more than 80% chance of crashing a UAV."',
            ),
            *(
                Claim(
                    f"{name} CBBA ends above SARSA",
                    "yes",
                    above(f"cbba_{name}", "sarsa"),
                    'Section 5.5.2: "Both CBBA variations outperformed SARSA."',
                )
                for name in ("aggressive", "conservative")
            ),
            Claim(
                "aggressive CBBA: optimality above 0.8",
                "> 80%",
                within("cbba_aggressive", "optimality", 0.8, np.inf),
                'Section 5.5.2: "The aggressive CBBA achieved more than 80% optimality in cost '
                'of 25% crash probability"',
            ),
            Claim(
                "aggressive CBBA: crash probability in [0.15, 0.35]",
                "≈ 25%",
                within("cbba_aggressive", "failure_rate", 0.15, 0.35),
                'Section 5.5.2: "The aggressive CBBA achieved more than 80% optimality in cost '
                'of 25% crash probability"',
            ),
            Claim(
                "conservative CBBA: 2-8% below aggressive",
                "≈ 5% below",
                ratio_within("cbba_conservative", "cbba_aggressive", -0.08, -0.02),
                'Section 5.5.2: "conservative CBBA had 5% less performance"',
            ),
            Claim(
                "conservative CBBA: crash probability at most 0.05",
                "rare",
                within("cbba_conservative", "failure_rate", 0.0, 0.05),
                'Section 5.5.2: "as expected, it realized a safe policy with rare chances of '
                'crashing."',
            ),
            Claim(
                "CSARSA ends above its CBBA (aggressive)",
                "+7%, significant",
                above("csarsa", "cbba_aggressive"),
                'Section 5.4.1: "CSARSA raised the optimality of CBBA by 7%. This improvement '
                'was statistically significant."',
            ),
            Claim(
                "CSARSA's crash probability is level with its CBBA's",
                "−6%, not significant",
                level("csarsa", "cbba_aggressive", "failure_rate"),
                'Section 5.4.1: "On average, CSARSA reduced the probability of failure of CBBA '
                'by 6%, yet this improvement was not statistically significant."',
            ),
            Claim(
                "CSARSA ends above SARSA",
                "yes",
                above("csarsa", "sarsa"),
                'Fig. 5-9\'s caption: "CSARSA improved the performance of both CBBA and SARSA."',
            ),
            Claim(
                "CSARSA crashes at most 0.3× as often as SARSA while learning",
                "(not in the thesis)",
                at_most("csarsa", "sarsa", 0.3),
            ),
            Claim(
                "iCCA (static model) ends above conservative CBBA",
                "yes, at ≈ 20% risk",
                above("icca", "cbba_conservative"),
                'Section 5.5.2: "The iCCA algorithm improved the performance of the '
                'conservative CBBA planner again by introducing risk of crash around 20%."',
            ),
            Claim(
                "iCCA (static model) ends level with aggressive CBBA",
                "above on average, not significant",
                level("icca", "cbba_aggressive"),
                'Section 5.5.2: "While on average it performed better than that aggressive '
                'policy, the difference was not statistically significant."',
            ),
            Claim(
                "AM-iCCA ends above every other method",
                "+22% over the best (≈ 0.9 optimal)",
                above_best("am_icca", _FIG_5_13_OTHERS),
                _AM_ICCA_BEST,
            ),
            Claim(
                "AM-iCCA crashes at most 0.3× as often as SARSA while learning",
                "(not in the thesis)",
                at_most("am_icca", "sarsa", 0.3),
            ),
            Claim(
                "AM-iCCA: crash probability in [0.1, 0.3]",
                "≈ 20% (= ε)",
                within("am_icca", "failure_rate", 0.1, 0.3),
                _AM_ICCA_RISK,
            ),
            Claim(
                "AM-iCCA with risk ≤ 20% allowed ends above every other method",
                '+22% ("allowed risk level of 20%")',
                above_best("am_icca_tolerant", _FIG_5_13_OTHERS),
                _AM_ICCA_BEST,
            ),
            Claim(
                "AM-iCCA with risk ≤ 20% crashes at most 0.3× as often as SARSA while learning",
                "(not in the thesis)",
                at_most("am_icca_tolerant", "sarsa", 0.3),
            ),
            Claim(
                "AM-iCCA with risk ≤ 20%: crash probability in [0.1, 0.3]",
                "≈ 20% (= ε)",
                within("am_icca_tolerant", "failure_rate", 0.1, 0.3),
                _AM_ICCA_RISK,
            ),
            Claim(
                "AM-iCCA with the fuel rule as its safety test ends above every other method",
                "+22% (as AM-iCCA; the variant is not in the thesis)",
                above_best("am_icca_fuel_rule", _FIG_5_13_ALL_COOPERATIVE),
                _AM_ICCA_BEST,
            ),
            Claim(
                "AM-iCCA with the fuel rule crashes at most 0.3× as often as SARSA while learning",
                "(not in the thesis)",
                at_most("am_icca_fuel_rule", "sarsa", 0.3),
            ),
        ),
    ),
    "fig_5_12": Figure(
        "Fig. 5-12: GridWorld-2, SARSA vs iCCA vs AM-iCCA",
        "examples/reproduction/fig_5_12.yaml",
        ("return", "learning_failures"),
        (
            Claim(
                "iCCA (static model) ends above both static policies",
                "yes",
                above_best("icca", ("conservative", "aggressive")),
                _STATIC,
            ),
            Claim(
                "SARSA ends above both static policies",
                "yes",
                above_best("sarsa", ("conservative", "aggressive")),
                _STATIC,
            ),
            Claim(
                "AM-iCCA ends above both static policies",
                "yes",
                above_best("am_icca", ("conservative", "aggressive")),
                _STATIC,
            ),
            Claim(
                "AM-iCCA and iCCA end level", "same level", level("am_icca", "icca"), _SAME_LEVEL
            ),
            Claim(
                "AM-iCCA and SARSA end level", "same level", level("am_icca", "sarsa"), _SAME_LEVEL
            ),
            Claim(
                "AM-iCCA learns faster than iCCA (AUC)",
                "half the data",
                above("am_icca", "icca", "auc_return"),
                _TWICE_FASTER,
            ),
            Claim(
                "AM-iCCA learns faster than SARSA (AUC)",
                "half the data",
                above("am_icca", "sarsa", "auc_return"),
                _TWICE_FASTER,
            ),
        ),
    ),
    "fig_5_14": Figure(
        "Section 5.5.3: GridWorld-3, AM-iCCA with and without the safety check switched off",
        "examples/reproduction/fig_5_14.yaml",
        ("return", "learning_failures"),
        (
            Claim(
                "the extension ends above AM-iCCA",
                "converges to the optimum; AM-iCCA does not",
                above("am_icca_switch_off", "am_icca"),
                'Section 5.5.3: "This can cause the AM-iCCA to converge to a suboptimal policy" '
                'and, of the extension, "we conjecture that the resulting process converges to '
                'the optimal policy under certain conditions."',
            ),
        ),
    ),
    **{
        name: _safe_rl(title, name, cost_limit, learners, cooperative, name != _NO_SHIELD)
        for name, title, cost_limit, learners, cooperative in (
            (
                "safe_rl_gridworld_1",
                "GridWorld-1",
                0.15,
                (*_CONSTRAINED, "actor_critic_pid_lagrangian"),
                ("csarsa", "icca"),
            ),
            (
                "safe_rl_gridworld_1_1e5",
                "GridWorld-1 with 10⁵ steps",
                0.15,
                (*_CONSTRAINED, "actor_critic_pid_lagrangian"),
                ("csarsa", "icca"),
            ),
            ("safe_rl_gridworld_2", "GridWorld-2", 0.05, _CONSTRAINED, ("icca", "am_icca")),
            (
                "safe_rl_uav_7_2",
                "UAV 7-2 with 5% traverse failures",
                0.1,
                (*_CONSTRAINED, "actor_critic_pid_lagrangian"),
                ("csarsa", "icca", "am_icca"),
            ),
        )
    },
    "ifdd_csarsa": Figure(
        "Section 6.2.6: CSARSA with online iFDD⁺ on UAV 10-2 with 5% failures",
        "examples/reproduction/ifdd_csarsa.yaml",
        ("return", "value_ratio", "failure_rate"),
        (
            Claim(
                "CSARSA + iFDD⁺ ends above tabular CSARSA",
                "(future work)",
                above("csarsa_ifdd", "csarsa_tabular"),
            ),
        ),
    ),
}


#: Ids that name several figures: ``safe_rl`` is the comparison on its three domains.
GROUPS = {"safe_rl": tuple(name for name in FIGURES if name.startswith("safe_rl_"))}


def figure_names(names: Sequence[str]) -> list[str]:
    """Return ``names`` checked against `FIGURES` (``fig_5_5``, ``5_5`` and ``5-5`` all name one).

    A `GROUPS` id names its figures.

    Raises
    ------
    InvalidParameterError
        For an unknown name, with a did-you-mean and the known names.
    """
    chosen = []
    for name in names:
        key = name.strip().lower().replace("-", "_").replace(".", "_")
        if key in GROUPS:
            chosen.extend(GROUPS[key])
            continue
        key = key if key in FIGURES else f"fig_{key}"
        if key == "fig_3_15":
            raise InvalidParameterError(
                "Fig. 3-15 is a batch evaluation, not a sweep: run `python "
                "docs/reproduction/fig_3_15.py` (its docstring gives the thesis's setting)."
            )
        if key not in FIGURES:
            raise InvalidParameterError(
                f"Unknown figure {name!r}.{did_you_mean(name, [*FIGURES, *GROUPS])} Known: "
                f"{', '.join([*FIGURES, *GROUPS])} (`conjure reproduce --list`)."
            )
        chosen.append(key)
    return list(dict.fromkeys(chosen))


# ------------------------------------------------------------------------------------ scales


def check_scale(scale: str) -> str:
    """Return ``scale`` if it is one of `SCALES`.

    Raises
    ------
    InvalidParameterError
        Otherwise, with a did-you-mean.
    """
    if scale not in SCALES:
        raise InvalidParameterError(
            f"Unknown scale {scale!r}.{did_you_mean(scale, list(SCALES))} Known: "
            f"{', '.join(SCALES)}."
        )
    return scale


def _quick(data: dict[str, Any]) -> dict[str, Any]:
    """The quick scale of raw sweep ``data`` (see the module docstring)."""
    quick = dict(data)
    sweep = SweepConfig.model_validate(quick)
    if sweep.selection is not None:
        seeds = fresh_seeds(sweep.seed_list(), sweep.selection.fresh_seeds)
        quick.pop("selection")
        quick["grid"], quick["domain_grids"] = {}, {}
    else:
        seeds = sweep.seed_list()
    quick["seeds"] = seeds[:QUICK_SEEDS]
    return quick


def load_figure_sweep(
    name: str, scale: str, root: str | Path, overrides: Sequence[str] = ()
) -> SweepConfig:
    """Return figure ``name``'s shipped sweep at ``scale``, with ``--set`` ``overrides`` applied.

    Parameters
    ----------
    name : str
        A `FIGURES` key.
    scale : {"quick", "thesis"}
        See the module docstring.
    root : str or Path
        The folder the figure's ``config`` path is relative to (the repository).
    overrides : sequence of str
        ``dotted.path=value`` as ``conjure sweep --set`` takes, applied after the scale.
    """
    check_scale(scale)
    figure = FIGURES[name]
    data = read_sweep_data(Path(root) / figure.config)
    if scale == "quick":
        data = _quick(data)
    source = f"{figure.config} ({scale})"
    return parse_overridden(data, overrides, apply_sweep_overrides, parse_sweep, source=source)


def _num_runs(sweep: SweepConfig) -> int:
    seeds = len(sweep.seed_list())
    runs = 0
    for domain_label in sweep.domain_specs():
        grid = {**sweep.grid, **sweep.domain_grids.get(domain_label, {})}
        for agent_label in sweep.agents:
            keys = grid_keys_for(list(grid), domain_label, agent_label)
            runs += math.prod(len(grid[key]) for key in keys) * seeds
            if sweep.selection is not None:
                runs += len(fresh_seeds(sweep.seed_list(), sweep.selection.fresh_seeds))
    return runs


def figure_cost(name: str, scale: str, root: str | Path) -> tuple[int, int]:
    """Return (runs, learning steps) of figure ``name`` at ``scale``, read from its config.

    Runs: per (domain, agent), the grid settings that concern it × the seeds, plus the fresh
    seeds of the selection rerun; learning steps: runs × ``budget_steps`` (policy checks are
    not counted). Reads the config without building its runs, so it is quick.
    """
    check_scale(scale)
    data = read_sweep_data(Path(root) / FIGURES[name].config)
    sweep = SweepConfig.model_validate(_quick(data) if scale == "quick" else data)
    runs = _num_runs(sweep)
    return runs, runs * sweep.budget_steps


# ------------------------------------------------------------------------------------ output


def comparison_markdown(name: str, finals: pd.DataFrame, *, scale: str) -> str:
    """The ``comparison.md`` of figure ``name``: its claims against ``finals`` (`finals_table`).

    Each claim's row gives the thesis's value, the measured value with its 95% interval and
    whether it holds (`claim_rows`).
    """
    figure = FIGURES[name]
    seeds = finals.groupby("label")["seed"].nunique()
    counts = f"{seeds.min()}" if seeds.min() == seeds.max() else f"{seeds.min()}-{seeds.max()}"
    lines = [
        f"# {figure.title}",
        "",
        f"`conjure reproduce {name} --scale {scale}` on `{figure.config}`: {counts} seeds per "
        "method. Final policy check, mean ± 95% t half-width; differences use Welch's interval.",
        "",
    ]
    if scale == "quick":
        lines += [
            f"Quick scale: with {counts} seeds a 'no' on an \"ends above\" claim often means "
            "the interval is too wide to decide; `--scale thesis` decides.",
            "",
        ]
    lines += [finals_markdown(finals), ""]
    if not figure.claims:
        lines.append("No claims are catalogued for this figure; see the table and the plots.")
    else:
        lines.append(claim_rows(figure.claims, finals))
        lines += ["", "What each claim quotes:", ""]
        lines += [
            f"- {claim.text}: {claim.quote or 'no sentence of the thesis; ' + claim.thesis}"
            for claim in figure.claims
        ]
    return "\n".join(lines) + "\n"
