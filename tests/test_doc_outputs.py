"""Printed outputs in the docs are what their commands print today (issue 21).

A doc shows a command's output as ``<!-- output: COMMAND -->`` followed by a fenced block.
This test runs COMMAND (``conjure`` as ``python -m conjure.cli``, from the repository root)
and checks that every line of the block appears in what it prints, spaces and table rules aside.
Lines that measure time (wall time, steps/s, µs) vary between machines and are not compared,
and in a line "…" stands for any text (a timing column in a table row); a doc may leave lines
out. A command's ``--out DIR`` is replaced by a fresh folder, so that finished
runs of an older version are never reused.
"""

from __future__ import annotations

import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
MARKER = re.compile(r"<!-- output: (?P<command>.+?) -->\n```[a-z]*\n(?P<block>.*?)\n```", re.S)
TIMING = re.compile(r"wall time|steps/s|µs|seconds|\bETA\b|\d s\b")


def shown_outputs() -> list:
    found = []
    for doc in DOCS:
        for match in MARKER.finditer(doc.read_text()):
            command = match["command"]
            found.append(pytest.param(command, match["block"], id=f"{doc.name}: {command}"))
    return found


def normalized(line: str) -> str:
    return " ".join(re.sub(r"[│┃┏┓┗┛┡┩━─┳┻╇╈┼┬┴┌┐└┘├┤]", " ", line).split())


def test_the_docs_show_outputs_to_check():
    assert len(shown_outputs()) >= 2


@pytest.mark.parametrize(("command", "block"), shown_outputs())
def test_a_shown_output_is_what_its_command_prints(command, block, tmp_path):
    words = shlex.split(command)
    assert words[0] == "conjure", f"only conjure commands are checked; got {command!r}"
    if "--out" in words:
        words[words.index("--out") + 1] = str(tmp_path / "out")
    env = {**os.environ, "PYTHONPATH": str(ROOT / "src"), "COLUMNS": "100"}
    result = subprocess.run(
        [sys.executable, "-m", "conjure.cli", *words[1:]],
        cwd=ROOT,
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
        check=False,
    )
    assert result.returncode == 0, result.stderr
    printed = [normalized(line) for line in result.stdout.splitlines()]
    for line in block.splitlines():
        if line.strip() and not TIMING.search(line) and normalized(line):
            pattern = re.compile(".*".join(map(re.escape, normalized(line).split("…"))))
            assert any(pattern.fullmatch(p) for p in printed), (
                f"{command!r} no longer prints {line!r}"
            )
