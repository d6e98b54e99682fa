"""Files written whole or not at all: `write_atomic`, the one writer of results and agents.

Notes
-----
- Choice: a file gets the mode ``open`` gives a new file (0666 less the umask, usually 0644),
  whether it holds a run's results or a saved agent: neither holds secrets.
"""

from __future__ import annotations

import os
import socket
import uuid
from pathlib import Path

__all__ = ["TEMP_MARK", "write_atomic"]

#: Marks a temporary file of `write_atomic`: ``.<name>.tmp-<host>-<pid>-<random>``.
TEMP_MARK = ".tmp-"


def write_atomic(path: str | Path, data: str | bytes) -> Path:
    """Write ``data`` to ``path`` via a fsynced temporary file and ``os.replace``.

    The temporary name is unique per host, process and call, so concurrent writers (several
    drivers, or nodes sharing a file system) never collide; the last complete write wins. An
    `OSError` of the write (disk full, file-size limit) names ``path``, not the temporary.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    unique = f"{socket.gethostname()}-{os.getpid()}-{uuid.uuid4().hex[:8]}"
    temp = path.with_name(f".{path.name}{TEMP_MARK}{unique}")
    payload = data.encode() if isinstance(data, str) else data
    try:
        with open(temp, "wb") as handle:
            handle.write(payload)
            handle.flush()
            os.fsync(handle.fileno())
        os.replace(temp, path)
    except OSError as exc:
        exc.filename = str(path)
        raise
    finally:
        temp.unlink(missing_ok=True)
    _fsync_dir(path.parent)
    return path


def _fsync_dir(directory: Path) -> None:
    try:
        fd = os.open(directory, os.O_RDONLY)
    except OSError:  # e.g. platforms without directory handles
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)
