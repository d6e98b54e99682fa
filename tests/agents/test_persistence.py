import json

import numpy as np
import pytest

from conjure.agents import SARSA, QLearning, persistence
from conjure.core import EpisodicDecay, IncompatibleComponentsError, InvalidParameterError
from conjure.domains import ChainMDP
from conjure.policies import EpsilonGreedy
from conjure.representations import Tabular, TileCoding


def test_saved_agent_is_json_plus_arrays_without_pickle(tmp_path):
    domain = ChainMDP()
    agent = SARSA(
        representation=TileCoding(num_tilings=2, tiles_per_dim=3),
        policy=EpsilonGreedy(epsilon=0.2),
        step_size=EpisodicDecay(alpha_0=0.5, n_0=10),
    ).setup(domain.domain_spec, seed=0)
    agent.save(tmp_path)
    document = json.loads((tmp_path / "agent.json").read_text())
    assert document["format"] == "conjure-agent" and document["version"] == 1
    assert document["component"]["class"] == "conjure.agents.sarsa.SARSA"
    assert document["component"]["params"]["policy"]["params"] == {"epsilon": 0.2}
    with np.load(tmp_path / "arrays.npz", allow_pickle=False) as arrays:
        assert arrays["weights"].shape == agent.weights_.shape
    restored = SARSA.restore(tmp_path)
    assert restored.schedule_ == EpisodicDecay(alpha_0=0.5, n_0=10)
    assert restored.rng_.random() == agent.rng_.random()


def test_restore_rejects_foreign_classes_and_wrong_types(tmp_path):
    with pytest.raises(InvalidParameterError, match="conjure component classes"):
        persistence.component_from_dict({"class": "os.system", "params": {}})
    SARSA(representation=TileCoding()).setup(ChainMDP().domain_spec, seed=0).save(tmp_path)
    with pytest.raises(IncompatibleComponentsError, match="not a QLearning"):
        QLearning.restore(tmp_path)
    with pytest.raises(InvalidParameterError, match="No saved agent"):
        SARSA.restore(tmp_path / "missing")


def _saved_chain_agent(tmp_path, **params):
    domain = ChainMDP(num_states=4, num_actions=2)
    agent = SARSA(representation=Tabular(), **params).setup(domain.domain_spec, seed=0)
    agent.weights_[:] = 1.0
    return agent.save(tmp_path / "agent")


def _rewrite_arrays(directory, **changes):
    with np.load(directory / "arrays.npz", allow_pickle=False) as data:
        arrays = {name: data[name] for name in data.files}
    arrays.update(changes)
    np.savez(directory / "arrays.npz", **arrays)


def _rewrite_document(directory, change):
    document = json.loads((directory / "agent.json").read_text())
    change(document)
    (directory / "agent.json").write_text(json.dumps(document))


@pytest.mark.parametrize(
    "qualified",
    [
        "conjure.cli.main.main",  # a callable under conjure.*, not a component class
        "conjure.experiments.run.Result",  # a class in a layer a saved agent never names
        "conjure.testing.fakes.SharedObservationBuffer",  # a component outside the packages
        "conjure.agents.persistence.SavedAgent",  # not Configurable
        "conjure.agents.linear_td.np",  # a module attribute that is not a class
        "conjure.agents.sarsa.LinearTDAgent",  # re-exported, defined elsewhere
        "conjure.agentsx.evil.Thing",
    ],
)
def test_a_crafted_class_name_is_refused_and_never_called(tmp_path, monkeypatch, qualified):
    import conjure.cli.main as cli

    monkeypatch.setattr(cli, "main", lambda **_: pytest.fail("the loader called main"))
    directory = _saved_chain_agent(tmp_path)
    _rewrite_document(directory, lambda d: d["component"].update({"class": qualified}))
    with pytest.raises(InvalidParameterError, match="component classes"):
        SARSA.restore(directory)


def test_unknown_saved_parameters_are_refused(tmp_path):
    directory = _saved_chain_agent(tmp_path)
    _rewrite_document(directory, lambda d: d["component"]["params"].update({"shell": "rm"}))
    with pytest.raises(InvalidParameterError, match=r"agent\.json|subset"):
        SARSA.restore(directory)


@pytest.mark.parametrize(
    ("weights", "problem"),
    [
        (np.ones((3, 7)), r"float64 of shape \(3, 7\).*expects float64 of shape \(4, 2\)"),
        (np.full((4, 2), np.nan), "NaN or infinite"),
        (np.full((4, 2), np.inf), "NaN or infinite"),
        (np.ones((4, 2), dtype=np.int64), "int64"),
        (np.ones(8), r"shape \(8,\)"),
    ],
)
def test_weights_of_the_wrong_shape_dtype_or_not_finite_are_refused(tmp_path, weights, problem):
    directory = _saved_chain_agent(tmp_path)
    _rewrite_arrays(directory, weights=weights)
    with pytest.raises(InvalidParameterError, match=problem) as caught:
        SARSA.restore(directory)
    assert "arrays.npz" in str(caught.value) and "'weights'" in str(caught.value)


