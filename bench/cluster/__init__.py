"""One way runs are spread: a Dask distributed cluster (issue 17).

``bench sweep``, ``bench campaign`` and ``bench claims --run`` hand their runs to ``Executor``:

* by default a local cluster, one worker process per core, one thread each (nothing to set
  up), with a rich progress bar on the terminal;
* ``--scheduler tcp://HOST:PORT``: an existing cluster (``dask scheduler`` and ``dask worker``
  processes on any machines with hil-bench installed: docs/sweeps.md); Dask's own dashboard
  shows the progress there (its address is printed), the progress bar too.

What a cluster does to a run, and what the executor makes of it:

* a worker that dies (killed, out of memory, its machine gone): Dask gives its unfinished
  tasks to the other workers (up to ``distributed.scheduler.allowed-failures`` times); every
  task's result reaches the caller once, whichever worker produced it;
* a task that raises (the bench's own failure) is never retried: it comes back as a
  ``TaskFailure`` with its traceback, a row like any other. A run whose controller faults is
  not an exception at all: it is the run's result;
* a run still going after the per-run time limit is ended by the runner (``limits``): the
  engine stops, the run says so, and that is its result.

A run starts a child process (the recorder, a ``multiprocessing`` fork) and Dask starts its
workers as daemonic processes, which ``multiprocessing`` forbids to have children (a check in
``Process.start``, nothing the operating system enforces). The daemon flag only tells the
worker's own ``multiprocessing`` what to do with its children at exit; the nanny that watches
the worker keeps its own view. So a task lifts the flag in the worker process while it runs
(``children_allowed``): any ``dask worker``, started as Dask's documentation says, runs the
bench's runs, and so does the local cluster (started the same way). Every run reaps the
processes it started before it returns.
"""
from __future__ import annotations

import os
import re
import resource
import threading
import time
import traceback
import uuid
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any, Callable, Iterable, Iterator

#: a Dask scheduler address: [protocol://]host:port (Dask's default protocol is tcp)
_ADDRESS = re.compile(r"(?:(?P<proto>[a-z]+)://)?(?P<host>\[[0-9A-Fa-f:.]+\]|[A-Za-z0-9._-]+)"
                      r":(?P<port>\d{1,5})\Z")
PROTOCOLS = ("tcp", "tls", "ws", "wss", "ucx")


class ClusterError(ValueError):
    """The executor cannot start: a bad scheduler address or worker count, a scheduler that
    does not answer; the message is one line (a ValueError: the commands that spread runs
    print those as their error line)."""


def check_scheduler_address(address: str) -> str:
    """``tcp://HOST:PORT`` (or another Dask protocol, or ``HOST:PORT``), else ClusterError."""
    m = _ADDRESS.match(address.strip())
    if not m or not 0 < int(m.group("port")) < 65536 or (
            m.group("proto") and m.group("proto") not in PROTOCOLS):
        raise ClusterError(f"--scheduler {address!r}: not a Dask scheduler address; give "
                           f"tcp://HOST:PORT (as `dask scheduler` prints it, e.g. "
                           f"tcp://192.168.1.10:8786)")
    return address.strip()

@dataclass
class TaskFailure:
    """A task that raised, or that Dask gave up on: the bench's failure, said in a row."""
    error: str
    worker: str = ""


@dataclass
class TaskResult:
    """What a task returned, with where and at what cost it ran."""
    value: Any
    worker: str
    cpu_s: float         # CPU of the worker process and the children it reaped, over the task
    wall_s: float


def process_cpu_s() -> float:
    """CPU seconds of this process and of every child it has reaped (getrusage)."""
    total = 0.0
    for who in (resource.RUSAGE_SELF, resource.RUSAGE_CHILDREN):
        r = resource.getrusage(who)
        total += r.ru_utime + r.ru_stime
    return total


def _worker_name() -> str:
    try:
        from distributed import get_worker

        return str(get_worker().address)
    except (ImportError, ValueError):
        return f"local pid {os.getpid()}"


_children_lock = threading.Lock()
_children_tasks = 0
_children_daemon: bool | None = None


@contextmanager
def children_allowed():
    """Within this block this process may start ``multiprocessing`` children even when it is a
    daemonic process (a Dask worker): the flag is lifted while any task of the process is in
    such a block, and put back after the last. ClusterError when it cannot be lifted."""
    import multiprocessing as mp

    global _children_tasks, _children_daemon
    proc = mp.current_process()
    with _children_lock:
        if _children_tasks == 0:
            _children_daemon = proc.daemon
            if _children_daemon:
                try:
                    proc.daemon = False
                except AssertionError:
                    raise ClusterError(
                        "this Dask worker is a daemonic process whose flag cannot be lifted, "
                        "and a run starts a child process (the recorder): start the workers "
                        "with DASK_DISTRIBUTED__WORKER__DAEMON=False") from None
        _children_tasks += 1
    try:
        yield
    finally:
        with _children_lock:
            _children_tasks -= 1
            if _children_tasks == 0 and _children_daemon:
                proc.daemon = True


