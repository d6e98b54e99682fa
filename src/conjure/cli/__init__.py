"""The ``conjure`` command line (`conjure.cli.main`); commands import their machinery lazily."""

from conjure.cli.main import main

__all__ = ["main"]
