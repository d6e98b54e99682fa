"""The examples run: the Python API (YAML config to a result), own representation, UAV iCCA."""

import importlib.util
from pathlib import Path

import pytest

from conjure.core.errors import InvalidParameterError
from conjure.representations import TileCoding

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "python_api.py"


def load_example():
    spec = importlib.util.spec_from_file_location("python_api_example", EXAMPLE)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_python_api_example_runs_the_yaml_config_to_a_result():
    example = load_example()
    overrides = ["budget_steps=300", "num_policy_checks=2", "eval_episodes=1"]
    result = example.run_from_config(seed=3, overrides=overrides)
    curve = result.curve
    # Policy checks at steps 0, 150 and 300: the override reached the run.
    assert curve["learning_steps"].tolist() == [0, 150, 300] and result.seed == 3
    # The agent is the YAML's: SARSA with 8 tilings of 10 tiles per dimension, trained.
    representation = result.agent.representation
    assert isinstance(representation, TileCoding)
    assert (representation.num_tilings, representation.tiles_per_dim) == (8, 10)
    assert result.agent.is_set_up_ and (curve["episode_length"] > 0).all()
    again = example.run_from_config(seed=3, overrides=overrides)
    assert again.curve["return"].tolist() == curve["return"].tolist()


def test_python_api_example_reports_a_bad_override_clearly():
    with pytest.raises(InvalidParameterError, match="budget_stepz"):
        load_example().run_from_config(overrides=["budget_stepz=10"])


def test_own_representation_example_learns_the_same_from_objects_and_from_a_config():
    path = EXAMPLE.with_name("own_representation.py")
    spec = importlib.util.spec_from_file_location("own_representation_example", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    from conjure.experiments import registry

    try:
        from_objects, from_config = module.main(budget_steps=5_000)
    finally:
        registry.REPRESENTATIONS.pop("HalfSpaces", None)
    assert from_objects == from_config and len(from_objects) == 11
    # Learning with the four half-space features changes how long the greedy policy balances.
    assert max(from_objects) > from_objects[0]


def test_uav_icca_example_runs_every_agent_and_the_docs_show_its_table(tmp_path):
    from click.testing import CliRunner

    from conjure.cli.main import main
    from conjure.experiments.config import load_config
    from conjure.experiments.results import read_run

    config = EXAMPLE.with_name("uav_icca.yaml")
    experiment = load_config(config)
    labels = ["sarsa", "cbba_aggressive", "csarsa", "am_icca"]
    assert list(experiment.agents) == labels
    assert experiment.domain.params == {"scenario": "uav-7-2", "traverse_failure": 0.05}
    tiny = ["budget_steps=200", "num_policy_checks=1", "eval_episodes=2", "seeds=1"]
    args = ["run", str(config), "--out", str(tmp_path), "--quiet", "--max-workers", "1"]
    result = CliRunner().invoke(main, [*args, *(f"--set={o}" for o in tiny)])
    assert result.exit_code == 0, result.output
    runs = [read_run(path) for path in (tmp_path / "runs").glob("*.json")]
    assert sorted(run["config"]["label"] for run in runs) == sorted(labels)
    root = EXAMPLE.parents[1]
    # The table shown is this config's; tests/test_doc_outputs.py checks its numbers.
    marker = "<!-- output: conjure run examples/uav_icca.yaml -->\n"
    for doc in ("docs/getting-started.md", "docs/tutorials/chapter-5.md"):
        text = (root / doc).read_text()
        table = text.split(marker, 1)[1].split("```", 2)[1]
        rows = [line.split("│") for line in table.splitlines() if line.startswith("│")]
        assert [row[1].strip() for row in rows] == labels, doc
        assert {row[2].strip() for row in rows} == {str(experiment.seeds)}, doc
