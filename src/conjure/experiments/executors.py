"""Where runs execute: one interface over a local process pool, Dask and Ray.

An `Executor` maps a picklable function over items and yields ``(index, outcome)`` pairs as
they finish, in any order. The outcome is the function's return value, or a `TaskFailure`
when the task never returned (its worker died more often than allowed). The sweep driver
(`conjure.experiments.parallel.execute_runs`) is the only caller: the function it maps catches
a run's own exceptions, so a run that raises fails alone on every engine.

=========== ==================================== ==========================================
executor    where                                a killed worker
=========== ==================================== ==========================================
``local``   a process pool on this machine       pool restarted, its unfinished tasks rerun
``dask``    ``--address`` of a scheduler, or a   the nanny restarts it; the scheduler
            `distributed.LocalCluster` it starts reruns the task (``allowed-failures``)
``ray``     ``--address`` of a Ray cluster, or   the task is retried (``max_retries``)
            a local Ray instance it starts
=========== ==================================== ==========================================

Notes
-----
- Choice: the local pool starts workers with "forkserver" (or "spawn"), never "fork": a
  forked numba or BLAS runtime can deadlock.
- Choice: a task is retried at most ``max_retries`` times after its worker died (default 3,
  as Ray and Dask default to); then it is reported as a `TaskFailure`. The local pool cannot
  tell which task killed its worker, so every task running at that moment counts a retry.
- Choice: local pool workers watch the driver's pid and exit when it is gone, so a driver
  killed with -9 leaves no orphaned workers behind.
- Choice: ``max_workers=1`` on the local executor runs every task in the calling process,
  with no pool (simplest to debug); there a task that kills its process kills the driver.
"""

from __future__ import annotations

import concurrent.futures as cf
import logging
import multiprocessing
import os
import threading
import time
import traceback
import uuid
from abc import ABC, abstractmethod
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass
from typing import Any, ClassVar

from conjure.core.errors import InvalidParameterError
from conjure.core.params import did_you_mean

__all__ = [
    "EXECUTORS",
    "DaskExecutor",
    "Executor",
    "LocalExecutor",
    "RayExecutor",
    "TaskFailure",
    "make_executor",
]


@dataclass
class TaskFailure:
    """A task that never returned: its worker died (more often than allowed) or was lost.

    Attributes
    ----------
    message : str
        One line.
    traceback : str
        The engine's account of the failure.
    """

    message: str
    traceback: str


def _failure(exc: BaseException, what: str) -> TaskFailure:
    text = "".join(traceback.format_exception(type(exc), exc, exc.__traceback__))
    first = f"{type(exc).__name__}: {exc}".splitlines()[0] if str(exc) else type(exc).__name__
    return TaskFailure(f"{what}: {first}", text)


class Executor(ABC):
    """Run a function over items on some workers; yield outcomes as they finish.

    Parameters
    ----------
    max_workers : int or None
        Worker processes for a cluster this executor starts itself (default: the CPU count).
        Ignored when connecting to an existing cluster through ``address``.
    address : str or None
        A running cluster to use (Dask scheduler or Ray head); ``None`` starts a local one.
    max_retries : int, default 3
        How many times a task whose worker died is rerun before it is reported as failed.

    Notes
    -----
    Use as a context manager (``with executor: ...``) or call `start` and `shutdown`; both are
    idempotent, so one started executor can serve several sweeps (a grid and its fresh-seed
    rerun, or every trial of a tuning study).
    """

    name: ClassVar[str] = ""

    def __init__(
        self, *, max_workers: int | None = None, address: str | None = None, max_retries: int = 3
    ):
        if max_workers is not None and (isinstance(max_workers, bool) or max_workers < 1):
            raise InvalidParameterError(
                f"`{type(self).__name__}.max_workers` must be an int >= 1; got {max_workers!r}."
            )
        if max_retries < 0:
            raise InvalidParameterError(
                f"`{type(self).__name__}.max_retries` must be an int >= 0; got {max_retries!r}."
            )
        self.max_workers = max_workers
        self.address = address
        self.max_retries = max_retries
        self.is_started = False

    @property
    def num_workers(self) -> int:
        """Workers this executor uses (for a remote cluster: the requested count, if any)."""
        return self.max_workers or os.cpu_count() or 1

    @property
    def is_local(self) -> bool:
        """Whether workers run on this machine (so warming numba's cache here serves them)."""
        return self.address is None

    def start(self) -> Executor:
        """Start or connect to the workers (no-op if started)."""
        if not self.is_started:
            self._start()
            self.is_started = True
        return self

    def shutdown(self) -> None:
        """Release the workers, stopping any cluster this executor started (idempotent)."""
        if self.is_started:
            self.is_started = False
            self._shutdown()

    def __enter__(self) -> Executor:
        return self.start()

    def __exit__(self, *exc_info: object) -> None:
        self.shutdown()

    @abstractmethod
    def _start(self) -> None: ...

    @abstractmethod
    def _shutdown(self) -> None: ...

    @abstractmethod
    def map_unordered(
        self, fn: Callable[[Any], Any], items: Sequence[Any]
    ) -> Iterator[tuple[int, Any]]:
        """Yield ``(index, fn(items[index]) or TaskFailure)`` for every item, as each finishes.

        ``fn`` and the items must be picklable (``fn`` importable by the workers, or pickled by
        value with ``cloudpickle.register_pickle_by_value``).
        """

    def __repr__(self) -> str:
        where = self.address or f"local, {self.num_workers} workers"
        return f"{type(self).__name__}({where})"


