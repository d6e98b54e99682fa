"""Tests of run(): budgets, policy checks, seeding, determinism and divergence."""

from __future__ import annotations

import json
import math
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from test_loop import FakeAgent, FakeWalk

from conjure.agents import SARSA, QLearning
from conjure.core.errors import DivergenceError, InvalidParameterError
from conjure.domains import BlocksWorld, ChainMDP
from conjure.experiments.run import CURVE_COLUMNS, TIMING_COLUMNS, Result, run
from conjure.representations import Tabular


def fake_run(seed: int = 0, **kwargs) -> Result:
    agent_params = kwargs.pop("agent_params", {})
    domain_params = kwargs.pop("domain_params", {})
    defaults = {"budget_steps": 1000, "num_policy_checks": 10}
    return run(
        domain=FakeWalk(length=6, max_episode_steps=15, **domain_params),
        agent=FakeAgent(**agent_params),
        seed=seed,
        **{**defaults, **kwargs},
    )


def without_timing(curve: pd.DataFrame) -> pd.DataFrame:
    return curve.drop(columns=list(TIMING_COLUMNS))


def test_curve_has_one_row_per_check_at_the_right_steps():
    result = fake_run(budget_steps=1000, num_policy_checks=4)
    assert list(result.curve.columns) == list(CURVE_COLUMNS)
    assert result.curve["learning_steps"].tolist() == [0, 250, 500, 750, 1000]
    assert len(result.agent.transitions_) == 1000  # the budget is exact
    assert result.curve["num_features"].tolist() == [1, 3, 6, 8, 11]
    assert np.isnan(result.curve["steps_per_second"].iloc[0])
    assert (result.curve["steps_per_second"].iloc[1:] > 0).all()
    assert result.curve["wall_time_s"].is_monotonic_increasing


def test_uneven_budget_checks_are_floored_and_end_at_the_budget():
    result = fake_run(budget_steps=10, num_policy_checks=3)
    assert result.curve["learning_steps"].tolist() == [0, 3, 6, 10]


def test_greedy_evaluation_is_recorded():
    result = fake_run(eval_episodes=3)
    # The greedy fake walks right; start states are 0, 1 or 2 on a length-6 walk.
    assert result.curve["episode_length"].between(4.0, 6.0).all()
    assert (result.curve["return"] == -result.curve["episode_length"]).all()
    assert result.agent.num_greedy_acts_ > 0


def test_evaluation_does_not_change_learning():
    few = fake_run(seed=3, num_policy_checks=1)
    many = fake_run(seed=3, num_policy_checks=17, eval_episodes=2)

    def trajectory(result):
        return [
            (float(t.state[0]), t.action, t.reward, t.next_action)
            for t in result.agent.transitions_
        ]

    assert trajectory(few) == trajectory(many)
    assert few.curve["learning_episodes"].iloc[-1] == many.curve["learning_episodes"].iloc[-1]


def test_same_seed_same_curve_different_seed_different_learning():
    first, second = fake_run(seed=7), fake_run(seed=7)
    pd.testing.assert_frame_equal(without_timing(first.curve), without_timing(second.curve))
    other = fake_run(seed=8)
    assert [t.action for t in other.agent.transitions_] != [
        t.action for t in first.agent.transitions_
    ]


def test_determinism_across_processes():
    here = Path(__file__).parent
    script = textwrap.dedent(
        f"""
        import sys
        sys.path.insert(0, {str(here)!r})
        from test_run import fake_run, without_timing
        print(without_timing(fake_run(seed=5).curve).to_json())
        """
    )
    out = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, check=True, timeout=120
    ).stdout
    other = json.loads(out.strip().splitlines()[-1])
    mine = json.loads(without_timing(fake_run(seed=5).curve).to_json())
    assert other == mine


