"""Start-up time and peak memory: ``conjure --help``, ``import conjure`` and one iFDD+ run.

Usage: ``python benchmarks/startup.py [--repeats R] [--skip-run] [--config PATH --agent LABEL
--seed N]``

Each measurement runs in a fresh interpreter (``subprocess``), reporting the median wall
seconds and CPU seconds (user + system: less sensitive to other processes on the machine) of
``repeats`` runs and the peak resident memory (``ru_maxrss`` of that child alone, from
``os.wait4``):

- ``conjure --help`` (``python -m conjure.cli --help``; target under 0.5 s);
- ``import conjure`` (which must load no pandas, matplotlib or scipy.stats);
- numba alone, importing it and compiling one trivial function: the floor under any run that
  calls a compiled kernel (LLVM's own memory);
- one BlocksWorld run of the ``ifdd_plus`` agent of ``examples/blocksworld.yaml`` (seed 100,
  its 100,000 steps and policy checks; target at most RLPy's peak, about 175 MiB) as a
  ``conjure run`` worker does it: the config is resolved here and the child runs
  `conjure.experiments.run.run_task` on the resolved run (workers never parse configs).
  Run it once before measuring so numba's on-disk cache is warm (a compiling run peaks
  higher); with a warm cache the run takes the compiled path. ``--config``/``--agent``/
  ``--seed`` measure another run instead (a sweep config runs at its base settings: its
  ``grid`` and ``selection`` are dropped), e.g. a chapter-5 workload of
  ``examples/reproduction/``.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

from rich.console import Console
from rich.table import Table

ROOT = Path(__file__).resolve().parents[1]

ONE_RUN = (
    "import json, sys\n"
    "from conjure.experiments.run import run_task\n"
    "assert run_task(json.loads(sys.argv[1]))['error'] is None\n"
)

#: Prints the resolved run as JSON (in its own interpreter: a child's peak RSS counts the
#: parent's at fork, so this process imports nothing of conjure). argv: config, agent, seed.
RESOLVE = (
    "import json, sys\n"
    "from pathlib import Path\n"
    "from conjure.experiments.config import load_yaml, parse_config, resolve_run\n"
    "path, agent, seed = sys.argv[1], sys.argv[2], int(sys.argv[3])\n"
    "data = load_yaml(Path(path).read_text(), source=path)\n"
    "data.pop('grid', None)\n"
    "data.pop('selection', None)\n"
    "print(json.dumps(resolve_run(parse_config(data, source=path), agent, seed)))\n"
)

RUN = "one run"
COMMANDS = {
    "conjure --help": [sys.executable, "-m", "conjure.cli", "--help"],
    "import conjure": [sys.executable, "-c", "import conjure"],
    "numba alone: import, compile one x + 1": [
        sys.executable,
        "-c",
        "import numba\nassert numba.njit(lambda x: x + 1)(1) == 2",
    ],
    RUN: [sys.executable, "-c", ONE_RUN],
}


ENV = {**os.environ, "PYTHONPATH": str(ROOT / "src")}


def resolved_run(config: str, agent: str, seed: int) -> str:
    """The resolved run of ``agent`` in ``config`` at ``seed`` as JSON."""
    command = [sys.executable, "-c", RESOLVE, config, agent, str(seed)]
    return subprocess.run(command, cwd=ROOT, env=ENV, check=True, capture_output=True).stdout


def measure(command: list[str]) -> tuple[float, float, float]:
    """Run ``command`` once; return (wall seconds, CPU seconds, peak RSS in MiB) of the child."""
    started = time.perf_counter()
    child = subprocess.Popen(command, cwd=ROOT, env=ENV, stdout=subprocess.DEVNULL)
    _, status, usage = os.wait4(child.pid, 0)  # this child's own usage, not all children's
    wall = time.perf_counter() - started
    child.returncode = os.waitstatus_to_exitcode(status)
    if child.returncode != 0:
        raise subprocess.CalledProcessError(child.returncode, command)
    return wall, usage.ru_utime + usage.ru_stime, usage.ru_maxrss / 1024  # KiB -> MiB


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--skip-run", action="store_true", help="Skip the run.")
    parser.add_argument("--config", default="examples/blocksworld.yaml", help="The run's config.")
    parser.add_argument("--agent", default="ifdd_plus", help="The run's agent label.")
    parser.add_argument("--seed", type=int, default=100, help="The run's seed.")
    args = parser.parse_args()
    COMMANDS[f"{args.config}, {args.agent}, seed {args.seed}"] = COMMANDS.pop(RUN)
    table = Table(title="conjure start-up and memory (fresh interpreter each time)")
    for name in ("command", "wall s (median)", "CPU s (median)", "peak RSS MiB"):
        table.add_column(name, justify="left" if name == "command" else "right")
    for name, command in COMMANDS.items():
        is_run = command[-1] == ONE_RUN
        if args.skip_run and is_run:
            continue
        repeats = 1 if is_run else args.repeats
        if is_run:
            command = [*command, resolved_run(args.config, args.agent, args.seed)]
        samples = [measure(command) for _ in range(repeats)]
        wall = statistics.median(s[0] for s in samples)
        cpu = statistics.median(s[1] for s in samples)
        table.add_row(name, f"{wall:.2f}", f"{cpu:.2f}", f"{max(s[2] for s in samples):.0f}")
    Console().print(table)


if __name__ == "__main__":
    main()