def _exit_with_driver(driver_pid: int) -> None:
    """In a pool worker: exit as soon as the driver process is gone (e.g. killed with -9)."""

    def watch() -> None:
        while True:
            time.sleep(1.0)
            try:
                os.kill(driver_pid, 0)
            except ProcessLookupError:
                os._exit(1)
            except PermissionError:  # alive, owned by another user: keep watching
                continue

    threading.Thread(target=watch, name="conjure-driver-watch", daemon=True).start()


class LocalExecutor(Executor):
    """A process pool on this machine (the default; needs no service).

    Examples
    --------
    >>> with LocalExecutor(max_workers=1) as executor:
    ...     sorted(executor.map_unordered(abs, [-2, 3]))
    [(0, 2), (1, 3)]
    """

    name = "local"

    def _start(self) -> None:
        if self.address is not None:
            raise InvalidParameterError(
                f"The local executor takes no address; got {self.address!r}. Use "
                f"--executor dask or --executor ray to reach a cluster."
            )

    def _shutdown(self) -> None:
        pass

    def map_unordered(
        self, fn: Callable[[Any], Any], items: Sequence[Any]
    ) -> Iterator[tuple[int, Any]]:
        self.start()
        workers = max(1, min(self.num_workers, len(items)))
        if workers == 1:
            for index, item in enumerate(items):
                try:
                    yield index, fn(item)
                except Exception as exc:
                    yield index, _failure(exc, "task raised")
            return
        methods = multiprocessing.get_all_start_methods()
        context = multiprocessing.get_context("forkserver" if "forkserver" in methods else "spawn")
        if context.get_start_method() == "forkserver":  # workers fork from a warm server
            context.set_forkserver_preload(["conjure.experiments.run"])
        pending = dict(enumerate(items))
        attempts = dict.fromkeys(pending, 0)
        while pending:
            pool = cf.ProcessPoolExecutor(
                min(workers, len(pending)),
                mp_context=context,
                initializer=_exit_with_driver,
                initargs=(os.getpid(),),
            )
            futures = {pool.submit(fn, item): index for index, item in pending.items()}
            is_broken = False
            try:
                for future in cf.as_completed(futures):
                    index = futures[future]
                    try:
                        outcome = future.result()
                    except BrokenProcessPool:
                        is_broken = True
                        break
                    except Exception as exc:  # e.g. an unpicklable result
                        outcome = _failure(exc, "task failed")
                    del pending[index]
                    yield index, outcome
                if is_broken:  # a worker died: keep what finished, rerun the rest
                    for future, index in futures.items():
                        if index not in pending:
                            continue
                        if future.done() and not future.cancelled() and not future.exception():
                            del pending[index]
                            yield index, future.result()
                            continue
                        attempts[index] += 1
                        if attempts[index] > self.max_retries:
                            exc = future.exception() if future.done() else None
                            del pending[index]
                            yield (
                                index,
                                _failure(
                                    exc or BrokenProcessPool("worker died"),
                                    f"worker died {attempts[index]} times",
                                ),
                            )
            finally:
                pool.shutdown(wait=not is_broken, cancel_futures=True)


