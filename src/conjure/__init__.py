"""conjure: practical reinforcement learning on large MDPs, after Geramifard (2012).

Layers, from the bottom: ``core`` (interfaces, errors, seeding, schedules); ``domains``,
``representations`` and ``policies``; ``agents``; ``experiments`` (configs, runs, CLI).
"""

__version__ = "0.1.0"
