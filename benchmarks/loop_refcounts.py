"""Reference counts in the compiled learning loop's code: what its inlined slots bind.

Usage: ``python benchmarks/loop_refcounts.py``

Compiles `conjure.compiled.learning_loop.learning_loop` afresh (not from the cache, about a
minute) for SARSA + tile coding on the pendulum (``compiled_loop.py``'s workload) and counts
the calls to numba's ``NRT_incref`` and ``NRT_decref`` left in the loop function's optimized
LLVM IR, by the value they count. Borrowed arrays and generators have a null memory record
(`conjure.core.compiled_form.borrowed`); a structref argument (iFDD's tables inside
``rep``, ``row_traces``, ``parts``) cannot be borrowed, so each count left on it is an atomic
add or subtract wherever that code runs. A static count, the same on every CPU.
"""

from __future__ import annotations

import collections
import re

from call_cost import cpu_model
from compiled_loop import make_agent
from numba import njit
from rich.console import Console
from rich.table import Table

from conjure.compiled import for_combination
from conjure.compiled import learning_loop as lp
from conjure.compiled.combination import agent_form, box_form, representation_form
from conjure.domains import InvertedPendulum

#: The loop's structref-holding arguments, as numba names them in the IR.
STRUCTREF_ARGUMENTS = ("arg.rep.2", "arg.row_traces", "arg.parts")


def loop_arguments() -> tuple:
    """`learning_loop`'s arguments for the pendulum workload, asking for no step."""
    domain = InvertedPendulum()
    agent = make_agent("tiles").setup(domain.domain_spec, 0)
    stepper = for_combination(domain, agent, seed=0)
    rep = representation_form(agent)
    form = box_form(agent, rep)
    return (
        0, domain.compiled_form(), domain.np_random, rep, agent_form(agent), agent.arrays_,
        agent.row_traces_, agent.rng_, 3000, stepper._obs, stepper._state, form.box,
        form.parts, True, 1,
    )  # fmt: skip


def loop_ir() -> str:
    """The optimized IR of the loop function, compiled afresh for the pendulum workload."""
    args = loop_arguments()
    loop = njit(lp.learning_loop.py_func)
    loop(*args)
    module = loop.inspect_llvm(loop.signatures[0])
    functions = re.split(r"\n(?=define )", module)
    return next(f for f in functions if re.match(r"define .*13learning_loop13learning_loop", f))


def main() -> None:
    counts = collections.Counter(
        re.sub(r"\.\d+$", "", value)
        for value in re.findall(r"call void @NRT_(?:incref|decref)\(ptr %([\w.]+)\)", loop_ir())
    )
    table = Table(title="NRT_incref / NRT_decref calls in learning_loop (SARSA + tiles)")
    table.add_column("counted value")
    table.add_column("calls", justify="right")
    for name in STRUCTREF_ARGUMENTS:
        table.add_row(f"{name} (structref)", str(counts[name]))
    table.add_row("every value", str(sum(counts.values())))
    console = Console()
    console.print(table)
    console.print(f"CPU: {cpu_model()} (the count does not depend on it)")


if __name__ == "__main__":
    main()
