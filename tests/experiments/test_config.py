"""Tests of experiment configs: YAML loading, validation messages, overrides and resolution."""

from __future__ import annotations

import re
import textwrap

import pytest
import yaml

from conjure.core.errors import InvalidParameterError
from conjure.experiments.config import (
    ExperimentConfig,
    apply_overrides,
    config_hash,
    load_config,
    parse_config,
    resolve,
    resolve_run,
)

BASE = textwrap.dedent(
    """\
    name: tiny
    domain:
      kind: ChainMDP
      params: {num_states: 4, num_actions: 2}
    agents:
      sarsa:
        kind: SARSA
        params:
          representation: {kind: Tabular}
          policy: {kind: EpsilonGreedy, params: {epsilon: 0.2}}
          step_size: 0.5
    budget_steps: 200
    num_policy_checks: 4
    seeds: 2
    """
)


@pytest.fixture
def config_file(tmp_path):
    path = tmp_path / "tiny.yaml"
    path.write_text(BASE)
    return path


def write(tmp_path, text, name="bad.yaml"):
    path = tmp_path / name
    path.write_text(textwrap.dedent(text))
    return path


def test_load_valid_config(config_file):
    config = load_config(config_file)
    assert isinstance(config, ExperimentConfig)
    assert config.seed_list() == [0, 1]
    assert config.eval_episodes == 1 and config.max_workers is None
    assert config.agents["sarsa"].params["step_size"] == 0.5


def test_malformed_yaml_names_file_and_line(tmp_path):
    path = write(tmp_path, "name: x\ndomain: {kind: ChainMDP\nagents: {}\n")
    with pytest.raises(InvalidParameterError) as caught:
        load_config(path)
    message = str(caught.value)
    assert str(path) in message and "malformed YAML" in message
    assert ":3:" in message  # the line where the parser gave up


def test_missing_file_is_a_clear_error(tmp_path):
    with pytest.raises(InvalidParameterError, match="Cannot read config"):
        load_config(tmp_path / "nope.yaml")


def test_unknown_top_level_field_suggests(tmp_path):
    path = write(tmp_path, BASE.replace("budget_steps", "budget_step"))
    with pytest.raises(InvalidParameterError) as caught:
        load_config(path)
    message = str(caught.value)
    assert "budget_step" in message and "Did you mean 'budget_steps'?" in message


def test_unknown_kind_suggests(tmp_path):
    path = write(tmp_path, BASE.replace("kind: SARSA", "kind: SARSSA"))
    with pytest.raises(InvalidParameterError) as caught:
        load_config(path)
    assert "agents.sarsa.kind" in str(caught.value)
    assert "Did you mean 'SARSA'?" in str(caught.value)


def test_unknown_param_suggests(tmp_path):
    path = write(tmp_path, BASE.replace("epsilon: 0.2", "epsilom: 0.2"))
    with pytest.raises(InvalidParameterError) as caught:
        load_config(path)
    assert "Did you mean 'epsilon'?" in str(caught.value)
    assert "agents.sarsa.params.policy.params" in str(caught.value)


def test_out_of_range_value_names_the_field(tmp_path):
    path = write(tmp_path, BASE.replace("epsilon: 0.2", "epsilon: 3.0"))
    with pytest.raises(InvalidParameterError) as caught:
        load_config(path)
    message = str(caught.value)
    assert "agents.sarsa.params.policy.params.epsilon" in message and "got 3.0" in message


def test_wrong_type_names_the_field(tmp_path):
    path = write(tmp_path, BASE.replace("budget_steps: 200", "budget_steps: lots"))
    with pytest.raises(InvalidParameterError, match=r"budget_steps: .*'lots'"):
        load_config(path)
    path = write(tmp_path, BASE.replace("step_size: 0.5", "step_size: fast"))
    with pytest.raises(InvalidParameterError, match=r"agents\.sarsa\.params\.step_size"):
        load_config(path)


