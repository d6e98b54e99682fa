"""Which pairs take the compiled path: every part's compiled form, and no overridden kernel."""

import numpy as np
import pytest

from conjure.agents import LSPI, SARSA, ActorCritic, QLearning
from conjure.agents import compiled_agent as agent_kernels
from conjure.compiled import why_not_compiled
from conjure.core.compiled_form import compiled_form
from conjure.core.errors import NotSetUpError
from conjure.core.schedules import FEATURE_NORMALIZED, ConstantStepSize, FeatureNormalizedDecay
from conjure.domains import (
    ChainMDP,
    GridWorld,
    InvertedPendulum,
    RescueMission,
    UAVMission,
)
from conjure.domains import compiled_domain as domain_forms
from conjure.policies import EpsilonGreedy, Gibbs
from conjure.policies.compiled_policy import EPSILON_GREEDY, GIBBS
from conjure.representations import (
    RBF,
    IndependentDiscretization,
    SparseDistributedMemory,
    Tabular,
    TileCoding,
)
from conjure.representations import compiled_representation as rep_kernels


class MySARSA(SARSA):
    """A user's subclass that changes ``learn``: the compiled loop would skip the override."""

    def learn(self, transition):
        return super().learn(transition)


def _set_up(domain, agent):
    return agent.setup(domain.domain_spec, 0)


def test_sarsa_lambda_gives_its_traces_schedule_and_policy():
    schedule = FeatureNormalizedDecay(alpha_0=1.0, n_0=100)
    agent = SARSA(representation=TileCoding(num_tilings=8), step_size=schedule, trace_decay=0.9)
    form = _set_up(InvertedPendulum(force_noise=5.0), agent).compiled_form()
    assert (form.kind, form.traces) == (agent_kernels.SARSA, agent_kernels.REPLACING)
    assert form.trace_decay == pytest.approx(0.95 * 0.9) and form.discount == 0.95
    assert form.schedule == (FEATURE_NORMALIZED, 1.0, 100.0)
    assert form.policy == (EPSILON_GREEDY, 0.1)
    rep = agent.representation_.compiled_form()
    assert (rep.kind, rep.num_tilings, rep.max_active) == (rep_kernels.TILES, 8, 8)


def test_pendulum_form_holds_its_noise_and_state():
    domain = InvertedPendulum(force_noise=5.0)
    domain.reset(seed=0)
    form = domain.compiled_form()
    assert form.pendulum == (5.0, 0.0) and form.fstate.tolist() == [0.0, 0.0]


def test_gridworld_move_table_matches_the_domain():
    domain = GridWorld.gridworld_1()
    form = domain.compiled_form()
    start = form.grid.start_cell
    cells = form.cells
    assert (cells[start, domain_forms.C_ROW], cells[start, domain_forms.C_COL]) == domain.start_
    for cell in (0, start, form.table.shape[0] - 1):
        moves = form.table[cell, 5 : 5 + form.table[cell, 4]].tolist()
        assert moves == list(domain._feasible[cell])


def test_actor_critic_with_gibbs_gives_its_form():
    agent = ActorCritic(representation=Tabular(), policy=Gibbs(temperature=2.0))
    form = _set_up(ChainMDP(num_actions=2), agent).compiled_form()
    assert form.kind == agent_kernels.ACTOR_CRITIC and form.policy == (GIBBS, 2.0)


@pytest.mark.parametrize(
    ("domain", "agent"),
    [
        (InvertedPendulum(), SARSA(representation=type("MyRBF", (RBF,), {"encode": RBF.encode})())),
        (InvertedPendulum(), MySARSA(representation=Tabular())),
        (ChainMDP(), SARSA(representation=SparseDistributedMemory())),  # no kernel
        (ChainMDP(), LSPI(representation=Tabular())),  # a batch learner
        (
            ChainMDP(),
            ActorCritic(representation=Tabular(), actor_representation=Tabular()),
        ),  # separate actor features
        (
            ChainMDP(),
            SARSA(
                representation=Tabular(),
                policy=type("MyPolicy", (EpsilonGreedy,), {"select": EpsilonGreedy.select})(),
            ),
        ),
        (
            ChainMDP(),
            SARSA(
                representation=Tabular(),
                step_size=type("MySchedule", (ConstantStepSize,), {"value": lambda s, e, k: 1})(),
            ),
        ),
    ],
)
def test_pairs_without_kernels_take_the_python_path(domain, agent):
    reason = why_not_compiled(domain, _set_up(domain, agent))
    assert reason is not None and "no compiled kernel" in reason


def test_a_subclass_that_overrides_nothing_keeps_the_kernel():
    agent = type("Plain", (SARSA,), {})(representation=Tabular())
    assert why_not_compiled(ChainMDP(), _set_up(ChainMDP(), agent)) is None


def test_an_agent_that_is_not_set_up_is_refused():
    with pytest.raises(NotSetUpError):
        why_not_compiled(ChainMDP(), SARSA(representation=Tabular()))


def test_forms_are_contiguous_and_typed():
    agent = _set_up(InvertedPendulum(), SARSA(representation=TileCoding(memory_size=64)))
    rep = compiled_form(agent.representation_)
    assert rep.rbf is None  # binary φ: the loop reads no values
    domain = InvertedPendulum().compiled_form()
    for array in (domain.fstate, rep.dims, rep.layout, rep.hash_table):
        assert array.flags.c_contiguous and array.dtype in (np.int64, np.float64)


def test_rbf_form_lists_every_feature_with_the_representations_values():
    domain, agent = GridWorld.gridworld_1(), QLearning(representation=RBF(num_centers=3))
    rep = _set_up(domain, agent).representation_
    form = rep.compiled_form()
    assert form.kind == rep_kernels.RBF and form.max_active == 3 * 3 + 1
    assert form.vector.tolist() == list(range(10)) and form.vector.flags.writeable
    state = np.array([1.0, 2.0])  # the loop's values are the representation's, bit for bit
    np.testing.assert_array_equal(rep_kernels.values_of(form, state), rep.encode(state).values)


def test_mission_forms_read_the_domains_tables():
    rescue = RescueMission(max_fuel=7)
    form = rescue.compiled_form()
    assert form.kind == domain_forms.RESCUE
    start = form.mission.start.tolist()
    assert start == rescue.reset(seed=0)[0].tolist() and start[1] == start[3] == 7.0
    assert form.table[:, :3].tolist() == rescue.neighbours_.tolist()
    assert form.table[0, 3] == 2 and form.cells[2, domain_forms.RESCUE_PEOPLE] == 3.0
    uav = UAVMission(traverse_failure=0.25)
    form = uav.compiled_form()
    assert form.mission.traverse_failure == 0.25
    assert form.mission.start.tolist() == uav.reset()[0].tolist()
    assert form.table[1:].tolist() == uav._adjacency.tolist()  # 7 nodes: the layout row is 7 wide


def test_independent_discretization_on_a_mission_is_compiled():
    domain = RescueMission()
    agent = _set_up(domain, QLearning(representation=IndependentDiscretization()))
    assert why_not_compiled(domain, agent) is None
