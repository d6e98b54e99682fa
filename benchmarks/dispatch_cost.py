"""What each way of dispatching to the components' kernels costs: cold compile, cache, step.

Usage: ``python benchmarks/dispatch_cost.py [--steps N] [--repeats R] [--options A,B]``

Workload: SARSA + tile coding (8 tilings of 10x10), ε-greedy (ε = 0.1), constant α = 0.05 on
the inverted pendulum (``benchmarks/compiled_loop.py``'s). Options:

- ``union``: today's `conjure.compiled.learning_loop` (one compilation for every binary-φ
  combination, union forms and ``kind ==`` branches), run by `conjure.compiled.
  for_combination`;
- ``specialised``, ``structref``, ``first-class``: the prototype loop of
  ``benchmarks/_dispatch_prototypes.py`` reaching the same kernels by compile-time
  resolution on named-tuple forms, on structref forms, or through first-class functions.

For each option, in a fresh process with an empty numba cache (``NUMBA_CACHE_DIR`` a new
temporary folder): the first call's CPU and wall seconds (``cold``: the compile, callees
included); then in a second process on that cache the first call again (``warm``: whether
``cache=True`` holds), the CPU µs per step over ``--steps`` steps (median of ``--repeats``,
a fresh learner each) and a checksum of θ after them (the same for every option: the same
kernels, draws and order). CPU seconds are this process's (`time.process_time`): on a
shared machine the wall seconds grow with the load, the CPU seconds much less.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

from rich.console import Console
from rich.table import Table

sys.path.insert(0, str(Path(__file__).resolve().parent))

from call_cost import cpu_model

OPTIONS = ("union", "specialised", "structref", "first-class")

_CHILD = """
import hashlib, json, statistics, sys, time
import numpy as np
from numba import typeof
sys.path.insert(0, sys.argv[1])
import _dispatch_prototypes as proto
from compiled_loop import make_agent
from conjure.compiled import for_combination
from conjure.compiled.combination import agent_form, representation_form
from conjure.domains import InvertedPendulum

option, steps, repeats = sys.argv[2], int(sys.argv[3]), int(sys.argv[4])


def pair():
    domain = InvertedPendulum()
    return domain, make_agent("tiles").setup(domain.domain_spec, 1)


def runner(steps_per_call):
    domain, agent = pair()
    if option == "union":
        stepper = for_combination(domain, agent, seed=1)
        return lambda: stepper.advance(steps_per_call), agent
    domain.reset(seed=1)
    base = representation_form(agent).base
    dom = proto.PendulumForm(np.zeros(2), np.array([domain.force_noise, domain.start_noise]))
    rep = proto.TilesForm(base.dims, base.layout, base.groups, base.num_tilings,
                          np.empty(2, dtype=np.int64))
    functions = None
    if option == "structref":
        dom, rep = proto.as_structrefs(dom, rep)
    elif option == "first-class":
        functions = (proto.pendulum_reset, proto.pendulum_step, proto.tiles_encode)
    weights = agent.arrays_.weights
    args = (dom, rep, functions, steps_per_call, domain.np_random, agent_form(agent), weights,
            agent.rng_, domain.domain_spec.max_episode_steps)

    def call():
        if option == "first-class" and not proto.prototype_loop.signatures:
            # one compilation for any kernels of the signatures (the dispatchers convert)
            kinds = [typeof(a) for a in args]
            kinds[2] = proto.FUNCTIONS
            proto.prototype_loop.compile(tuple(kinds))
            proto.prototype_loop.disable_compile()
        proto.prototype_loop(*args)

    return call, agent


def timed(call):
    wall, cpu = time.perf_counter(), time.process_time()
    call()
    return time.perf_counter() - wall, time.process_time() - cpu


call, _ = runner(1)
wall, cpu = timed(call)
got = {"option": option, "first_call_wall_s": wall, "first_call_cpu_s": cpu}
if steps:
    spent = []
    for _ in range(repeats):
        call, agent = runner(steps)
        spent.append(timed(call)[1])
    got["us_per_step"] = statistics.median(spent) / steps * 1e6
    theta = np.ascontiguousarray(agent.arrays_.weights)
    got["theta"] = hashlib.sha1(theta.tobytes()).hexdigest()[:12]
print(json.dumps(got))
"""


def measure(option: str, steps: int, repeats: int) -> dict:
    """Cold first call in a fresh cache, then warm first call and steps on that cache."""
    here = str(Path(__file__).resolve().parent)
    got: dict = {}
    with tempfile.TemporaryDirectory() as cache:
        for phase, count in (("cold", 0), ("warm", steps)):
            out = subprocess.run(
                [sys.executable, "-c", _CHILD, here, option, str(count), str(repeats)],
                env={**os.environ, "NUMBA_CACHE_DIR": cache},
                check=False,
                capture_output=True,
                text=True,
            )
            if out.returncode:
                raise RuntimeError(f"{option} ({phase}) failed:\n{out.stderr[-3000:]}")
            row = json.loads(out.stdout.strip().splitlines()[-1])
            got.update({f"{phase}_{k}": v for k, v in row.items() if k.startswith("first")})
            got.update({k: v for k, v in row.items() if not k.startswith("first")})
    return got


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=1_000_000)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--options", default=",".join(OPTIONS), help="Comma-separated options.")
    args = parser.parse_args()
    console = Console()
    console.print(f"CPU: {cpu_model()}; load average at start: {os.getloadavg()}")
    table = Table(title=f"Pendulum SARSA + tiles: dispatch options ({args.steps:,} steps)")
    columns = ("cold CPU s", "cold wall s", "warm CPU s", "CPU µs/step", "θ")
    for name in ("option", *columns):
        table.add_column(name, justify="right")
    for option in args.options.split(","):
        got = measure(option, args.steps, args.repeats)
        console.print(f"{option}: {json.dumps(got)}")
        table.add_row(
            option,
            f"{got['cold_first_call_cpu_s']:.1f}",
            f"{got['cold_first_call_wall_s']:.1f}",
            f"{got['warm_first_call_cpu_s']:.2f}",
            f"{got['us_per_step']:.3f}",
            got["theta"],
        )
    console.print(table)
    console.print(f"CPU: {cpu_model()}; load average at end: {os.getloadavg()}")


if __name__ == "__main__":
    main()
