"""Where runs execute: one interface over a local process pool, Dask and Ray.

An `Executor` maps a picklable function over items and yields ``(index, outcome)`` pairs as
they finish, in any order. The outcome is the function's return value, a `TaskFailure`
when the task never returned (its worker died more often than allowed), or `NOT_CLAIMED` when
the ``claim`` callback declined the item just before it would have started (another driver
holds it, `conjure.experiments.claims`). The sweep driver
(`conjure.experiments.parallel.execute_runs`) is the only caller: the function it maps catches
a run's own exceptions, so a run that raises fails alone on every engine.

=========== ============================== ============================== =====================
executor    where                          a killed worker                ``max_memory``
=========== ============================== ============================== =====================
``local``   a process pool on this machine its task alone is rerun; the   ``RLIMIT_AS`` in each
                                           other workers carry on         worker: a run over it
                                                                          gets a `MemoryError`
``dask``    ``--address`` of a scheduler,  the nanny restarts it; the     the `LocalCluster`'s
            or a `distributed.LocalCluster` scheduler reruns the task     ``memory_limit``: the
            it starts                      (``allowed-failures``)         nanny restarts a
                                                                          worker past 95% of it
``ray``     ``--address`` of a Ray         the task is retried            not enforced (warns)
            cluster, or a local Ray        (``max_retries``)
            instance it starts
=========== ============================== ============================== =====================

Notes
-----
- Choice: the local pool starts workers with "forkserver" (or "spawn"), never "fork": a
  forked numba or BLAS runtime can deadlock.
- Choice: a task is retried at most ``max_retries`` times after its worker died (default 3,
  as Ray and Dask default to); then it is reported as a `TaskFailure` naming how the worker
  died (``killed by SIGKILL`` is what the kernel's out-of-memory killer does). Each local
  worker runs one task at a time, so a death is charged to the task that worker held only.
- Choice: a local pool worker dies with the driver wherever it is, even inside a long
  compiled call that never gives the GIL back: on Linux the kernel SIGKILLs the forkserver
  when the driver dies and each worker when the forkserver dies (``PR_SET_PDEATHSIG``, set in
  the forkserver by its preload `conjure.experiments._forkserver_guard`, and in each worker);
  elsewhere, and as a second guard, a thread in each worker watches the driver's pid. The
  forkserver must be started by a thread that lives as long as the driver (the main thread
  in `conjure sweep`): the kernel signals the death of the parent thread.
- Choice: items are claimed just before they start, and Dask and Ray hold at most two tasks
  per worker in flight, so that two drivers on one folder split the runs between them.
- Choice: the local pool reports each death it retries through ``on_retry``; Dask and Ray
  retry inside their schedulers, unseen.
- Choice: the local pool refuses to start from a script's top level outside
  ``if __name__ == "__main__":`` (`conjure.experiments.main_guard`): each worker imports the
  script first and would run it again.
- Choice: ``max_workers=1`` on the local executor runs every task in the calling process,
  with no pool (simplest to debug); there a task that kills its process kills the driver.
  With ``max_memory`` (or ``in_process=False``) it uses one worker process instead: the limit
  cannot be set on the caller without limiting it too.
- Choice: ``max_memory`` is not enforced on Ray: a Ray worker maps about 8 GiB of address space
  before any task (measured with Ray 2.60), so ``RLIMIT_AS`` cannot bound a run there, and
  Ray's own ``memory`` option only reserves capacity for scheduling. Ray's memory monitor
  kills (and retries) tasks when a node runs low on memory. A Dask cluster reached through
  ``address`` or ``client`` keeps the memory limit its workers were started with
  (``dask worker --memory-limit``). Both warn when given ``max_memory``.
"""

from __future__ import annotations

import ctypes
import logging
import multiprocessing
import os
import pickle
import signal
import sys
import threading
import time
import traceback
import uuid
import warnings
from abc import ABC, abstractmethod
from collections import deque
from collections.abc import Callable, Iterator, Sequence
from contextlib import suppress
from dataclasses import dataclass
from multiprocessing.connection import Connection, wait
from typing import Any, ClassVar

