"""The README stays true: its set-up commands open it and its quick start runs."""

import re
from pathlib import Path

README = (Path(__file__).resolve().parents[1] / "README.md").read_text()


def test_readme_opens_with_the_two_setup_commands():
    first_lines = README.splitlines()[:3]
    assert first_lines == [
        "```",
        "python -m pip install -e . && conjure run examples/pendulum.yaml",
        'python -m pip install -e ".[test]" && python -m pytest',
    ]


def test_quick_start_runs_and_saves(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    code = re.findall(r"```python\n(.*?)```", README, re.S)[0]
    namespace: dict = {}
    exec(compile(code, "README.md", "exec"), namespace)
    assert namespace["result"].curve["episode_length"].iloc[-1] > 0
    assert (tmp_path / "pendulum-agent" / "agent.json").is_file()
