"""A lazily indexed box costs memory for the states a run meets, not for its capacity.

θ, SARSA(λ)'s trace slots and Algorithm 24's counts are sized by a `HashedTabular`'s capacity
(rows numbered by first visit); they start as zeros that the operating system maps only when
written, and Algorithm 26's count reset clears only the rows in use. Checked with Linux's
``mincore`` (which pages of an array are resident).
"""

import ctypes
import json
import mmap
import os
import subprocess
import sys
from pathlib import Path

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


def _mapped_fractions(agent: AdaptiveCooperativeLearner) -> dict[str, float]:
    """The resident fraction of θ, the trace slots and the counts after a run of 2,000 steps."""
    learner = agent.learner_
    assert agent.num_policy_changes_ >= 1  # the counts were reset
    assert 0 < agent.index_.num_stored_ < 2_000
    tables = {"θ": learner.weights_, "trace slots": learner.trace_slots_, "counts": agent.counts_}
    assert all(table.nbytes > 30 * 2**20 for table in tables.values())  # 37-78 MB each
    return {name: _resident_fraction(table) for name, table in tables.items()}


def _run(compiled: bool) -> dict[str, float]:
    domain = UAVMission(scenario="uav-7-2", traverse_failure=0.05)
    agent = _am_icca().setup(domain.domain_spec, 1)
    stepper = for_combination(domain, agent, seed=1) if compiled else None
    (stepper or LearningLoop(domain, agent, seed=1)).advance(2_000)
    return _mapped_fractions(agent)


def _fractions_in_fresh_process(compiled: bool) -> dict[str, float]:
    """`_run` in a fresh interpreter: a long-lived process's allocator may serve np.zeros from
    reused heap memory, which calloc clears (and so maps) page by page."""
    code = f"import json, test_lazy_tables as t; print(json.dumps(t._run(compiled={compiled})))"
    here = Path(__file__).resolve()
    paths = [str(here.parent), str(here.parents[2] / "src"), os.environ.get("PYTHONPATH", "")]
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(p for p in paths if p)}
    done = subprocess.run(
        [sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True
    )
    return json.loads(done.stdout.strip().splitlines()[-1])


@pytest.mark.parametrize("compiled", [False, True], ids=["python", "compiled"])
def test_a_box_maps_only_the_rows_its_run_reached(compiled):
    for name, fraction in _fractions_in_fresh_process(compiled).items():
        assert 0 < fraction < 0.1, name  # the rows written, not the rest
