"""Private (unshared) memory of each worker process during a 2-worker reproduction.

Usage: ``python benchmarks/worker_memory.py [--figure fig_5_5] [--workers 2] [--interval 0.2]``

Runs ``conjure reproduce FIGURE --scale quick --max-workers N`` into a temporary folder and
samples, every ``--interval`` seconds while it runs, ``Private_Clean + Private_Dirty`` of
``/proc/PID/smaps_rollup`` for every process forked from the local pools' forkserver, in the
order they started: for ``conjure reproduce``, the preflight checker
(`conjure.experiments.preflight`, which sets up every (domain, agent) pair), the warm-up's
worker (`conjure.experiments.parallel.warm_up`), then the pool's workers, which run the runs
(issue 33's target: at most 60 MiB each). Pages a process shares with the forkserver it forked
from (the modules and kernels the server loaded before forking) are not private. Prints each
process's peak private memory and peak RSS, the forkserver's, and the CPU model and load
average beside them (the machine may be shared). Linux only.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from rich.console import Console
from rich.table import Table

sys.path.insert(0, str(Path(__file__).resolve().parent))

from call_cost import cpu_model

MIB = 1024 * 1024


def _children(pid: int) -> list[int]:
    """The child processes of ``pid`` (from /proc/PID/task/*/children)."""
    found = []
    for task in Path(f"/proc/{pid}/task").glob("*"):
        try:
            found += [int(c) for c in (task / "children").read_text().split()]
        except OSError:
            pass
    return found


def _descendants(pid: int) -> list[int]:
    out, todo = [], [pid]
    while todo:
        for child in _children(todo.pop()):
            out.append(child)
            todo.append(child)
    return out


def _memory(pid: int) -> tuple[int, int] | None:
    """(private bytes, RSS bytes) of ``pid`` from smaps_rollup, or None once it is gone."""
    try:
        text = Path(f"/proc/{pid}/smaps_rollup").read_text()
    except OSError:
        return None
    fields = {}
    for line in text.splitlines()[1:]:
        name, _, rest = line.partition(":")
        parts = rest.split()
        if parts and parts[0].isdigit():
            fields[name] = int(parts[0]) * 1024
    return fields.get("Private_Clean", 0) + fields.get("Private_Dirty", 0), fields.get("Rss", 0)


def _is_forkserver(pid: int) -> bool:
    try:
        return b"multiprocessing.forkserver" in Path(f"/proc/{pid}/cmdline").read_bytes()
    except OSError:
        return False


def sample(command: list[str], interval: float) -> tuple[dict, dict, float]:
    """Run ``command``; peak (private, RSS) per worker pid and of the forkserver; seconds."""
    started = time.perf_counter()
    process = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    workers: dict[int, tuple[int, int]] = {}
    servers: dict[int, tuple[int, int]] = {}
    while process.poll() is None:
        for pid in _descendants(process.pid):
            if not _is_forkserver(pid):
                continue
            parent_is_server = any(pid in _children(s) for s in servers)
            found = _memory(pid)
            if found is None:
                continue
            table = workers if parent_is_server else servers
            before = table.get(pid, (0, 0))
            table[pid] = (max(before[0], found[0]), max(before[1], found[1]))
        time.sleep(interval)
    if process.returncode != 0:
        raise SystemExit(f"{' '.join(command)} failed:\n{process.stderr.read().decode()}")
    return workers, servers, time.perf_counter() - started


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--figure", default="fig_5_5")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--interval", type=float, default=0.2)
    args = parser.parse_args()
    console = Console(width=120)
    console.print(f"CPU: {cpu_model()}; load average at start: {os.getloadavg()}")
    with tempfile.TemporaryDirectory() as out:
        command = [
            sys.executable, "-m", "conjure.cli", "reproduce", args.figure, "--scale", "quick",
            "--max-workers", str(args.workers), "--out", out, "--quiet",
        ]  # fmt: skip
        workers, servers, seconds = sample(command, args.interval)
    table = Table(title=f"conjure reproduce {args.figure} --scale quick, {args.workers} workers")
    for column in ("process", "pid", "peak private MiB", "peak RSS MiB"):
        table.add_column(column, justify="right")
    for label, found in (("forkserver", servers), ("forked", workers)):
        for k, (pid, (private, rss)) in enumerate(sorted(found.items()), start=1):
            name = label if label == "forkserver" else f"{label} #{k}"
            table.add_row(name, str(pid), f"{private / MIB:.0f}", f"{rss / MIB:.0f}")
    console.print(table)
    peak = max((private for private, _ in workers.values()), default=0)
    console.print(f"largest private memory forked: {peak / MIB:.0f} MiB; run took {seconds:.0f} s")
    console.print(f"CPU: {cpu_model()}; load average at end: {os.getloadavg()}")


if __name__ == "__main__":
    main()
