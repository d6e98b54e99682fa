"""Shared test set-up: the run-loop and sweep fakes (tests/experiments) and `fresh_python`
(tests/) import by bare name; the compiled loop warmed before the test processes start."""

import os
import subprocess
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent / "experiments"))
sys.path.insert(0, str(Path(__file__).parent))


#: One learning-loop compilation per φ kind (`conjure.compiled.stepper.warm_up`'s two).
_WARM_ONE = """
from conjure.agents.sarsa import SARSA
from conjure.compiled import for_combination
from conjure.domains.chain import ChainMDP
from conjure.representations import {kind}
domain = ChainMDP()
agent = SARSA(representation={kind}()).setup(domain.domain_spec, 0)
for_combination(domain, agent, seed=0).advance(1)
"""


def pytest_configure(config):
    """Compile the loop's two forms into numba's disk cache at once, in two processes.

    On a cold cache (a fresh clone, as in CI) each xdist worker would otherwise compile both
    forms itself, one after the other, the first time a test needs them: four compilations of
    minutes each where two, side by side, serve every worker. A warm cache loads in seconds.
    """
    if hasattr(config, "workerinput") or not config.getoption("numprocesses", None):
        return  # an xdist worker (the controller warmed it), or no workers (`-n 0`)
    source = str(Path(__file__).resolve().parents[1] / "src")
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([source, os.environ.get("PYTHONPATH", "")])}
    warming = [
        subprocess.Popen([sys.executable, "-c", _WARM_ONE.format(kind=kind)], env=env)
        for kind in ("Tabular", "RBF")
    ]
    for process in warming:
        process.wait()


def pytest_addoption(parser):
    """``--fuzz N``: the long fuzzing mode of tests/test_fuzz.py (N cases per property)."""
    parser.addoption(
        "--fuzz",
        type=int,
        default=int(os.environ.get("CONJURE_FUZZ", "0")),
        help="Fuzz cases per property of tests/test_fuzz.py (default: the CI size; also "
        "CONJURE_FUZZ=N).",
    )
