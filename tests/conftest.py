"""Shared test set-up: the run-loop and sweep fakes (tests/experiments) and `fresh_python`
(tests/) import by bare name."""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent / "experiments"))
sys.path.insert(0, str(Path(__file__).parent))
