"""The progress display's phases: what a command is doing between its runs' progress bar.

`phase` shows one step of a command (setting up, compiling kernels, plotting) while it runs
and how long it took once it ends. It imports only rich, so the command line can show its
first phase (loading conjure) before the heavier modules load.
"""

from __future__ import annotations

import time
from collections.abc import Iterator
from contextlib import contextmanager

from rich.console import Console
from rich.markup import escape

__all__ = ["phase"]


@contextmanager
def phase(console: Console | None, text: str, *, keep: bool = True) -> Iterator[None]:
    """Show ``text`` as a phase of the progress display while the block runs, then its time.

    A spinner on a terminal; with ``keep``, one line ``text: N s`` when the block ends (also
    when the output is not a terminal). ``console`` None shows nothing (``--quiet``).
    """
    if console is None:
        yield
        return
    started = time.perf_counter()
    with console.status(escape(text)):
        yield
    if keep:
        seconds = time.perf_counter() - started
        console.print(f"{escape(text)}: {seconds:.1f} s", highlight=False)
