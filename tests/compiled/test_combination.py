"""Which combinations have a compiled path: exact types only, everything else takes Python's."""

import numpy as np
import pytest

from conjure.agents import LSPI, SARSA, ActorCritic, QLearning
from conjure.compiled import _adaptive_kernel as ak
from conjure.compiled import _kernels as k
from conjure.compiled.combination import pack_combination
from conjure.core.errors import NotSetUpError
from conjure.core.schedules import ConstantStepSize, FeatureNormalizedDecay
from conjure.domains import (
    BlocksWorld,
    ChainMDP,
    GridWorld,
    InvertedPendulum,
    RescueMission,
    UAVMission,
)
from conjure.policies import EpsilonGreedy, Gibbs
from conjure.representations import RBF, IndependentDiscretization, Tabular, TileCoding


class MySARSA(SARSA):
    """A user's subclass: its methods may differ, so it must take the Python path."""


def _pack(domain, agent):
    return pack_combination(domain, agent.setup(domain.domain_spec, 0))


def test_pendulum_tile_coding_sarsa_lambda_is_packed():
    schedule = FeatureNormalizedDecay(alpha_0=1.0, n_0=100)
    agent = SARSA(representation=TileCoding(num_tilings=8), step_size=schedule, trace_decay=0.9)
    combo = _pack(InvertedPendulum(force_noise=5.0), agent)
    codes = combo.ints[[k.I_DOMAIN, k.I_REP, k.I_AGENT, k.I_POLICY, k.I_SCHEDULE, k.I_TRACES]]
    assert codes.tolist() == [
        k.PENDULUM,
        k.TILES,
        k.SARSA,
        k.EPSILON_GREEDY,
        k.FEATURE_NORMALIZED,
        k.REPLACING,
    ]
    assert combo.ints[k.I_MAX_ACTIVE] == 8 and combo.ints[k.I_CAP] == 3000
    assert combo.floats[k.F_TRACE_FACTOR] == pytest.approx(0.95 * 0.9)
    assert combo.floats[[k.F_ALPHA, k.F_N0, k.F_POLICY]].tolist() == [1.0, 100.0, 0.1]
    assert combo.domain_arrays[0].tolist() == [5.0, 0.0]  # force noise, start noise


def test_gridworld_move_table_matches_the_domain():
    domain = GridWorld.gridworld_1()
    combo = _pack(domain, QLearning(representation=Tabular()))
    dparams, table, cells = combo.domain_arrays
    start = int(dparams[1])
    assert (cells[start, k.C_ROW], cells[start, k.C_COL]) == domain.start_
    for cell in (0, start, table.shape[0] - 1):
        moves = table[cell, 5 : 5 + table[cell, 4]].tolist()
        assert moves == list(domain._feasible[cell])


def test_actor_critic_with_gibbs_is_packed():
    agent = ActorCritic(representation=Tabular(), policy=Gibbs(temperature=2.0))
    combo = _pack(ChainMDP(num_actions=2), agent)
    assert combo.ints[k.I_AGENT] == k.ACTOR_CRITIC and combo.ints[k.I_POLICY] == k.GIBBS
    assert combo.floats[k.F_POLICY] == 2.0


@pytest.mark.parametrize(
    ("domain", "agent"),
    [
        (InvertedPendulum(), SARSA(representation=type("MyRBF", (RBF,), {})())),  # a subclass
        (InvertedPendulum(), MySARSA(representation=Tabular())),  # a subclass
        (BlocksWorld(num_blocks=3), SARSA(representation=Tabular())),  # legal actions, a table
        (ChainMDP(), LSPI(representation=Tabular())),  # a batch learner
        (
            ChainMDP(),
            ActorCritic(representation=Tabular(), actor_representation=Tabular()),
        ),  # separate actor features
        (
            ChainMDP(),
            SARSA(representation=Tabular(), policy=type("MyPolicy", (EpsilonGreedy,), {})()),
        ),
        (
            ChainMDP(),
            SARSA(
                representation=Tabular(),
                step_size=type("MySchedule", (ConstantStepSize,), {})(),
            ),
        ),
    ],
)
def test_combinations_without_kernels_take_the_python_path(domain, agent):
    assert _pack(domain, agent) is None


def test_an_agent_that_is_not_set_up_is_refused():
    with pytest.raises(NotSetUpError):
        pack_combination(ChainMDP(), SARSA(representation=Tabular()))


def test_packed_arrays_are_contiguous():
    combo = _pack(InvertedPendulum(), SARSA(representation=TileCoding(memory_size=64)))
    *tables, rbf = combo.representation_arrays
    assert rbf is None  # binary φ: the kernel reads no values
    for array in (*combo.domain_arrays, *tables):
        assert array.flags.c_contiguous and array.dtype in (np.int64, np.float64)


def test_rbf_is_packed_with_every_feature_listed():
    domain, agent = GridWorld.gridworld_1(), QLearning(representation=RBF(num_centers=3))
    combo = _pack(domain, agent)
    rep = agent.representation_
    assert combo.ints[k.I_REP] == k.RBF and combo.ints[k.I_MAX_ACTIVE] == 3 * 3 + 1
    rvec, (affine, centers) = combo.representation_arrays[3], combo.representation_arrays[6]
    assert rvec.tolist() == list(range(10)) and rvec.flags.writeable
    # The kernel's values for a state are the representation's own, bit for bit.
    state = np.array([1.0, 2.0])
    values = k.feature_values((affine, centers), 10, state)
    np.testing.assert_array_equal(values, rep.encode(state).values)
    assert k.feature_values(None, 10, state) is None


def test_mission_packing_reads_the_domains_tables():
    rescue = RescueMission(max_fuel=7)
    combo = _pack(rescue, SARSA(representation=IndependentDiscretization()))
    dparams, table, cells = combo.domain_arrays
    assert combo.is_adaptive and combo.ints[k.I_DOMAIN] == ak.RESCUE
    start = dparams[ak.RESCUE_START :].tolist()
    assert start == rescue.reset(seed=0)[0].tolist() and start[1] == start[3] == 7.0
    assert table[:, :3].tolist() == rescue.neighbours_.tolist()
    assert table[0, 3] == 2 and cells[2, ak.RESCUE_PEOPLE] == 3.0  # base: 2 edges; node 2: 3
    uav = UAVMission(traverse_failure=0.25)
    combo = _pack(uav, QLearning(representation=IndependentDiscretization()))
    dparams, table, cells = combo.domain_arrays
    assert dparams[0] == 0.25 and dparams[ak.UAV_START :].tolist() == uav.reset()[0].tolist()
    assert table[1:].tolist() == uav._adjacency.tolist()  # 7 nodes: the layout row is 7 wide
