"""The compiled path: whole learning loops in one numba function.

`for_combination` (domain, agent) returns a `CompiledStepper` when every part has a compiled
kernel, else ``None`` (the caller keeps the Python path); `why_not_compiled` says which part
has no kernel.
"""

from conjure.compiled.combination import why_not_compiled
from conjure.compiled.stepper import (
    AdvanceStats,
    CompiledStepper,
    compile_seconds,
    for_combination,
    is_warm,
    warm_up,
)

__all__ = [
    "AdvanceStats",
    "CompiledStepper",
    "compile_seconds",
    "for_combination",
    "is_warm",
    "warm_up",
    "why_not_compiled",
]