def test_divergence_keeps_the_partial_curve_and_names_the_fix():
    with pytest.raises(DivergenceError) as caught:
        fake_run(budget_steps=1000, num_policy_checks=10, agent_params={"diverge_at": 450})
    message = str(caught.value)
    assert "step 450" in message
    assert "step size" in message
    partial = caught.value.partial_result
    assert isinstance(partial, Result)
    assert not partial.is_complete
    assert partial.curve["learning_steps"].tolist() == [0, 100, 200, 300, 400]
    assert "stopped early" in partial.summary()


def test_bad_run_arguments():
    with pytest.raises(InvalidParameterError, match="budget_steps"):
        fake_run(budget_steps=0)
    with pytest.raises(InvalidParameterError, match="num_policy_checks"):
        fake_run(num_policy_checks=0)
    with pytest.raises(InvalidParameterError, match="eval_episodes"):
        fake_run(eval_episodes=0)


def test_result_summary_and_frame():
    result = fake_run(seed=2)
    text = result.summary()
    assert "FakeAgent on FakeWalk, seed 2" in text and "1,000 learning steps" in text
    frame = result.to_frame()
    assert frame["seed"].eq(2).all() and len(frame) == 11


def test_run_config_with_real_components():
    pytest.importorskip("conjure.agents")
    from conjure.experiments.run import run_config

    config = {
        "name": "chain",
        "domain": {"kind": "ChainMDP", "params": {"num_states": 4, "num_actions": 2}},
        "agents": {
            "q": {
                "kind": "QLearning",
                "params": {
                    "representation": {"kind": "Tabular"},
                    "policy": {"kind": "EpsilonGreedy", "params": {"epsilon": 0.2}},
                    "step_size": 0.5,
                },
            }
        },
        "budget_steps": 300,
        "num_policy_checks": 3,
    }
    first = run_config(config, agent_name="q", seed=1)
    second = run_config(config, agent_name="q", seed=1)
    pd.testing.assert_frame_equal(without_timing(first.curve), without_timing(second.curve))
    assert first.config["label"] == "q"
    assert first.config["agent"]["params"]["policy"]["params"]["epsilon"] == 0.2
    assert first.curve["learning_steps"].tolist() == [0, 100, 200, 300]


def test_policy_checks_do_not_perturb_a_real_agent():
    pytest.importorskip("conjure.agents")
    from conjure.agents import SARSA
    from conjure.domains import InvertedPendulum
    from conjure.policies import EpsilonGreedy
    from conjure.representations import TileCoding

    def trained(num_policy_checks):
        agent = SARSA(representation=TileCoding(), policy=EpsilonGreedy(epsilon=0.1))
        run(
            domain=InvertedPendulum(),
            agent=agent,
            budget_steps=1500,
            seed=4,
            num_policy_checks=num_policy_checks,
        )
        return agent.weights_

    np.testing.assert_array_equal(trained(1), trained(9))


def test_safety_metrics_failures_failure_rate_and_optimality():
    walls = {"wall_cost": True, "bounds": (-15.0, -4.0)}
    result = fake_run(num_policy_checks=4, domain_params=walls)
    curve = result.curve
    transitions = result.agent.transitions_
    counts = [sum(t.next_state[0] == 0 for t in transitions[:n]) for n in curve["learning_steps"]]
    assert curve["learning_failures"].tolist() == counts and counts[-1] > 0
    assert curve["learning_cost"].tolist() == [float(c) for c in counts]  # c_t = 1 per failure
    rate = curve["learning_cost"] / curve["learning_steps"]
    assert math.isnan(curve["cost_rate"].iloc[0]) and curve["cost_rate"].iloc[1:].eq(rate[1:]).all()
    assert curve["failure_rate"].eq(0.0).all()  # the greedy fake walks right, away from 0
    assert curve["episode_cost"].eq(0.0).all()
    # Greedy return -(6 - start) for starts 0..2, scaled between worst -15 and best -4.
    np.testing.assert_allclose(curve["optimality"], (curve["return"] + 15.0) / 11.0)
    assert curve["optimality"].between(9 / 11, 1.0).all()
    assert curve["value_ratio"].isna().all()  # V* = −4 ≤ 0: no fraction of the optimum

    above = fake_run(num_policy_checks=4, domain_params={"wall_cost": True, "bounds": (-15, 8)})
    np.testing.assert_allclose(above.curve["value_ratio"], above.curve["return"] / 8.0)

    lefty = fake_run(eval_episodes=3, agent_params={"greedy_action": 0}, domain_params=walls)
    assert lefty.curve["failure_rate"].eq(1.0).all()
    assert lefty.curve["episode_cost"].ge(1.0).all()
    np.testing.assert_allclose(lefty.curve["optimality"], (-15.0 + 15.0) / 11.0)