class DaskExecutor(Executor):
    """Dask distributed: a scheduler at ``address``, or a `LocalCluster` it starts.

    Notes
    -----
    For SLURM (or PBS, SGE, ...), start the cluster with dask-jobqueue and pass its scheduler
    address, or build the `distributed.Client` yourself and pass it as ``client``.
    Choice: the local cluster has one single-threaded worker process per CPU (runs hold the
    GIL), no dashboard, and ``distributed.scheduler.allowed-failures = max_retries``.
    """

    name = "dask"

    def __init__(
        self,
        *,
        max_workers: int | None = None,
        address: str | None = None,
        max_retries: int = 3,
        client: Any = None,
    ):
        super().__init__(max_workers=max_workers, address=address, max_retries=max_retries)
        self.client = client

    @property
    def is_local(self) -> bool:
        return self.address is None and self.client is None

    def _start(self) -> None:
        import dask
        from distributed import Client, LocalCluster

        self._cluster = None
        self._owns_client = self.client is None
        if self.client is not None:
            return
        if self.address is not None:
            self.client = Client(self.address)
            return
        with dask.config.set({"distributed.scheduler.allowed-failures": self.max_retries}):
            self._cluster = LocalCluster(
                n_workers=self.num_workers,
                threads_per_worker=1,
                processes=True,
                dashboard_address=None,
                silence_logs=logging.ERROR,
            )
        self.client = Client(self._cluster)

    def _shutdown(self) -> None:
        if self._owns_client and self.client is not None:
            self.client.close()
            self.client = None
        if self._cluster is not None:
            self._cluster.close()
            self._cluster = None

    def map_unordered(
        self, fn: Callable[[Any], Any], items: Sequence[Any]
    ) -> Iterator[tuple[int, Any]]:
        from distributed import as_completed

        self.start()
        batch = uuid.uuid4().hex[:8]
        futures = [
            self.client.submit(fn, item, key=f"conjure-run-{batch}-{index}", pure=False)
            for index, item in enumerate(items)
        ]
        index_of = {future.key: index for index, future in enumerate(futures)}
        try:
            for future in as_completed(futures):
                index = index_of[future.key]
                try:
                    outcome = future.result()
                except Exception as exc:  # KilledWorker after allowed-failures, lost data
                    outcome = _failure(exc, "dask task failed")
                future.release()
                yield index, outcome
        finally:
            self.client.cancel([f for f in futures if not f.done()])


def _call(fn: Callable[[Any], Any], item: Any) -> Any:
    """Call ``fn(item)`` (Ray remote functions must be plain functions, not partials)."""
    return fn(item)


class RayExecutor(Executor):
    """Ray: the cluster at ``address`` (``"auto"`` finds a local head), or a local instance.

    Notes
    -----
    Choice: tasks request one CPU each and are retried ``max_retries`` times if their worker
    dies (Ray's default is 3), never on an exception the run itself raised. A local instance
    gets ``num_cpus = max_workers``, no dashboard, and is shut down by `shutdown`; a cluster
    reached through ``address`` is only disconnected from.
    """

    name = "ray"

    def _start(self) -> None:
        import ray

        self._owns_ray = not ray.is_initialized()
        if not self._owns_ray:
            return
        options: dict[str, Any] = {
            "include_dashboard": False,
            "log_to_driver": False,
            "logging_level": logging.ERROR,
        }
        if self.address is None:
            options["num_cpus"] = self.num_workers
        else:
            options["address"] = self.address
        ray.init(**options)

    def _shutdown(self) -> None:
        import ray

        if self._owns_ray:
            ray.shutdown()

    def map_unordered(
        self, fn: Callable[[Any], Any], items: Sequence[Any]
    ) -> Iterator[tuple[int, Any]]:
        import ray

        self.start()
        remote = ray.remote(num_cpus=1, max_retries=self.max_retries, retry_exceptions=False)(_call)
        pending = {remote.remote(fn, item): index for index, item in enumerate(items)}
        try:
            while pending:
                ready, _ = ray.wait(list(pending), num_returns=1)
                for ref in ready:
                    index = pending.pop(ref)
                    try:
                        outcome = ray.get(ref)
                    except Exception as exc:  # WorkerCrashedError after max_retries, ...
                        outcome = _failure(exc, "ray task failed")
                    yield index, outcome
        finally:
            for ref in pending:
                ray.cancel(ref, force=True)


#: Executors by their ``--executor`` name.
EXECUTORS: dict[str, type[Executor]] = {
    "local": LocalExecutor,
    "dask": DaskExecutor,
    "ray": RayExecutor,
}

_EXTRAS = {"dask": ("distributed", "dask"), "ray": ("ray", "ray")}


def make_executor(
    name: str = "local", *, address: str | None = None, max_workers: int | None = None
) -> Executor:
    """Return the executor called ``name`` (``local``, ``dask`` or ``ray``), not yet started.

    Raises
    ------
    InvalidParameterError
        For an unknown name (with a did-you-mean) or an engine whose extra is not installed.
    """
    if name not in EXECUTORS:
        raise InvalidParameterError(
            f"Unknown executor {name!r}.{did_you_mean(name, EXECUTORS)} "
            f"Known: {', '.join(EXECUTORS)}."
        )
    if name in _EXTRAS:
        module, extra = _EXTRAS[name]
        try:
            __import__(module)
        except ImportError:
            raise InvalidParameterError(
                f"The {name} executor needs {module!r}; install it with "
                f"`pip install 'conjure[{extra}]'`."
            ) from None
    return EXECUTORS[name](max_workers=max_workers, address=address)
