"""Chapter 5's stored results and the tables of docs/reproduction.md made from them.

    python docs/reproduction/chapter5.py store FIGURE DIR   # DIR: a finished `conjure sweep`
    python docs/reproduction/chapter5.py render [--check]

``store`` reads DIR/selected/ (the fresh-seed rerun of the selected settings; DIR itself when the
sweep had no selection) and writes, under docs/reproduction/chapter5/:

- ``FIGURE_finals.csv``: one row per method and seed: the final policy check's metrics, the
  failures while learning and the area under the return curve (the selection criterion);
- ``FIGURE_curve.csv``: per method and policy check, the mean, the 95% Student-t half-width
  and the interval's ends cut at the metric's range, of each metric over seeds (what the
  learning-curve plots show);
- ``FIGURE_selection.csv``: DIR/selection.csv, the settings the grid search chose;

and the learning-curve plots (``docs/reproduction/FIGURE_<metric>.png``).

``render`` rewrites every block between ``<!-- chapter5:FIGURE -->`` and
``<!-- /chapter5:FIGURE -->`` in docs/reproduction.md from the stored CSVs: the final table
and the figure's claims, each with the thesis's value, the measured value and whether it holds.
``--check`` changes nothing and exits with status 1 if the doc differs from what the CSVs give
(tests/test_reproduction_docs.py runs it).
"""

from __future__ import annotations

import argparse
import shutil
import sys
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
from scipy import stats

from conjure.experiments.metric_ranges import clip_interval, metric_range
from conjure.experiments.numbers import format_interval
from conjure.experiments.results import t_confidence
from conjure.reporting.plots import plot_learning_curves
from conjure.sweeps.selection import score_runs

HERE = Path(__file__).resolve().parent
STORE = HERE / "chapter5"
DOC = HERE.parent / "reproduction.md"

#: The curve columns stored, with their table headings.
METRICS = {
    "return": "final return",
    "value_ratio": "V/V*",
    "optimality": "optimality",
    "failure_rate": "failure rate",
    "learning_failures": "failures while learning",
}


# ------------------------------------------------------------------------------------ store


def finals_table(frame: pd.DataFrame) -> pd.DataFrame:
    """One row per run: label, seed, the last policy check's metrics and the return's AUC."""
    last = frame.sort_values("learning_steps").groupby("run_id", sort=False).tail(1)
    finals = last[["run_id", "label", "seed", "learning_steps", *METRICS]].copy()
    auc = score_runs(frame, "return", "auc")
    finals["auc_return"] = finals["run_id"].map(auc).to_numpy(dtype=float)
    order = {label: k for k, label in enumerate(frame["label"].drop_duplicates())}
    finals = finals.assign(_order=finals["label"].map(order)).sort_values(["_order", "seed"])
    return finals.drop(columns=["_order", "run_id"]).reset_index(drop=True)


def curve_table(frame: pd.DataFrame) -> pd.DataFrame:
    """Mean, 95% t half-width and cut interval of every metric per label and policy check."""
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


def store(figure: str, results_dir: Path) -> None:
    """Write FIGURE's CSVs and plots from a finished sweep folder."""
    if figure not in FIGURES:
        sys.exit(f"Unknown figure {figure!r}; known: {', '.join(FIGURES)}.")
    folder = results_dir / "selected" if (results_dir / "selected").is_dir() else results_dir
    frame = pd.read_parquet(folder / "results.parquet")
    STORE.mkdir(exist_ok=True)
    finals_table(frame).to_csv(STORE / f"{figure}_finals.csv", index=False)
    curve_table(frame).to_csv(STORE / f"{figure}_curve.csv", index=False)
    if (results_dir / "selection.csv").is_file():
        shutil.copyfile(results_dir / "selection.csv", STORE / f"{figure}_selection.csv")
    for metric in FIGURES[figure].plots:
        plot_learning_curves(
            frame, HERE / f"{figure}_{metric}.png", metric=metric, title=FIGURES[figure].title
        )
    print(f"stored {figure} from {folder} ({frame['run_id'].nunique()} runs)")


