"""A lazily indexed box costs memory for the states a run meets, not for its capacity.

θ, SARSA(λ)'s trace slots and Algorithm 24's counts are sized by a `HashedTabular`'s capacity
(rows numbered by first visit); they start as zeros that the operating system maps only when
written, and Algorithm 26's count reset clears only the rows in use. Checked with Linux's
``mincore`` (which pages of an array are resident).
"""

import ctypes
import mmap
import sys

import numpy as np
import pytest

from conjure.agents import SARSA
from conjure.compiled import for_combination
from conjure.core.schedules import EpisodicDecay
from conjure.domains import UAVMission
from conjure.experiments.loop import LearningLoop
from conjure.models.approximate_model import ApproximateModel
from conjure.planners import CBBAPlanner, SwitchingPlanner
from conjure.representations import HashedTabular
from conjure.safety import AdaptiveCooperativeLearner, MonteCarloRiskAnalyzer

pytestmark = pytest.mark.skipif(sys.platform != "linux", reason="mincore: Linux only")


def _resident_fraction(array: np.ndarray) -> float:
    """The fraction of ``array``'s pages resident in memory (Linux ``mincore``)."""
    libc = ctypes.CDLL(None, use_errno=True)
    address = array.__array_interface__["data"][0]
    start = address - address % mmap.PAGESIZE
    length = address + array.nbytes - start
    pages = (length + mmap.PAGESIZE - 1) // mmap.PAGESIZE
    resident = (ctypes.c_ubyte * pages)()
    assert libc.mincore(ctypes.c_void_p(start), ctypes.c_size_t(length), resident) == 0
    return sum(flag & 1 for flag in resident) / pages


def _am_icca() -> AdaptiveCooperativeLearner:
    """Fig. 5-13's AM-iCCA with a calm prior, so that π^p switches (and the counts reset)."""
    domain = UAVMission(scenario="uav-7-2")
    return AdaptiveCooperativeLearner(
        learner=SARSA(
            representation=HashedTabular(capacity=200_000),
            step_size=EpisodicDecay(alpha_0=0.1, n_0=1000),
            trace_decay=1.0,
        ),
        planner=SwitchingPlanner(
            conservative=CBBAPlanner(variant="conservative"),
            aggressive=CBBAPlanner(variant="aggressive"),
        ),
        risk=MonteCarloRiskAnalyzer(risk_tolerance=0.4),
        model=ApproximateModel(
            domain=domain, initial_noise=0.3, prior_weight=20.0, is_adaptive=True
        ),
        index=HashedTabular(capacity=200_000),
        num_known_visits=2,
        veto_reward=-1750.0,
    )


@pytest.mark.parametrize("compiled", [False, True])
def test_a_box_maps_only_the_rows_its_run_reached(compiled):
    domain = UAVMission(scenario="uav-7-2", traverse_failure=0.05)
    agent = _am_icca().setup(domain.domain_spec, 1)
    stepper = for_combination(domain, agent, seed=1) if compiled else None
    (stepper or LearningLoop(domain, agent, seed=1)).advance(2_000)
    learner = agent.learner_
    assert agent.num_policy_changes_ >= 1  # the counts were reset
    assert 0 < agent.index_.num_stored_ < 2_000
    tables = {
        "θ": learner.weights_,
        "trace slots": learner.trace_slots_,
        "counts": agent.counts_,
    }
    for name, table in tables.items():  # 37-78 MB each at capacity 200,000
        assert table.nbytes > 30 * 2**20
        assert 0 < _resident_fraction(table) < 0.1, name  # the rows written, not the rest
