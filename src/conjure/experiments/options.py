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

from conjure.core.errors import InvalidParameterError
from conjure.experiments.memory import parse_memory_limit

__all__ = ["max_memory_option", "max_workers_option", "out_dir_option", "overrides_option"]


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


def overrides_option(help_text: str) -> Callable[[Any], Any]:
    """The repeatable ``--set PATH=VALUE`` option (parameter ``overrides``, a tuple of str).

    Examples
    --------
    >>> from click.testing import CliRunner
    >>> @click.command()
    ... @overrides_option("Override a config value (repeatable).")
    ... def show(overrides):
    ...     click.echo(repr(overrides))
    >>> CliRunner().invoke(show, ["--set", "seeds=3", "--set", "x=1"]).output.strip()
    "('seeds=3', 'x=1')"
    """
    return click.option("--set", "overrides", multiple=True, metavar="PATH=VALUE", help=help_text)


def _parse_memory(context: click.Context, parameter: click.Parameter, value: Any) -> int | None:
    try:
        return parse_memory_limit(value)
    except InvalidParameterError as exc:
        raise click.BadParameter(str(exc)) from None


#: The ``--max-memory SIZE`` option of ``conjure run``, ``sweep`` and ``tune`` (bytes or None).
max_memory_option = click.option(
    "--max-memory",
    metavar="SIZE",
    default=None,
    callback=_parse_memory,
    help="Each run's memory limit, e.g. 4GiB (default: the config's max_memory, else none). "
    "A run over it fails alone.",
)


#: The ``--max-workers N`` option of ``conjure run``, ``sweep``, ``tune`` and ``reproduce``.
max_workers_option = click.option(
    "--max-workers",
    type=click.IntRange(min=1),
    default=None,
    help="Worker processes (default: the config's max_workers, else the CPU count); 1 runs "
    "in this process.",
)