from conjure.core.errors import InvalidParameterError, raise_if_interrupted
from conjure.core.params import did_you_mean
from conjure.experiments.main_guard import check_main_guarded
from conjure.experiments.memory import (
    check_memory_limit,
    format_memory_size,
    limit_memory,
    parse_memory_limit,
)

__all__ = [
    "EXECUTORS",
    "NOT_CLAIMED",
    "DaskExecutor",
    "Executor",
    "LocalExecutor",
    "RayExecutor",
    "TaskFailure",
    "die_with_parent",
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


class _NotClaimed:
    """The outcome of an item its ``claim`` callback declined (it was never started)."""

    def __repr__(self) -> str:
        return "NOT_CLAIMED"


NOT_CLAIMED = _NotClaimed()
#: ``claim(index) -> bool``: whether to start item ``index`` now (called just before it starts).
Claim = Callable[[int], bool]
#: ``on_retry(index, cause)``: item ``index``'s worker died (``cause``) and the item is rerun.
OnRetry = Callable[[int, str], None]


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
    max_memory : int, str or None
        Each worker's memory limit, in bytes or as ``"4GiB"`` (`conjure.experiments.memory`);
        ``None`` (default): none. How each engine enforces it is in the module's table.

    Notes
    -----
    Use as a context manager (``with executor: ...``) or call `start` and `shutdown`; both are
    idempotent, so one started executor can serve several sweeps (a grid and its fresh-seed
    rerun, or every trial of a tuning study).
    """

    name: ClassVar[str] = ""

    def __init__(
        self,
        *,
        max_workers: int | None = None,
        address: str | None = None,
        max_retries: int = 3,
        max_memory: int | str | None = None,
    ):
        if max_workers is not None and (isinstance(max_workers, bool) or max_workers < 1):
            raise InvalidParameterError(
                f"`{type(self).__name__}.max_workers` must be an int >= 1; got {max_workers!r}."
            )
        if max_retries < 0:
            raise InvalidParameterError(
                f"`{type(self).__name__}.max_retries` must be an int >= 0; got {max_retries!r}."
            )
        try:
            self.max_memory = parse_memory_limit(max_memory)
        except InvalidParameterError as exc:
            raise InvalidParameterError(f"`{type(self).__name__}.max_memory`: {exc}.") from None
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

    @property
    def runs_in_caller(self) -> bool:
        """Whether tasks run in the calling process (no worker process at all)."""
        return False

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
        self,
        fn: Callable[[Any], Any],
        items: Sequence[Any],
        *,
        claim: Claim | None = None,
        on_retry: OnRetry | None = None,
    ) -> Iterator[tuple[int, Any]]:
        """Yield ``(index, fn(items[index]) or TaskFailure)`` for every item, as each finishes.

        ``fn`` and the items must be picklable (``fn`` importable by the workers, or pickled by
        value with ``cloudpickle.register_pickle_by_value``). ``claim(index)`` is asked just
        before an item starts; an item it declines yields `NOT_CLAIMED`. ``on_retry`` hears of
        each worker death the executor retries (the local pool only).
        """

    @property
    def window(self) -> int:
        """Tasks in flight at most on a cluster engine: two per worker."""
        return 2 * self.num_workers

    def __repr__(self) -> str:
        where = self.address or f"local, {self.num_workers} workers"
        return f"{type(self).__name__}({where})"


def _exit_with_driver(driver_pid: int) -> None:
    """In a pool worker: exit as soon as the driver process is gone (e.g. killed with -9).

    A thread checks every second, so a worker inside a long compiled call (which holds the
    GIL) only notices when the call returns: `die_with_parent` covers that on Linux.
    """

    def watch() -> None:
        while True:
            try:
                os.kill(driver_pid, 0)
            except ProcessLookupError:
                os._exit(1)
            except PermissionError:  # alive, owned by another user: keep watching
                pass
            time.sleep(1.0)

    threading.Thread(target=watch, name="conjure-driver-watch", daemon=True).start()


_PR_SET_PDEATHSIG = 1  # <linux/prctl.h>


def die_with_parent() -> bool:
    """On Linux, have the kernel SIGKILL this process when its parent dies; whether it will.

    A SIGKILL needs no cooperation from the process, so it stops one deep in a compiled call
    that never gives the GIL back. Elsewhere (no ``prctl``): ``False``, nothing done.
    """
    if not sys.platform.startswith("linux"):
        return False
    libc = ctypes.CDLL(None, use_errno=True)
    return libc.prctl(_PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0) == 0


def _serve(connection: Connection, driver_pid: int, max_memory: int | None) -> None:
    """A pool worker: run each task received, ``(index, pickled (fn, item))``, one at a time.

    Sends back ``(index, outcome)``; ``None`` received (or the driver gone) ends the worker.
    """
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the driver's to handle
    die_with_parent()  # the forkserver, which dies with the driver (its preload)
    _exit_with_driver(driver_pid)
    if max_memory is not None:
        limit_memory(max_memory)
    while True:
        try:
            task = connection.recv()
        except EOFError:  # the driver is gone
            return
        if task is None:
            return
        index, payload = task
        try:
            fn, item = pickle.loads(payload)
            outcome = fn(item)
        except Exception as exc:
            outcome = _failure(exc, "task raised")
        try:
            connection.send((index, outcome))
        except Exception as exc:  # e.g. an unpicklable result
            connection.send((index, _failure(exc, "task failed")))


def _death_cause(exitcode: int | None, max_memory: int | None) -> str:
    """Say how a worker process ended, e.g. ``killed by SIGKILL (...)``."""
    if exitcode is not None and exitcode < 0:
        try:
            cause = f"killed by {signal.Signals(-exitcode).name}"
        except ValueError:
            cause = f"killed by signal {-exitcode}"
        if -exitcode == signal.SIGKILL:
            cause += " (the signal the kernel's out-of-memory killer sends)"
    else:
        cause = f"exited with status {exitcode}"
    if max_memory is not None:
        cause += f"; its memory limit was {format_memory_size(max_memory)} (RLIMIT_AS)"
        if exitcode == -signal.SIGABRT:
            cause += ", and native code (LLVM, numba) aborts when an allocation fails under it"
    return cause


@dataclass
class _Worker:
    """A pool worker process, its end of the pipe, and the index of the task it runs."""

    process: Any
    connection: Connection
    task: int | None = None


class _ProcessPool:
    """Worker processes that run one task each at a time, so a death is its task's alone.

    Unlike `concurrent.futures.ProcessPoolExecutor`, which breaks as a whole when one worker
    dies, this pool knows which task each worker holds: a dead worker's task is rerun (or
    reported after ``max_retries`` reruns), a new worker takes its place, and the others
    carry on undisturbed.
    """

    def __init__(self, num_workers: int, *, max_memory: int | None):
        check_main_guarded()  # a worker imports __main__: an unguarded script would rerun
        methods = multiprocessing.get_all_start_methods()
        method = "forkserver" if "forkserver" in methods else "spawn"
        self._context = multiprocessing.get_context(method)
        if method == "forkserver":  # workers fork from a warm server that dies with us
            self._context.set_forkserver_preload(
                [
                    "conjure.experiments._forkserver_guard",
                    "conjure.experiments.run",
                    "conjure.experiments._forkserver_kernels",
                ]
            )
        self.num_workers = num_workers
        self.max_memory = max_memory
        self._workers: list[_Worker] = []

    def map_unordered(
        self,
        fn: Callable[[Any], Any],
        items: Sequence[Any],
        *,
        max_retries: int,
        claim: Claim | None,
        on_retry: OnRetry | None,
    ) -> Iterator[tuple[int, Any]]:
        pending = deque(range(len(items)))
        deaths = [0] * len(items)
        while pending or any(worker.task is not None for worker in self._workers):
            yield from self._dispatch(fn, items, pending, claim, deaths)
            if not any(worker.task is not None for worker in self._workers):
                continue  # every pending item was declined or could not be sent
            for worker in self._ready():
                index = worker.task
                assert index is not None
                has_outcome, outcome = self._receive(worker)
                if has_outcome:
                    yield index, outcome
                    continue
                cause = self._bury(worker)
                deaths[index] += 1
                if deaths[index] <= max_retries:
                    if on_retry is not None:
                        on_retry(index, cause)
                    pending.appendleft(index)
                    continue
                message = f"worker died {deaths[index]} times running this task, last {cause}"
                yield index, TaskFailure(message, message + "\n")

    def _dispatch(
        self,
        fn: Callable[[Any], Any],
        items: Sequence[Any],
        pending: deque[int],
        claim: Claim | None,
        deaths: list[int],
    ) -> Iterator[tuple[int, Any]]:
        """Hand pending tasks to idle workers; yield those declined or that cannot be pickled.

        A task rerun after its worker died keeps its claim: it is not asked again.
        """
        while pending and (worker := self._idle_worker()) is not None:
            index = pending.popleft()
            if claim is not None and not deaths[index] and not claim(index):
                yield index, NOT_CLAIMED
                continue
            try:
                payload = pickle.dumps((fn, items[index]))
            except Exception as exc:
                yield index, _failure(exc, "task could not be sent to a worker")
                continue
            try:
                worker.connection.send((index, payload))
            except OSError:  # it died idle: not this task's doing
                pending.appendleft(index)
                self._bury(worker)
                continue
            worker.task = index

    def _idle_worker(self) -> _Worker | None:
        """Return an idle live worker, starting one if the pool is not full; else ``None``."""
        for worker in list(self._workers):
            if worker.task is None:
                if worker.process.is_alive():
                    return worker
                self._bury(worker)
        if len(self._workers) >= self.num_workers:
            return None
        ours, theirs = self._context.Pipe()
        process = self._context.Process(
            target=_serve,
            args=(theirs, os.getpid(), self.max_memory),
            name=f"conjure-worker-{len(self._workers)}",
        )
        process.start()
        theirs.close()
        self._workers.append(_Worker(process, ours))
        return self._workers[-1]

    def _ready(self) -> list[_Worker]:
        """Wait until a busy worker has sent an outcome or died; return those workers."""
        busy = [worker for worker in self._workers if worker.task is not None]
        ready = set(wait([w.connection for w in busy] + [w.process.sentinel for w in busy]))
        return [w for w in busy if w.connection in ready or w.process.sentinel in ready]

    @staticmethod
    def _receive(worker: _Worker) -> tuple[bool, Any]:
        """Read a worker's outcome: ``(True, outcome)``, or ``(False, None)`` if it died."""
        try:
            if not worker.connection.poll():
                return False, None
            _, outcome = worker.connection.recv()
        except (EOFError, OSError):
            return False, None
        except Exception as exc:  # an outcome this process cannot unpickle
            outcome = _failure(exc, "task outcome could not be read")
        worker.task = None
        return True, outcome

    def _bury(self, worker: _Worker) -> str:
        """Reap a dead (or silent) worker, drop it from the pool, and say how it ended."""
        worker.process.join(timeout=5.0)
        if worker.process.is_alive():
            worker.process.kill()
            worker.process.join()
        worker.connection.close()
        self._workers.remove(worker)
        return _death_cause(worker.process.exitcode, self.max_memory)

    def close(self) -> None:
        """Stop every worker: idle ones are told to exit, busy ones (abandoned) are killed."""
        for worker in self._workers:
            if worker.task is None:
                with suppress(OSError):
                    worker.connection.send(None)
            else:
                worker.process.kill()
        for worker in list(self._workers):
            self._bury(worker)


