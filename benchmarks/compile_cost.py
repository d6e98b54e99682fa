"""What a cold compile costs and what it saves: the numbers behind the compile rule.

Usage: ``python benchmarks/compile_cost.py [--seconds S] [--python-only] [--only NAME]``

For each workload of the shipped examples (the UAV 7-2 methods of ``examples/uav_icca.yaml``:
SARSA, CSARSA (Algorithm 24) and AM-iCCA (Algorithm 26); SARSA on the pendulum of
``examples/pendulum.yaml``; iCCA on GridWorld-1 of ``examples/gridworld_icca.yaml``), in a
fresh process with an empty numba cache (``NUMBA_CACHE_DIR`` a new temporary folder):

- ``python first s``: the Python `Stepper`'s first ``advance(1)`` (its components' own numba
  kernels compile then, on the Python path too), then ``python steps/s`` over about
  ``--seconds`` after as long again untimed (some kernels are first called later);
- ``cold compile s``: then the compiled stepper's first ``advance(1)`` on a fresh agent (the
  loop's compile, as a first ``conjure run`` on a machine pays it), then ``compiled steps/s``;
- ``break-even steps``: the steps after which the compile has paid for itself,
  compile / (1/python - 1/compiled) (`conjure.experiments.loop.compile_pays`).

Each workload runs in its own process, one after another; the machine may be shared, so the
load average is printed beside the CPU model.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import tempfile
from pathlib import Path

from rich.console import Console
from rich.table import Table

sys.path.insert(0, str(Path(__file__).resolve().parent))

from call_cost import cpu_model

#: (name, shipped example, agent label).
WORKLOADS = (
    ("UAV 7-2 CSARSA", "uav_icca.yaml", "csarsa"),
    ("UAV 7-2 AM-iCCA", "uav_icca.yaml", "am_icca"),
    ("UAV 7-2 SARSA", "uav_icca.yaml", "sarsa"),
    ("Pendulum SARSA tiles", "pendulum.yaml", None),
    ("GridWorld-1 iCCA", "gridworld_icca.yaml", "icca"),
)

_CHILD = """
import json, sys, time
from conjure.compiled import compile_seconds, for_combination
from conjure.experiments import registry
from conjure.experiments.config import load_config, resolve_run
from conjure.experiments.loop import Stepper

path, label, seconds, python_only = sys.argv[1], sys.argv[2], float(sys.argv[3]), sys.argv[4]
experiment = load_config(path)
label = label if label != "-" else next(iter(experiment.agents))
spec = resolve_run(experiment, label, 0)


def pair(seed):
    domain = registry.build("domain", spec["domain"])
    agent = registry.build("agent", spec["agent"]).setup(domain.domain_spec, seed)
    return domain, agent


def timed(stepper, steps):
    started = time.perf_counter()
    stepper.advance(steps)
    return time.perf_counter() - started


def rate(stepper):
    # steps/s over about `seconds`, after as long again untimed (kernels first called late)
    for _ in range(2):
        steps, spent, chunk = 0, 0.0, 100
        while spent < seconds:
            spent += timed(stepper, chunk)
            steps += chunk
            chunk = min(chunk * 2, 20000)
    return steps / spent


python = Stepper(*pair(2), seed=2)
got = {"label": label, "python_first_call_s": timed(python, 1), "python_steps_per_s": rate(python)}
if python_only == "no":
    compiled = for_combination(*pair(1), seed=1)
    got["cold_compile_s"] = timed(compiled, 1)
    got["compiled_steps_per_s"] = rate(compiled)
print(json.dumps(got))
"""


def measure(config: str, label: str | None, seconds: float, python_only: bool) -> dict:
    """One workload in a fresh process with an empty numba cache."""
    examples = Path(__file__).resolve().parents[1] / "examples"
    with tempfile.TemporaryDirectory() as cache:
        out = subprocess.run(
            [
                sys.executable,
                "-c",
                _CHILD,
                str(examples / config),
                label or "-",
                str(seconds),
                "yes" if python_only else "no",
            ],
            env={**os.environ, "NUMBA_CACHE_DIR": cache},
            check=True,
            capture_output=True,
            text=True,
        )
    return json.loads(out.stdout.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=3.0)
    parser.add_argument(
        "--python-only", action="store_true", help="Measure the Python path only (no compile)."
    )
    parser.add_argument("--only", default="", help="Only workloads whose name contains this.")
    args = parser.parse_args()
    console = Console()
    console.print(f"CPU: {cpu_model()}; load average at start: {os.getloadavg()}")
    table = Table(title="Cold compile vs steps saved (empty numba cache per workload)")
    columns = ("python first s", "python steps/s", "cold compile s", "compiled steps/s")
    for name in ("workload", *columns, "break-even"):
        table.add_column(name, justify="right")
    for name, config, label in (w for w in WORKLOADS if args.only in w[0]):
        got = measure(config, label, args.seconds, args.python_only)
        python, compiled = got["python_steps_per_s"], got.get("compiled_steps_per_s", math.inf)
        saved = 1 / python - 1 / compiled
        cold = got.get("cold_compile_s", math.nan)
        even = f"{cold / saved:,.0f}" if saved > 0 and not math.isnan(cold) else "-"
        table.add_row(
            name,
            f"{got['python_first_call_s']:.1f}",
            f"{python:,.0f}",
            f"{cold:.1f}",
            f"{compiled:,.0f}",
            even,
        )
        console.print(f"{name}: {json.dumps(got)}")
    console.print(table)
    console.print(f"CPU: {cpu_model()}; load average at end: {os.getloadavg()}")


if __name__ == "__main__":
    main()
