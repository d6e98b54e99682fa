"""Experiments layer: the run loop, runs, configs, the registry, results, plots and the CLI.

``run(domain=..., agent=..., budget_steps=..., seed=...)`` learns and records a learning curve;
``run_experiment(load_config("examples/pendulum.yaml"), "results/pendulum")`` compares several
agents over seeds in parallel; ``conjure run CONFIG`` does the same from the shell.
"""

from conjure.experiments.config import (
    ComponentConfig,
    ExperimentConfig,
    load_config,
    parse_config,
    resolve,
    resolve_run,
)
from conjure.experiments.loop import EpisodeStats, LearningLoop, run_episode
from conjure.experiments.parallel import ExperimentResult, run_experiment
from conjure.experiments.plots import plot_learning_curves
from conjure.experiments.registry import build
from conjure.experiments.results import load_results, summarize
from conjure.experiments.run import Result, run, run_config

__all__ = [
    "ComponentConfig",
    "EpisodeStats",
    "ExperimentConfig",
    "ExperimentResult",
    "LearningLoop",
    "Result",
    "build",
    "load_config",
    "load_results",
    "parse_config",
    "plot_learning_curves",
    "resolve",
    "resolve_run",
    "run",
    "run_config",
    "run_episode",
    "run_experiment",
    "summarize",
]
