"""Tests of the metric ranges confidence intervals are cut at."""

from __future__ import annotations

import math

import pandas as pd

from conjure.agents import SARSA
from conjure.domains import ChainMDP, GridWorld
from conjure.experiments.metric_ranges import (
    clip_interval,
    describe_range,
    domain_bounds,
    metric_range,
)
from conjure.experiments.run import run
from conjure.representations import Tabular


def runs(**columns) -> pd.DataFrame:
    return pd.DataFrame(columns)


def test_rates_and_fractions_lie_in_zero_one_whatever_the_domain():
    frame = runs(seed=[0, 1])
    assert metric_range(frame, "failure_rate") == (0.0, 1.0)
    assert metric_range(frame, "optimality") == (0.0, 1.0)  # issue 21: a band reached 1.75
    assert metric_range(frame, "value_ratio") == (-math.inf, 1.0)
    assert metric_range(frame, "learning_failures") == (0.0, math.inf)
    assert metric_range(frame, "return") == (-math.inf, math.inf)  # nothing declared


def test_the_episode_cap_and_value_bounds_a_domain_declares_bound_its_metrics():
    # Issue 21: a pendulum band reached 3,170 steps above its 3,000-step cap.
    pendulum = runs(**domain_bounds(3000, None), seed=[0])
    assert metric_range(pendulum, "episode_length") == (0.0, 3000.0)
    assert metric_range(pendulum, "return") == (-math.inf, math.inf)
    uav = runs(seed=[0, 1], **{k: [v, v] for k, v in domain_bounds(40, (-2.0, 0.8)).items()})
    assert metric_range(uav, "return") == (-2.0, 0.8)
    assert metric_range(uav, "value_ratio") == (-2.5, 1.0)  # worst / best, and V/V* <= 1


def test_runs_shown_together_take_the_union_and_an_undeclared_run_leaves_it_open():
    two_domains = runs(max_episode_steps=[100.0, 3000.0], worst_return=[-1.0, -5.0])
    assert metric_range(two_domains, "episode_length") == (0.0, 3000.0)
    assert metric_range(two_domains, "return") == (-5.0, math.inf)
    old_and_new = runs(max_episode_steps=[3000.0, math.nan])  # a run recorded before ranges
    assert metric_range(old_and_new, "episode_length") == (0.0, math.inf)


def test_clip_interval_and_describe_range():
    assert clip_interval(2 / 3, 1.43, (0.0, 1.0)) == (0.0, 1.0)
    assert clip_interval(1.2, 0.1, (0.0, 1.0)) == (1.0, 1.0)  # a mean past its range
    assert all(math.isnan(end) for end in clip_interval(0.5, math.nan, (0.0, 1.0)))
    assert describe_range((0.0, 3000.0)) == "[0, 3,000]"
    assert describe_range((-math.inf, 1.0)) == "(-inf, 1]"


def test_return_bounds_cut_the_return_only_and_the_tighter_declared_range_wins():
    # Issue 21: GridWorld-1 (return <= 1) printed `0.543 ± 1.226`; a chain band reached 47.
    grid = runs(**domain_bounds(1000, None, (-1.999, 1.0)), seed=[0])
    assert metric_range(grid, "return") == (-1.999, 1.0)
    assert metric_range(grid, "optimality") == (0.0, 1.0)  # never scaled by return bounds
    assert metric_range(grid, "value_ratio") == (-math.inf, 1.0)
    both = runs(**domain_bounds(40, (-2.0, 0.8), (-5.0, 3.0)), seed=[0])
    assert metric_range(both, "return") == (-2.0, 0.8)
    assert metric_range(both, "value_ratio") == (-2.5, 1.0)


def test_a_run_on_gridworld_and_the_chain_records_what_an_episode_can_return():
    chain = ChainMDP(num_states=8)
    for domain, bounds in ((GridWorld.gridworld_1(), (-1.999, 1.0)), (chain, (0.0, 7.0))):
        assert domain.value_bounds() is None  # optimality stays undefined there
        agent = SARSA(representation=Tabular())
        result = run(domain=domain, agent=agent, budget_steps=200, seed=0, num_policy_checks=1)
        declared = result.domain_bounds
        assert (declared["lowest_return"], declared["highest_return"]) == bounds
        assert "worst_return" not in declared
        returns = [row["return"] for row in result.rows]
        assert all(bounds[0] <= r <= bounds[1] for r in returns)