def test_bad_seeds_and_labels():
    raw = yaml.safe_load(BASE)
    with pytest.raises(InvalidParameterError, match="seeds"):
        parse_config({**raw, "seeds": 0})
    with pytest.raises(InvalidParameterError, match="seeds"):
        parse_config({**raw, "seeds": [1, 1]})
    assert parse_config({**raw, "seeds": [3, 9]}).seed_list() == [3, 9]
    with pytest.raises(InvalidParameterError, match="folder name"):
        parse_config({**raw, "agents": {"a/b": raw["agents"]["sarsa"]}})
    with pytest.raises(InvalidParameterError, match="must be a mapping"):
        parse_config([1, 2])


def test_overrides_set_values(config_file):
    config = load_config(
        config_file,
        [
            "agents.sarsa.params.step_size=1e-2",
            "agents.sarsa.params.policy.params.epsilon=0.05",
            "agents.sarsa.params.trace_decay=0.5",  # absent from the file: a default
            "budget_steps=300",
            "seeds=[4, 5]",
            "domain.params.slip=0.1",
        ],
    )
    params = config.agents["sarsa"].params
    assert params["step_size"] == 0.01 and isinstance(params["step_size"], float)
    assert params["policy"]["params"]["epsilon"] == 0.05
    assert params["trace_decay"] == 0.5
    assert config.budget_steps == 300 and config.seed_list() == [4, 5]
    assert config.domain.params["slip"] == 0.1


def test_override_replaces_or_builds_nested_components():
    raw = yaml.safe_load(BASE)
    del raw["agents"]["sarsa"]["params"]["policy"]
    changed = apply_overrides(
        raw,
        [
            "agents.sarsa.params.step_size={kind: ConstantStepSize, params: {alpha_0: 0.3}}",
            "agents.sarsa.params.policy.kind=Gibbs",
            "agents.sarsa.params.policy.params.temperature=2.0",
        ],
    )
    params = changed["agents"]["sarsa"]["params"]
    assert params["step_size"] == {"kind": "ConstantStepSize", "params": {"alpha_0": 0.3}}
    assert params["policy"] == {"kind": "Gibbs", "params": {"temperature": 2.0}}
    assert "policy" not in raw["agents"]["sarsa"]["params"]  # the input is not modified
    config = parse_config(changed)
    assert config.agents["sarsa"].params["policy"]["kind"] == "Gibbs"
    with pytest.raises(InvalidParameterError, match="plain value"):
        apply_overrides(yaml.safe_load(BASE), ["agents.sarsa.params.step_size.kind=X"])


@pytest.mark.parametrize(
    ("override", "suggestion"),
    [
        ("budget_step=5", "budget_steps"),
        ("agents.sarssa.params.step_size=0.1", "sarsa"),
        ("agents.sarsa.parms.step_size=0.1", "params"),
        ("agents.sarsa.params.step_sise=0.1", "step_size"),
        ("agents.sarsa.params.policy.params.epsilom=0.1", "epsilon"),
        ("domain.params.num_state=3", "num_states"),
    ],
)
def test_bad_override_paths_suggest(config_file, override, suggestion):
    with pytest.raises(InvalidParameterError) as caught:
        load_config(config_file, [override])
    assert f"Did you mean '{suggestion}'?" in str(caught.value)


def test_override_without_equals(config_file):
    with pytest.raises(InvalidParameterError, match=r"dotted\.path=value"):
        load_config(config_file, ["budget_steps"])


def test_override_value_is_validated(config_file):
    with pytest.raises(
        InvalidParameterError, match=r"agents\.sarsa\.params\.policy\.params\.epsilon"
    ):
        load_config(config_file, ["agents.sarsa.params.policy.params.epsilon=-1"])


def test_resolve_fills_every_default(config_file):
    resolved = resolve(load_config(config_file))
    agent = resolved["agents"]["sarsa"]
    assert agent["params"]["trace_decay"] == 0.0  # SARSA's default
    assert agent["params"]["representation"]["params"]["num_buckets"] == 20
    assert resolved["domain"]["params"]["discount"] == 0.9
    assert resolved["seeds"] == [0, 1] and resolved["eval_episodes"] == 1
    assert yaml.safe_load(yaml.safe_dump(resolved)) == resolved  # plain YAML data


