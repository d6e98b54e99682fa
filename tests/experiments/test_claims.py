"""Run claims: one owner per run, taken over from dead or silent owners, split by drivers."""

from __future__ import annotations

import errno
import io
import json
import os
import socket
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest
from rich.console import Console

from conjure.experiments.claims import CLAIMS_DIR, Claims, Owner, process_start
from conjure.experiments.parallel import _say_held
from conjure.experiments.results import RUNS_DIR

ROOT = Path(__file__).resolve().parents[2]


def plant(
    out: Path, identifier: str, host: str, pid: int, age_s: float = 0.0, **started: str
) -> Path:
    """A claim of another driver renewed ``age_s`` seconds ago (``started=...``: its start)."""
    path = out / CLAIMS_DIR / f"{identifier}.claim"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps({"host": host, "pid": pid, "token": "theirs", **started}))
    if age_s:
        stamp = path.stat().st_mtime - age_s
        os.utime(path, (stamp, stamp))
    return path


def dead_pid() -> int:
    child = subprocess.Popen([sys.executable, "-c", "pass"])
    child.wait()
    return child.pid


def test_a_claim_is_held_by_one_driver_until_released(tmp_path):
    with Claims(tmp_path) as first, Claims(tmp_path) as second:
        parent = os.getppid()  # alive
        second.owner = Owner(first.owner.host, parent, "another driver", process_start(parent))
        assert first.take("r1") and first.take("r1")  # idempotent for its owner
        assert not second.take("r1")
        assert second.holders(["r1", "r2"]) == {first.owner: 1}
        first.release("r1")
        assert second.take("r1")
        assert not first.take("r1")
    assert not (tmp_path / CLAIMS_DIR).exists()  # every claim released, the folder removed


def test_the_last_driver_out_removes_the_empty_claims_folder(tmp_path):
    with Claims(tmp_path) as first:
        with Claims(tmp_path) as second:
            assert first.take("r1") and second.take("r2")
        assert (tmp_path / CLAIMS_DIR / "r1.claim").is_file()
        (tmp_path / CLAIMS_DIR / "r1.claim").unlink()  # as if released elsewhere
        (tmp_path / CLAIMS_DIR).rmdir()  # a driver that left removed the emptied folder
        assert first.take("r3")
    assert not (tmp_path / CLAIMS_DIR).exists()


def test_claims_of_dead_or_silent_owners_are_taken_over(tmp_path):
    host = socket.gethostname()
    with Claims(tmp_path, lease_seconds=60) as claims:
        plant(tmp_path, "dead", host, dead_pid())
        plant(tmp_path, "alive", host, os.getppid())
        plant(tmp_path, "silent", "elsewhere", 1, age_s=120)  # no renewal for two leases
        plant(tmp_path, "renewed", "elsewhere", 1, age_s=10)
        assert claims.take("dead") and claims.take("silent")
        assert not claims.take("alive") and not claims.take("renewed")
        text = (tmp_path / CLAIMS_DIR / "dead.claim").read_text()
        assert json.loads(text)["token"] == claims.owner.token
        assert claims.holders(["dead", "alive", "silent", "renewed"]) == {
            Owner(host, os.getppid(), "theirs"): 1,
            Owner("elsewhere", 1, "theirs"): 1,
        }


@pytest.mark.skipif(process_start(1) is None, reason="no process start in /proc")
def test_a_claim_whose_process_id_was_reused_is_taken_over(tmp_path):
    # Issue 20 audit: a claim naming this host and pid 1 (its driver gone with a container
    # restart, the id reused) made a resume wait forever.
    host = socket.gethostname()
    boot, _, ticks = process_start(1).rpartition(":")
    with Claims(tmp_path) as claims:
        plant(tmp_path, "reused", host, 1, started=f"{boot}:{int(ticks) + 1}")
        plant(tmp_path, "other boot", host, 1, started=f"another-boot:{ticks}")
        plant(tmp_path, "same", host, 1, started=process_start(1))
        assert claims.take("reused") and claims.take("other boot")
        assert not claims.take("same")


