"""The wheel runs the shipped configs from any folder: `conjure reproduce --list`, a quick
figure and the pendulum example, from a venv that holds the wheel's conjure and sees the
installed dependencies.
"""

import os
import subprocess
import sys
import sysconfig
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.slow
def test_wheel_reproduces_and_runs_examples_from_any_folder(tmp_path):
    wheels = tmp_path / "wheels"
    subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "--no-deps", "-q", "-w", str(wheels), str(ROOT)],
        check=True,
    )
    (wheel,) = wheels.glob("conjure-*.whl")
    work = tmp_path / "elsewhere"
    work.mkdir()
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    venv = tmp_path / "venv"
    subprocess.run(
        [sys.executable, "-m", "venv", "--without-pip", "--system-site-packages", str(venv)],
        check=True,
    )
    python = venv / "bin" / "python"
    site = subprocess.run(
        [python, "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
        check=True, capture_output=True, text=True,
    ).stdout.strip()  # fmt: skip
    subprocess.run(
        [sys.executable, "-m", "pip", "--python", str(python), "install", "--no-deps", "-q",
         str(wheel)],
        check=True, env=env,
    )  # fmt: skip
    # Then the dependencies installed beside this interpreter, after the wheel's conjure (a path
    # line: an editable conjure's own .pth is not read).
    Path(site, "installed_dependencies.pth").write_text(sysconfig.get_paths()["purelib"] + "\n")

    def conjure(*args):
        return subprocess.run(
            [python, "-m", "conjure.cli", *args],
            cwd=work, env=env, capture_output=True, text=True, timeout=600,
        )  # fmt: skip

    where = subprocess.run(
        [python, "-c", "import conjure; print(conjure.__file__)"],
        cwd=work, env=env, check=True, capture_output=True, text=True,
    ).stdout  # fmt: skip
    assert where.startswith(site), where
    listed = conjure("reproduce", "--list")
    assert listed.returncode == 0, listed.stderr
    assert "fig_5_8" in listed.stdout
    figure = conjure(
        "reproduce", "fig_5_8", "--scale", "quick", "--out", "fig", "--max-workers", "1",
        "--set", "budget_steps=1000", "--set", "num_policy_checks=1", "--quiet",
    )  # fmt: skip
    assert figure.returncode == 0, figure.stdout + figure.stderr
    assert (work / "fig" / "comparison.md").is_file()
    pendulum = conjure(
        "run", "examples/pendulum.yaml", "--seeds", "1", "--set", "budget_steps=2000",
        "--max-workers", "1", "--quiet",
    )  # fmt: skip
    assert pendulum.returncode == 0, pendulum.stdout + pendulum.stderr
    assert (work / "results" / "pendulum" / "results.parquet").is_file()
