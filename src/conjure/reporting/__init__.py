"""Reporting layer: read an experiment's or sweep's results folder and present it.

``plots`` draws learning curves (mean and a 95% confidence band over seeds) and performance
profiles; ``report`` writes ``report.md`` with final-performance tables, IQM intervals and
per-domain figures; ``statistics`` computes the IQM, the probability of improvement and
performance profiles with their bootstrap intervals by rliable.
"""
