"""The Python API example (examples/python_api.py) runs a YAML config to a result."""

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
