"""conjure: practical reinforcement learning on large MDPs, after Geramifard (2012).

Layers, from the bottom: ``core`` (interfaces, errors, seeding, schedules); ``domains``,
``representations`` and ``policies``; ``agents`` and ``planners``; ``safety``; ``experiments``
(configs, runs, results); ``sweeps`` and ``reporting``; ``cli`` (the ``conjure`` command).
Importing the package registers the domains as Gymnasium environments (`conjure.environments`)
without importing them: ``gymnasium.make("conjure/GridWorld1-v0")`` works after it.
"""

from conjure.environments import register_environments

__version__ = "0.1.0"

register_environments()
