"""Refuse to start worker processes from a script's unguarded top level.

A "forkserver" or "spawn" worker imports the script that started it (``__main__``) before it
runs anything, so a script that calls ``run_experiment(config, out, max_workers=2)`` at its
top level, outside ``if __name__ == "__main__":``, would start its experiment again in every
worker; each worker then dies before its first run. `check_main_guarded` turns that into one
error in the driver, before any worker starts.

Notes
-----
- Choice: the driver finds the script's ``<module>`` frame on the call stack and reads the
  script's syntax tree: the call is guarded when its line lies inside an
  ``if __name__ == "__main__":`` block. No script file (an interactive session, a notebook,
  ``python -c``) or one that cannot be read passes. A worker that is still importing the
  script (multiprocessing's bootstrapping phase) raises the same error, so a call the driver
  could not see fails there without starting processes of its own.
"""

from __future__ import annotations

import ast
import inspect
import multiprocessing
import sys
from pathlib import Path

from conjure.core.errors import InvalidParameterError

__all__ = ["check_main_guarded"]


def check_main_guarded() -> None:
    """Raise `InvalidParameterError` if worker processes would rerun the calling script.

    Examples
    --------
    >>> check_main_guarded()  # a doctest is no script: nothing to check
    """
    if getattr(multiprocessing.current_process(), "_inheriting", False):
        raise InvalidParameterError(_message("the script that started this worker", None))
    main = sys.modules.get("__main__")
    path = getattr(main, "__file__", None)
    if main is None or path is None:
        return
    here = inspect.currentframe()
    frame = here.f_back if here is not None else None
    while frame is not None and not (
        frame.f_code.co_name == "<module>" and frame.f_globals is vars(main)
    ):
        frame = frame.f_back
    if frame is None:
        return
    try:
        tree = ast.parse(Path(path).read_text(encoding="utf-8"))
    except (OSError, SyntaxError, ValueError, UnicodeDecodeError):
        return
    if not _is_guarded(tree, frame.f_lineno):
        raise InvalidParameterError(_message(path, frame.f_lineno))


def _is_guarded(tree: ast.Module, line: int) -> bool:
    """Whether ``line`` lies in the body of an ``if __name__ == "__main__":`` block."""
    return any(
        isinstance(node, ast.If)
        and _tests_main(node.test)
        and node.body[0].lineno <= line <= (node.body[-1].end_lineno or line)
        for node in ast.walk(tree)
    )


def _tests_main(test: ast.expr) -> bool:
    """Whether ``test`` is ``__name__ == "__main__"`` (either way round)."""
    if not (isinstance(test, ast.Compare) and len(test.ops) == 1):
        return False
    if not isinstance(test.ops[0], ast.Eq):
        return False
    sides = [test.left, test.comparators[0]]
    names = [s.id for s in sides if isinstance(s, ast.Name)]
    values = [s.value for s in sides if isinstance(s, ast.Constant)]
    return names == ["__name__"] and values == ["__main__"]


def _message(where: str, line: int | None) -> str:
    at = f"{where}, line {line}," if line is not None else where
    return (
        f"{at} starts worker processes from the script's top level: each worker imports the "
        'script and would run it again. Put the call under `if __name__ == "__main__":` (or '
        "pass max_workers=1, which runs in this process)."
    )
