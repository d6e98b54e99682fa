"""Tests of `conjure tune`: a small study, clear errors, and a trial whose process was killed."""

from __future__ import annotations

import os
import re
import signal
import sqlite3
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pandas as pd
import pytest
from sweep_fakes import fake_sweep, isolated_fakes, run_with_fakes

from conjure.core.errors import InvalidParameterError

optuna = pytest.importorskip("optuna")

from conjure.sweeps.tune import parse_tune, tune  # noqa: E402

HERE = Path(__file__).resolve().parents[1] / "experiments"  # sweep_fakes and test_loop
ROOT = HERE.parents[1]

pytestmark = pytest.mark.usefixtures(isolated_fakes.__name__)


def tune_config(**search):
    sweep = fake_sweep(
        domains=None,
        domain={"kind": "FakeWalk", "params": {"length": 4}},
        agents={"a": {"kind": "FakeAgent", "params": {}}},
        seeds=2,
    )
    del sweep["grid"], sweep["domains"]
    space = {"agents.a.params.step_size": {"low": 0.1, "high": 1.0, "log": True}}
    return {**sweep, "search": {"space": space, "num_trials": 3, **search}}


def test_tune_runs_trials_and_continues(tmp_path):
    table = tune(tune_config(), tmp_path, max_workers=1, run_fn=run_with_fakes, progress=False)
    assert table.loc[0, "num_complete"] == 3 and table.loc[0, "study"] == "fake_sweep.a"
    trials = pd.read_csv(tmp_path / "trials.csv")
    assert (trials["state"] == "COMPLETE").sum() == 3
    assert "agents.a.params.step_size" in (tmp_path / "best.yaml").read_text()
    assert len(list((tmp_path / "runs").glob("*.json"))) == 3 * 2
    again = tune(tune_config(), tmp_path, max_workers=1, run_fn=run_with_fakes, progress=False)
    assert again.loc[0, "num_complete"] == 3  # nothing more to do


def test_tuned_values_print_short(tmp_path):
    # Issue 21: values such as 0.05002000000000905 were echoed back whole.
    from rich.console import Console

    console = Console(width=200, record=True)
    tune(tune_config(), tmp_path, max_workers=1, run_fn=run_with_fakes, console=console)
    text = console.export_text()
    assert "trial 2: COMPLETE" in text and "agents.a.params.step_size=0." in text
    assert not re.search(r"\d\.\d{7,}", text), text


def test_bad_search_configs_are_clear():
    bad_key = tune_config()
    bad_key["search"]["space"] = {"agents.a.params.step_sise": {"low": 0.1, "high": 1.0}}
    with pytest.raises(InvalidParameterError, match="Did you mean 'step_size'"):
        parse_tune(bad_key)
    with pytest.raises(InvalidParameterError, match="low < high"):
        parse_tune(tune_config(space={"agents.a.params.step_size": {"low": 1.0, "high": 0.1}}))
    with pytest.raises(InvalidParameterError, match="Did you mean 'num_trials'"):
        parse_tune(tune_config(num_trial=3))


DRIVER = textwrap.dedent(
    """
    import sys
    from sweep_fakes import register_fakes, run_with_fakes
    from conjure.sweeps.tune import tune
    register_fakes()
    config = eval(sys.argv[2])
    tune(config, sys.argv[1], max_workers=1, run_fn=run_with_fakes, progress=False)
    """
)


@pytest.mark.slow
def test_trial_of_a_killed_process_is_failed_and_retried(tmp_path):
    config = tune_config(num_trials=1, heartbeat_interval=1, grace_period=1)
    config["domain"] = {"kind": "SlowWalk", "params": {"length": 4, "sleep_s": 0.05}}
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(HERE), str(ROOT / "src")])}
    driver = subprocess.Popen([sys.executable, "-c", DRIVER, str(tmp_path), repr(config)], env=env)
    database = tmp_path / "optuna.db"
    try:
        deadline = time.monotonic() + 60
        while True:
            assert driver.poll() is None and time.monotonic() < deadline
            if database.is_file():
                with sqlite3.connect(database) as db:
                    try:
                        beats = db.execute("select count(*) from trial_heartbeats").fetchone()[0]
                        params = db.execute("select count(*) from trial_params").fetchone()[0]
                    except sqlite3.OperationalError:
                        beats = params = 0
                if beats and params:  # the trial is running and has drawn its parameters
                    break
            time.sleep(0.1)
        driver.send_signal(signal.SIGKILL)
        driver.wait()
    finally:
        if driver.poll() is None:
            driver.kill()
    time.sleep(3.0)  # well past the grace period, even on a loaded machine
    config["domain"]["params"]["sleep_s"] = 0.05  # the same trial parameters and runs
    tune(config, tmp_path, max_workers=1, run_fn=run_with_fakes, progress=False)
    trials = pd.read_csv(tmp_path / "trials.csv")
    assert trials.loc[0, "state"] == "FAIL"
    retried = trials[trials["retry_of"] == 0]
    assert len(retried) == 1 and retried["state"].item() == "COMPLETE"
    assert (
        retried["param.agents.a.params.step_size"].item()
        == trials.loc[0, "param.agents.a.params.step_size"]
    )