def test_optimality_is_nan_without_value_bounds_and_bad_bounds_are_refused():
    assert fake_run().curve["optimality"].isna().all()
    assert fake_run().curve["value_ratio"].isna().all()
    assert fake_run().curve["learning_failures"].eq(0).all()
    with pytest.raises(InvalidParameterError, match="value_bounds"):
        fake_run(domain_params={"bounds": (1.0, 1.0)})


def test_a_run_records_the_ranges_its_domain_declares():
    # Issue 21: intervals are cut at the episode cap and the value bounds, so runs keep them.
    from conjure.experiments.run import run_task

    bounded = fake_run(num_policy_checks=2, domain_params={"bounds": (-15.0, -4.0)})
    assert bounded.domain_bounds == {
        "max_episode_steps": 15.0,
        "worst_return": -15.0,
        "best_return": -4.0,
    }
    assert fake_run(num_policy_checks=2).domain_bounds == {"max_episode_steps": 15.0}
    spec = {
        "label": "q",
        "domain": {"kind": "ChainMDP"},
        "agent": {"kind": "QLearning", "params": {"representation": {"kind": "Tabular"}}},
        "budget_steps": 20,
        "seed": 0,
        "num_policy_checks": 1,
        "eval_episodes": 1,
    }
    out = run_task(spec)
    assert out["meta"]["max_episode_steps"] == ChainMDP().domain_spec.max_episode_steps


def test_the_summary_line_prints_numbers_without_exponents():
    # Issue 21: `2e+05` in printed numbers.
    row = {column: 1.0 for column in CURVE_COLUMNS}
    row.update(learning_steps=200000, learning_episodes=40, num_features=3, episode_length=3000.0)
    text = Result([{**row, "return": 200000.0}], seed=0).summary()
    assert "final greedy return 200,000 (best 200,000," in text and "e+" not in text
    assert "episode length 3,000" in text


def test_before_policy_check_is_called_before_every_check():
    result = fake_run(budget_steps=100, num_policy_checks=4)
    checks = [i for i, event in enumerate(result.agent.events_) if event == "check"]
    assert len(checks) == 5
    assert result.agent.steps_at_check_ == [0, 25, 50, 75, 100]


