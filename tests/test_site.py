"""The documentation site builds with warnings as errors (mkdocs.yml: ``strict: true``).

A broken internal link or anchor, a page missing from the navigation, or a docstring the API
reference cannot render fails the build, and so this test.
"""

import os
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

ROOT = Path(__file__).resolve().parents[1]


def test_the_site_configuration_is_strict_and_checks_links():
    # mkdocs.yml's !!python tags are none; a plain safe load reads it.
    config = yaml.safe_load((ROOT / "mkdocs.yml").read_text())
    assert config["strict"] is True
    assert config["validation"]["links"]["not_found"] == "warn"  # an error under strict
    assert config["validation"]["links"]["anchors"] == "warn"


@pytest.mark.slow
def test_the_site_builds_strictly(tmp_path):
    env = {**os.environ, "NO_MKDOCS_2_WARNING": "1"}
    result = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(tmp_path)],
        cwd=ROOT,
        env=env,
        capture_output=True,
        text=True,
        timeout=600,
        check=False,
    )
    assert result.returncode == 0, result.stderr[-5000:]
    assert (tmp_path / "index.html").is_file()
    assert (tmp_path / "api" / "agents" / "index.html").is_file()
    assert (tmp_path / "reproduction" / "fig_5_5" / "index.html").is_file()
