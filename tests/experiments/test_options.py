"""Tests of the shared command-line options."""

from __future__ import annotations

from pathlib import Path

import click
from click.testing import CliRunner

from conjure.experiments.options import out_dir_option


@click.command()
@out_dir_option("Where the results go.")
def show(out_dir):
    click.echo(repr(out_dir))


def test_out_gives_a_path_or_none_and_its_help():
    runner = CliRunner()
    assert runner.invoke(show, ["--out", "a/b"]).output.strip() == repr(Path("a/b"))
    assert runner.invoke(show, []).output.strip() == "None"
    assert "Where the results go." in runner.invoke(show, ["--help"]).output
