"""Why CSARSA falls into GridWorld-1's pits more often than SARSA while learning (Fig. 5-8).

    python docs/reproduction/fig_5_8_pit_entries.py [--seeds 30] [--first-seed 20000]
    python docs/reproduction/fig_5_8_pit_entries.py --quick    # 2 seeds, 1,000 steps

Learns with the agents of examples/reproduction/fig_5_8.yaml (their base settings are the ones
the area criterion selected) for the config's 10⁴ steps, seeded as `conjure run` seeds a run
(one seed split into the domain's and the agent's), on seeds from 20,000 that no sweep used,
and counts every pit entry while learning by its cause:

- who chose the executed action (Algorithm 24): π^p because the pair (s, π^p(s)) was not yet
  known (line 3 failed), π^p because the learner's proposal was vetoed (line 5 failed), or the
  learner's approved proposal (line 6), the same as π^p(s) or not; SARSA and the planners:
  their own action;
- how the agent got there: the move it chose led into the pit, or the 30% noise replaced it
  (the cell reached is not the chosen move's);

and the learning steps each chooser took and the episodes, so a count reads against its exposure.
Beside SARSA and the two planners (``vi_planner``: π^p alone; ``optimal``: value iteration on
the true noise), the variants of the selected ``csarsa`` (𝒦 = 50) change one parameter each.
"""

from __future__ import annotations

import argparse
import copy
import sys
from collections import Counter
from pathlib import Path

import numpy as np
import yaml

from conjure.core.seeding import seed_to_int, split_seed
from conjure.experiments.config import build_components, parse_config
from conjure.experiments.loop import Stepper
from conjure.experiments.numbers import format_interval
from conjure.experiments.results import t_confidence
from conjure.experiments.run import SEED_STREAMS, run_config

CONFIG = Path(__file__).resolve().parents[2] / "examples" / "reproduction" / "fig_5_8.yaml"


def variants(data: dict) -> dict[str, dict]:
    """The agents measured: the config's, and the selected CSARSA with one parameter changed."""
    agents = data["agents"]
    names = ("sarsa", "vi_planner", "optimal", "csarsa", "csarsa_printed")
    out = {name: agents[name] for name in names}
    for known in (10, 20):
        changed = copy.deepcopy(agents["csarsa"])
        changed["params"]["num_known_visits"] = known
        out[f"csarsa K={known}"] = changed
    no_veto = copy.deepcopy(agents["csarsa"])
    no_veto["params"]["veto_reward"] = None
    out["csarsa no veto"] = no_veto
    for alpha_0, n_0 in ((0.1, 1000), (1.0, 100)):
        changed = copy.deepcopy(agents["csarsa"])
        changed["params"]["learner"]["params"]["step_size"]["params"].update(
            alpha_0=alpha_0, n_0=n_0
        )
        out[f"csarsa alpha_0={alpha_0:g} N_0={n_0}"] = changed
    noisy = copy.deepcopy(agents["csarsa"])
    noisy["params"]["model"]["params"]["domain"]["params"]["noise"] = data["domain"]["params"][
        "noise"
    ]
    out["csarsa, T̂ with the domain's noise"] = noisy
    adaptive = copy.deepcopy(agents["csarsa"])
    adaptive["kind"] = "AdaptiveCooperativeLearner"
    adaptive["params"]["replan_threshold"] = 0.01  # value iteration per 0.01 of η̂
    adaptive["params"]["model"]["params"].update(is_adaptive=True, prior_weight=100.0)
    out["csarsa, T̂ adaptive (Algorithm 26)"] = adaptive
    return out


