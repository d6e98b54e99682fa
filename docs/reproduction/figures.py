"""The reproduced figures' stored results and the documentation pages made from them.

    python docs/reproduction/figures.py store FIGURE DIR   # DIR: a finished sweep or reproduce
    python docs/reproduction/figures.py render [--check]

``store`` reads DIR/selected/ (the fresh-seed rerun of the selected settings; DIR itself when the
sweep had no selection) and writes, under docs/reproduction/chapter<N>/ (N: the figure's
chapter, 4 or 5; Section 6.2.6 with chapter 5):

- ``FIGURE_finals.csv``: one row per method and seed: the final policy check's metrics, the
  failures while learning and the area under the return curve (the selection criterion);
- ``FIGURE_curve.csv``: per method and policy check, the mean, the 95% Student-t half-width
  and the interval's ends cut at the metric's range, of each metric over seeds (what the
  learning-curve plots show);
- ``FIGURE_selection.csv``: DIR/selection.csv, the settings the grid search chose;

and the learning-curve plots (``docs/reproduction/FIGURE_<metric>.png``).

``render`` rewrites, from the stored CSVs, every block between ``<!-- chapterN:FIGURE -->`` and
``<!-- /chapterN:FIGURE -->`` in the pages docs/reproduction/*.md (the command, the selected
settings, the final table, the figure's claims, each with the thesis's value, the measured
value and whether it holds, and the plots) and every ``<!-- claims:FIGURE -->`` block
(README.md) with the claims alone. A figure with stored results whose block is on no page gets
a page of its own, ``docs/reproduction/FIGURE.md``; the list of figure pages in
docs/reproduction/index.md and the site's navigation (mkdocs.yml) follow the pages. ``--check``
changes nothing and exits with status 1 if a document differs from what the CSVs give
(tests/test_reproduction_docs.py runs it).

The figures, their claims and the tables come from the package's catalogue,
`conjure.sweeps.reproduction`, which ``conjure reproduce`` uses too: a claim is defined once.
"""

from __future__ import annotations

import argparse
import re
import shutil
import sys
from pathlib import Path

import pandas as pd

from conjure.experiments import registry
from conjure.reporting.plots import plot_learning_curves
from conjure.sweeps import reproduction
from conjure.sweeps.reproduction import claim_rows, curve_table, finals_markdown, finals_table
from conjure.sweeps.sweep import load_sweep

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
#: The reproduction's index page: how the runs were made, the summary, the list of pages.
INDEX = HERE / "index.md"
#: The site's configuration, whose navigation lists the figure pages.
SITE = ROOT / "mkdocs.yml"
README = ROOT / "README.md"

#: Every reproduced figure, from the package's catalogue (with its claims).
FIGURES = reproduction.FIGURES


def chapter(figure: str) -> str:
    """The thesis chapter of a figure ("4" or "5"; Section 6.2.6's CSARSA + iFDD counts as 5)."""
    return "4" if figure.startswith("fig_4_") else "5"


def store_dir(figure: str) -> Path:
    """Where a figure's stored results live: docs/reproduction/chapter<N>/."""
    return HERE / f"chapter{chapter(figure)}"


# ------------------------------------------------------------------------------------ store


def store(figure: str, results_dir: Path) -> None:
    """Write FIGURE's CSVs and plots from a finished sweep folder."""
    if figure not in FIGURES:
        sys.exit(f"Unknown figure {figure!r}; known: {', '.join(FIGURES)}.")
    folder = results_dir / "selected" if (results_dir / "selected").is_dir() else results_dir
    frame = pd.read_parquet(folder / "results.parquet")
    store = store_dir(figure)
    store.mkdir(exist_ok=True)
    metric = FIGURES[figure].plots[0]  # the figure's learning-curve metric (its AUC too)
    finals_table(frame, metric).to_csv(store / f"{figure}_finals.csv", index=False)
    curve_table(frame).to_csv(store / f"{figure}_curve.csv", index=False)
    if (results_dir / "selection.csv").is_file():
        shutil.copyfile(results_dir / "selection.csv", store / f"{figure}_selection.csv")
    for metric in FIGURES[figure].plots:
        plot_learning_curves(
            frame, HERE / f"{figure}_{metric}.png", metric=metric, title=FIGURES[figure].title
        )
    print(f"stored {figure} from {folder} ({frame['run_id'].nunique()} runs)")


# ------------------------------------------------------------------------------------ render


def selection_rows(name: str) -> str:
    """The settings the grid search chose, one line per method with a grid."""
    path = store_dir(name) / f"{name}_selection.csv"
    if not path.is_file():
        return "No grid search (every method has one setting)."
    selection = pd.read_csv(path, keep_default_na=False)
    chosen = selection[selection["setting"] != ""]
    lines = [f"Selected by {chosen['criterion'].iloc[0]} on the search seeds:", ""]
    # with a cost limit the count is of the settings within it, else of those that finished
    counted = "within the limit" if "episodic cost" in chosen["criterion"].iloc[0] else "finished"
    for row in chosen.itertuples():
        lines.append(f"- `{row.label}`: {row.setting} ({row.num_settings} settings {counted})")
    return "\n".join(lines)


def episode_cap(name: str) -> float:
    """The episode cap of the figure's domain (its sweep config's one ``domain``)."""
    sweep = load_sweep(HERE.parents[1] / FIGURES[name].config)
    domain = registry.build("domain", sweep.domain.model_dump(), path="domain")
    return float(domain.domain_spec.max_episode_steps)