def hand_written_run(domain, agent, *, budget_steps, num_policy_checks, seed):
    """An independent reference of `run`'s documented protocol, written out by hand."""
    from conjure.core.interfaces import Transition
    from conjure.core.seeding import seed_to_int, split_seed

    seeds = split_seed(seed, ("domain", "evaluation", "agent"))
    agent.setup(domain.domain_spec, seeds["agent"])
    eval_domain = domain.clone()
    spec = domain.domain_spec

    def legal(d, s):
        return d.legal_actions(s) if spec.has_action_constraints else None

    def greedy_episode():
        s = eval_domain.reset(seed=seed_to_int(seeds["evaluation"]))[0]
        a = agent.act(s, True, legal(eval_domain, s))
        total = discounted = 0.0
        for t in range(spec.max_episode_steps):
            s, r, terminated, truncated, _ = eval_domain.step(a)
            total, discounted = total + r, discounted + spec.discount**t * r
            if terminated or truncated:
                break
            a = agent.act(s, True, legal(eval_domain, s))
        return total, discounted, t + 1

    rows, steps, episodes, state, action, length = [], 0, 0, None, 0, 0
    domain_seed = seed_to_int(seeds["domain"])
    for i in range(num_policy_checks + 1):
        while steps < budget_steps * i // num_policy_checks:
            if state is None:
                state = domain.reset(seed=domain_seed if episodes == 0 else None)[0].copy()
                agent.begin_episode()
                action, length = agent.act(state, False, legal(domain, state)), 0
            next_state, r, terminated, truncated, _ = domain.step(action)
            next_state, steps, length = next_state.copy(), steps + 1, length + 1
            next_legal = None if terminated else legal(domain, next_state)
            next_action = 0 if terminated else agent.act(next_state, False, next_legal)
            agent.learn(
                Transition(state, action, r, next_state, next_action, terminated, next_legal)
            )
            if terminated or truncated or length >= spec.max_episode_steps:
                state, episodes = None, episodes + 1
            else:
                state, action = next_state, next_action
        agent.before_policy_check()
        rows.append((steps, episodes, *greedy_episode(), agent.num_features))
    return rows


@pytest.mark.parametrize(
    "make",
    [
        lambda: (ChainMDP(num_states=6), SARSA(representation=Tabular(), step_size=0.5)),
        lambda: (
            BlocksWorld(num_blocks=3, max_episode_steps=40),
            QLearning(representation=Tabular(), step_size=0.3),
        ),
    ],
    ids=["chain-sarsa", "blocksworld-q-legal-actions"],
)
def test_run_takes_the_same_steps_as_a_hand_written_loop(make):
    domain, agent = make()
    curve = run(domain=domain, agent=agent, budget_steps=700, num_policy_checks=7, seed=3).curve
    domain, agent = make()
    expected = hand_written_run(domain, agent, budget_steps=700, num_policy_checks=7, seed=3)
    columns = [
        "learning_steps",
        "learning_episodes",
        "return",
        "discounted_return",
        "episode_length",
        "num_features",
    ]
    assert len(curve) == len(expected) == 8
    np.testing.assert_allclose(curve[columns].to_numpy(float), np.array(expected), rtol=1e-12)
    assert curve["learning_episodes"].iloc[-1] > 0  # episodes ended and restarted


def test_a_worker_imports_neither_pandas_nor_scipy_stats_nor_rich():
    from fresh_python import python

    result = python(
        "import sys\n"
        "from conjure.experiments.run import run_task\n"
        "out = run_task({'label': 'q', 'domain': {'kind': 'ChainMDP'}, 'agent': {'kind': "
        "'QLearning', 'params': {'representation': {'kind': 'Tabular'}}}, 'budget_steps': 20, "
        "'seed': 0, 'num_policy_checks': 1, 'eval_episodes': 1})\n"
        "assert out['error'] is None, out['error']\n"
        "print(sorted(m for m in ('pandas', 'scipy.stats', 'rich') if m in sys.modules))"
    )
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip() == "[]"


def test_a_failing_run_task_returns_its_error_as_data():
    from conjure.experiments.run import run_task

    out = run_task({"label": "x", "domain": {"kind": "NoSuchDomain"}})
    assert out["curve"] is None and "NoSuchDomain" in out["message"]


