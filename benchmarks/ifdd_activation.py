"""Where online iFDD's activation spends its time as features grow (Algorithm 19).

Usage: ``python benchmarks/ifdd_activation.py [--states N]``

On Persistent Surveillance with one indicator per state value (k_0 = 12 active), SARSA +
OnlineIFDD is run to 100 and to 10,000 discovered features by ``ifdd_speed.py``'s `loop_at`
(ξ = 0, ``max_features`` caps the count, 2,000 more steps), then:

- ``live``: N more learning steps with every ``activate`` call timed (``perf_counter_ns``),
  split into cache hits and misses (a miss writes the activation cache);
- ``recorded``: the N initial active sets those steps saw, each passed again to
  ``_features_within`` (the search a miss runs), reporting µs per call, the median number m
  of features found within a set, and the child rows a miss walks (a parent's block is
  walked when it holds at most x rows, x its position in the found list; else x pairs are
  looked up);
- ``µs/cover``: Algorithm 19's greedy covering of those found lists (``_cover``, the rest of
  a miss), µs per call: 20 passes over the recorded sets in one compiled call (no Python
  call counted), compiled afresh each time (a cached caller would keep an edited kernel).
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np
from ifdd_speed import loop_at
from numba import njit  # this folder: the growth benchmark's loops
from numba.typed import List
from rich.console import Console
from rich.table import Table

from conjure.domains import PersistentSurveillance
from conjure.experiments.loop import LearningLoop
from conjure.representations import IndependentDiscretization
from conjure.representations import _ifdd_kernels as kernels


@njit(cache=True)
def parent_index(tables: kernels.IFDDTables) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The parent index of `OnlineIFDD.kernel_tables`: (links, children, pair_table)."""
    return tables.links, tables.children, tables.pair_table


@njit(cache=True)
def cache_written(tables: kernels.IFDDTables) -> int:
    """How many cells the activation cache has written (a miss writes some)."""
    return tables.cache_written[0]


def live(loop: LearningLoop, steps: int) -> tuple[list[np.ndarray], dict[str, list[float]]]:
    """The initial sets of ``steps`` learning steps, and their activations' µs by hit/miss."""
    rep = loop.agent.representation_
    encode, activate = rep._encode_base, kernels.activate
    sets: list[np.ndarray] = []
    times: dict[str, list[float]] = {"hit": [], "miss": []}

    def recorded(state: np.ndarray) -> np.ndarray:
        sets.append(encode(state).copy())
        return sets[-1]

    def timed(initial, tables):
        written = cache_written(tables)
        start = time.perf_counter_ns()
        phi = activate(initial, tables)
        elapsed = (time.perf_counter_ns() - start) / 1e3
        times["miss" if cache_written(tables) != written else "hit"].append(elapsed)
        return phi

    rep._encode_base, kernels.activate = recorded, timed
    try:
        loop.advance(steps)
    finally:
        rep._encode_base, kernels.activate = encode, activate
    return sets, times


#: Passes over the recorded sets when timing `_cover` (one pass is a few milliseconds).
COVER_PASSES = 20


@njit
def cover_all(sets: List, founds: List, bits: List, passes: int) -> int:
    """`_cover` of every recorded set, ``passes`` times, in one compiled call."""
    total = 0
    for _ in range(passes):
        for i in range(len(sets)):
            total += kernels._cover(sets[i].shape[0], founds[i], bits[i]).shape[0]
    return total


def rows_walked(found: np.ndarray, links: np.ndarray) -> int:
    """Child rows the search walks for one found list (its pair lookups are not counted)."""
    counts = links[found, kernels.L_COUNT]
    return int(counts[counts <= np.arange(found.shape[0])].sum())


def recorded(loop: LearningLoop, sets: list[np.ndarray]) -> tuple[float, float, float, float]:
    """(µs per `_features_within` call, median m, median child rows walked, µs per `_cover`)."""
    links, children, pair_table = parent_index(loop.agent.representation_.kernel_tables())
    hint = np.zeros(1, dtype=np.int64)  # the search's capacity, learnt by the first pass
    within = [kernels._features_within(s, links, children, pair_table, hint) for s in sets]
    start = time.process_time()
    for s in sets:
        kernels._features_within(s, links, children, pair_table, hint)
    seconds = time.process_time() - start
    founds, bits = List([f for f, _ in within]), List([b for _, b in within])
    cover_all(List(sets), founds, bits, 1)  # compiled (or loaded) before timing
    start = time.process_time()
    cover_all(List(sets), founds, bits, COVER_PASSES)
    cover = (time.process_time() - start) / COVER_PASSES
    walked = [rows_walked(f, links) for f, _ in within]
    sizes = [f.shape[0] for f, _ in within]
    per_call = 1e6 / len(sets)
    return seconds * per_call, statistics.median(sizes), statistics.median(walked), cover * per_call


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--states", type=int, default=3_000)
    parser.add_argument(
        "--features", type=int, nargs="+", default=[100, 10_000], help="discovered features"
    )
    args = parser.parse_args()
    table = Table(title="OnlineIFDD activation on PersistentSurveillance (k_0 = 12)")
    for name in (
        "discovered",
        "hits",
        "µs/hit",
        "misses",
        "µs/miss",
        "m",
        "rows",
        "µs/search",
        "µs/cover",
    ):
        table.add_column(name, justify="right")
    for num in args.features:
        loop, _ = loop_at(PersistentSurveillance, IndependentDiscretization(), num)
        sets, times = live(loop, args.states)
        search, size, walked, cover = recorded(loop, sets)
        table.add_row(
            f"{num:,}",
            f"{len(times['hit']):,}",
            f"{statistics.median(times['hit']):.2f}",
            f"{len(times['miss']):,}",
            f"{statistics.median(times['miss']):.2f}",
            f"{size:.0f}",
            f"{walked:.0f}",
            f"{search:.2f}",
            f"{cover:.2f}",
        )
    Console().print(table)


if __name__ == "__main__":
    main()
