"""Sweeps layer: many settings of an experiment, and choosing among them.

``conjure.sweeps.sweep`` expands domains × agents × parameter grids × seeds into resolved runs
and runs them (`run_sweep`); ``selection`` picks each method's best setting and reruns it on
fresh seeds; ``tune`` searches settings with Optuna. Runs execute through
`conjure.experiments.parallel` on its executors.
"""
