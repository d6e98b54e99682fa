"""Printed outputs in the README and the site's pages are what their commands print today.

A doc shows a command's output as ``<!-- output: COMMAND -->`` followed by a fenced block.
This test runs COMMAND (``conjure`` as ``python -m conjure.cli``) and checks that every line
of the block appears in what it prints, spaces and table rules aside. Lines that measure time
(wall time, steps/s, µs) vary between machines and are not compared, nor is a table row's
``steps/s`` cell; neither are the lines that say which path a method learned on (compiled or
Python: that depends on numba's disk cache). In a line "…" stands for any text; a doc may
leave lines out. The command runs in a fresh folder (its arguments that name a file of the
repository, such as ``examples/uav_icca.yaml``, made absolute), and its ``--out DIR`` is
replaced by a fresh folder, so that finished runs of an older version are never reused: a
run's default ``results/NAME`` is then written there too.
"""

from __future__ import annotations

import functools
import os
import re
import shlex
import subprocess
import sys
import tempfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]
MARKER = re.compile(r"<!-- output: (?P<command>.+?) -->\n```[a-z]*\n(?P<block>.*?)\n```", re.S)
TIMING = re.compile(r"wall time|steps/s|µs|seconds|\bETA\b|\d s\b|: learned on the ")


def shown_outputs() -> list:
    found = []
    for doc in DOCS:
        for match in MARKER.finditer(doc.read_text()):
            command = match["command"]
            learns = command.startswith(("conjure run", "conjure sweep"))  # a minute or so
            marks = [pytest.mark.slow] if learns else []
            param = pytest.param(
                command, match["block"], id=f"{doc.relative_to(ROOT)}: {command}", marks=marks
            )
            found.append(param)
    return found


def normalized(line: str) -> str:
    return " ".join(re.sub(r"[│┃┏┓┗┛┡┩━─┳┻╇╈┼┬┴┌┐└┘├┤]", " ", line).split())


def without_speeds(block: str) -> list[str]:
    """The block's lines, a table's ``steps/s`` cells (the speed of this machine) as "…"."""
    lines = block.splitlines()
    heading = next((line for line in lines if line.startswith("┃") and "steps/s" in line), None)
    if heading is None:
        return lines
    column = [cell.strip() for cell in heading.split("┃")].index("steps/s")
    rows = []
    for line in lines:
        cells = line.split("│")
        if line.startswith("│") and len(cells) > column:
            cells[column] = " … "
        rows.append("│".join(cells))
    return rows


def test_the_docs_show_outputs_to_check():
    assert len(shown_outputs()) >= 2


@functools.cache
def printed_by(command: str) -> list[str]:
    """What ``command`` prints, normalized; run once per command (two docs may show one)."""
    words = shlex.split(command)
    assert words[0] == "conjure", f"only conjure commands are checked; got {command!r}"
    words = [str(ROOT / w) if (ROOT / w).is_file() else w for w in words]
    with tempfile.TemporaryDirectory(prefix="doc-output-") as folder:
        if "--out" in words:
            words[words.index("--out") + 1] = str(Path(folder) / "out")
        env = {**os.environ, "PYTHONPATH": str(ROOT / "src"), "COLUMNS": "100"}
        result = subprocess.run(
            [sys.executable, "-m", "conjure.cli", *words[1:]],
            cwd=folder,
            env=env,
            capture_output=True,
            text=True,
            timeout=300,
            check=False,
        )
    assert result.returncode == 0, result.stderr
    return [normalized(line) for line in result.stdout.splitlines()]


@pytest.mark.parametrize(("command", "block"), shown_outputs())
def test_a_shown_output_is_what_its_command_prints(command, block):
    printed = printed_by(command)
    for line in without_speeds(block):
        if line.strip() and not TIMING.search(line) and normalized(line):
            pattern = re.compile(".*".join(map(re.escape, normalized(line).split("…"))))
            assert any(pattern.fullmatch(p) for p in printed), (
                f"{command!r} no longer prints {line!r}"
            )