# ------------------------------------------------------------------------------------ claims


@dataclass(frozen=True)
class Claim:
    """A sentence of the thesis, its number, and how to measure it from the finals."""

    text: str
    thesis: str
    measure: Callable[[pd.DataFrame], tuple[str, bool]]


def values(finals: pd.DataFrame, label: str, metric: str) -> np.ndarray:
    """The per-seed final ``metric`` of ``label``."""
    chosen = finals.loc[finals["label"] == label, metric].to_numpy(dtype=float)
    if chosen.size == 0:
        known = ", ".join(finals["label"].drop_duplicates())
        raise SystemExit(f"No stored results for {label!r}; the stored labels are {known}.")
    return chosen


def welch(a: np.ndarray, b: np.ndarray) -> tuple[float, float]:
    """mean(a) − mean(b) and its 95% Welch half-width (0 when both have no spread)."""
    difference = float(a.mean() - b.mean())
    va, vb = a.var(ddof=1) / a.size, b.var(ddof=1) / b.size
    if va + vb == 0.0:
        return difference, 0.0
    dof = (va + vb) ** 2 / (va**2 / (a.size - 1) + vb**2 / (b.size - 1))
    return difference, float(stats.t.ppf(0.975, dof) * np.sqrt(va + vb))


def above(
    better: str, worse: str, metric: str = "return", *, by: float = 0.0, significant: bool = True
) -> Callable[[pd.DataFrame], tuple[str, bool]]:
    """``better`` ends above ``worse`` by more than ``by`` × |worse|.

    With ``significant`` the 95% Welch interval of the difference must lie above that margin;
    otherwise ("at or above") it must not lie below it: no significant shortfall.
    """

    def measure(finals: pd.DataFrame) -> tuple[str, bool]:
        a, b = values(finals, better, metric), values(finals, worse, metric)
        difference, half = welch(a, b)
        base = abs(b.mean())
        relative = f" ({difference / base:+.1%})" if base > 0 else ""
        text = f"{better} − {worse}: {format_interval(difference, half)}{relative}"
        if significant:
            return text, bool(difference - half > by * base)
        return text, bool(difference + half >= by * base)

    return measure


def above_best(
    label: str, others: tuple[str, ...], metric: str = "return", *, by: float = 0.0
) -> Callable[[pd.DataFrame], tuple[str, bool]]:
    """``label`` ends above the best of ``others`` (by mean) by more than ``by``, significantly."""

    def measure(finals: pd.DataFrame) -> tuple[str, bool]:
        best = max(others, key=lambda other: values(finals, other, metric).mean())
        return above(label, best, metric, by=by)(finals)

    return measure


def ratio_within(
    label: str, other: str, low: float, high: float, metric: str = "return"
) -> Callable[[pd.DataFrame], tuple[str, bool]]:
    """The ratio of the means of ``label`` and ``other``, minus 1, lies in [low, high]."""

    def measure(finals: pd.DataFrame) -> tuple[str, bool]:
        a, b = values(finals, label, metric).mean(), values(finals, other, metric).mean()
        change = a / b - 1.0
        return f"{label} / {other} − 1 = {change:+.1%}", bool(low <= change <= high)

    return measure


def at_most(
    label: str, other: str, fraction: float, metric: str = "learning_failures"
) -> Callable[[pd.DataFrame], tuple[str, bool]]:
    """The mean ``metric`` of ``label`` is at most ``fraction`` × that of ``other``."""

    def measure(finals: pd.DataFrame) -> tuple[str, bool]:
        a, b = values(finals, label, metric).mean(), values(finals, other, metric).mean()
        ratio = a / b if b > 0 else np.inf
        return f"{label} / {other}: {a:,.0f} / {b:,.0f} = {ratio:.2f}", bool(ratio <= fraction)

    return measure


