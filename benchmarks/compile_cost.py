"""What a cold compile costs and what it saves: the numbers behind the compile rule.

Usage: ``python benchmarks/compile_cost.py [--seconds S]``

For each workload of the shipped examples (the UAV 7-2 methods of ``examples/uav_icca.yaml``:
SARSA, CSARSA (Algorithm 24) and AM-iCCA (Algorithm 26); SARSA on the pendulum of
``examples/pendulum.yaml``; iCCA on GridWorld-1 of ``examples/gridworld_icca.yaml``), in a
fresh process with an empty numba cache (``NUMBA_CACHE_DIR`` a new temporary folder):

- ``python first s``: the Python `Stepper`'s first ``advance(1)`` (its components' own numba
  kernels compile then, on the Python path too), then ``python steps/s`` over about
  ``--seconds``;
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

path, label, seconds = sys.argv[1], sys.argv[2], float(sys.argv[3])
experiment = load_config(path)
label = label if label != "-" else next(iter(experiment.agents))
spec = resolve_run(experiment, label, 0)

def pair(seed):
    domain = registry.build("domain", spec["domain"])
    agent = registry.build("agent", spec["agent"]).setup(domain.domain_spec, seed)
    return domain, agent

def rate(stepper):
    steps, started = 0, time.perf_counter()
    chunk = 100
    while time.perf_counter() - started < seconds:
        stepper.advance(chunk)
        steps += chunk
        chunk = min(chunk * 2, 20000)
    return steps / (time.perf_counter() - started)

python = Stepper(*pair(2), seed=2)
started = time.perf_counter()
python.advance(1)
python_first = time.perf_counter() - started
python_rate = rate(python)
domain, agent = pair(1)
compiled = for_combination(domain, agent, seed=1)
started = time.perf_counter()
compiled.advance(1)
cold = time.perf_counter() - started
print(json.dumps({
    "label": label,
    "python_first_call_s": python_first,
    "python_steps_per_s": python_rate,
    "cold_compile_s": cold,
    "compiled_steps_per_s": rate(compiled),
}))
"""


def measure(config: str, label: str | None, seconds: float) -> dict:
    """One workload in a fresh process with an empty numba cache."""
    examples = Path(__file__).resolve().parents[1] / "examples"
    with tempfile.TemporaryDirectory() as cache:
        out = subprocess.run(
            [sys.executable, "-c", _CHILD, str(examples / config), label or "-", str(seconds)],
            env={**os.environ, "NUMBA_CACHE_DIR": cache},
            check=True,
            capture_output=True,
            text=True,
        )
    return json.loads(out.stdout.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=3.0)
    args = parser.parse_args()
    console = Console()
    console.print(f"CPU: {cpu_model()}; load average at start: {os.getloadavg()}")
    table = Table(title="Cold compile vs steps saved (empty numba cache per workload)")
    columns = ("python first s", "python steps/s", "cold compile s", "compiled steps/s")
    for name in ("workload", *columns, "break-even"):
        table.add_column(name, justify="right")
    for name, config, label in WORKLOADS:
        got = measure(config, label, args.seconds)
        python, compiled = got["python_steps_per_s"], got["compiled_steps_per_s"]
        saved = 1 / python - 1 / compiled
        even = f"{got['cold_compile_s'] / saved:,.0f}" if saved > 0 else "never"
        table.add_row(
            name,
            f"{got['python_first_call_s']:.1f}",
            f"{python:,.0f}",
            f"{got['cold_compile_s']:.1f}",
            f"{compiled:,.0f}",
            even,
        )
        console.print(f"{name}: {json.dumps(got)}")
    console.print(table)
    console.print(f"CPU: {cpu_model()}; load average at end: {os.getloadavg()}")


if __name__ == "__main__":
    main()