def test_trace_indices_out_of_range_are_refused(tmp_path):
    directory = _saved_chain_agent(tmp_path, trace_decay=0.5)
    n = 3
    _rewrite_arrays(
        directory,
        trace_features=np.array([0, 1, 99]),
        trace_actions=np.zeros(n, dtype=np.int64),
        trace_values=np.ones(n),
    )
    with pytest.raises(InvalidParameterError, match=r"outside \[0, 4\)"):
        SARSA.restore(directory)


def test_actor_weights_are_checked_too(tmp_path):
    from conjure.agents import ActorCritic

    domain = ChainMDP(num_states=4, num_actions=2)
    directory = ActorCritic(representation=Tabular()).setup(domain.domain_spec, 0).save(tmp_path)
    _rewrite_arrays(directory, actor_weights=np.ones((5, 2)))
    with pytest.raises(InvalidParameterError, match="'actor_weights'"):
        ActorCritic.restore(directory)


def test_a_truncated_arrays_file_is_one_clear_error(tmp_path):
    directory = _saved_chain_agent(tmp_path)
    data = (directory / "arrays.npz").read_bytes()
    (directory / "arrays.npz").write_bytes(data[: len(data) // 2])
    with pytest.raises(InvalidParameterError, match=r"arrays\.npz.*damaged"):
        SARSA.restore(directory)
    (directory / "arrays.npz").unlink()
    with pytest.raises(InvalidParameterError, match=r"arrays\.npz.*missing"):
        SARSA.restore(directory)


def test_a_broken_metadata_file_is_one_clear_error(tmp_path):
    directory = _saved_chain_agent(tmp_path)
    text = (directory / "agent.json").read_text()
    (directory / "agent.json").write_text(text[: len(text) // 2])
    with pytest.raises(InvalidParameterError, match=r"agent\.json.*not valid JSON"):
        SARSA.restore(directory)


@pytest.mark.parametrize(
    "change",
    [
        lambda d: d.pop("state"),
        lambda d: d["state"].pop("rng"),
        lambda d: d.pop("spec"),
        lambda d: d["spec"].update({"num_actions": "two"}),
        lambda d: d["component"]["params"].update({"step_size": -1.0}),
        lambda d: d.update({"component": ["SARSA"]}),
    ],
)
def test_missing_or_wrong_metadata_is_one_clear_error_naming_the_save(tmp_path, change):
    directory = _saved_chain_agent(tmp_path)
    _rewrite_document(directory, change)
    with pytest.raises(InvalidParameterError) as caught:
        SARSA.restore(directory)
    assert str(directory) in str(caught.value)


def test_an_intact_save_still_restores_exactly(tmp_path):
    directory = _saved_chain_agent(tmp_path, trace_decay=0.5)
    restored = SARSA.restore(directory)
    assert restored.weights_.tolist() == [[1.0, 1.0]] * 4


def test_dense_traces_of_earlier_saves_are_converted(tmp_path):
    # Earlier conjure saved RBF SARSA(λ) traces as one dense (n, |A|) array 'traces'.
    from conjure.domains import InvertedPendulum
    from conjure.representations import RBF
    from conjure.testing.checks import _rollout

    domain = InvertedPendulum()
    agent = SARSA(representation=RBF(), trace_decay=0.5).setup(domain.domain_spec, seed=0)
    _rollout(domain, agent, 5, seed=0)
    directory = agent.save(tmp_path / "agent")
    dense = np.zeros(agent.weights_.shape)
    dense[3, 1], dense[7, 0] = 0.25, 1.5
    with np.load(directory / "arrays.npz", allow_pickle=False) as data:
        arrays = {k: data[k] for k in data.files if not k.startswith("trace_")}
    np.savez(directory / "arrays.npz", **arrays, traces=dense)
    restored = SARSA.restore(directory)
    count = int(restored.trace_count_[0])
    live = {
        (int(f), int(a)): float(v)
        for f, a, v in zip(
            restored.trace_features_[:count],
            restored.trace_actions_[:count],
            restored.trace_values_[:count],
            strict=True,
        )
    }
    assert live == {(3, 1): 0.25, (7, 0): 1.5}
    assert restored.trace_slots_[3, 1] > 0 and restored.trace_slots_[0, 0] == 0  # 1 + slot
