"""Why AM-iCCA ends below CSARSA on the noisy UAV 7-2 (Figs. 5-9/5-13): a measurement.

    python docs/reproduction/am_icca_switch.py trace [--seed 30000] [--steps 20000]
    python docs/reproduction/am_icca_switch.py judge [--seed 30000] [--episodes 100]
    python docs/reproduction/am_icca_switch.py variants [--seeds 10] [--workers 2]

All read examples/reproduction/fig_5_9_13.yaml, whose base settings are the selected ones
(`am_icca`: Algorithm 26 with Algorithm 25's M = 5 rollouts and ε = 20%, K = 20, a vetoed
proposal as printed; `csarsa`: Algorithm 24 with aggressive CBBA and the fuel rule).

``trace`` trains ``am_icca`` on one seed through the Python `Stepper` (the same steps and draws
as the compiled loop; its Monte-Carlo rollouts make it slow, so 2·10⁴ steps by default) and
writes, every ``--chunk`` steps, η̂ (the model's noise estimate), whether π^p is the aggressive
policy, the policy changes, the counts in use, the pairs known (count ≥ K), the learner's
proposals other than π^p(s) and how many the analyser vetoed, and the failures while
learning; and prints the switch's step and the counts its reset erased.

``judge`` runs ``am_icca`` for the config's 10⁵ steps (compiled) on one seed and plays
``--episodes`` greedy episodes of the final agent on the Python path: as evaluated (vetoes
counted), then with every proposal executed. Then it checks Section 5.5.1's condition ("the
planner's policy should be seen safe through the eyes of the risk analyzer at all times"):
over the states π^p itself reaches (`UAVMission.evaluate_policy`, at the true 5%), the share
where the analyser finds π^p(s)'s own action unsafe (risk ≥ ε), plain and weighted by the
probability of reaching the state, beside π^p's exact value and crash probability from s₀.

``variants`` runs, per seed, the final return and learning failures of: ``csarsa``;
``am_icca``; AM-iCCA started aggressive (initial noise 5%: π^p never switches, so no
reset); AM-iCCA with the fuel rule for Algorithm 25 (the analyser CSARSA uses);
``am_icca_tolerant`` (ε = 40%); and AM-iCCA with Section 5.5.3's check switched off from
knownness 1 on (``trusted_knownness=1``).
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
CONFIG = HERE.parents[1] / "examples" / "reproduction" / "fig_5_9_13.yaml"
TRACE_CSV = HERE / "chapter5" / "am_icca_switch_trace.csv"
VARIANTS_CSV = HERE / "chapter5" / "am_icca_switch_variants.csv"
#: Run seeds start here: above every seed the project's configs and docs used.
FIRST_SEED = 30000


def experiment() -> dict[str, Any]:
    """fig_5_9_13.yaml at its base (selected) settings, with the variants added."""
    data = yaml.safe_load(CONFIG.read_text())
    for key in ("grid", "selection"):
        data.pop(key)
    agents = data["agents"]
    am_icca = agents["am_icca"]
    variants = {
        "am_icca_aggressive_start": copy.deepcopy(am_icca),
        "am_icca_fuel_rule": copy.deepcopy(am_icca),
        "am_icca_trusted": copy.deepcopy(am_icca),
    }
    variants["am_icca_aggressive_start"]["params"]["model"]["params"]["initial_noise"] = 0.05
    variants["am_icca_fuel_rule"]["params"]["risk"] = {"kind": "FuelRiskAnalyzer"}
    variants["am_icca_trusted"]["params"]["trusted_knownness"] = 1.0
    agents.update(variants)
    return data


def build(label: str, seed: int) -> tuple[Any, Any, tuple[int, int]]:
    """(learning domain, set-up agent, (domain seed, evaluation seed)) as `run` builds them."""
    from conjure.core.seeding import seed_to_int, split_seed
    from conjure.experiments import registry
    from conjure.experiments.config import parse_config, resolve_run
    from conjure.experiments.run import SEED_STREAMS

    data = experiment()
    spec = resolve_run(parse_config(data), label, seed)
    domain = registry.build("domain", spec["domain"], path="domain")
    agent = registry.build("agent", spec["agent"], path=f"agents.{label}")
    seeds = split_seed(seed, SEED_STREAMS)
    agent.setup(domain.domain_spec, seeds["agent"])
    return domain, agent, (seed_to_int(seeds["domain"]), seed_to_int(seeds["evaluation"]))


def trace(seed: int, steps: int, chunk: int) -> tuple[pd.DataFrame, list[dict[str, Any]]]:
    """Train ``am_icca`` through the Python stepper: per chunk η̂, π^p, counts and vetoes.

    Returns the per-chunk table and the policy switches (step, η̂, counts erased).
    """
    from conjure.experiments.loop import Stepper

    domain, agent, (domain_seed, _) = build("am_icca", seed)
    risk, planner = agent.risk_, agent.planner_
    tally = {"proposals": 0, "vetoes": 0}
    switches: list[dict[str, Any]] = []
    stepper = Stepper(domain, agent, seed=domain_seed)
    update, learn = planner.update, agent.learn
    steps_learned = [0]

    def counting_learn(transition):
        steps_learned[0] += not transition.is_imagined
        return learn(transition)

    def recording_update(model):
        erased = int(agent.counts_.sum())
        known = int((agent.counts_ >= agent.num_known_visits).sum())
        changed = update(model)
        if changed:
            switches.append(
                {
                    "step": steps_learned[0],
                    "noise": float(model.noise_),
                    "counts_erased": erased,
                    "known_pairs_erased": known,
                    "is_aggressive": bool(planner.is_aggressive_),
                }
            )
        return changed

    risk.is_safe = counting(risk.is_safe, tally)
    planner.update, agent.learn = recording_update, counting_learn
    rows, started = [], time.perf_counter()
    while stepper.total_steps < steps:
        stepper.advance(min(chunk, steps - stepper.total_steps))
        rows.append(
            {
                "seconds": round(time.perf_counter() - started, 1),
                "learning_steps": stepper.total_steps,
                "learning_episodes": stepper.num_completed_episodes,
                "learning_failures": stepper.num_failures,
                "noise_estimate": float(agent.model_.noise_),
                "is_aggressive": bool(planner.is_aggressive_),
                "num_policy_changes": int(agent.num_policy_changes_),
                "counts_total": int(agent.counts_.sum()),
                "known_pairs": int((agent.counts_ >= agent.num_known_visits).sum()),
                "proposals": tally["proposals"],
                "vetoes": tally["vetoes"],
            }
        )
        print(rows[-1], flush=True)
    return pd.DataFrame(rows), switches


def counting(is_safe: Any, tally: dict[str, int]) -> Any:
    """``is_safe`` that also counts the proposals other than π^p(s) and the vetoed ones."""

    def counted(state, action, rng=None, *, planner_action=None):
        safe = is_safe(state, action, rng, planner_action=planner_action)
        if planner_action is None or action != planner_action:
            tally["proposals"] += 1
            tally["vetoes"] += not safe
        return safe

    return counted


def judge(
    seed: int, budget: int | None, episodes: int, max_planner_states: int | None = None
) -> dict[str, Any]:
    """The final ``am_icca`` of a run (compiled) judged greedily, and π^p by its analyser.

    Greedy episodes on the Python path (`run_episode`, so that the vetoes can be counted) from
    the run's evaluation seed: as evaluated, then with every proposal executed. Then Section
    5.5.1's condition on the states π^p reaches: is π^p(s)'s own action safe by the analyser?
    ``max_planner_states`` judges only the first that many of them (time order; None: all).
    """
    import numpy as np

    from conjure.core.seeding import seed_to_int, split_seed
    from conjure.experiments.config import parse_config
    from conjure.experiments.loop import run_episode
    from conjure.experiments.run import SEED_STREAMS, run_config

    data = experiment()
    if budget is not None:
        data["budget_steps"] = budget
    result = run_config(parse_config(data), agent_name="am_icca", seed=seed)
    agent = result.agent
    domain, _, _ = build("am_icca", seed)
    risk, planner = agent.risk_, agent.planner_
    eval_seed = seed_to_int(split_seed(seed, SEED_STREAMS)["evaluation"])

    def play() -> list[Any]:
        return [
            run_episode(domain, agent, seed=eval_seed if k == 0 else None) for k in range(episodes)
        ]

    tally = {"proposals": 0, "vetoes": 0}
    is_safe = risk.is_safe
    risk.is_safe = counting(is_safe, tally)
    evaluated = play()
    risk.is_safe = lambda state, action, rng=None, *, planner_action=None: True
    executed = play()
    risk.is_safe = is_safe
    truth = domain.evaluate_policy(planner.action)  # the non-terminal states π^p reaches
    rng = np.random.default_rng(seed)
    limit = slice(None, max_planner_states)
    pairs = zip(truth.states[limit], truth.actions[limit], strict=True)
    planner_risks = np.array([risk.risk(state, action, rng) for state, action in pairs])
    is_unsafe = planner_risks >= risk.risk_tolerance
    weights = truth.reach_probabilities[limit] / truth.reach_probabilities[limit].sum()
    return {
        "seed": seed,
        "learning_steps": int(result.rows[-1]["learning_steps"]),
        "num_policy_changes": int(agent.num_policy_changes_),
        "is_aggressive": bool(planner.is_aggressive_),
        "noise_estimate": float(agent.model_.noise_),
        "run_final_check_return": float(result.rows[-1]["return"]),
        "greedy_return": float(np.mean([e.episode_return for e in evaluated])),
        "greedy_failure_rate": float(np.mean([e.num_failures > 0 for e in evaluated])),
        "greedy_proposals": tally["proposals"],
        "greedy_vetoes": tally["vetoes"],
        "executed_return": float(np.mean([e.episode_return for e in executed])),
        "executed_failure_rate": float(np.mean([e.num_failures > 0 for e in executed])),
        "planner_states": int(planner_risks.size),
        "planner_unsafe_share": float(is_unsafe.mean()),
        "planner_unsafe_share_by_reach": float(weights @ is_unsafe),
        "planner_mean_risk_by_reach": float(weights @ planner_risks),
        "planner_exact_value": float(truth.value),
        "planner_exact_crash": float(truth.crash_probability),
        "risk_tolerance": float(risk.risk_tolerance),
        "num_rollouts": int(risk.num_rollouts),
    }


def final(label: str, seed: int, budget: int | None = None) -> dict[str, Any]:
    """One run of ``label`` at ``budget`` steps (None: the config's): its final policy check."""
    from conjure.experiments.config import parse_config
    from conjure.experiments.run import run_config

    data = experiment()
    if budget is not None:
        data["budget_steps"] = budget
    result = run_config(parse_config(data), agent_name=label, seed=seed)
    last = result.rows[-1]
    return {
        "label": label,
        "seed": seed,
        "return": float(last["return"]),
        "failure_rate": float(last["failure_rate"]),
        "learning_failures": int(last["learning_failures"]),
        "path": result.path,
    }


LABELS = (
    "csarsa",
    "am_icca",
    "am_icca_aggressive_start",
    "am_icca_fuel_rule",
    "am_icca_tolerant",
    "am_icca_trusted",
)


def main() -> None:
    """Parse the command line; run ``trace`` or ``variants``."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("mode", choices=["trace", "judge", "variants"])
    parser.add_argument("--seed", type=int, default=FIRST_SEED)
    parser.add_argument("--steps", type=int, default=20_000, help="trace: Python-path steps")
    parser.add_argument("--budget", type=int, default=None, help="judge: the run's steps")
    parser.add_argument("--chunk", type=int, default=2_000)
    parser.add_argument("--episodes", type=int, default=100)
    parser.add_argument("--seeds", type=int, default=10)
    parser.add_argument("--first-seed", type=int, default=FIRST_SEED, help="variants' first seed")
    parser.add_argument("--labels", nargs="+", choices=LABELS, default=list(LABELS))
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--csv", type=Path, default=None)
    args = parser.parse_args()
    started = time.perf_counter()
    if args.mode == "trace":
        table, switches = trace(args.seed, args.steps, args.chunk)
        table.to_csv(args.csv or TRACE_CSV, index=False, float_format="%.6g")
        print(f"switches: {switches}")
    elif args.mode == "judge":
        for key, value in judge(args.seed, args.budget, args.episodes).items():
            print(f"{key}: {value}")
    else:
        tasks = [(label, args.first_seed + k) for k in range(args.seeds) for label in args.labels]
        rows = []
        with ProcessPoolExecutor(max_workers=max(args.workers, 1)) as pool:
            for row in pool.map(final, *zip(*tasks, strict=True)):
                rows.append(row)
                print(f"{len(rows)}/{len(tasks)}: {row}", flush=True)
        table = pd.DataFrame(rows)
        table.to_csv(args.csv or VARIANTS_CSV, index=False, float_format="%.6g")
        from conjure.experiments.results import t_confidence

        for label, group in table.groupby("label", sort=False):
            mean, half = t_confidence(group["return"].to_numpy())
            print(
                f"{label:<26} return {mean:7.1f} ± {half:5.1f}  crash (greedy) "
                f"{group['failure_rate'].mean():.3f}  learning failures "
                f"{group['learning_failures'].mean():7.1f}  ({len(group)} seeds)"
            )
    print(f"{time.perf_counter() - started:.0f} s")


if __name__ == "__main__":
    main()
