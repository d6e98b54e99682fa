import json

import numpy as np
import pytest

from conjure.agents import SARSA, QLearning, persistence
from conjure.core import EpisodicDecay, IncompatibleComponentsError, InvalidParameterError
from conjure.domains import ChainMDP
from conjure.policies import EpsilonGreedy
from conjure.representations import TileCoding


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
    with pytest.raises(InvalidParameterError, match="conjure classes"):
        persistence.component_from_dict({"class": "os.system", "params": {}})
    SARSA(representation=TileCoding()).setup(ChainMDP().domain_spec, seed=0).save(tmp_path)
    with pytest.raises(IncompatibleComponentsError, match="not a QLearning"):
        QLearning.restore(tmp_path)
    with pytest.raises(InvalidParameterError, match="No saved agent"):
        SARSA.restore(tmp_path / "missing")
