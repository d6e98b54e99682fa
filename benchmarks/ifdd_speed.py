"""Online iFDD's speed: per-step cost vs. the number of features, and the cost of a discovery.

Usage: ``python benchmarks/ifdd_speed.py [--steps N] [--repeats R]``

The thesis's claim (Geramifard 2012, Section 4.1.3) is that online iFDD's per-step cost does
not depend on the total number of features n_t. Three measurements, after a warm-up (numba
compilation excluded), each the median of ``repeats`` runs:

1. Per-step microseconds of SARSA + OnlineIFDD through `LearningLoop` (domain step, φ̇ by
   Algorithm 19, TD update, Algorithm 20) on InvertedPendulum with 8 tilings of 20 x 20 as
   initial features (k_0 = 8), once with about 100 and once with about 10,000 discovered
   features: ``max_features`` caps the count and a small threshold reaches the cap quickly;
   timing starts once the cap is reached (relevances keep being tracked).
2. Learning steps per second of SARSA + OnlineIFDD on InvertedPendulum (20 buckets per
   dimension, ξ = 0.5), BlocksWorld and Persistent Surveillance (the examples/ settings).
3. Microseconds of one `discover` call that adds exactly one feature (a fresh pair), with and
   without the learner's `grow_weights`, against a call that adds nothing.
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np
from rich.console import Console
from rich.table import Table

from conjure.agents import SARSA
from conjure.domains import BlocksWorld, InvertedPendulum, PersistentSurveillance
from conjure.experiments.loop import LearningLoop
from conjure.policies import EpsilonGreedy
from conjure.representations import BinaryIndicators, IndependentDiscretization, TileCoding
from conjure.representations.online_ifdd import OnlineIFDD
from conjure.representations.weights import grow_weights


def sarsa(representation: OnlineIFDD) -> SARSA:
    return SARSA(representation=representation, policy=EpsilonGreedy(epsilon=0.1), step_size=0.05)


def per_step_at(num_discovered: int, steps: int, repeats: int) -> tuple[float, int]:
    """Median µs per learning step once ``num_discovered`` features were discovered."""
    base = TileCoding(num_tilings=8, tiles_per_dim=20)
    domain = InvertedPendulum()
    n0 = base.clone().setup(domain.domain_spec, seed=0).num_features_
    agent = sarsa(OnlineIFDD(base=base, discovery_threshold=0.05, max_features=n0 + num_discovered))
    agent.setup(domain.domain_spec, seed=0)
    loop = LearningLoop(domain, agent, seed=0)
    while agent.representation_.num_discovered_ < num_discovered:
        loop.advance(1_000)
    loop.advance(2_000)
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        loop.advance(steps)
        times.append((time.perf_counter() - start) / steps * 1e6)
    return statistics.median(times), agent.representation_.num_features_


def domain_rate(make_domain, representation, steps: int, repeats: int) -> tuple[float, int]:
    """Median learning steps/s of SARSA + ``representation`` on fresh copies of a domain."""
    rates, features = [], 0
    for repeat in range(repeats + 1):
        domain = make_domain()
        agent = sarsa(representation.clone())
        agent.setup(domain.domain_spec, seed=repeat)
        loop = LearningLoop(domain, agent, seed=repeat)
        start = time.perf_counter()
        loop.advance(steps)
        if repeat:  # the first run warms up numba's cache
            rates.append(steps / (time.perf_counter() - start))
            features = agent.representation_.num_features_
    return statistics.median(rates), features


#: The issue-3 workloads, with the thresholds of the examples/ configs.
DOMAIN_WORKLOADS = (
    (
        "InvertedPendulum, 20 buckets/dim, iFDD xi = 0.5",
        InvertedPendulum,
        OnlineIFDD(base=IndependentDiscretization(num_buckets=20), discovery_threshold=0.5),
    ),
    (
        "BlocksWorld, On(.,.) indicators, iFDD+ xi = 0.05 (RLPy: about 2,100/s)",
        BlocksWorld,
        OnlineIFDD(base=BinaryIndicators(), discovery_threshold=0.05, relevance="ifdd_plus"),
    ),
    (
        "PersistentSurveillance, indicators, iFDD+ xi = 200",
        PersistentSurveillance,
        OnlineIFDD(
            base=IndependentDiscretization(), discovery_threshold=200.0, relevance="ifdd_plus"
        ),
    ),
)


def discovery_cost(num: int, repeats: int) -> tuple[float, float, float]:
    """µs per discover() adding one feature, the same plus grow_weights, and adding none."""
    domain = InvertedPendulum()
    spec = domain.domain_spec
    results = []
    for _ in range(repeats):
        rep = OnlineIFDD(base=TileCoding(num_tilings=8, tiles_per_dim=20), discovery_threshold=0.0)
        rep.setup(spec, seed=0)
        n0 = rep.num_initial_features_
        rng = np.random.default_rng(0)
        pairs = set()
        while len(pairs) < 2 * num:
            i, j = sorted(rng.choice(n0, size=2, replace=False).tolist())
            pairs.add((i, j))
        pairs = [np.array(p, dtype=np.int64) for p in sorted(pairs, key=lambda p: hash(p))]
        rep.discover(pairs[0], 1.0)  # compile / load
        start = time.perf_counter()
        for pair in pairs[1 : num + 1]:
            rep.discover(pair, 1.0)
        alone = (time.perf_counter() - start) / num * 1e6
        weights = np.zeros((rep.num_features_, spec.num_actions))
        start = time.perf_counter()
        for pair in pairs[num + 1 :]:
            weights = grow_weights(weights, rep.discover(pair, 1.0))
        with_weights = (time.perf_counter() - start) / (len(pairs) - num - 1) * 1e6
        nothing = rep.active_features(np.array([0.1, 0.1]))[:2]
        rep.discover(nothing, 1.0)
        start = time.perf_counter()
        for _ in range(num):
            rep.discover(nothing, 1.0)  # already a feature: no new feature
        idle = (time.perf_counter() - start) / num * 1e6
        results.append((alone, with_weights, idle))
    return tuple(statistics.median(r[i] for r in results) for i in range(3))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=20_000)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    console = Console()

    table = Table(title="SARSA + OnlineIFDD per step vs. discovered features (pendulum, 8 tilings)")
    table.add_column("discovered features (cap)", justify="right")
    table.add_column("total features", justify="right")
    table.add_column("us/step", justify="right")
    low, n_low = per_step_at(100, args.steps, args.repeats)
    high, n_high = per_step_at(10_000, args.steps, args.repeats)
    table.add_row("100", f"{n_low:,}", f"{low:.2f}")
    table.add_row("10,000", f"{n_high:,}", f"{high:.2f}")
    table.add_row("ratio (target <= 1.5)", "", f"{high / low:.2f}")
    console.print(table)

    table = Table(title=f"SARSA + OnlineIFDD learning speed ({5 * args.steps:,} steps per run)")
    table.add_column("workload")
    table.add_column("steps/s", justify="right")
    table.add_column("us/step", justify="right")
    table.add_column("final features", justify="right")
    for name, make_domain, representation in DOMAIN_WORKLOADS:
        rate, features = domain_rate(make_domain, representation, 5 * args.steps, args.repeats)
        table.add_row(name, f"{rate:,.0f}", f"{1e6 / rate:.2f}", f"{features:,}")
    console.print(table)

    alone, with_weights, idle = discovery_cost(5_000, args.repeats)
    table = Table(title="Cost of discovering one feature (target < 50 us)")
    table.add_column("call", justify="left")
    table.add_column("us", justify="right")
    table.add_row("discover() adding one feature", f"{alone:.2f}")
    table.add_row("discover() + grow_weights()", f"{with_weights:.2f}")
    table.add_row("discover() adding nothing (same pair)", f"{idle:.2f}")
    console.print(table)


if __name__ == "__main__":
    main()