class LocalExecutor(Executor):
    """A process pool on this machine (the default; needs no service).

    Each worker process runs one task at a time, so a worker that dies (the kernel's
    out-of-memory killer, a crash in native code) is charged to the task it was running only:
    that task is rerun or reported, and the other workers carry on.

    Parameters
    ----------
    in_process : bool or None
        Run the tasks one by one in the calling process instead of a pool. ``None``
        (default): only when ``max_workers`` is 1 and there is no ``max_memory``. ``False``
        always uses worker processes, so a task that kills its process cannot kill the caller.
    **options
        As `Executor`.

    Examples
    --------
    >>> with LocalExecutor(max_workers=1) as executor:
    ...     sorted(executor.map_unordered(abs, [-2, 3]))
    [(0, 2), (1, 3)]
    """

    name = "local"

    def __init__(self, *, in_process: bool | None = None, **options: Any):
        super().__init__(**options)
        if in_process and self.max_memory is not None:
            raise InvalidParameterError(
                "LocalExecutor: in_process=True cannot take max_memory (the limit would bind "
                "the calling process too)."
            )
        self.in_process = in_process

    def _start(self) -> None:
        if self.address is not None:
            raise InvalidParameterError(
                f"The local executor takes no address; got {self.address!r}. Use "
                f"--executor dask or --executor ray to reach a cluster."
            )
        if self.max_memory is not None:
            check_memory_limit(self.max_memory)

    def _shutdown(self) -> None:
        pass

    @property
    def runs_in_caller(self) -> bool:
        """``in_process``, or by default: one worker and no ``max_memory``."""
        if self.in_process is None:
            return self.num_workers == 1 and self.max_memory is None
        return self.in_process

    def map_unordered(
        self,
        fn: Callable[[Any], Any],
        items: Sequence[Any],
        *,
        claim: Claim | None = None,
        on_retry: OnRetry | None = None,
    ) -> Iterator[tuple[int, Any]]:
        self.start()
        if self.runs_in_caller:
            for index, item in enumerate(items):
                if claim is not None and not claim(index):
                    yield index, NOT_CLAIMED
                    continue
                try:
                    outcome = fn(item)
                except Exception as exc:
                    raise_if_interrupted(exc)
                    outcome = _failure(exc, "task raised")
                yield index, outcome
            return
        pool = _ProcessPool(min(self.num_workers, len(items)), max_memory=self.max_memory)
        try:
            yield from pool.map_unordered(
                fn, items, max_retries=self.max_retries, claim=claim, on_retry=on_retry
            )
        finally:
            pool.close()