def test_a_claim_naming_no_start_lives_on_its_lease_on_this_host_too(tmp_path):
    host = socket.gethostname()
    with Claims(tmp_path, lease_seconds=60) as claims:
        plant(tmp_path, "silent", host, 1, age_s=120)  # written without a start, not renewed
        plant(tmp_path, "renewed", host, 1, age_s=10)
        assert claims.take("silent") and not claims.take("renewed")


def test_a_claim_that_cannot_be_written_is_not_left_empty(tmp_path, monkeypatch):
    def no_space(*args, **kwargs):
        raise OSError(errno.ENOSPC, "No space left on device")

    with Claims(tmp_path) as claims:
        monkeypatch.setattr(json, "dump", no_space)
        with pytest.raises(OSError) as caught:
            claims.take("r")
    assert caught.value.filename == str(tmp_path / CLAIMS_DIR / "r.claim")
    assert not (tmp_path / CLAIMS_DIR).exists()


def test_the_held_runs_line_counts_from_one_look_at_the_claims(tmp_path):
    # Issue 20 audit: "4 run(s) are held by another driver (vm:16833 holds 2)", or "(ending)".
    host, parent = socket.gethostname(), os.getppid()
    for identifier in ("a", "b", "c"):
        plant(tmp_path, identifier, host, parent, started=process_start(parent))
    output = io.StringIO()
    with Claims(tmp_path) as claims:
        (tmp_path / CLAIMS_DIR / "c.claim").unlink()  # finished meanwhile
        console = Console(file=output, width=200)
        assert _say_held(claims.holders(["a", "b", "c"]), console)
        assert not _say_held(claims.holders(["c"]), console)  # none held: nothing to say
    assert output.getvalue().splitlines() == [
        f"2 run(s) are held by another driver ({host}:{parent} holds 2); waiting for them "
        "(this driver runs any whose owner stops)."
    ]


def test_a_claim_being_written_is_not_stolen(tmp_path):
    path = tmp_path / CLAIMS_DIR / "r.claim"
    path.parent.mkdir()
    path.write_text("")  # created, owner not yet written
    with Claims(tmp_path) as claims:
        assert not claims.take("r")
        stamp = path.stat().st_mtime - 60
        os.utime(path, (stamp, stamp))  # abandoned half-way
        assert claims.take("r")


DRIVER = textwrap.dedent(
    """
    import sys
    from sweep_fakes import fake_sweep, run_with_fakes, register_fakes
    from conjure.experiments.executors import LocalExecutor
    from conjure.sweeps.sweep import run_sweep
    register_fakes()
    sweep = fake_sweep(
        domains={"slow": {"kind": "LoggedWalk", "params": {"sleep_s": 0.01,
                                                            "start_log": sys.argv[2]}}},
        agents={"a": {"kind": "FakeAgent", "params": {}}},
        grid={"agents.a.params.step_size": [0.1, 0.3, 0.5, 0.7]},
        seeds=3,
    )
    outcome = run_sweep(sweep, sys.argv[1], executor=LocalExecutor(max_workers=1),
                        run_fn=run_with_fakes, progress=True)
    print("RESULTS", outcome.results["run_id"].nunique())
    """
)


@pytest.mark.slow
def test_two_drivers_on_one_folder_split_the_runs(tmp_path):
    # Issue 20: two `conjure sweep` on one --out both ran 12 of 12 runs.
    out, log = tmp_path / "out", tmp_path / "starts"
    fakes = ROOT / "tests" / "experiments"
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(fakes), str(ROOT / "src")])}
    drivers = [
        subprocess.Popen(
            [sys.executable, "-c", DRIVER, str(out), str(log)],
            env=env,
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            text=True,
        )
        for _ in range(2)
    ]
    outputs = [driver.communicate(timeout=240)[0] for driver in drivers]
    assert [driver.returncode for driver in drivers] == [0, 0], outputs
    starts = log.read_text().split()
    by_driver = {pid: starts.count(pid) for pid in set(starts)}
    assert len(starts) == 2 * 12, by_driver  # each run (a learning and an evaluation walk) once
    assert len(by_driver) == 2, by_driver  # both drivers worked
    assert all("RESULTS 12" in text for text in outputs)  # each reports all 12 runs
    assert len(list((out / RUNS_DIR).glob("*.json"))) == 12
    assert not (out / CLAIMS_DIR).exists()
