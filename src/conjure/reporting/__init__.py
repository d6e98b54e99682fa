"""Reporting layer: read an experiment's or sweep's results folder and present it.

``plots`` draws learning curves (mean and a 95% confidence band over seeds); ``report``
writes ``report.md`` with final-performance tables, IQM intervals and per-domain figures.
"""