def count(data: dict, agent_spec: dict, seed: int, budget: int) -> tuple[Counter, Counter, int]:
    """(pit entries, learning steps), each by (chooser, how), and the episodes of one run."""
    config = parse_config({**data, "agents": {"agent": agent_spec}})
    domain, agents = build_components(config)
    agent = agents["agent"]
    seeds = split_seed(seed, SEED_STREAMS)
    agent.setup(domain.domain_spec, seeds["agent"])
    chooser = {"last": "its own action"}
    if hasattr(agent, "learner_"):  # Algorithm 24: who chose the action act returns
        learner_act, is_safe = agent.learner_.act, agent.risk_.is_safe

        def consulting(*args, **kwargs):
            chooser["consulted"] = True
            return learner_act(*args, **kwargs)

        def judging(state, action, *args, **kwargs):
            chooser["safe"] = safe = is_safe(state, action, *args, **kwargs)
            chooser["planned"] = action == kwargs.get("planner_action")
            return safe

        agent.learner_.act, agent.risk_.is_safe = consulting, judging
        act = agent.act

        def acting(*args, **kwargs):
            chooser.update(consulted=False, safe=True)
            action = act(*args, **kwargs)
            if not chooser["consulted"]:
                chooser["last"] = "planner, pair not known"
            elif not chooser["safe"]:
                chooser["last"] = "planner, proposal vetoed"
            elif chooser["planned"]:
                chooser["last"] = "learner, approved, = π^p(s)"
            else:
                chooser["last"] = "learner, approved, ≠ π^p(s)"
            return action

        agent.act = acting
    entries, steps = Counter(), Counter()
    step = domain.step

    def stepping(action):
        intended = domain._moves[domain._cell][int(action)]
        out = step(action)
        how = "chosen move" if domain._cell == intended else "noise"
        steps[chooser["last"]] += 1
        if out[4].get("cost", 0.0) > 0.0:
            entries[(chooser["last"], how)] += 1
        return out

    domain.step = stepping
    stepper = Stepper(domain, agent, seed=seed_to_int(seeds["domain"]))
    stepper.advance(budget)
    return entries, steps, stepper.num_episodes


def main() -> None:
    """Count the pit entries of every variant on the seeds; print them by cause."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--seeds", type=int, default=30)
    parser.add_argument("--first-seed", type=int, default=20_000)
    parser.add_argument("--quick", action="store_true", help="2 seeds, 1,000 steps")
    parser.add_argument("--agents", nargs="*", default=None, help="only these (default all)")
    parser.add_argument(
        "--returns", action="store_true", help="also each run's final greedy return (slower)"
    )
    args = parser.parse_args()
    sweep = yaml.safe_load(CONFIG.read_text())
    data = {key: value for key, value in sweep.items() if key not in ("grid", "selection")}
    budget = 1_000 if args.quick else int(data["budget_steps"])
    seeds = range(args.first_seed, args.first_seed + (2 if args.quick else args.seeds))
    print(f"{CONFIG.name}, {budget:,} learning steps, seeds {seeds[0]}-{seeds[-1]}")
    for name, spec in variants(data).items():
        if args.agents is not None and name not in args.agents:
            continue
        entries, steps, episodes = Counter(), Counter(), 0
        for seed in seeds:
            run_entries, run_steps, run_episodes = count(data, spec, seed, budget)
            entries.update(run_entries)
            steps.update(run_steps)
            episodes += run_episodes
        total = sum(entries.values())
        print(
            f"\n{name}: {total / len(seeds):.1f} pit entries per run, in "
            f"{episodes / len(seeds):.1f} episodes begun ({total / episodes:.3f} per episode)"
        )
        if args.returns:
            checked = {**data, "budget_steps": budget, "num_policy_checks": 1}
            config = parse_config({**checked, "agents": {"agent": spec}})
            finals = [
                run_config(config, agent_name="agent", seed=seed).curve["return"].iloc[-1]
                for seed in seeds
            ]
            mean, half = t_confidence(np.array(finals))
            print(f"  final greedy return {format_interval(mean, half)} (mean ± 95% t)")
        for who in sorted(steps):
            by_how = {how: entries[(who, how)] / len(seeds) for how in ("chosen move", "noise")}
            cells = ", ".join(f"{how} {value:.1f}" for how, value in by_how.items())
            share = steps[who] / sum(steps.values())
            print(f"  {who:30s} {share:6.1%} of steps; pit entries per run: {cells}")
    sys.stdout.flush()


if __name__ == "__main__":
    main()
