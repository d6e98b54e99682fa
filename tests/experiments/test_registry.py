"""Tests of the component registry: build, did-you-mean, field paths, round trips."""

from __future__ import annotations

import pytest
from test_loop import FakeAgent, FakeWalk

from conjure.core.errors import InvalidParameterError
from conjure.experiments import registry


@pytest.fixture
def fakes(monkeypatch):
    monkeypatch.setitem(registry.AGENTS, "FakeAgent", FakeAgent)
    monkeypatch.setitem(registry.DOMAINS, "FakeWalk", FakeWalk)


def test_registries_are_keyed_by_kind_and_unique_across_layers():
    kinds = [kind for layer in registry.LAYERS.values() for kind in layer]
    assert len(kinds) == len(set(kinds))
    assert registry.DOMAINS["Gymnasium"].__name__ == "GymnasiumDomain"
    for name in ("SARSA", "QLearning", "ActorCritic"):
        assert name in registry.AGENTS
    for name in ("TileCoding", "Tabular", "IndependentDiscretization", "RBF"):
        assert name in registry.REPRESENTATIONS
    assert "ConstantStepSize" in registry.SCHEDULES
    assert "CBBAPlanner" in registry.COOPERATIVE_PLANNERS
    for layer in registry.LAYERS.values():
        for kind, cls in layer.items():
            if kind != "Gymnasium":
                assert cls.__name__ == kind


def test_build_nested_components():
    agent = registry.build(
        "agent",
        {
            "kind": "SARSA",
            "params": {
                "representation": {"kind": "TileCoding", "params": {"num_tilings": 4}},
                "policy": {"kind": "EpsilonGreedy", "params": {"epsilon": 0.2}},
                "step_size": {"kind": "ConstantStepSize", "params": {"alpha_0": 0.1}},
            },
        },
    )
    assert type(agent).__name__ == "SARSA"
    assert agent.representation.num_tilings == 4
    assert agent.policy.epsilon == 0.2
    assert type(agent.step_size).__name__ == "ConstantStepSize"


def test_to_spec_round_trips_with_every_default():
    agent = registry.build(
        "agent", {"kind": "SARSA", "params": {"representation": {"kind": "Tabular"}}}
    )
    spec = registry.to_spec(agent)
    assert set(spec["params"]) == set(type(agent).param_names())
    assert spec["params"]["representation"]["kind"] == "Tabular"
    assert registry.build("agent", spec) == agent


def test_unknown_kind_suggests_and_lists(fakes):
    with pytest.raises(InvalidParameterError) as caught:
        registry.build("agent", {"kind": "SARSAA", "params": {}}, path="agents.a")
    message = str(caught.value)
    assert "agents.a.kind" in message and "Did you mean 'SARSA'?" in message
    assert "Known:" in message and "QLearning" in message


def test_nested_kind_is_looked_up_in_every_layer():
    with pytest.raises(InvalidParameterError, match="Did you mean 'TileCoding'"):
        registry.build(
            "agent",
            {"kind": "SARSA", "params": {"representation": {"kind": "TileCodin"}}},
            path="agents.a",
        )


def test_unknown_param_suggests(fakes):
    with pytest.raises(InvalidParameterError) as caught:
        registry.build(
            "agent", {"kind": "FakeAgent", "params": {"step_sise": 0.1}}, path="agents.a"
        )
    assert "Did you mean 'step_size'?" in str(caught.value)
    assert "agents.a.params" in str(caught.value)


def test_bad_value_names_the_field_path(fakes):
    with pytest.raises(InvalidParameterError) as caught:
        registry.build(
            "agent", {"kind": "FakeAgent", "params": {"step_size": 2.0}}, path="agents.tile_coding"
        )
    message = str(caught.value)
    assert message.startswith("agents.tile_coding.params.step_size: `FakeAgent.step_size` must")
    with pytest.raises(InvalidParameterError, match=r"step_size.*got 'fast'"):
        registry.build("agent", {"kind": "FakeAgent", "params": {"step_size": "fast"}})


def test_nested_bad_value_names_the_nested_path():
    with pytest.raises(InvalidParameterError) as caught:
        registry.build(
            "agent",
            {
                "kind": "SARSA",
                "params": {
                    "representation": {"kind": "Tabular"},
                    "policy": {"kind": "EpsilonGreedy", "params": {"epsilon": 1.5}},
                },
            },
            path="agents.x",
        )
    assert "agents.x.params.policy.params.epsilon" in str(caught.value)


def test_missing_required_parameter():
    with pytest.raises(InvalidParameterError, match=r"`SARSA.representation` is required"):
        registry.build("agent", {"kind": "SARSA"})


def test_malformed_component():
    with pytest.raises(InvalidParameterError, match="kind"):
        registry.build("agent", {"params": {}})
    with pytest.raises(InvalidParameterError, match="Did you mean 'params'"):
        registry.build("agent", {"kind": "SARSA", "parms": {}})


def test_wrong_layer_is_unknown():
    with pytest.raises(InvalidParameterError, match="unknown agent kind 'TileCoding'"):
        registry.build("agent", {"kind": "TileCoding"})


def test_kinds_match_case_insensitively_and_resolve_to_the_registered_spelling():
    from conjure.experiments.config import parse_config, resolve_run

    agent = registry.build(
        "agent", {"kind": "Sarsa", "params": {"representation": {"kind": "tabular"}}}
    )
    assert type(agent).__name__ == "SARSA"
    config = parse_config(
        {
            "name": "case",
            "domain": {"kind": "chainmdp"},
            "agents": {"s": {"kind": "Sarsa", "params": {"representation": {"kind": "TABULAR"}}}},
            "budget_steps": 10,
        }
    )
    spec = resolve_run(config, "s", 0)
    assert (spec["agent"]["kind"], spec["domain"]["kind"]) == ("SARSA", "ChainMDP")
    assert spec["agent"]["params"]["representation"]["kind"] == "Tabular"