class DaskExecutor(Executor):
    """Dask distributed: a scheduler at ``address``, or a `LocalCluster` it starts.

    Parameters
    ----------
    client : distributed.Client or None
        A client of a cluster you started yourself (then ``address`` is not used).
    **options
        As `Executor`.

    Notes
    -----
    For SLURM (or PBS, SGE, ...), start the cluster with dask-jobqueue and pass its scheduler
    address, or build the `distributed.Client` yourself and pass it as ``client``.
    Choice: the local cluster has one single-threaded worker process per CPU (runs hold the
    GIL), no dashboard, ``distributed.scheduler.allowed-failures = max_retries``, and
    ``memory_limit = max_memory`` per worker (default Dask's: the machine's memory divided
    among the workers); Dask's nanny restarts a worker whose resident memory passes 95% of it.
    """

    name = "dask"

    def __init__(self, *, client: Any = None, **options: Any):
        super().__init__(**options)
        self.client = client
        if self.max_memory is not None and not self.is_local:
            warnings.warn(
                "DaskExecutor: max_memory applies to the LocalCluster it starts; an existing "
                "cluster keeps its workers' memory limit (dask worker --memory-limit).",
                stacklevel=2,
            )

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
                memory_limit=self.max_memory or "auto",
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
        self,
        fn: Callable[[Any], Any],
        items: Sequence[Any],
        *,
        claim: Claim | None = None,
        on_retry: OnRetry | None = None,
    ) -> Iterator[tuple[int, Any]]:
        from distributed import as_completed

        self.start()
        batch = uuid.uuid4().hex[:8]
        waiting = deque(range(len(items)))
        index_of: dict[str, int] = {}
        running = as_completed()

        def submit() -> Iterator[tuple[int, Any]]:
            while waiting and len(index_of) < self.window:
                index = waiting.popleft()
                if claim is not None and not claim(index):
                    yield index, NOT_CLAIMED
                    continue
                key = f"conjure-run-{batch}-{index}"
                running.add(self.client.submit(fn, items[index], key=key, pure=False))
                index_of[key] = index

        try:
            yield from submit()
            for future in running:
                index = index_of.pop(future.key)
                try:
                    outcome = future.result()
                except Exception as exc:  # KilledWorker after allowed-failures, lost data
                    outcome = _failure(exc, "dask task failed")
                    if self.max_memory is not None and self._cluster is not None:
                        outcome.message += (
                            f" (workers' memory limit: {format_memory_size(self.max_memory)})"
                        )
                future.release()
                yield index, outcome
                yield from submit()
        finally:
            self.client.cancel([f for f in running.futures if not f.done()])


