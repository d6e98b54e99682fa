"""Run claims: drivers sharing one results folder split its runs instead of repeating them.

Before a driver starts a run it takes the run's claim, ``OUT/claims/<run_id>.claim``, a file
created atomically (``O_CREAT | O_EXCL``) that names its owner: host, process id, the
process's start (`process_start`) and a token unique to the driver. A claim is *live* while
its owner is: on the owner's own host, while a process with that id *and that start* exists
(a process that merely reuses the id, after a reboot or a container restart, is not the
owner); from another host (a shared file system), or when the start cannot be compared, while
the owner keeps renewing it (a heartbeat thread touches every claim it holds, so its
modification time stays within the lease). A run whose claim is held by a live owner is left
to that owner; a claim whose owner died or whose lease expired is taken over. The result
file, not the claim, says that a run is finished: a claim is released when its run's result
or error file is written, and every claim a driver holds when it stops.

Notes
-----
- Choice: a takeover first renames the dead owner's claim to a name unique to the taker
  (``os.rename`` succeeds for one process only), then creates its own claim with
  ``O_EXCL``; two drivers that find the same dead claim therefore never both run the run.
- Choice: the lease is 10 minutes, renewed every 2; owners on this host depend on it only
  where ``/proc`` gives no process start (not Linux) or the claim names none.
- Choice: a claim that cannot be written (disk full) is removed, never left empty, and the
  `OSError` names the claim file.
- Choice: a driver removes the claims folder on exit when it is empty (a finished folder
  keeps no empty ``claims/``); a driver that then finds it gone creates it again.
"""

from __future__ import annotations

import dataclasses
import json
import os
import socket
import threading
import time
import uuid
from collections import Counter
from contextlib import suppress
from dataclasses import dataclass
from pathlib import Path

__all__ = ["CLAIMS_DIR", "Claims", "Owner", "process_exists", "process_start"]

CLAIMS_DIR = "claims"
LEASE_SECONDS = 600.0
_SUFFIX = ".claim"
_WRITING_SECONDS = 10.0


@dataclass(frozen=True)
class Owner:
    """Who holds a claim: a driver process on a host, with a token unique to that driver.

    ``started`` is the process's start (`process_start`), ``None`` where it is unknown.
    """

    host: str
    pid: int
    token: str
    started: str | None = None

    def __str__(self) -> str:
        return f"{self.host}:{self.pid}"


