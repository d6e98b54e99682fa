"""Tests of the shared command-line options."""

from __future__ import annotations

from pathlib import Path

import click
from click.testing import CliRunner

from conjure.experiments.options import max_memory_option, out_dir_option

GiB = 2**30


@click.command()
@out_dir_option("Where the results go.")
def show(out_dir):
    click.echo(repr(out_dir))


def test_out_gives_a_path_or_none_and_its_help():
    runner = CliRunner()
    assert runner.invoke(show, ["--out", "a/b"]).output.strip() == repr(Path("a/b"))
    assert runner.invoke(show, []).output.strip() == "None"
    assert "Where the results go." in runner.invoke(show, ["--help"]).output


def test_the_command_line_option_gives_bytes_or_a_usage_error():
    @click.command()
    @max_memory_option
    def show(max_memory):
        click.echo(repr(max_memory))

    assert CliRunner().invoke(show, ["--max-memory", "4GiB"]).output.strip() == str(4 * GiB)
    assert CliRunner().invoke(show, []).output.strip() == "None"
    bad = CliRunner().invoke(show, ["--max-memory", "lots"])
    assert bad.exit_code == 2 and "'--max-memory'" in bad.output and "'lots'" in bad.output
