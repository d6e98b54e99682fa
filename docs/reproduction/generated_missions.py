"""iCCA against CBBA on generated UAV missions, each with its exact optimum (Section 5.3.5).

    python docs/reproduction/generated_missions.py            # 30 missions x 5 seeds, 1e5 steps
    python docs/reproduction/generated_missions.py --missions 2 --seeds 1 --budget 300

Fig. 5-6 compares iCCA with CBBA on one graph. The calibrated graphs (`uav_7_2`, `uav_10_2`)
plant a valuable target beside the base whose best use CBBA's one-UAV-per-task model cannot
plan, so CBBA's whole noise-free gap is one decision at s₀. Here every mission is drawn by
`mission_graph.sample_mission` without that motif (``UAVMission(mission_seed=m)`` on UAV 7-2's
nodes, edges and horizon: 7 nodes, 2 UAVs, H = 8, small enough to solve each exactly),
and on each one:

- V* by backward induction (`UAVMission.exact_solution`);
- CBBA's value: aggressive CBBA replanned at every step, evaluated exactly
  (`UAVMission.evaluate_policy`; without noise aggressive CBBA is Fig. 5-6's planner);
- iCCA's value: Fig. 5-6's ``icca`` (examples/reproduction/fig_5_6.yaml, the selected
  settings) learns for ``--budget`` steps on the noise-free mission; its final greedy policy
  is evaluated exactly, and the final policy check's mean return (``--eval-episodes``
  episodes) is kept beside it.

The gain is V^iCCA / V^CBBA − 1. One row per mission and seed goes to
``chapter5/generated_missions_gain.csv``; the plot (``generated_missions_gain.png``) shows each
mission's gain per seed, missions sorted by their mean gain. At most ``--workers`` processes
run at once.
"""

from __future__ import annotations

import argparse
import copy
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

import pandas as pd
import yaml

HERE = Path(__file__).resolve().parent
CONFIG = HERE.parents[1] / "examples" / "reproduction" / "fig_5_6.yaml"
CSV = HERE / "chapter5" / "generated_missions_gain.csv"
PLOT = HERE / "generated_missions_gain.png"
#: The generated missions' base scenario (nodes, edges, horizon); its targets and fuel are drawn.
SCENARIO = "uav-7-2"
#: The run seeds start here: above every seed the project's configs and docs used.
FIRST_SEED = 20000


def experiment(mission: int, budget: int, eval_episodes: int) -> dict[str, Any]:
    """Fig. 5-6's ``icca`` and ``cbba`` on generated mission ``mission`` (a config mapping)."""
    sweep = yaml.safe_load(CONFIG.read_text())
    domain = {"kind": "UAVMission", "params": {"scenario": SCENARIO, "mission_seed": mission}}
    agents = {label: copy.deepcopy(sweep["agents"][label]) for label in ("icca", "cbba")}
    for agent in agents.values():  # the planners' model is the learning domain's mission
        agent["params"]["model"]["params"]["domain"] = copy.deepcopy(domain)
    return {
        "name": f"generated_mission_{mission}",
        "domain": domain,
        "agents": agents,
        "budget_steps": budget,
        "num_policy_checks": 10,
        "eval_episodes": eval_episodes,
        "seeds": 1,
    }


def greedy(agent: Any, domain: Any) -> Any:
    """The agent's greedy policy among the legal joint actions, as a policy check acts."""
    return lambda state: agent.act(state, True, domain.legal_actions(state))


def measure(mission: int, seed: int, budget: int, eval_episodes: int) -> dict[str, Any]:
    """One row: the mission's V*, CBBA's exact value, and iCCA's after ``budget`` steps."""
    from conjure.experiments import registry
    from conjure.experiments.config import parse_config, resolve_run
    from conjure.experiments.run import run_resolved

    config = parse_config(experiment(mission, budget, eval_episodes))
    domain = registry.build("domain", config.domain.model_dump(), path="domain")
    graph = domain.graph_
    v_star = domain.exact_solution().optimal_return
    cbba = registry.build("agent", resolve_run(config, "cbba", seed)["agent"], path="cbba")
    cbba.setup(domain.domain_spec, seed)
    v_cbba = domain.evaluate_policy(greedy(cbba, domain)).value
    started = time.perf_counter()
    result = run_resolved(resolve_run(config, "icca", seed))
    seconds = time.perf_counter() - started
    icca = result.agent
    v_icca = domain.evaluate_policy(greedy(icca, domain)).value
    return {
        "mission_seed": mission,
        "seed": seed,
        "fuel": " ".join(map(str, graph.fuel)),
        "num_targets": int(graph.targets.size),
        "v_star": v_star,
        "v_cbba": v_cbba,
        "v_icca": v_icca,
        "icca_final_return": float(result.rows[-1]["return"]),
        "cbba_ratio": v_cbba / v_star,
        "icca_ratio": v_icca / v_star,
        "gain": v_icca / v_cbba - 1.0,
        "budget_steps": budget,
        "run_seconds": seconds,
    }