def stored_finals(name: str) -> pd.DataFrame:
    """A figure's stored finals, with its domain's episode cap where it has episode lengths.

    The stored CSV holds no cap; an episode length's interval (in the table and the claims)
    is cut at the cap of the figure's domain, read from its config, as a run's tables cut it.
    """
    finals = pd.read_csv(store_dir(name) / f"{name}_finals.csv")
    if "episode_length" not in finals.columns:
        return finals
    return finals.assign(max_episode_steps=episode_cap(name))


def block(name: str) -> str:
    """The generated text of one figure: its command, selection, final table and claims."""
    figure = FIGURES[name]
    finals = stored_finals(name)
    scales = (
        "; V/V* is the return over the exact optimum, optimality (V − V_worst)/(V* − V_worst) "
        "the thesis's Fig. 5-6b scale"
        if chapter(name) == "5"
        else ""
    )
    cut = (
        "; an interval past the episode cap is cut there and reads `mean [low, high]`"
        if "max_episode_steps" in finals.columns
        else ""
    )
    parts = [
        f"Stored results: `docs/reproduction/chapter{chapter(name)}/{name}_*.csv` "
        f"(`python docs/reproduction/figures.py store {name} DIR` after "
        f"`conjure sweep {figure.config} --out DIR`, or `conjure reproduce {name} --scale "
        f"thesis --out DIR`). Final policy check on the fresh seeds (mean ± 95% t "
        f"half-width){scales}{cut}.",
        "",
        selection_rows(name),
        "",
        finals_markdown(finals),
    ]
    if figure.claims:
        parts += ["", claim_rows(figure.claims, finals)]
    for metric in figure.plots:
        if (HERE / f"{name}_{metric}.png").is_file():
            parts += ["", f"![{figure.title}: {metric}]({name}_{metric}.png)"]
    return "\n".join(parts)


def claims_block(name: str) -> str:
    """A figure's claims alone, from its stored finals (README's comparison table)."""
    return claim_rows(FIGURES[name].claims, stored_finals(name))


def rendered(text: str) -> str:
    """``text`` with every figure's blocks regenerated from the stored CSVs."""
    for name in FIGURES:
        for marker, make in (
            (f"chapter{chapter(name)}:{name}", block),
            (f"claims:{name}", claims_block),
        ):
            start, end = f"<!-- {marker} -->", f"<!-- /{marker} -->"
            if start in text:
                text = replaced(text, start, end, f"{make(name)}\n")
    return text


def figure_order(page: Path) -> tuple[int, ...]:
    """Where a page sorts: by the thesis's figure number (Section 6.2.6 as 6-2)."""
    numbers = re.findall(r"\d+", page.stem) or ["6", "2"]
    return tuple(int(number) for number in numbers)


def pages(texts: dict[Path, str]) -> list[Path]:
    """The figure pages (those on disk and ``texts``'s), in the thesis's order."""
    found = {*HERE.glob("*.md"), *texts} - {INDEX}
    return sorted(found, key=lambda page: (figure_order(page), page.name))


def new_pages(texts: dict[Path, str]) -> dict[Path, str]:
    """A page for each figure with stored results whose block is on no page."""
    created = {}
    for name, figure in FIGURES.items():
        marker = f"<!-- chapter{chapter(name)}:{name} -->"
        stored = (store_dir(name) / f"{name}_finals.csv").is_file()
        if stored and not any(marker in text for text in texts.values()):
            created[HERE / f"{name}.md"] = (
                f"# {figure.title}\n\n{marker}\n<!-- /chapter{chapter(name)}:{name} -->\n"
            )
    return created


def page_title(text: str) -> str:
    """A page's first heading."""
    return text.split("\n", 1)[0].removeprefix("# ").strip()


def replaced(text: str, start: str, end: str, body: str) -> str:
    """``text`` with what lies between the lines ``start`` and ``end`` replaced by ``body``."""
    head, rest = text.split(start, 1)
    _, tail = rest.split(end, 1)
    return f"{head}{start}\n{body}{end}{tail}"


def documents() -> dict[Path, str]:
    """Every document `render` writes, as it should read: path -> text."""
    texts = {page: page.read_text() for page in HERE.glob("*.md")}
    texts.update(new_pages(texts))
    texts = {page: rendered(text) for page, text in texts.items()}
    figure_pages = pages(texts)
    listing = "".join(f"- [{page_title(texts[page])}]({page.name})\n" for page in figure_pages)
    texts[INDEX] = replaced(
        texts[INDEX], "<!-- figure-pages -->", "<!-- /figure-pages -->", listing
    )
    navigation = "".join(f"      - reproduction/{page.name}\n" for page in figure_pages)
    site = SITE.read_text()
    texts[SITE] = replaced(site, "      # figure pages", "      # /figure pages", navigation)
    texts[README] = rendered(README.read_text())
    return texts


def render(check: bool) -> int:
    """Write every document `render` makes (or, with ``check``, report which differ)."""
    status = 0
    texts = documents()
    for document, new in texts.items():
        if document.is_file() and document.read_text() == new:
            continue
        if check:
            print(
                f"{document.relative_to(ROOT)} differs from the stored results; run "
                "`python docs/reproduction/figures.py render`."
            )
            status = 1
        else:
            document.write_text(new)
    if check and status == 0:
        print(f"{len(texts)} documents equal what the stored results give.")
    return status


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
