"""Online iFDD's speed: per-step cost vs. the number of features, and the cost of a discovery.

Usage: ``python benchmarks/ifdd_speed.py [--steps N] [--repeats R] [--growth-only |
--paths-only | --scaling FEATURES ...]``

The thesis's claim (Geramifard 2012, Section 4.1.3) is that online iFDD's per-step cost does
not depend on the total number of features n_t. Four measurements, after a warm-up (numba
compilation excluded), each the median of ``repeats`` runs:

1. Per-step microseconds of SARSA + OnlineIFDD through `LearningLoop` (domain step, φ̇ by
   Algorithm 19, TD update, Algorithm 20) on the three iFDD domains: InvertedPendulum with 8
   tilings of 20 x 20 (k_0 = 8), BlocksWorld with its On(.,.) indicators and Persistent
   Surveillance with one indicator per state value (k_0 = 12), once with 100 and once with
   10,000 discovered features (5,000 on BlocksWorld): ``max_features`` caps the count and
   ξ = 0 reaches the cap quickly; timing starts once the cap is reached (relevances keep
   being tracked), counts this process's CPU time and alternates between the two loops in
   chunks of N/5 steps (5 R rounds, the median of each), so the ratio compares like with
   like on a shared machine.
2. Learning steps per second of SARSA + OnlineIFDD on InvertedPendulum (20 buckets per
   dimension, ξ = 0.5), BlocksWorld and Persistent Surveillance (the examples/ settings).
3. Microseconds of one `discover` call that adds exactly one feature (a fresh pair), with and
   without the learner's `grow_weights`, against a call that adds nothing.
4. SARSA + iFDD+ on BlocksWorld (``examples/blocksworld.yaml``'s ``ifdd_plus`` agent) and
   Persistent Surveillance, Actor-Critic + iFDD+ on BlocksWorld, SARSA + signed iFDD+ on the
   pendulum (``examples/reproduction/fig_4_8_pendulum_ifdd_plus.yaml``), SARSA + iFDD at a
   fixed rate on Rescue Mission (``fig_4_7_rescue.yaml``) and SARSA + ARiFDD on the pendulum
   (``fig_4_11.yaml``'s ``arifdd``) on the Python path
   (`LearningLoop`) and on the compiled path (`conjure.compiled`), the same 5 N
   steps from the same seeds; the compiled kernels' first calls in this process (compile, or
   load from numba's disk cache) are timed separately and not in steps/s. ``--paths-only``
   runs only this table.

``--scaling 10000 50000 200000`` runs only Persistent Surveillance's per-step cost at 100
discovered features against each given count (as in 1.), with where it goes: µs per step in
``active_features`` and in ``discover`` (timed separately, not interleaved), how often the
tables grew in that window, and the node hash table's entries, load, mean successful probe
length and size with the node arrays and pool.
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np
from rich.console import Console
from rich.table import Table

from conjure.agents import SARSA, ActorCritic
from conjure.compiled import compile_seconds, for_combination
from conjure.core.schedules import FeatureNormalizedDecay
from conjure.domains import BlocksWorld, InvertedPendulum, PersistentSurveillance, RescueMission
from conjure.experiments.loop import LearningLoop
from conjure.policies import EpsilonGreedy
from conjure.representations import (
    ARiFDD,
    BinaryIndicators,
    IndependentDiscretization,
    TileCoding,
)
from conjure.representations.online_ifdd import OnlineIFDD
from conjure.representations.weights import grow_weights


def sarsa(representation: OnlineIFDD) -> SARSA:
    return SARSA(representation=representation, policy=EpsilonGreedy(epsilon=0.1), step_size=0.05)


#: (name, domain class, initial features, the larger feature count) of the per-step cost;
#: BlocksWorld's reachable states hold about 7,000 conjunctions, so it stops at 5,000
GROWTH_WORKLOADS = (
    ("InvertedPendulum, 8 tilings of 20 x 20", InvertedPendulum,
     TileCoding(num_tilings=8, tiles_per_dim=20), 10_000),
    ("BlocksWorld, On(.,.) indicators", BlocksWorld, BinaryIndicators(), 5_000),
    ("PersistentSurveillance, indicators", PersistentSurveillance, IndependentDiscretization(),
     10_000),
)  # fmt: skip


def loop_at(make_domain, base, num_discovered: int) -> tuple[LearningLoop, int]:
    """A warmed-up SARSA + OnlineIFDD loop once ``num_discovered`` features were discovered."""
    domain = make_domain()
    n0 = base.clone().setup(domain.domain_spec, seed=0).num_features_
    agent = sarsa(OnlineIFDD(base=base, discovery_threshold=0.0, max_features=n0 + num_discovered))
    agent.setup(domain.domain_spec, seed=0)
    loop = LearningLoop(domain, agent, seed=0)
    while agent.representation_.num_discovered_ < num_discovered:
        loop.advance(1_000)
    loop.advance(2_000)
    return loop, agent.representation_.num_features_


def per_step_interleaved(loops: list[LearningLoop], steps: int, repeats: int) -> list[float]:
    """Median µs per learning step of each loop, timed in alternation (CPU time).

    Each round times ``steps // 5`` steps of every loop in turn, ``5 * repeats`` rounds, so a
    slow spell of a shared machine falls on all of them alike.
    """
    chunk = max(steps // 5, 1)
    times: list[list[float]] = [[] for _ in loops]
    for _ in range(5 * repeats):
        for loop, samples in zip(loops, times, strict=True):
            start = time.process_time()
            loop.advance(chunk)
            samples.append((time.process_time() - start) / chunk * 1e6)
    return [statistics.median(samples) for samples in times]


def table_stats(rep: OnlineIFDD) -> dict[str, float]:
    """The node hash table's size, load and mean successful probe length (public arrays)."""
    arrays = rep.state_arrays()
    table, node_key = arrays["table"], arrays["node_key"]
    used = table[table >= 0]
    mask = table.shape[0] - 1
    home = node_key[used] & mask
    position = np.flatnonzero(table >= 0)
    probes = ((position - home) & mask) + 1
    node_bytes = sum(arrays[name].nbytes for name in arrays if name.startswith("node_"))
    return {
        "nodes": float(used.shape[0]),
        "load": used.shape[0] / table.shape[0],
        "probes": float(probes.mean()),
        "megabytes": (table.nbytes + node_bytes + arrays["pool"].nbytes) / 2**20,
    }


