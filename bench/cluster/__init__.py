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

The runs start child processes (the firmware stub, the recorder): a worker must not be a
daemonic process. The local cluster is started with ``distributed.worker.daemon = False``;
workers of an external cluster need ``DASK_DISTRIBUTED__WORKER__DAEMON=False`` in their
environment (a task on a daemonic worker comes back as a TaskFailure that says so).
"""
from __future__ import annotations

import os
import resource
import time
import traceback
import uuid
from dataclasses import dataclass
from typing import Any, Callable, Iterable, Iterator


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


def call(fn: Callable, args: tuple, time_limit_s: float | None) -> TaskResult | TaskFailure:
    """Run one task on a worker (or here): never raises."""
    import multiprocessing as mp

    from .limits import time_limit

    if mp.current_process().daemon:
        return TaskFailure("this Dask worker is a daemonic process and a run starts child "
                           "processes (the stub, the recorder): start the workers with "
                           "DASK_DISTRIBUTED__WORKER__DAEMON=False (docs/sweeps.md)",
                           _worker_name())
    c0, t0 = process_cpu_s(), time.monotonic()
    try:
        with time_limit(time_limit_s):
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

        import dask
        from distributed import Client, LocalCluster
        from rich.console import Console

        self.console = console or Console(stderr=True)
        self.progress = progress
        self.label = label
        self.cluster = None
        if scheduler:
            self.client = Client(scheduler, timeout="10s")
            self.where = f"Dask scheduler {scheduler}"
            link = getattr(self.client, "dashboard_link", None)
            n = len(self.client.scheduler_info().get("workers", {}))
            self.console.print(f"{label}: on {scheduler} ({n} workers)"
                               + (f"; progress on Dask's dashboard {link}" if link else ""))
        else:
            n = workers or default_workers()
            with dask.config.set({"distributed.worker.daemon": False}):
                self.cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                                            dashboard_address=None, silence_logs=logging.ERROR)
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
