"""Why AM-iCCA stays near aggressive CBBA on the noisy UAV 7-2 (docs/reproduction/fig_5_9_13.md).

    python docs/reproduction/am_icca_vetoes.py [--seed 101] [--risk-tolerance 0.2]
    python docs/reproduction/am_icca_vetoes.py --quick   # 2,000 steps, 3 episodes (a smoke run)

Trains `am_icca` of examples/reproduction/fig_5_9_13.yaml (its base settings are the selected
ones) for the config's 10⁵ steps on one seed, then runs 300 greedy episodes three ways: as
evaluated (unsafe proposals replaced by π^p), counting how many of the learner's proposals
that differ from π^p the Monte-Carlo analyser vetoes, and with every proposal executed.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import yaml

from conjure.domains import UAVMission
from conjure.experiments.config import parse_config
from conjure.experiments.loop import run_episode
from conjure.experiments.run import run_config

CONFIG = Path(__file__).resolve().parents[2] / "examples" / "reproduction" / "fig_5_9_13.yaml"


def greedy_return(agent, domain, episodes: int) -> float:
    """The mean return of ``episodes`` greedy episodes on fixed evaluation seeds."""
    returns = [
        run_episode(domain, agent, learn=False, seed=10_000 + k).episode_return
        for k in range(episodes)
    ]
    return float(np.mean(returns))


def main() -> None:
    """Train, then evaluate with vetoes counted and without vetoes."""
    parser = argparse.ArgumentParser()
    parser.add_argument("--seed", type=int, default=101)
    parser.add_argument("--risk-tolerance", type=float, default=None)
    parser.add_argument("--episodes", type=int, default=300)
    parser.add_argument("--quick", action="store_true", help="2,000 steps and 3 episodes")
    args = parser.parse_args()
    data = yaml.safe_load(CONFIG.read_text())
    for key in ("grid", "selection"):
        data.pop(key)
    if args.quick:
        data.update(budget_steps=2000, eval_episodes=3)
        args.episodes = 3
    if args.risk_tolerance is not None:
        data["agents"]["am_icca"]["params"]["risk"]["params"]["risk_tolerance"] = (
            args.risk_tolerance
        )
    data["num_policy_checks"] = 1
    result = run_config(parse_config(data), agent_name="am_icca", seed=args.seed)
    agent, domain = result.agent, UAVMission(**data["domain"]["params"])
    risk, planner = agent.risk_, agent.planner_
    proposals = {"proposed": 0, "vetoed": 0}
    is_safe = risk.is_safe

    def counting(state, action, rng=None, *, planner_action=None):
        safe = is_safe(state, action, rng, planner_action=planner_action)
        if action != (planner.action(state) if planner_action is None else planner_action):
            proposals["proposed"] += 1
            proposals["vetoed"] += not safe
        return safe

    risk.is_safe = counting
    evaluated = greedy_return(agent, domain, args.episodes)
    print(f"greedy return, proposals vetoed as unsafe: {evaluated:.1f}; {proposals}")
    risk.is_safe = lambda state, action, rng=None, *, planner_action=None: True
    executed = greedy_return(agent, domain, args.episodes)
    print(f"greedy return, every proposal executed: {executed:.1f}")


if __name__ == "__main__":
    main()