def test_a_run_says_which_path_its_learning_steps_took(monkeypatch):
    # Issue 22: the fast path was chosen silently, and an option it lacks fell back unseen.
    from conjure.agents import ActorCritic
    from conjure.experiments import loop
    from conjure.experiments.run import run_task

    monkeypatch.setattr(loop, "compile_pays", lambda *args, **kwargs: True)  # even a short run
    compiled = run(
        domain=ChainMDP(), agent=SARSA(representation=Tabular()), budget_steps=200, seed=0
    )
    assert compiled.path == "compiled" and "(compiled path)" in compiled.summary()
    separate = ActorCritic(representation=Tabular(), actor_representation=Tabular())
    python = run(domain=ChainMDP(), agent=separate, budget_steps=200, seed=0)
    assert python.path.startswith("python: ActorCritic with these parameters has no compiled")
    assert "sharing the critic's features" in python.path
    fake = run(domain=FakeWalk(), agent=FakeAgent(), budget_steps=50, seed=0)
    assert fake.path == "python: the domain FakeWalk has no compiled kernel"
    monkeypatch.setattr(loop, "compile_pays", lambda *args, **kwargs: False)
    cold = loop.learning_stepper(
        ChainMDP(),
        SARSA(representation=Tabular()).setup(ChainMDP().domain_spec, 0),
        budget_steps=100,
    )
    assert cold.path == "compiled" or "would not earn the compile back" in cold.path
    spec = {
        "domain": {"kind": "ChainMDP"},
        "agent": {
            "kind": "ActorCritic",
            "params": {
                "representation": {"kind": "Tabular"},
                "actor_representation": {"kind": "Tabular"},
            },
        },
        "budget_steps": 100,
        "num_policy_checks": 1,
        "eval_episodes": 1,
        "seed": 0,
    }
    assert run_task(spec)["meta"]["path"].startswith("python: ActorCritic with these")


def test_compile_steps_weighs_a_cold_compile_against_more_than_the_run(monkeypatch):
    # A thesis-scale sweep of 10⁵-step runs on a fresh machine ran every run in Python: no run
    # alone earned the compile back, and the warm-up's tiny runs never compiled.
    import conjure.compiled
    from conjure.experiments import loop

    monkeypatch.setattr(conjure.compiled, "is_warm", lambda stepper=None: False)
    short = {"domain": ChainMDP(), "budget_steps": 100, "seed": 0}
    python = run(agent=SARSA(representation=Tabular()), **short)
    assert "would not earn the compile back" in python.path
    steps = loop.COMPILE_WORTH_STEPS
    compiled = run(agent=SARSA(representation=Tabular()), compile_steps=steps, **short)
    assert compiled.path == "compiled"
    timing = ["wall_time_s", "steps_per_second"]
    curves = [pd.DataFrame(r.rows).drop(columns=timing) for r in (compiled, python)]
    pd.testing.assert_frame_equal(*curves)  # the same steps either way (NaN equal to NaN)


def test_a_restored_agent_is_evaluated_as_saved_and_learns_on_only_when_asked(tmp_path):
    from conjure.experiments.run import evaluate

    def chain():
        return ChainMDP(num_states=6, num_actions=2)

    def learn(agent, **options):
        return run(domain=chain(), agent=agent, budget_steps=300, seed=3, **options)

    agent = QLearning(representation=Tabular(), step_size=0.5)
    trained = learn(agent, num_policy_checks=1)
    agent.save(tmp_path / "agent")
    restored = QLearning.restore(tmp_path / "agent")
    scores = evaluate(domain=chain(), agent=restored, seed=5, num_episodes=2)
    assert scores == evaluate(domain=chain(), agent=agent, seed=5, num_episodes=2)
    assert set(scores) < set(CURVE_COLUMNS)
    # Learning on: the first check sees the saved policy (the same evaluation seed), and the
    # restored agent learns on exactly as the original does.
    more = learn(restored, num_policy_checks=1, continue_learning=True)
    assert more.rows[0]["return"] == trained.rows[-1]["return"]
    learn(agent, num_policy_checks=1, continue_learning=True)
    np.testing.assert_array_equal(restored.weights_, agent.weights_)
    # Without it the agent starts afresh, and says so.
    fresh = learn(QLearning(representation=Tabular(), step_size=0.5), num_policy_checks=1)
    with pytest.warns(UserWarning, match="continue_learning=True"):
        again = learn(restored, num_policy_checks=1)
    assert again.rows == [dict(row, **{c: again.rows[i][c] for c in TIMING_COLUMNS})
                          for i, row in enumerate(fresh.rows)]  # fmt: skip