class Claims:
    """The claims one driver holds in a results folder (a context manager that releases them).

    Parameters
    ----------
    out_dir : str or Path
        The results folder.
    lease_seconds : float, default 600
        How long a claim of another host's driver stays live without being renewed.
    """

    def __init__(self, out_dir: str | Path, lease_seconds: float = LEASE_SECONDS):
        self.folder = Path(out_dir) / CLAIMS_DIR
        self.lease_seconds = lease_seconds
        pid = os.getpid()
        self.owner = Owner(socket.gethostname(), pid, uuid.uuid4().hex, process_start(pid))
        self._held: set[str] = set()
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._heartbeat: threading.Thread | None = None

    def __enter__(self) -> Claims:
        self.folder.mkdir(parents=True, exist_ok=True)
        self._heartbeat = threading.Thread(
            target=self._renew_forever, name="conjure-claims-heartbeat", daemon=True
        )
        self._heartbeat.start()
        return self

    def __exit__(self, *exc_info: object) -> None:
        self._stop.set()
        for identifier in list(self._held):
            self.release(identifier)
        with suppress(OSError):  # left in place while another driver holds claims in it
            self.folder.rmdir()

    def take(self, identifier: str) -> bool:
        """Claim run ``identifier``; ``False`` if a live driver holds it."""
        path = self._path(identifier)
        if self._create(path):
            return self._hold(identifier)
        holder = self._read(path)
        if holder == self.owner:
            return True
        if self._is_live(path, holder):
            return False
        tomb = path.with_name(f"{path.name}.stale-{self.owner.token}")
        try:
            os.rename(path, tomb)  # only one taker succeeds
        except FileNotFoundError:  # another taker was first, or the owner released it
            return self._hold(identifier) if self._create(path) else False
        tomb.unlink(missing_ok=True)
        return self._hold(identifier) if self._create(path) else False

    def release(self, identifier: str) -> None:
        """Give up the claim of run ``identifier`` (its result or error is written)."""
        with self._lock:
            if identifier not in self._held:
                return
            self._held.discard(identifier)
        path = self._path(identifier)
        if self._read(path) == self.owner:
            path.unlink(missing_ok=True)

    def holders(self, identifiers: list[str]) -> Counter[Owner]:
        """How many of ``identifiers`` each other live driver holds."""
        counts: Counter[Owner] = Counter()
        for identifier in identifiers:
            path = self._path(identifier)
            holder = self._read(path)
            if holder != self.owner and path.exists() and self._is_live(path, holder):
                counts[holder] += 1
        return counts

    def _path(self, identifier: str) -> Path:
        return self.folder / f"{identifier}{_SUFFIX}"

    def _hold(self, identifier: str) -> bool:
        with self._lock:
            self._held.add(identifier)
        return True

    def _create(self, path: Path) -> bool:
        """Create ``path`` naming this driver, atomically; ``False`` if it exists.

        A claim that cannot be written is removed and the `OSError` names ``path``.
        """
        flags = os.O_CREAT | os.O_EXCL | os.O_WRONLY
        try:
            try:
                handle = os.open(path, flags, 0o644)
            except FileNotFoundError:  # another driver removed the emptied folder on its exit
                path.parent.mkdir(parents=True, exist_ok=True)
                handle = os.open(path, flags, 0o644)
        except FileExistsError:
            return False
        except OSError as exc:
            exc.filename = str(path)
            raise
        try:
            with os.fdopen(handle, "w") as stream:
                json.dump(dataclasses.asdict(self.owner), stream)
        except OSError as exc:
            path.unlink(missing_ok=True)
            exc.filename = str(path)
            raise
        return True

    @staticmethod
    def _read(path: Path) -> Owner | None:
        """The owner named in ``path``; ``None`` if it is gone or half written."""
        try:
            fields = json.loads(path.read_text())
            started = fields.get("started")
            return Owner(
                str(fields["host"]),
                int(fields["pid"]),
                str(fields["token"]),
                None if started is None else str(started),
            )
        except (OSError, ValueError, KeyError, TypeError):
            return None

    def _is_live(self, path: Path, holder: Owner | None) -> bool:
        """Whether ``holder`` still runs (its own host), or renewed ``path`` within the lease.

        On this host a process with the holder's id and start is the holder; one with its id
        but another start reused the id of a holder that died. Where either start is unknown,
        the lease decides (after checking that the id exists). An unreadable claim (its owner
        is still writing it) is live for a few seconds.
        """
        if holder is not None and holder.host == self.owner.host:
            if not process_exists(holder.pid):
                return False
            started = process_start(holder.pid)
            if holder.started is not None and started is not None:
                return started == holder.started
        try:
            age = time.time() - path.stat().st_mtime
        except FileNotFoundError:
            return False
        return age < (self.lease_seconds if holder is not None else _WRITING_SECONDS)

    def _renew_forever(self) -> None:
        """Touch every held claim every fifth of the lease, until the driver stops."""
        while not self._stop.wait(self.lease_seconds / 5):
            with self._lock:
                held = list(self._held)
            for identifier in held:
                try:
                    os.utime(self._path(identifier))
                except FileNotFoundError:
                    continue


def process_start(pid: int) -> str | None:
    """When process ``pid`` started: the boot's id and the start in clock ticks since boot.

    Two processes that ever had the same id on a machine differ in it. ``None`` where
    ``/proc`` does not tell (not Linux) or the process is gone.
    """
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
        boot = Path("/proc/sys/kernel/random/boot_id").read_text().strip()
    except OSError:
        return None
    # Fields after the command name (which may hold spaces), from field 3; starttime is 22.
    return f"{boot}:{stat.rpartition(')')[2].split()[19]}"


def process_exists(pid: int) -> bool:
    """Whether a process ``pid`` exists on this host."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # another user's process
        return True
    return True
