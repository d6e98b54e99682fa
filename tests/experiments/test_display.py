"""The progress display's phases: a line with the phase's time, nothing when quiet."""

import io

from rich.console import Console

from conjure.experiments.display import phase


def test_a_phase_prints_its_text_and_time_when_it_ends():
    out = io.StringIO()
    console = Console(file=out, force_terminal=False, width=100)
    ran = []
    with phase(console, "compiling kernels [first run only]"):
        ran.append(True)
    assert ran == [True]
    line = out.getvalue().strip()
    assert line.startswith("compiling kernels [first run only]: ") and line.endswith(" s")


def test_a_phase_not_kept_leaves_no_line_and_none_shows_nothing():
    out = io.StringIO()
    with phase(Console(file=out, force_terminal=False), "setting up", keep=False):
        pass
    with phase(None, "setting up"):
        pass
    assert out.getvalue().strip() == ""