def test_resolve_run_and_hash(config_file):
    config = load_config(config_file)
    run_spec = resolve_run(config, "sarsa", 1)
    assert run_spec["label"] == "sarsa" and run_spec["seed"] == 1
    assert run_spec["agent"]["kind"] == "SARSA"
    assert config_hash(run_spec) == config_hash(resolve_run(config, "sarsa", 1))
    assert config_hash(run_spec) != config_hash(resolve_run(config, "sarsa", 0))
    with pytest.raises(InvalidParameterError, match="Did you mean 'sarsa'"):
        resolve_run(config, "sarsaa", 0)


def test_a_bad_agent_label_is_named_without_dumping_every_agent():
    from conjure.core import InvalidParameterError
    from conjure.experiments.config import parse_config

    agent = {"kind": "SARSA", "params": {"representation": {"kind": "Tabular"}}}
    config = {
        "name": "x",
        "domain": {"kind": "ChainMDP"},
        "agents": {"fine": agent, "bad+label": agent},
        "budget_steps": 10,
    }
    with pytest.raises(InvalidParameterError, match="'bad\\+label'") as error:
        parse_config(config)
    assert "'kind': 'SARSA'" not in str(error.value)


def test_max_memory_is_a_size_that_does_not_change_run_ids(config_file):
    config = load_config(config_file, ["max_memory=1.5GiB"])
    assert config.max_memory == 3 * 2**29
    assert resolve(config)["max_memory"] == 3 * 2**29
    assert load_config(config_file).max_memory is None
    plain = resolve_run(load_config(config_file), "sarsa", 0)
    assert config_hash(resolve_run(config, "sarsa", 0)) == config_hash(plain)
    with pytest.raises(InvalidParameterError, match=r"max_memory: a memory size .*got '4XB'"):
        load_config(config_file, ["max_memory=4XB"])


def test_a_bad_set_value_is_blamed_on_the_flag_and_a_bad_file_on_the_file(tmp_path):
    path = tmp_path / "tiny.yaml"
    path.write_text(
        "name: tiny\n"
        "domain: {kind: ChainMDP, params: {num_states: 4}}\n"
        "agents: {q: {kind: QLearning, params: {representation: {kind: Tabular}}}}\n"
        "budget_steps: 100\n"
    )
    with pytest.raises(InvalidParameterError) as bad:
        load_config(path, ["seeds=2", "agents.q.params.step_size=-3"])
    assert str(bad.value).startswith("--set 'agents.q.params.step_size=-3': agents.q.params")
    path.write_text(path.read_text().replace("budget_steps: 100", "budget_steps: -1"))
    with pytest.raises(InvalidParameterError, match=rf"^{re.escape(str(path))}: budget_steps"):
        load_config(path, ["seeds=2"])
    assert load_config(path, ["budget_steps=50"]).budget_steps == 50  # the flag fixes the file


@pytest.mark.parametrize("field", ["grid", "domains", "domain_grids", "selection"])
def test_a_sweep_config_is_named_with_the_sweep_command(tmp_path, field):
    path = tmp_path / "fig.yaml"
    path.write_text(BASE + f"{field}: {{}}\n")
    with pytest.raises(InvalidParameterError) as info:
        load_config(path)
    assert str(info.value) == (
        f"{path} is a sweep config (it has `{field}`), not an experiment; run it with "
        f"`conjure sweep {path}`."
    )


def test_a_tuning_config_is_named_with_the_tune_command(tmp_path):
    path = tmp_path / "tune.yaml"
    path.write_text(BASE + "search: {space: {}}\n")
    with pytest.raises(InvalidParameterError, match=r"tuning config .* `conjure tune "):
        load_config(path, ["seeds=2"])
