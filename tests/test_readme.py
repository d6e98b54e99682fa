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


def test_extras_are_installed_from_the_checkout_and_sb3_with_cpu_torch_first():
    root = Path(__file__).resolve().parents[1]
    pages = {path.name: path.read_text() for path in [root / "README.md", *root.glob("docs/*.md")]}
    for name, text in pages.items():  # conjure is not on a registry: "conjure[sb3]" fails
        assert not re.search(r"pip install ['\"]?conjure\[", text), name
    install = re.search(
        r"```\n(python -m pip install torch .*?)```", pages["other-libraries.md"], re.S
    )
    assert install is not None
    assert install.group(1).splitlines() == [
        "python -m pip install torch --index-url https://download.pytorch.org/whl/cpu",
        'python -m pip install -e ".[sb3]"',
    ]


def test_every_package_folder_is_in_the_architecture_map():
    root = Path(__file__).resolve().parents[1] / "src" / "conjure"
    table = README[README.index("## What is here") :].split("\n\n")[1]
    rows = {line.split("|")[1].strip().split(" ")[0].strip("`") for line in table.splitlines()}
    folders = {
        path.relative_to(root).as_posix()
        for path in root.rglob("*")
        if path.is_dir() and "__pycache__" not in path.parts
    }
    assert folders - rows == set(), "folders missing from the README's table"


def test_the_layer_order_is_the_import_linter_contracts():
    import tomllib

    root = Path(__file__).resolve().parents[1]
    contracts = tomllib.loads((root / "pyproject.toml").read_text())["tool"]["importlinter"]
    layers = next(c["layers"] for c in contracts["contracts"] if c["type"] == "layers")
    bullet = re.search(r"Layers import only the layers below them \((.*?)\)", README, re.S)
    order = [
        {name.strip().strip("`") for name in step.split("|")}
        for step in " ".join(bullet.group(1).split()).split(",")[0].split("→")
    ]
    expected = [
        {name.strip().removeprefix("conjure.") for name in layer.split("|")}
        for layer in reversed(layers)
    ]
    assert order == expected


def test_the_mountain_car_speed_rows_are_dated_and_the_prose_quotes_their_reference():
    # Issue 21: the MountainCar row had no date, and the sentence under the table quoted
    # `env.step` at 63,000-73,000 steps/s where the reference row said 105,802.
    rows = [line.split(" | ") for line in README.splitlines() if line.startswith("|")]
    car = [row for row in rows if "MountainCar-v0 via `from_gymnasium`" in row[0]]
    reference = [row for row in rows if row[0].startswith("| reference: MountainCar-v0")]
    assert len(car) == 1 and len(reference) == 1
    assert re.search(r"\d{4}-\d\d-\d\d, \d\d:\d\d UTC", car[0][0])
    assert car[0][1] == "`python benchmarks/learning_speed.py --steps 100000 --repeats 5`"
    prose = README.split(reference[0][0], 1)[1].split("## Development", 1)[0]
    assert f"`env.step` alone ran {reference[0][2]} steps/s" in prose