def plot(rows: pd.DataFrame, path: Path) -> None:
    """Each mission's gain per seed (dots) and mean (bar), missions sorted by mean gain."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    means = rows.groupby("mission_seed")["gain"].mean().sort_values()
    order = {mission: k for k, mission in enumerate(means.index)}
    fig, ax = plt.subplots(figsize=(8, 4))
    ax.bar(range(len(means)), 100 * means.to_numpy(), color="tab:blue", alpha=0.4, label="mean")
    ax.scatter(
        rows["mission_seed"].map(order),
        100 * rows["gain"],
        s=12,
        color="tab:blue",
        label="one seed",
    )
    ax.axhline(0.0, color="black", linewidth=0.8)
    ax.set_xticks(range(len(means)), [str(m) for m in means.index], fontsize=7)
    ax.set_xlabel("generated mission (mission_seed), sorted by mean gain")
    ax.set_ylabel("iCCA over CBBA, exact (%)")
    budget = int(rows["budget_steps"].iloc[0])
    ax.set_title(
        f"iCCA vs aggressive CBBA on {len(means)} generated UAV missions "
        f"(7 nodes, 2 UAVs, no noise, {budget:,} steps)",
        fontsize=9,
    )
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def summary(rows: pd.DataFrame) -> str:
    """The gain's distribution over missions (each mission's mean over its seeds)."""
    from conjure.experiments.results import t_confidence

    gains = rows.groupby("mission_seed")["gain"].mean()
    mean, half = t_confidence(gains.to_numpy())
    cbba = rows.groupby("mission_seed")["cbba_ratio"].first()
    icca = rows.groupby("mission_seed")["icca_ratio"].mean()
    return "\n".join(
        [
            f"{len(gains)} missions x {rows.groupby('mission_seed').size().min()} seeds, "
            f"{int(rows['budget_steps'].iloc[0]):,} steps",
            f"gain V^iCCA/V^CBBA - 1 per mission: mean {100 * mean:+.1f}% "
            f"(95% t: ±{100 * half:.1f}), "
            f"median {100 * gains.median():+.1f}%, min {100 * gains.min():+.1f}%, "
            f"max {100 * gains.max():+.1f}%",
            f"missions with a positive mean gain: {(gains > 0).sum()} of {len(gains)}; "
            f"with a negative one: {(gains < 0).sum()}",
            f"V/V*: CBBA mean {cbba.mean():.3f} (min {cbba.min():.3f}), iCCA mean "
            f"{icca.mean():.3f} (min {icca.min():.3f})",
        ]
    )


def main() -> None:
    """Run every mission and seed (at most ``--workers`` at once), write the CSV and plot."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--missions", type=int, default=30, help="mission seeds 0 .. M-1")
    parser.add_argument("--seeds", type=int, default=5, help="run seeds per mission")
    parser.add_argument("--budget", type=int, default=100_000, help="iCCA's learning steps")
    parser.add_argument("--eval-episodes", type=int, default=100)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--csv", type=Path, default=CSV)
    parser.add_argument("--plot", type=Path, default=PLOT)
    args = parser.parse_args()
    tasks = [
        (mission, FIRST_SEED + k, args.budget, args.eval_episodes)
        for mission in range(args.missions)
        for k in range(args.seeds)
    ]
    started, rows = time.perf_counter(), []
    with ProcessPoolExecutor(max_workers=max(args.workers, 1)) as pool:
        for row in pool.map(measure, *zip(*tasks, strict=True)):
            rows.append(row)
            print(
                f"{len(rows)}/{len(tasks)}: mission {row['mission_seed']} seed {row['seed']}: "
                f"gain {100 * row['gain']:+.2f}% ({time.perf_counter() - started:.0f} s)",
                flush=True,
            )
    table = pd.DataFrame(rows)
    args.csv.parent.mkdir(parents=True, exist_ok=True)
    table.to_csv(args.csv, index=False, float_format="%.6g")
    plot(table, args.plot)
    print(summary(table))
    seconds = time.perf_counter() - started
    print(f"{len(tasks)} runs in {seconds:.0f} s; wrote {args.csv}, {args.plot}")


if __name__ == "__main__":
    main()