def _call(fn: Callable[[Any], Any], item: Any) -> Any:
    """Call ``fn(item)`` (Ray remote functions must be plain functions, not partials)."""
    return fn(item)


class RayExecutor(Executor):
    """Ray: the cluster at ``address`` (``"auto"`` finds a local head), or a local instance.

    Parameters
    ----------
    **options
        As `Executor`; ``max_memory`` is not enforced on Ray (see the module notes), and warns.

    Notes
    -----
    Choice: tasks request one CPU each and are retried ``max_retries`` times if their worker
    dies (Ray's default is 3), never on an exception the run itself raised. A local instance
    gets ``num_cpus = max_workers``, no dashboard, and is shut down by `shutdown`; a cluster
    reached through ``address`` is only disconnected from.
    """

    name = "ray"

    def __init__(self, **options: Any):
        super().__init__(**options)
        if self.max_memory is not None:
            warnings.warn(
                "RayExecutor does not enforce max_memory (see conjure.experiments.executors); "
                "Ray's memory monitor kills and retries tasks when a node runs low on memory.",
                stacklevel=2,
            )

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
        self,
        fn: Callable[[Any], Any],
        items: Sequence[Any],
        *,
        claim: Claim | None = None,
        on_retry: OnRetry | None = None,
    ) -> Iterator[tuple[int, Any]]:
        import ray

        self.start()
        remote = ray.remote(num_cpus=1, max_retries=self.max_retries, retry_exceptions=False)(_call)
        waiting = deque(range(len(items)))
        pending: dict[Any, int] = {}

        def submit() -> Iterator[tuple[int, Any]]:
            while waiting and len(pending) < self.window:
                index = waiting.popleft()
                if claim is not None and not claim(index):
                    yield index, NOT_CLAIMED
                    continue
                pending[remote.remote(fn, items[index])] = index

        try:
            yield from submit()
            while pending:
                ready, _ = ray.wait(list(pending), num_returns=1)
                for ref in ready:
                    index = pending.pop(ref)
                    try:
                        outcome = ray.get(ref)
                    except Exception as exc:  # WorkerCrashedError after max_retries, ...
                        outcome = _failure(exc, "ray task failed")
                    yield index, outcome
                yield from submit()
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
    name: str = "local",
    *,
    address: str | None = None,
    max_workers: int | None = None,
    max_memory: int | str | None = None,
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
                f"`pip install -e '.[{extra}]'` in the conjure checkout."
            ) from None
    return EXECUTORS[name](max_workers=max_workers, address=address, max_memory=max_memory)