def call(fn: Callable, args: tuple, time_limit_s: float | None) -> TaskResult | TaskFailure:
    """Run one task on a worker (or here): never raises."""
    from .limits import time_limit

    c0, t0 = process_cpu_s(), time.monotonic()
    try:
        with children_allowed(), time_limit(time_limit_s):
            value = fn(*args)
    except Exception as exc:  # noqa: BLE001 - a task's failure is a row, never a crash
        return TaskFailure(f"{type(exc).__name__}: {exc}\n{traceback.format_exc(limit=6)}",
                           _worker_name())
    return TaskResult(value, _worker_name(), process_cpu_s() - c0, time.monotonic() - t0)


def default_workers() -> int:
    return max(1, len(os.sched_getaffinity(0)))


class Executor:
    """A Dask client on a local cluster (default) or on ``scheduler``; a context manager."""

    def __init__(self, scheduler: str | None = None, workers: int | None = None, *,
                 progress: bool = True, console=None, label: str = "runs"):
        import logging

        from rich.console import Console

        from hil_bench.installation import require_extra

        require_extra(f"spreading runs ({label}) on a Dask cluster", "distributed")
        from distributed import Client, LocalCluster

        self.console = console or Console(stderr=True)
        self.progress = progress
        self.label = label
        self.cluster = None
        if workers is not None and (isinstance(workers, bool) or not isinstance(workers, int)
                                    or workers < 1):
            raise ClusterError(f"--workers {workers!r}: give a number of worker processes >= 1 "
                               f"(default: one per core, {default_workers()} here)")
        if scheduler is not None:
            scheduler = check_scheduler_address(scheduler)
            try:
                self.client = Client(scheduler, timeout="10s")
            except (OSError, TimeoutError, ValueError) as exc:
                why = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
                raise ClusterError(f"cannot reach the Dask scheduler {scheduler}: {why}") from None
            self.where = f"Dask scheduler {scheduler}"
            link = getattr(self.client, "dashboard_link", None)
            n = len(self.client.scheduler_info().get("workers", {}))
            self.console.print(f"{label}: on {scheduler} ({n} workers)"
                               + (f"; progress on Dask's dashboard {link}" if link else "")
                               + ("; no worker has joined yet: the runs wait for one" if not n
                                  else ""))
        else:
            n = workers or default_workers()
            # workers started as `dask worker` starts them (daemonic): children_allowed
            # the scheduler's HTTP server (its health and metrics, even without a dashboard) on a
            # free port: two sweeps started together would both want Dask's default 8787
            self.cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                                        dashboard_address="127.0.0.1:0",
                                        silence_logs=logging.ERROR)
            self.client = Client(self.cluster)
            self.where = f"local Dask cluster ({n} worker processes)"
        self.n_workers = n

    def map(self, fn: Callable, items: Iterable[tuple[str, tuple]], *,
            time_limit_s: float | None = None,
            describe: Callable[[str], str] | None = None) -> Iterator[tuple[str, TaskResult | TaskFailure]]:
        """Run ``fn(*args)`` for every (key, args) on the cluster; yield (key, result) as each
        ends, every key exactly once. ``fn`` must be importable on the workers."""
        from distributed import as_completed
        from rich.progress import (BarColumn, MofNCompleteColumn, Progress, TextColumn,
                                   TimeElapsedColumn)

        items = list(items)
        tag = uuid.uuid4().hex[:8]
        futures = {}
        for key, args in items:
            fut = self.client.submit(call, fn, args, time_limit_s, pure=False, retries=0,
                                     key=f"{self.label}-{key}-{tag}")
            futures[fut] = key
        done: set[str] = set()
        with Progress(TextColumn(f"[bold]{self.label}[/bold] {{task.description}}"), BarColumn(),
                      MofNCompleteColumn(), TimeElapsedColumn(), console=self.console,
                      disable=not (self.progress and self.console.is_terminal)) as bar:
            task = bar.add_task("", total=len(items))
            try:
                for fut in as_completed(list(futures)):
                    key = futures.pop(fut)
                    try:
                        result = fut.result()
                    except Exception as exc:  # noqa: BLE001 - e.g. KilledWorker: every retry died
                        result = TaskFailure(f"{type(exc).__name__}: {exc}")
                    fut.release()
                    if key in done:
                        continue
                    done.add(key)
                    bar.update(task, advance=1, description=describe(key) if describe else key)
                    yield key, result
            finally:
                # the caller stopped early (an error, its table cannot be written): the runs not
                # started are not started, those running are abandoned
                if futures:
                    self.client.cancel(list(futures))

    def close(self) -> None:
        try:
            self.client.close()
        finally:
            if self.cluster is not None:
                self.cluster.close()

    def __enter__(self) -> "Executor":
        return self

    def __exit__(self, *exc) -> None:
        self.close()
