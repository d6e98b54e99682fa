"""Where a fresh compile of the learning loop spends its time: inlining, typing, LLVM.

Usage: ``python benchmarks/compile_profile.py``

Compiles `conjure.compiled.learning_loop.learning_loop` afresh for SARSA + tile coding on the
pendulum (``compiled_loop.py``'s workload; the kernels it calls without inlining load from
numba's cache, so this is the loop function's own compile) under `cProfile`, and prints the
cumulative seconds of numba's stages: the untyped inlining of ``inline="always"`` kernels
(``inline_function``, with the IR copies ``copy_ir`` it makes at every site and the passes it
runs on each copy, which inline that copy's own callees, so the two overlap), type inference,
and LLVM's optimisation and finalisation. Each site copies the callee's IR with everything
inlined into it, so a slot nested in slots is copied once per level. Where numba has several
functions of one name in one file, the row is the one with the most cumulative time. Timings
depend on the CPU and its load; both are printed.
"""

from __future__ import annotations

import cProfile
import os
import pstats
import time

from call_cost import cpu_model
from loop_refcounts import loop_arguments
from numba import njit
from rich.console import Console
from rich.table import Table

from conjure.compiled import learning_loop as lp

#: (stage, the profiled function's file and name).
STAGES = (
    ("inlining inline='always' kernels", "inline_closurecall.py", "inline_function"),
    ("  copies of a callee's IR, every level", "inline_closurecall.py", "copy_ir"),
    ("  passes on the copies, nested inlining in", "inline_closurecall.py", "run_untyped_passes"),
    ("type inference", "typeinfer.py", "propagate"),
    ("LLVM optimisation and finalisation", "codegen.py", "finalize"),
)


def profile() -> tuple[float, dict[tuple[str, str], tuple[int, float]]]:
    """Wall seconds of one fresh compile and (calls, cumulative seconds) by function."""
    args = loop_arguments()
    loop = njit(lp.learning_loop.py_func)
    profiler = cProfile.Profile()
    start = time.perf_counter()
    profiler.runcall(loop, *args)
    seconds = time.perf_counter() - start
    stats = pstats.Stats(profiler).stats  # {(file, line, name): (cc, nc, tt, ct, callers)}
    by_function: dict[tuple[str, str], tuple[int, float]] = {}
    for (path, _, name), (_, calls, _, cumulative, _) in stats.items():
        key = (os.path.basename(path), name)
        if cumulative > by_function.get(key, (0, -1.0))[1]:
            by_function[key] = (calls, cumulative)
    return seconds, by_function


def main() -> None:
    seconds, by_function = profile()
    table = Table(title="A fresh compile of learning_loop (SARSA + tiles), under cProfile")
    table.add_column("stage")
    table.add_column("calls", justify="right")
    table.add_column("cumulative s", justify="right")
    for stage, path, name in STAGES:
        calls, total = by_function.get((path, name), (0, 0.0))
        table.add_row(stage, f"{calls:,}", f"{total:.1f}")
    table.add_row("the whole compile (wall)", "", f"{seconds:.1f}")
    console = Console()
    console.print(table)
    console.print(f"CPU: {cpu_model()}; load average at end: {os.getloadavg()}")


if __name__ == "__main__":
    main()
