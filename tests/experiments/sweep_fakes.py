"""Fakes for the sweep, executor and tuning tests, importable by worker processes.

`run_with_fakes` registers the fake components (in whichever process runs it) and runs a
resolved config; pass it as ``run_fn``. For Ray (whose workers do not share the test's
``sys.path``), `pickle_fakes_by_value` makes cloudpickle ship these modules by value.
"""

from __future__ import annotations

import math
import os
import signal
import time
from pathlib import Path
from typing import Any

import numba
import numpy as np
import pytest
from test_loop import FakeAgent, FakeWalk

from conjure.core import files
from conjure.experiments import registry
from conjure.experiments.run import run_resolved


class SlowWalk(FakeWalk):
    """FakeWalk that sleeps ``sleep_s`` per step (to have runs in flight when killed)."""

    def __init__(self, *, length: int = 5, max_episode_steps: int = 50, sleep_s: float = 0.0):
        super().__init__(length=length, max_episode_steps=max_episode_steps)
        self.sleep_s = sleep_s

    def step(self, action: int):
        if self.sleep_s:
            time.sleep(self.sleep_s)
        return super().step(action)


class LoggedWalk(SlowWalk):
    """SlowWalk that appends its process id to ``start_log`` on its first reset (a run began)."""

    def __init__(self, *, length: int = 5, sleep_s: float = 0.0, start_log: str = ""):
        super().__init__(length=length, sleep_s=sleep_s)
        self.start_log = start_log
        self._is_logged = False

    def reset(self, *, seed=None, options=None):
        if not self._is_logged:
            with open(self.start_log, "a") as log:
                log.write(f"{os.getpid()}\n")
            self._is_logged = True
        return super().reset(seed=seed, options=options)


class KillerAgent(FakeAgent):
    """FakeAgent that SIGKILLs its own process once (first setup, marked by a file), or always.

    Never in process ``spare_pid`` (the test process).
    """

    def __init__(
        self,
        *,
        step_size: float = 0.5,
        kill_marker: str | None = None,
        spare_pid: int = 0,
        kill_every_time: bool = False,
    ):
        super().__init__(step_size=step_size)
        self.kill_marker = kill_marker
        self.spare_pid = spare_pid
        self.kill_every_time = kill_every_time

    def setup(self, spec, seed):
        if os.getpid() != self.spare_pid:
            if self.kill_every_time:
                os.kill(os.getpid(), signal.SIGKILL)
            if self.kill_marker and not Path(self.kill_marker).exists():
                Path(self.kill_marker).write_text(str(os.getpid()))
                os.kill(os.getpid(), signal.SIGKILL)
        return super().setup(spec, seed)


class LoggedAgent(FakeAgent):
    """FakeAgent that appends a line to the file ``start_log`` whenever a run sets it up."""

    def __init__(self, *, step_size: float = 0.5, start_log: str = ""):
        super().__init__(step_size=step_size)
        self.start_log = start_log

    def setup(self, spec, seed):
        with open(self.start_log, "a") as log:
            log.write(f"{os.getpid()}\n")
        return super().setup(spec, seed)


class HogAgent(LoggedAgent):
    """LoggedAgent that allocates and fills ``num_bytes`` at setup (a table too big for memory)."""

    def __init__(self, *, step_size: float = 0.5, start_log: str = "", num_bytes: int = 0):
        super().__init__(step_size=step_size, start_log=start_log)
        self.num_bytes = num_bytes

    def setup(self, spec, seed):
        super().setup(spec, seed)
        self.table_ = np.ones(self.num_bytes, dtype=np.uint8)
        return self


def kill_self(_: Any) -> None:
    os.kill(os.getpid(), signal.SIGKILL)


@numba.njit(cache=False)
def _spin(num_iterations: int) -> float:
    """A compiled loop that holds the GIL for as long as it runs."""
    total = 0.0
    for i in range(num_iterations):
        total += math.sqrt(i) * 1e-9
    return total


def spin(marker_dir: str) -> float:
    """Compile `_spin`, write this process's id under ``marker_dir``, then spin for minutes."""
    _spin(10)
    (Path(marker_dir) / str(os.getpid())).write_text("spinning")
    return _spin(10**13)


def register_fakes() -> None:
    registry.AGENTS.setdefault("FakeAgent", FakeAgent)
    registry.AGENTS.setdefault("KillerAgent", KillerAgent)
    registry.AGENTS.setdefault("LoggedAgent", LoggedAgent)
    registry.AGENTS.setdefault("HogAgent", HogAgent)
    registry.DOMAINS.setdefault("FakeWalk", FakeWalk)
    registry.DOMAINS.setdefault("SlowWalk", SlowWalk)
    registry.DOMAINS.setdefault("LoggedWalk", LoggedWalk)


def run_with_fakes(spec: dict[str, Any]):
    register_fakes()
    return run_resolved(spec)


def pickle_fakes_by_value() -> None:
    import cloudpickle
    import sweep_fakes
    import test_loop

    cloudpickle.register_pickle_by_value(test_loop)
    cloudpickle.register_pickle_by_value(sweep_fakes)


def fake_sweep(**overrides: Any) -> dict[str, Any]:
    sweep = {
        "name": "fake_sweep",
        "domains": {
            "short": {"kind": "FakeWalk", "params": {"length": 4, "max_episode_steps": 12}},
            "long": {"kind": "FakeWalk", "params": {"length": 6, "max_episode_steps": 12}},
        },
        "agents": {
            "a": {"kind": "FakeAgent", "params": {"step_size": 0.5}},
            "b": {"kind": "FakeAgent", "params": {}},
        },
        "grid": {"agents.a.params.step_size": [0.1, 0.9]},
        "budget_steps": 60,
        "num_policy_checks": 3,
        "seeds": 2,
    }
    sweep.update(overrides)
    return sweep


@pytest.fixture
def isolated_fakes(monkeypatch):
    """Register the fakes in copies of the registries (restored after the test)."""
    monkeypatch.setattr(registry, "AGENTS", registry.AGENTS.copy())
    monkeypatch.setattr(registry, "DOMAINS", registry.DOMAINS.copy())
    layers = {**registry.LAYERS, "agent": registry.AGENTS, "domain": registry.DOMAINS}
    monkeypatch.setattr(registry, "LAYERS", layers)
    register_fakes()


def fail_writes(monkeypatch: pytest.MonkeyPatch, name: str, code: int) -> None:
    """Make every atomic write of a file called ``name`` fail as the disk would (``code``).

    Like a full disk (or a file-size limit) the failure comes from the write itself, which
    names no file.
    """
    real_open = open

    def failing_open(file: Any, mode: str = "r", *args: Any, **kwargs: Any) -> Any:
        handle = real_open(file, mode, *args, **kwargs)
        if Path(file).name.startswith(f".{name}.tmp-"):
            handle.close()
            raise OSError(code, os.strerror(code))
        return handle

    monkeypatch.setattr(files, "open", failing_open, raising=False)
