"""Figure 3-15 (Geramifard 2012, Section 3.3.1): FDLSTD on the inverted pendulum.

Policy evaluation of the fixed policy "torque against the angular velocity" from 1,000,
2,000 and 5,000 samples, starting from 20 buckets per dimension (120 features), adding one
conjunction per iteration chosen by Random, iFDD (Eq. 3.19), iFDD+ (Eq. 3.18 with the
magnitude |Σδ|/√count, RLPy's form), signed iFDD+ (Eq. 3.18 as printed, Σδ/√count) or Best
(the pair that minimises the sample RMSE to the reference V). The reference V is LSTD with the
tabular representation (1,200 features) on 100,000 samples. The error is the RMSE between
Ṽ and V at the sample states after each iteration (iteration 0 = the initial features).

    python docs/reproduction/fig_3_15.py --seeds 20 --expansions 20 --out /tmp/repro/fig_3_15
    python docs/reproduction/fig_3_15.py --quick --out /tmp/fig_3_15_quick   # a smoke run

writes OUT/fig_3_15.csv (one row per seed, size, method, iteration), OUT/fig_3_15_summary.csv
(mean RMSE with a 95% t-interval per size, method and iteration) and OUT/fig_3_15.png.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
import scipy.sparse as sp
from scipy import stats

from conjure.agents.fdlstd import FDLSTD
from conjure.agents.lstd import LSTD
from conjure.core.interfaces import Transition
from conjure.core.linalg import lstd_system, solve_regularized
from conjure.domains import InvertedPendulum
from conjure.representations import IndependentDiscretization, Tabular

SIZES = (1000, 2000, 5000)
METHODS = ("random", "ifdd", "ifdd_plus", "ifdd_plus_signed", "best")


def damping_policy(state: np.ndarray) -> int:
    """Torque opposite to θ̇ (Section 3.3.1)."""
    return 2 if state[1] > 0 else (0 if state[1] < 0 else 1)


def pendulum_samples(num_samples: int, seed: int) -> list[Transition]:
    """Transitions of the damping policy, episodes capped at 3,000 steps."""
    domain = InvertedPendulum()
    state, _ = domain.reset(seed=seed)
    out, steps = [], 0
    while len(out) < num_samples:
        action = damping_policy(state)
        following, reward, terminated, _, _ = domain.step(action)
        out.append(Transition(state, action, reward, following, 0, terminated))
        steps += 1
        if terminated or steps >= 3000:
            (state, _), steps = domain.reset(), 0
        else:
            state = following
    return out


def rmse_per_iteration(agent: FDLSTD, data: list[Transition], target: np.ndarray) -> list[float]:
    """RMSE after 0, 1, ..., iterations_ expansions: LSTD on each prefix of the features."""
    phi = agent.encode([t.state for t in data])
    live = np.array([not t.terminated for t in data], dtype=float)
    phi_next = sp.csr_matrix(sp.diags(live) @ agent.encode([t.next_state for t in data]))
    rewards = np.array([t.reward for t in data], dtype=float)
    n0 = agent.num_features_ - agent.iterations_
    out = []
    for k in range(agent.iterations_ + 1):
        a, b = lstd_system(
            sp.csr_matrix(phi[:, : n0 + k]),
            sp.csr_matrix(phi_next[:, : n0 + k]),
            rewards,
            agent.spec_.discount,
        )
        weights = solve_regularized(a, b, float(agent.regularization))
        values = phi[:, : n0 + k] @ weights
        out.append(float(np.sqrt(np.mean((values - target) ** 2))))
    return out


def main() -> None:
    """Run every seed, size and expansion; write the tables and the figure."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=20)
    parser.add_argument("--expansions", type=int, default=20)
    parser.add_argument("--reference-samples", type=int, default=100_000)
    parser.add_argument("--out", type=Path, default=Path("/tmp/repro/fig_3_15"))
    parser.add_argument(
        "--quick", action="store_true", help="a smoke run: 2 seeds, 1 expansion, 1,000 samples"
    )
    args = parser.parse_args()
    sizes = SIZES
    if args.quick:
        args.seeds, args.expansions, args.reference_samples, sizes = 2, 1, 2_000, SIZES[:1]
    args.out.mkdir(parents=True, exist_ok=True)

    spec = InvertedPendulum().domain_spec
    reference = LSTD(representation=Tabular(num_buckets=20)).setup(spec, 0)
    reference.fit(pendulum_samples(args.reference_samples, 1234))
    rows = []
    for size in sizes:
        for seed in range(args.seeds):
            data = pendulum_samples(size, seed)  # the same data for every method
            target = reference.values([t.state for t in data])
            for method in METHODS:
                started = time.perf_counter()
                agent = FDLSTD(
                    representation=IndependentDiscretization(num_buckets=20),
                    expansion=method,
                    num_expansions=args.expansions,
                    seed=seed,
                )
                agent.setup(spec, 0).fit(data, reference=reference)
                seconds = time.perf_counter() - started
                for k, rmse in enumerate(rmse_per_iteration(agent, data, target)):
                    rows.append(
                        {
                            "samples": size,
                            "seed": seed,
                            "method": method,
                            "iteration": k,
                            "rmse": rmse,
                            "fit_seconds": seconds,
                        }
                    )
            print(f"samples={size} seed={seed} done", flush=True)
    table = pd.DataFrame(rows)
    table.to_csv(args.out / "fig_3_15.csv", index=False)

    def interval(values: pd.Series) -> pd.Series:
        v = values.to_numpy(dtype=float)
        half = stats.t.ppf(0.975, len(v) - 1) * v.std(ddof=1) / np.sqrt(len(v))
        return pd.Series({"mean": v.mean(), "ci95": half, "runs": len(v)})

    summary = (
        table.groupby(["samples", "method", "iteration"])["rmse"]
        .apply(interval)
        .unstack()
        .reset_index()
    )
    summary.to_csv(args.out / "fig_3_15_summary.csv", index=False)

    fig, axes = plt.subplots(
        1, len(sizes), figsize=(4.2 * len(sizes), 3.6), sharey=True, squeeze=False
    )
    axes = axes[0]
    names = {
        "random": "Random",
        "ifdd": "iFDD (Eq. 3.19)",
        "ifdd_plus": "iFDD+ |Σδ|/√n",
        "ifdd_plus_signed": "iFDD+ Σδ/√n (Eq. 3.18)",
        "best": "Best",
    }
    for ax, size in zip(axes, sizes, strict=True):
        for method in METHODS:
            part = summary[(summary["samples"] == size) & (summary["method"] == method)]
            x, m, h = part["iteration"], part["mean"], part["ci95"]
            ax.plot(x, m, label=names[method])
            ax.fill_between(x, m - h, m + h, alpha=0.2)
        ax.set_title(f"{size:,} samples")
        ax.set_xlabel("iteration (features added)")
    axes[0].set_ylabel("RMSE to reference V")
    axes[0].legend()
    fig.suptitle(f"Fig. 3-15: FDLSTD on the inverted pendulum ({args.seeds} seeds, 95% t-bands)")
    fig.tight_layout()
    fig.savefig(args.out / "fig_3_15.png", dpi=110)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