def within(
    label: str, metric: str, low: float, high: float
) -> Callable[[pd.DataFrame], tuple[str, bool]]:
    """The mean final ``metric`` of ``label`` lies in [low, high]."""

    def measure(finals: pd.DataFrame) -> tuple[str, bool]:
        mean, half = t_confidence(values(finals, label, metric))
        text = format_interval(mean, half, metric_range(finals, metric))
        return f"{label}: {text}", bool(low <= mean <= high)

    return measure


# ------------------------------------------------------------------------------------ figures


@dataclass(frozen=True)
class Figure:
    """One chapter-5 figure: its sweep config, plots and claims."""

    title: str
    config: str
    plots: tuple[str, ...]
    claims: tuple[Claim, ...]


FIGURES: dict[str, Figure] = {
    "fig_5_5": Figure(
        "Fig. 5-5: GridWorld-1, Actor-Critic vs iCCA",
        "examples/reproduction/fig_5_5.yaml",
        ("return", "learning_failures"),
        (
            Claim(
                "iCCA ends above the VI planner",
                "yes, from 6,000 steps",
                above("icca", "vi_planner"),
            ),
            Claim(
                "iCCA fails at most half as often as Actor-Critic while learning",
                "fewer failures",
                at_most("icca", "actor_critic", 0.5),
            ),
            Claim("iCCA ends above Actor-Critic", "yes", above("icca", "actor_critic")),
            Claim(
                "Actor-Critic ends below the planner",
                "yes, at 10⁴ steps",
                above("vi_planner", "actor_critic"),
            ),
            Claim(
                "Algorithm 23 as printed (λ = 100, Q critic) ends above the planner",
                "yes (as iCCA)",
                above("icca_printed", "vi_planner"),
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
            Claim("CSARSA ends above SARSA", "yes", above("csarsa", "sarsa")),
            Claim(
                "CSARSA ends above the VI planner",
                "yes, given enough interactions",
                above("csarsa", "vi_planner"),
            ),
            Claim(
                "CSARSA fails less than SARSA while learning",
                "yes",
                at_most("csarsa", "sarsa", 1.0),
            ),
            Claim(
                "Algorithm 24 as printed ends above the VI planner",
                "(as CSARSA)",
                above("csarsa_printed", "vi_planner"),
            ),
        ),
    ),
    "fig_5_6": Figure(
        "Fig. 5-6: UAV 7-2 without noise, Actor-Critic vs iCCA vs CBBA",
        "examples/reproduction/fig_5_6.yaml",
        ("return", "value_ratio", "learning_failures"),
        (
            Claim("iCCA ends at least 3% above CBBA", "+10%", above("icca", "cbba", by=0.03)),
            Claim(
                "iCCA crashes at most a tenth as often as Actor-Critic while learning",
                "risky actions filtered",
                at_most("icca", "actor_critic", 0.1),
            ),
            Claim("Actor-Critic ends below CBBA", "yes", above("cbba", "actor_critic")),
            Claim(
                "Algorithm 23 as printed ends above CBBA",
                "yes (as iCCA)",
                above("icca_printed", "cbba"),
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
            Claim("iCCA ends above CBBA", "yes, significantly", above("icca", "cbba")),
            Claim(
                "Actor-Critic ends below CBBA",
                "yes, no sensible policy after 10⁵ steps",
                above("cbba", "actor_critic"),
            ),
            Claim(
                "iCCA crashes at most a tenth as often as Actor-Critic while learning",
                "risky actions filtered",
                at_most("icca", "actor_critic", 0.1),
            ),
            Claim(
                "Algorithm 23 as printed ends above CBBA",
                "yes (as iCCA)",
                above("icca_printed", "cbba"),
            ),
        ),
    ),
    "fig_5_9_13": Figure(
        "Figs. 5-9 and 5-13: UAV 7-2 with 5% traverse failures",
        "examples/reproduction/fig_5_9_13.yaml",
        ("return", "value_ratio", "failure_rate", "learning_failures"),
        (
            Claim(
                "SARSA: optimality below 0.5", "< 50%", within("sarsa", "optimality", -np.inf, 0.5)
            ),
            Claim(
                "SARSA: crash probability above 0.8",
                "> 80% (≈ 90%)",
                within("sarsa", "failure_rate", 0.8, 1.0),
            ),
            Claim(
                "aggressive CBBA: V/V* in [0.70, 0.92]",
                "> 80%",
                within("cbba_aggressive", "value_ratio", 0.70, 0.92),
            ),
            Claim(
                "aggressive CBBA: crash probability in [0.15, 0.35]",
                "≈ 25%",
                within("cbba_aggressive", "failure_rate", 0.15, 0.35),
            ),
            Claim(
                "conservative CBBA: 2-8% below aggressive",
                "≈ 5% below",
                ratio_within("cbba_conservative", "cbba_aggressive", -0.08, -0.02),
            ),
            Claim(
                "conservative CBBA: crash probability at most 0.05",
                "rare",
                within("cbba_conservative", "failure_rate", 0.0, 0.05),
            ),
            Claim(
                "CSARSA ends at least 3% above its CBBA (aggressive)",
                "+7%",
                above("csarsa", "cbba_aggressive", by=0.03),
            ),
            Claim(
                "CSARSA crashes at most 0.3× as often as SARSA while learning",
                "far fewer",
                at_most("csarsa", "sarsa", 0.3),
            ),
            Claim(
                "iCCA (static model) ends above conservative CBBA",
                "yes, at ≈ 20% risk",
                above("icca", "cbba_conservative"),
            ),
            Claim(
                "AM-iCCA ends at least 5% above the better CBBA",
                "+22% (≈ 0.9 optimal)",
                above_best("am_icca", ("cbba_aggressive", "cbba_conservative"), by=0.05),
            ),
            Claim(
                "AM-iCCA crashes at most 0.3× as often as SARSA while learning",
                "far fewer",
                at_most("am_icca", "sarsa", 0.3),
            ),
            Claim(
                "AM-iCCA: crash probability in [0.1, 0.3]",
                "≈ 20% (= ε)",
                within("am_icca", "failure_rate", 0.1, 0.3),
            ),
            Claim(
                "AM-iCCA with risk ≤ 20% allowed ends at least 5% above the better CBBA",
                '+22% ("allowed risk level of 20%")',
                above_best("am_icca_tolerant", ("cbba_aggressive", "cbba_conservative"), by=0.05),
            ),
            Claim(
                "AM-iCCA with risk ≤ 20% allowed ends above the better CBBA",
                "yes",
                above_best("am_icca_tolerant", ("cbba_aggressive", "cbba_conservative")),
            ),
            Claim(
                "AM-iCCA with risk ≤ 20% crashes at most 0.3× as often as SARSA while learning",
                "far fewer",
                at_most("am_icca_tolerant", "sarsa", 0.3),
            ),
            Claim(
                "AM-iCCA with risk ≤ 20%: crash probability in [0.1, 0.3]",
                "≈ 20% (= ε)",
                within("am_icca_tolerant", "failure_rate", 0.1, 0.3),
            ),
        ),
    ),
    "fig_5_12": Figure(
        "Fig. 5-12: GridWorld-2, SARSA vs iCCA vs AM-iCCA",
        "examples/reproduction/fig_5_12.yaml",
        ("return", "learning_failures"),
        (
            Claim(
                "iCCA (static model) ends at or above the conservative policy",
                "above both static policies",
                above("icca", "conservative", significant=False),
            ),
            Claim(
                "SARSA ends above the aggressive policy",
                "above both static policies",
                above("sarsa", "aggressive"),
            ),
            Claim(
                "AM-iCCA ends above the aggressive policy",
                "above both static policies",
                above("am_icca", "aggressive"),
            ),
            Claim(
                "AM-iCCA learns faster than iCCA (AUC)",
                "half the data",
                above("am_icca", "icca", "auc_return"),
            ),
            Claim(
                "AM-iCCA learns faster than SARSA (AUC)",
                "half the data",
                above("am_icca", "sarsa", "auc_return"),
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
            ),
        ),
    ),
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


# ------------------------------------------------------------------------------------ render


def final_rows(finals: pd.DataFrame) -> str:
    """The markdown table of the final policy check, one row per method."""
    metrics = [m for m in METRICS if np.isfinite(finals[m].to_numpy(dtype=float)).any()]
    heading = ["method", "seeds", *(METRICS[m] for m in metrics), "AUC of return"]
    lines = ["| " + " | ".join(heading) + " |", "|" + "---|" * len(heading)]
    for label, group in finals.groupby("label", sort=False):
        cells = [label, str(group["seed"].nunique())]
        for metric in [*metrics, "auc_return"]:
            mean, half = t_confidence(group[metric])
            cells.append(format_interval(mean, half, metric_range(group, metric)))
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def claim_rows(figure: Figure, finals: pd.DataFrame) -> str:
    """The markdown table of the figure's claims: thesis, measured, holds."""
    lines = ["| claim | thesis | measured (95% interval) | holds? |", "|---|---|---|---|"]
    for claim in figure.claims:
        measured, holds = claim.measure(finals)
        lines.append(f"| {claim.text} | {claim.thesis} | {measured} | {'yes' if holds else 'no'} |")
    return "\n".join(lines)


def selection_rows(name: str) -> str:
    """The settings the grid search chose, one line per method with a grid."""
    path = STORE / f"{name}_selection.csv"
    if not path.is_file():
        return "No grid search (every method has one setting)."
    selection = pd.read_csv(path, keep_default_na=False)
    chosen = selection[selection["setting"] != ""]
    lines = [f"Selected by {chosen['criterion'].iloc[0]} on the search seeds:", ""]
    for row in chosen.itertuples():
        lines.append(f"- `{row.label}`: {row.setting} ({row.num_settings} settings finished)")
    return "\n".join(lines)


def block(name: str) -> str:
    """The generated text of one figure: its command, selection, final table and claims."""
    figure = FIGURES[name]
    finals = pd.read_csv(STORE / f"{name}_finals.csv")
    parts = [
        f"Stored results: `docs/reproduction/chapter5/{name}_*.csv` "
        f"(`python docs/reproduction/chapter5.py store {name} DIR` after "
        f"`conjure sweep {figure.config} --out DIR`). Final policy check on the fresh seeds "
        f"(mean ± 95% t half-width); V/V* is the return over the exact optimum, optimality "
        f"(V − V_worst)/(V* − V_worst) the thesis's Fig. 5-6b scale.",
        "",
        selection_rows(name),
        "",
        final_rows(finals),
    ]
    if figure.claims:
        parts += ["", claim_rows(figure, finals)]
    return "\n".join(parts)


def rendered(text: str) -> str:
    """``text`` with every chapter-5 block regenerated from the stored CSVs."""
    for name in FIGURES:
        start, end = f"<!-- chapter5:{name} -->", f"<!-- /chapter5:{name} -->"
        if start not in text:
            continue
        head, rest = text.split(start, 1)
        _, tail = rest.split(end, 1)
        text = f"{head}{start}\n{block(name)}\n{end}{tail}"
    return text


def render(check: bool) -> int:
    """Rewrite docs/reproduction.md (or, with ``check``, report whether it is up to date)."""
    text = DOC.read_text()
    new = rendered(text)
    if check:
        if new != text:
            print(
                "docs/reproduction.md differs from the stored chapter-5 results; run "
                "`python docs/reproduction/chapter5.py render`."
            )
            return 1
        return 0
    DOC.write_text(new)
    return 0


def main() -> None:
    """Command line: ``store FIGURE DIR`` or ``render [--check]``."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    commands = parser.add_subparsers(dest="command", required=True)
    storing = commands.add_parser("store")
    storing.add_argument("figure")
    storing.add_argument("results_dir", type=Path)
    rendering = commands.add_parser("render")
    rendering.add_argument("--check", action="store_true")
    args = parser.parse_args()
    if args.command == "store":
        store(args.figure, args.results_dir)
    else:
        sys.exit(render(args.check))


if __name__ == "__main__":
    main()
