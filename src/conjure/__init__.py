"""conjure: practical reinforcement learning on large MDPs, after Geramifard (2012).

Layers, from the bottom: ``core`` (interfaces, errors, seeding, schedules); ``domains``,
``representations`` and ``policies``; ``agents`` and ``planners``; ``safety``; ``experiments``
(configs, runs, results); ``sweeps`` and ``reporting``; ``cli`` (the ``conjure`` command).
Importing the package registers the domains as Gymnasium environments (`conjure.environments`)
without importing them: ``gymnasium.make("conjure/GridWorld1-v0")`` works after it.
``core`` comes first: it keys numba's cache of the kernels on all kernel sources.
"""

import conjure.core  # noqa: F401 (first: see `conjure.core.kernel_cache`)
from conjure.environments import register_environments

__version__ = "0.1.0"

register_environments()
