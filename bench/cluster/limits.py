"""A per-run time limit the executor sets around a task, which the runner's watch loop honours
(hil_bench.loop.runner: the engine is asked to stop, the run ends STOPPED and says why).

Kept free of Dask so that the runner can import it on any machine."""
from __future__ import annotations

import contextvars
import math
import time
from contextlib import contextmanager

_deadline: contextvars.ContextVar[tuple[float, float] | None] = contextvars.ContextVar(
    "hil_bench_run_deadline", default=None)


@contextmanager
def time_limit(seconds: float | None):
    """Within this block a run that is still going after ``seconds`` is ended (None: no limit;
    anything else must be a finite number of seconds > 0)."""
    if seconds is not None and not (isinstance(seconds, (int, float)) and not isinstance(seconds, bool)
                                    and math.isfinite(seconds) and seconds > 0):
        raise ValueError(f"a per-run time limit must be a finite number of seconds > 0, got "
                         f"{seconds!r}")
    token = _deadline.set((time.monotonic() + seconds, seconds) if seconds else None)
    try:
        yield
    finally:
        _deadline.reset(token)


def expired() -> float | None:
    """The limit [s] if it has passed, else None."""
    d = _deadline.get()
    if d is None or time.monotonic() < d[0]:
        return None
    return d[1]
