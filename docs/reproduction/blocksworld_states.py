"""How many BlocksWorld states the tabular learner of Fig. 4-5(b) indexes (HashedTabular).

    python docs/reproduction/blocksworld_states.py
    python docs/reproduction/blocksworld_states.py --quick   # a smoke run: seed 3, 2,000 steps

Reruns the selected tabular setting (alpha_0 = 1, N_0 = 100) on fresh seeds 3-7 and prints the
states indexed after 1e5 learning steps (the states learned from: policy checks index none)
and the final greedy return. 6 blocks have 4,051 reachable states.
"""

import sys

from conjure.experiments.run import run_config

CONFIG = {
    "name": "blocksworld_states",
    "domain": {"kind": "BlocksWorld", "params": {}},
    "agents": {
        "tabular": {
            "kind": "SARSA",
            "params": {
                "representation": {"kind": "HashedTabular", "params": {"capacity": 10231}},
                "policy": {"kind": "EpsilonGreedy", "params": {"epsilon": 0.1}},
                "step_size": {
                    "kind": "FeatureNormalizedDecay",
                    "params": {"alpha_0": 1.0, "n_0": 100},
                },
            },
        }
    },
    "budget_steps": 100000,
    "num_policy_checks": 10,
    "eval_episodes": 5,
    "metric": "return",
}

if __name__ == "__main__":
    seeds = range(3, 8)
    if "--quick" in sys.argv[1:]:
        CONFIG.update(budget_steps=2000, num_policy_checks=1)
        seeds = range(3, 4)
    for seed in seeds:
        result = run_config(CONFIG, agent_name="tabular", seed=seed)
        stored = result.agent.representation_.num_stored_
        final = result.curve["return"].iloc[-1]
        print(f"seed {seed}: {stored:,} states indexed, final return {final:.3f}")
