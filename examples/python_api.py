"""From a YAML experiment config to a result in Python: ``load_config`` → ``build`` → ``run``.

The command line runs a config with ``conjure run examples/pendulum.yaml``. This script takes
the same config through the Python API, for notebooks and scripts that want the objects:

1. ``load_config(path, overrides)`` reads and validates the YAML (``overrides`` are the
   ``--set`` strings of the CLI, e.g. ``"budget_steps=2000"``) into an ``ExperimentConfig``.
2. ``build("domain", config.domain.model_dump())`` and ``build("agent", ...)`` turn its
   ``{kind, params}`` entries into a domain and an agent (validated, not set up).
3. ``run(domain=..., agent=..., budget_steps=..., seed=...)`` learns and returns a ``Result``:
   ``result.curve`` (one row per policy check), ``result.summary()``, the trained
   ``result.agent``.

``run_config(config, agent_name=..., seed=...)`` does 2-3 in one call, and
``run_experiment(config, out_dir)`` runs every agent over every seed in parallel and writes
the results folder as ``conjure run`` does (the CLI then also plots).

Run with:  python examples/python_api.py  (5,000 steps of the tile-coding agent)
"""

from __future__ import annotations

import sys
from collections.abc import Sequence
from pathlib import Path

from conjure.experiments import Result, build, load_config, run

PENDULUM = Path(__file__).with_name("pendulum.yaml")


def run_from_config(
    config_path: str | Path = PENDULUM,
    agent_name: str = "tile_coding",
    seed: int = 0,
    overrides: Sequence[str] = (),
) -> Result:
    """Learn with agent ``agent_name`` of the config at ``config_path`` for one seed."""
    config = load_config(config_path, overrides)
    domain = build("domain", config.domain.model_dump(), path="domain")
    agent = build("agent", config.agents[agent_name].model_dump(), path=f"agents.{agent_name}")
    return run(
        domain=domain,
        agent=agent,
        budget_steps=config.budget_steps,
        seed=seed,
        num_policy_checks=config.num_policy_checks,
        eval_episodes=config.eval_episodes,
    )


if __name__ == "__main__":
    result = run_from_config(overrides=["budget_steps=5000", *sys.argv[1:]])
    print(result.summary())
    print(result.curve[["learning_steps", "return", "episode_length", "num_features"]])
