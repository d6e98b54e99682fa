"""Command-line options shared by the ``conjure`` commands (click only: cheap to import).

Notes
-----
- Choice: ``--out`` is parsed as a plain path; the command checks it with
  `conjure.experiments.results.make_out_dir` before any run, so an unwritable folder is one
  clear line (exit status 2) rather than click's own path checks.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import click

__all__ = ["out_dir_option"]


def out_dir_option(help_text: str) -> Callable[[Any], Any]:
    """The ``--out DIR`` option (parameter ``out_dir``, a `Path` or None) with ``help_text``.

    Examples
    --------
    >>> from click.testing import CliRunner
    >>> @click.command()
    ... @out_dir_option("Where results go.")
    ... def show(out_dir):
    ...     click.echo(repr(out_dir))
    >>> CliRunner().invoke(show, ["--out", "results/x"]).output.strip()
    "PosixPath('results/x')"
    """
    return click.option(
        "--out", "out_dir", type=click.Path(path_type=Path), default=None, help=help_text
    )
