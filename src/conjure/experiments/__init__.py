"""Experiments layer: the run loop, runs, configs, the registry, results and parallel execution.

``run(domain=..., agent=..., budget_steps=..., seed=...)`` learns and records a learning curve
(``continue_learning=True`` learns on from a restored agent; ``evaluate`` only evaluates it);
``run_experiment(load_config("examples/pendulum.yaml"), "results/pendulum")`` compares several
agents over seeds in parallel; ``conjure run CONFIG`` does the same from the shell. Sweeps
(`conjure.sweeps`), reports and plots (`conjure.reporting`) and the command line
(`conjure.cli`) build on this layer.

The names below are imported on first use (importing the package loads none of them).
"""

from __future__ import annotations

import sys
import types
from typing import Any

from conjure.core.lazy import lazy_exports

#: Each exported name and the submodule that defines it.
_EXPORTS = {
    "ComponentConfig": "config",
    "ExperimentConfig": "config",
    "load_config": "config",
    "parse_config": "config",
    "resolve": "config",
    "resolve_run": "config",
    "EpisodeStats": "loop",
    "LearningLoop": "loop",
    "run_episode": "loop",
    "ExperimentResult": "parallel",
    "run_experiment": "parallel",
    "build": "registry",
    "load_results": "results",
    "summarize": "results",
    "Result": "run",
    "evaluate": "run",
    "run": "run",
    "run_config": "run",
}

__all__ = sorted(_EXPORTS)
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)


class _Package(types.ModuleType):
    """The package module; importing the submodule ``run`` does not hide the function `run`."""

    def __setattr__(self, name: str, value: Any) -> None:
        if name in _EXPORTS and isinstance(value, types.ModuleType):
            return
        super().__setattr__(name, value)


sys.modules[__name__].__class__ = _Package
