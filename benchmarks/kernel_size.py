"""The LLVM IR size of conjure's cached numba kernels: the memory a run pays to load them.

Usage: ``python benchmarks/kernel_size.py [--most N]``

Loading a kernel from numba's disk cache parses the LLVM module it keeps for linking (all the
code it calls), so a kernel's IR size is memory in every process that calls it
(``benchmarks/startup.py`` measures the peak). For each cached compilation under
``src/conjure`` (run the workloads first to fill the cache) this prints the instructions of
that module, its functions and its bitcode bytes, largest first, and for the largest the
biggest functions inside it. Reads numba's cache files (a private format: pickled
``(name, "object", (object code, bitcode))`` as the first entry).
"""

from __future__ import annotations

import argparse
import pickle
from pathlib import Path

import llvmlite.binding as llvm
from rich.console import Console
from rich.table import Table

SOURCE = Path(__file__).resolve().parents[1] / "src" / "conjure"


def functions(bitcode: bytes) -> list[tuple[int, str]]:
    """(instructions, name) of every function the module defines, largest first."""
    module = llvm.parse_bitcode(bitcode)
    sizes = [
        (sum(1 for block in fn.blocks for _ in block.instructions), fn.name)
        for fn in module.functions
        if not fn.is_declaration
    ]
    return sorted(sizes, reverse=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--most", type=int, default=12)
    args = parser.parse_args()
    rows = []
    for path in sorted(SOURCE.rglob("__pycache__/*.nbc")):
        bitcode = pickle.loads(path.read_bytes())[0][2][1]
        sizes = functions(bitcode)
        rows.append((sum(n for n, _ in sizes), len(sizes), len(bitcode), path, sizes))
    rows.sort(key=lambda row: row[0], reverse=True)
    table = Table(title=f"Cached kernels, largest {args.most} of {len(rows)}")
    for name in ("compilation", "instructions", "functions", "bitcode KB"):
        table.add_column(name, justify="left" if name == "compilation" else "right")
    for total, count, size, path, _ in rows[: args.most]:
        name = f"{path.parent.parent.name}/{path.stem}"
        table.add_row(name, f"{total:,}", f"{count}", f"{size / 1e3:,.0f}")
    console = Console()
    console.print(table)
    if rows:
        console.print(f"largest functions of {rows[0][3].stem}:")
        for n, name in rows[0][4][:8]:
            console.print(f"  {n:>6,}  {name[:100]}", highlight=False, soft_wrap=True)


if __name__ == "__main__":
    main()