def split_costs(loop: LearningLoop, steps: int) -> tuple[float, float, int]:
    """µs per step in ``active_features`` and in ``discover``, and the tables' growths.

    Both methods are wrapped on the instance for ``steps`` steps (the wrapper costs the same
    at every size); a growth is seen as a change of the node arrays' capacity.
    """
    rep = loop.agent.representation_
    spent = {"active_features": 0, "discover": 0}

    def timed(name):
        method = getattr(rep, name)

        def call(*args, **kwargs):
            start = time.perf_counter_ns()
            result = method(*args, **kwargs)
            spent[name] += time.perf_counter_ns() - start
            return result

        return call

    capacity = rep.state_arrays()["node_key"].shape[0]
    growths = 0
    rep.active_features, rep.discover = timed("active_features"), timed("discover")
    try:
        for _ in range(steps // 1_000):
            loop.advance(1_000)
            now = rep.state_arrays()["node_key"].shape[0] if steps <= 20_000 else capacity
            growths += now != capacity
            capacity = now
    finally:
        del rep.active_features, rep.discover
    return spent["active_features"] / steps / 1e3, spent["discover"] / steps / 1e3, growths


def print_scaling(console: Console, sizes: list[int], steps: int, repeats: int) -> None:
    """Persistent Surveillance's per-step cost at 100 and at each of ``sizes`` features."""
    base = IndependentDiscretization()
    table = Table(title="PersistentSurveillance, SARSA + OnlineIFDD (xi = 0): cost vs features")
    for column in (
        "discovered (cap)",
        "total features",
        "us/step",
        "ratio to 100",
        "activate us",
        "discover us",
        "growths",
        "nodes",
        "load",
        "probes",
        "MB",
    ):
        table.add_column(column, justify="right")  # fmt: skip
    for size in sizes:
        loops = [loop_at(PersistentSurveillance, base, num) for num in (100, size)]
        costs = per_step_interleaved([loop for loop, _ in loops], steps, repeats)
        for (loop, total), num, cost in zip(loops, (100, size), costs, strict=True):
            activate_us, discover_us, growths = split_costs(loop, steps)
            stats = table_stats(loop.agent.representation_)
            table.add_row(
                f"{num:,}", f"{total:,}", f"{cost:.2f}", f"{cost / costs[0]:.2f}",
                f"{activate_us:.2f}", f"{discover_us:.2f}", f"{growths}",
                f"{stats['nodes']:,.0f}", f"{stats['load']:.3f}", f"{stats['probes']:.2f}",
                f"{stats['megabytes']:.1f}",
            )  # fmt: skip
            console.print(f"{num:,} discovered: {cost:.2f} us/step", highlight=False)
    console.print(table)


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


#: The workloads, with the thresholds of the examples/ configs.
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


def blocks_ifdd_plus() -> tuple[BlocksWorld, SARSA]:
    """A fresh BlocksWorld and examples/blocksworld.yaml's ``ifdd_plus`` learner (not set up)."""
    representation = OnlineIFDD(
        base=BinaryIndicators(), discovery_threshold=0.05, relevance="ifdd_plus"
    )
    step_size = FeatureNormalizedDecay(alpha_0=0.1, n_0=100)
    policy = EpsilonGreedy(epsilon=0.1)
    agent = SARSA(representation=representation, policy=policy, step_size=step_size)
    return BlocksWorld(), agent


def surveillance_ifdd_plus() -> tuple[PersistentSurveillance, SARSA]:
    """A fresh Persistent Surveillance and the iFDD+ learner of `DOMAIN_WORKLOADS`."""
    return PersistentSurveillance(), sarsa(DOMAIN_WORKLOADS[2][2].clone())


def blocks_actor_critic() -> tuple[BlocksWorld, ActorCritic]:
    """`blocks_ifdd_plus`'s features and critic step size under Actor-Critic (Gibbs actor)."""
    domain, sarsa_agent = blocks_ifdd_plus()
    agent = ActorCritic(representation=sarsa_agent.representation, step_size=sarsa_agent.step_size)
    return domain, agent


def pendulum_ifdd_plus() -> tuple[InvertedPendulum, SARSA]:
    """examples/reproduction/fig_4_8_pendulum_ifdd_plus.yaml's learner (ξ = 0.02)."""
    representation = OnlineIFDD(
        base=IndependentDiscretization(num_buckets=20),
        relevance="ifdd_plus_signed",
        discovery_threshold=0.02,
    )
    step_size = FeatureNormalizedDecay(alpha_0=1.0, n_0=100)
    policy = EpsilonGreedy(epsilon=0.1)
    agent = SARSA(representation=representation, policy=policy, step_size=step_size)
    return InvertedPendulum(), agent


def rescue_ifdd_fixed_rate() -> tuple[RescueMission, SARSA]:
    """examples/reproduction/fig_4_7_rescue.yaml's ``ifdd_fixed_rate`` learner."""
    representation = OnlineIFDD(base=IndependentDiscretization(), discovery_rate=0.004)
    step_size = FeatureNormalizedDecay(alpha_0=0.1, n_0=1000)
    policy = EpsilonGreedy(epsilon=0.1)
    agent = SARSA(representation=representation, policy=policy, step_size=step_size)
    return RescueMission(), agent


def pendulum_arifdd() -> tuple[InvertedPendulum, SARSA]:
    """examples/reproduction/fig_4_11.yaml's ``arifdd`` learner (2 tiles per dimension)."""
    representation = ARiFDD(initial_tiles_per_dim=2, discovery_threshold=1.0, split_threshold=1.0)
    step_size = FeatureNormalizedDecay(alpha_0=1.0, n_0=100)
    policy = EpsilonGreedy(epsilon=0.1)
    agent = SARSA(representation=representation, policy=policy, step_size=step_size)
    return InvertedPendulum(), agent


#: (name, fresh (domain, learner)) of the Python vs compiled comparison.
PATH_WORKLOADS = (
    ("BlocksWorld, SARSA + iFDD+ xi = 0.05 (examples/)", blocks_ifdd_plus),
    ("PersistentSurveillance, SARSA + iFDD+ xi = 200", surveillance_ifdd_plus),
    ("BlocksWorld, Actor-Critic + iFDD+ xi = 0.05", blocks_actor_critic),
    ("InvertedPendulum, SARSA + signed iFDD+ xi = 0.02 (fig 4-8)", pendulum_ifdd_plus),
    ("RescueMission, SARSA + iFDD at C = 0.004 (fig 4-7)", rescue_ifdd_fixed_rate),
    ("InvertedPendulum, SARSA + ARiFDD, 2 tiles per dim (fig 4-11)", pendulum_arifdd),
)


def both_paths(make, steps: int, repeats: int) -> dict[str, tuple[float, int]]:
    """Median steps/s and final features of the Python and compiled paths (seeds 1..repeats)."""
    results: dict[str, tuple[float, int]] = {}
    for path in ("python", "compiled"):
        rates, features = [], []
        for seed in range(repeats + 1):  # seed 0 warms up (numba's cache, the kernel)
            domain, agent = make()
            agent.setup(domain.domain_spec, seed=seed)
            if path == "python":
                stepper = LearningLoop(domain, agent, seed=seed)
            else:
                stepper = for_combination(domain, agent, seed=seed)
            start = time.perf_counter()
            stepper.advance(steps if seed else 1_000)
            if seed:
                rates.append(steps / (time.perf_counter() - start))
                features.append(agent.representation_.num_features_)
        results[path] = (statistics.median(rates), int(statistics.median(features)))
    return results


def print_both_paths(console: Console, steps: int, repeats: int) -> None:
    table = Table(title=f"iFDD learners, Python vs compiled path: {steps:,} steps per run")
    table.add_column("workload")
    table.add_column("path")
    table.add_column("steps/s", justify="right")
    table.add_column("us/step", justify="right")
    table.add_column("final features", justify="right")
    for name, make in PATH_WORKLOADS:
        results = both_paths(make, steps, repeats)
        for path, (rate, features) in results.items():
            table.add_row(name, path, f"{rate:,.0f}", f"{1e6 / rate:.2f}", f"{features:,}")
        ratio = results["compiled"][0] / results["python"][0]
        table.add_row(name, "compiled / python", f"{ratio:.1f}x", "", "")
    console.print(table)
    console.print(
        f"the compiled kernels' first calls in this process (compile or cache load; not in "
        f"steps/s, the warm-up seed makes them): {compile_seconds():.2f} s",
        highlight=False,
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=20_000)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--growth-only", action="store_true", help="only the per-step cost")
    parser.add_argument(
        "--paths-only", action="store_true", help="only the Python vs compiled paths"
    )
    parser.add_argument(
        "--scaling",
        type=int,
        nargs="+",
        metavar="FEATURES",
        help="only Persistent Surveillance's cost at 100 vs each FEATURES discovered, with "
        "where it goes (activate, discover, growths, hash table load and probes)",
    )
    args = parser.parse_args()
    console = Console()
    if args.scaling:
        print_scaling(console, args.scaling, args.steps, args.repeats)
        return
    if args.paths_only:
        print_both_paths(console, 5 * args.steps, args.repeats)
        return

    table = Table(title="SARSA + OnlineIFDD per step vs. discovered features (iFDD, xi = 0)")
    table.add_column("workload")
    table.add_column("discovered (cap)", justify="right")
    table.add_column("total features", justify="right")
    table.add_column("us/step", justify="right")
    table.add_column("steps/s", justify="right")
    for name, make_domain, base, high in GROWTH_WORKLOADS:
        (low_loop, low_total), (high_loop, high_total) = (
            loop_at(make_domain, base, num) for num in (100, high)
        )
        costs = per_step_interleaved([low_loop, high_loop], args.steps, args.repeats)
        for num, total, cost in zip((100, high), (low_total, high_total), costs, strict=True):
            table.add_row(name, f"{num:,}", f"{total:,}", f"{cost:.2f}", f"{1e6 / cost:,.0f}")
            console.print(f"{name}: {total:,} features, {cost:.2f} us/step", highlight=False)
        table.add_row(name, "ratio (target <= 1.5)", "", f"{costs[1] / costs[0]:.2f}", "")
    console.print(table)
    if args.growth_only:
        return

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

    print_both_paths(console, 5 * args.steps, args.repeats)


if __name__ == "__main__":
    main()
