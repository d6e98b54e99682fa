"""Every script under docs/ runs: each in its short mode, as a subprocess from the repository root.

The scripts regenerate the numbers the docs quote; a script that no longer runs (an API it
calls changed) leaves a number nobody can regenerate. Each script's short mode (``--quick``,
or arguments that make it small) is listed in `SHORT_RUNS`, and a new script must add its own.
"""

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"

#: Each script's arguments for a short run: ``{tmp}`` is a fresh directory, ``{results}`` a
#: tiny finished sweep (`tiny_results`). `figures.py store` writes into docs/, so only its
#: `render --check` runs here (the stored tables equal what the stored results give).
SHORT_RUNS = {
    "reproduction/am_icca_switch.py": [
        *("trace", "--steps", "200", "--chunk", "100"),
        "--csv",
        "{tmp}/t.csv",
    ],
    "reproduction/am_icca_vetoes.py": ["--quick"],
    "reproduction/blocksworld_states.py": ["--quick"],
    "reproduction/fig_3_15.py": ["--quick", "--out", "{tmp}"],
    "reproduction/fig_4_11_plot.py": ["docs/reproduction/fig_4_11.csv", "{tmp}/fig_4_11.png"],
    "reproduction/fig_5_8_pit_entries.py": ["--quick"],
    "reproduction/fig_5_14_thresholds.py": [
        *("--thresholds", "0.5", "--seeds", "10005"),
        "--budget",
        "300",
    ],
    "reproduction/figures.py": ["render", "--check"],
    "reproduction/generated_missions.py": [
        *("--missions", "1", "--seeds", "1", "--budget", "300", "--eval-episodes", "5"),
        *("--workers", "1", "--csv", "{tmp}/gain.csv", "--plot", "{tmp}/gain.png"),
    ],
    "reproduction/make_configs.py": ["--out", "{tmp}"],
    "reproduction/rescue_optimum.py": ["--quick"],
    "reproduction/safe_rl.py": ["render", "--check"],
    "reproduction/tables.py": ["{results}", "--steps", "200"],
    "reproduction/uav_calibration.py": ["--quick"],
}


def test_every_script_under_docs_has_a_short_run():
    scripts = {path.relative_to(DOCS).as_posix() for path in DOCS.rglob("*.py")}
    assert scripts == set(SHORT_RUNS), "add the new script's short run to SHORT_RUNS"


@pytest.fixture(scope="module")
def tiny_results(tmp_path_factory) -> Path:
    """A finished sweep of examples/sweep_chain.yaml cut to 200 steps, with its report."""
    out = tmp_path_factory.mktemp("sweep_chain")
    conjure = [sys.executable, "-m", "conjure.cli"]
    sweep = ["sweep", "examples/sweep_chain.yaml", "--out", str(out), "--max-workers", "1"]
    cut = ["--quiet", "--set", "budget_steps=200", "--set", "grid={}"]
    for command in (sweep + cut, ["report", str(out)]):
        subprocess.run(conjure + command, cwd=ROOT, check=True, capture_output=True, timeout=300)
    return out


@pytest.mark.slow
@pytest.mark.parametrize("script", sorted(SHORT_RUNS))
def test_a_doc_script_runs_in_its_short_mode(script, tmp_path, request):
    values = {"tmp": str(tmp_path)}
    if any("{results}" in arg for arg in SHORT_RUNS[script]):
        values["results"] = str(request.getfixturevalue("tiny_results"))
    args = [arg.format(**values) for arg in SHORT_RUNS[script]]
    done = subprocess.run(
        [sys.executable, str(DOCS / script), *args],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert done.returncode == 0, done.stderr[-3000:]
    assert done.stdout.strip() or any(tmp_path.iterdir())  # it printed or wrote something
