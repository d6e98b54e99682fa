"""Shared test set-up: the run-loop and sweep fakes (tests/experiments) and `fresh_python`
(tests/) import by bare name."""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent / "experiments"))
sys.path.insert(0, str(Path(__file__).parent))


def pytest_addoption(parser):
    """``--fuzz N``: the long fuzzing mode of tests/test_fuzz.py (N cases per property)."""
    import os

    parser.addoption(
        "--fuzz",
        type=int,
        default=int(os.environ.get("CONJURE_FUZZ", "0")),
        help="Fuzz cases per property of tests/test_fuzz.py (default: the CI size; also "
        "CONJURE_FUZZ=N).",
    )
