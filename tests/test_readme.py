"""The README and the site's pages stay true: set-up commands, links, maps, no dated logs."""

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text()
PAGES = sorted((ROOT / "docs").rglob("*.md"))


def test_readme_opens_with_the_title_then_the_two_setup_commands():
    first_lines = README.splitlines()[:6]
    assert first_lines == [
        "# conjure",
        "",
        "```",
        "python -m pip install -e . && conjure run examples/pendulum.yaml",
        'python -m pip install -e ".[test]" && python -m pytest',
        "```",
    ]


def test_readme_is_at_most_150_lines_and_shows_a_chapter_4_and_a_chapter_5_result():
    assert len(README.splitlines()) <= 150
    assert "<!-- claims:fig_4_" in README and "<!-- claims:fig_5_" in README
    plots = re.findall(r"!\[[^\]]*\]\((docs/reproduction/fig_[45]_[^)]+\.png)\)", README)
    assert {Path(plot).name[:5] for plot in plots} == {"fig_4", "fig_5"}
    assert 'python -m pip install -e ".[docs]" && mkdocs serve' in README


def test_every_relative_link_of_the_readme_exists():
    for target in re.findall(r"\]\(([^)#]+)(?:#[^)]*)?\)", README):
        if not target.startswith("http"):
            assert (ROOT / target).exists(), target


def test_quick_start_runs_and_saves(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    page = (ROOT / "docs" / "getting-started.md").read_text()
    code = re.findall(r"```python\n(.*?)```", page, re.S)[0]
    namespace: dict = {}
    exec(compile(code, "getting-started.md", "exec"), namespace)
    assert namespace["result"].curve["episode_length"].iloc[-1] > 0
    assert (tmp_path / "pendulum-agent" / "agent.json").is_file()


def test_extras_are_installed_from_the_checkout_and_sb3_with_cpu_torch_first():
    pages = {path.name: path.read_text() for path in [ROOT / "README.md", *PAGES]}
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
    about = (ROOT / "docs" / "about.md").read_text()
    source = ROOT / "src" / "conjure"
    table = about[about.index("## What is here") :].split("\n\n")[1]
    rows = {line.split("|")[1].strip().split(" ")[0].strip("`") for line in table.splitlines()}
    folders = {
        path.relative_to(source).as_posix()
        for path in source.rglob("*")
        if path.is_dir() and "__pycache__" not in path.parts
    }
    assert folders - rows == set(), "folders missing from docs/about.md's table"


def test_the_layer_order_is_the_import_linter_contracts():
    import tomllib

    contracts = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["importlinter"]
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


DATED = re.compile(r"\b20\d\d-\d\d-\d\d\b|\b[Ii]ssues? \d+|\bissue-\d+|\d\d:\d\d UTC")


def test_pages_state_what_holds_today_with_dates_and_issues_in_the_changelog_only():
    for path in [ROOT / "README.md", *PAGES]:
        if path.name == "changelog.md":
            continue
        for number, line in enumerate(path.read_text().splitlines(), 1):
            assert not DATED.search(line), f"{path.relative_to(ROOT)}:{number}: {line}"


def test_commands_in_the_docs_need_nothing_outside_the_repository():
    for path in [ROOT / "README.md", *PAGES]:
        text = path.read_text()
        assert "../shared" not in text, path.name
        assert "seeds=[" not in text, f"{path.name}: use --set seeds=START..END"


def test_the_benchmarks_page_shows_each_command_it_ran_and_the_cpu(monkeypatch):
    import importlib.util

    monkeypatch.syspath_prepend(str(ROOT / "benchmarks"))  # as when run as a script
    spec = importlib.util.spec_from_file_location("docs_page", ROOT / "benchmarks" / "docs_page.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    page = (ROOT / "docs" / "benchmarks.md").read_text()
    assert re.search(r"^- CPU: .+, \d+ logical cores$", page, re.M)
    for _, _, arguments in module.COMMANDS:
        assert f"```\npython {' '.join(arguments)}\n```\n\n```text\n" in page
