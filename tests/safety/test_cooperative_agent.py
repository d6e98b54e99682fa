import tempfile

import numpy as np
import pytest
from safety_fakes import gridworld_model

from conjure.agents import SARSA
from conjure.core.errors import IncompatibleComponentsError, InvalidParameterError
from conjure.domains import GridWorld
from conjure.experiments.loop import LearningLoop
from conjure.planners import ShortestPathPlanner
from conjure.representations import Tabular, TileCoding
from conjure.safety import CooperativeLearner, MonteCarloRiskAnalyzer


def csarsa(model=None, index=None):
    return CooperativeLearner(
        learner=SARSA(representation=Tabular()),
        planner=ShortestPathPlanner(),
        risk=MonteCarloRiskAnalyzer(),
        model=gridworld_model(GridWorld.gridworld_2()) if model is None else model,
        index=index,
        num_known_visits=2,
    )


def test_the_parts_share_one_model_and_planner():
    agent = csarsa().setup(GridWorld.gridworld_2().domain_spec, seed=0)
    assert agent.risk_.model_ is agent.model_ and agent.risk_.planner_ is agent.planner_
    assert agent.planned_noise_ == agent.model_.noise_ == 0.2
    assert agent.learner_.num_features == agent.num_features == 5 * 22


def test_a_model_of_another_map_is_refused():
    agent = csarsa(model=gridworld_model(GridWorld.gridworld_1()))
    with pytest.raises(IncompatibleComponentsError, match="map or graph"):
        agent.setup(GridWorld.gridworld_2().domain_spec, seed=0)


def test_the_index_needs_one_feature_per_state():
    agent = csarsa(index=TileCoding(num_tilings=2, tiles_per_dim=3))
    agent.setup(GridWorld.gridworld_2().domain_spec, seed=0)
    with pytest.raises(IncompatibleComponentsError, match="one feature per state"):
        agent.act(np.array([4.0, 11.0]))


def learn(agent, seed, num_steps, loop=None):
    domain = GridWorld.gridworld_2()
    loop = LearningLoop(domain, agent, seed=seed) if loop is None else loop
    loop.advance(num_steps)
    return loop


def test_save_and_restore_continue_exactly():
    spec = GridWorld.gridworld_2().domain_spec
    straight = csarsa().setup(spec, seed=3)
    learn(straight, seed=1, num_steps=400)
    learn(straight, seed=2, num_steps=400)

    halves = csarsa().setup(spec, seed=3)
    learn(halves, seed=1, num_steps=400)
    with tempfile.TemporaryDirectory() as directory:
        halves.save(directory)
        resumed = CooperativeLearner.restore(directory)
    learn(resumed, seed=2, num_steps=400)
    np.testing.assert_array_equal(resumed.learner_.weights_, straight.learner_.weights_)
    np.testing.assert_array_equal(resumed.counts_, straight.counts_)
    assert resumed.risk_.rng_.bit_generator.state == straight.risk_.rng_.bit_generator.state


def test_restore_refuses_another_class(tmp_path):
    from conjure.safety import AdaptiveCooperativeLearner

    csarsa().setup(GridWorld.gridworld_2().domain_spec, seed=0).save(tmp_path)
    with pytest.raises(IncompatibleComponentsError, match="not a AdaptiveCooperativeLearner"):
        AdaptiveCooperativeLearner.restore(tmp_path)


@pytest.mark.parametrize(
    ("counts", "problem"),
    [
        (np.zeros((3, 7), dtype=np.int32), "shape"),
        (np.zeros((110, 4), dtype=np.float64), "int32"),
    ],
)
def test_a_damaged_count_table_is_refused_naming_the_file(tmp_path, counts, problem):
    csarsa().setup(GridWorld.gridworld_2().domain_spec, seed=0).save(tmp_path)
    with np.load(tmp_path / "arrays.npz") as data:
        arrays = {name: data[name] for name in data.files}
    arrays["counts"] = counts
    np.savez(tmp_path / "arrays.npz", **arrays)
    with pytest.raises(InvalidParameterError, match=r"arrays\.npz") as error:
        CooperativeLearner.restore(tmp_path)
    assert "'counts'" in str(error.value) and problem in str(error.value)


def test_a_truncated_save_is_one_clear_error(tmp_path):
    csarsa().setup(GridWorld.gridworld_2().domain_spec, seed=0).save(tmp_path)
    (tmp_path / "agent.json").write_text('{"format": "conjure-agent", "vers')
    with pytest.raises(InvalidParameterError, match=r"agent\.json"):
        CooperativeLearner.restore(tmp_path)


def test_missions_get_a_lazily_indexed_count_table_and_never_crash_by_choice():
    # UAV 7-2 [R] has 7·7·7·7·2^7·9 = 2.8 million cells: the default index is HashedTabular.
    from conjure.domains import UAVMission
    from conjure.models.approximate_model import ApproximateModel
    from conjure.planners import CBBAPlanner
    from conjure.representations import HashedTabular
    from conjure.safety import FuelRiskAnalyzer

    class CrashCounter(UAVMission):
        def step(self, action):
            outcome = super().step(action)
            self.num_crashes = getattr(self, "num_crashes", 0) + int(outcome[-1]["cost"])
            return outcome

    domain = CrashCounter(traverse_failure=0.0)
    agent = CooperativeLearner(
        learner=SARSA(representation=HashedTabular(capacity=20_000)),
        planner=CBBAPlanner(variant="aggressive"),
        risk=FuelRiskAnalyzer(),
        model=ApproximateModel(domain=UAVMission()),
        num_known_visits=1,
    ).setup(domain.domain_spec, seed=0)
    assert isinstance(agent.index_, HashedTabular) and agent.counts_.shape == (100_000, 49)
    LearningLoop(domain, agent, seed=0).advance(2000)
    assert domain.num_crashes == 0  # without traverse failures the fuel rule keeps UAVs safe
    stored = agent.index_.num_stored_
    unseen = domain.graph_.initial_state()
    unseen[-2] = 1.0  # a target obtained at t = 0: unreachable
    agent.act(unseen, greedy=True)
    assert agent.index_.num_stored_ == stored  # greedy acting only looks states up
