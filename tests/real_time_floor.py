"""Whether this machine keeps real time right now, measured in the test that needs it.

A real-time run is paced by the wall clock: on a busy host it loses periods, and what it then
shows is the host, not the loop. The tests that judge a loop in real time (tests/test_realtime.py)
measure the machine first, in the same test, with ``build/bin/wakeup_latency`` (the engine's
real-time loop with nothing in it, bench/perf/wakeup_latency.c) at the run's period and at
normal priority: the priority of the kernel's pty work and of the other processes a run needs
(the engine and the stub ask for SCHED_FIFO, the pty's bytes are carried by the kernel's
ordinary workers). A thread that starts more than a period late in more than
``LOST_PERIODS_LIMIT`` of its periods means the machine cannot keep real time now: the test
skips, saying so with the figures (as tests/c/test_engine.c's test_sil_realtime does). It never
waits longer: lateness is what real time measures.
"""
from __future__ import annotations

import json
import subprocess
from dataclasses import dataclass

import pytest

#: the share of periods a run (or the floor) may lose before it says nothing about the loop: on
#: a shared VM the hypervisor stops the guest for milliseconds at a time (docs/performance.md,
#: "Real time": a lone SCHED_FIFO thread loses 2.2e-3 of its periods when the machine is quiet),
#: and a sensorless loop that loses 1e-2 of its duty updates degrades, as it would on a drive
LOST_PERIODS_LIMIT = 0.01
#: how long the floor is measured before a run
FLOOR_S = 0.5


@dataclass
class Floor:
    """One measurement of build/bin/wakeup_latency."""

    period_us: int
    periods: int
    late: int              #: periods that started more than one period late
    start_p99_us: float
    start_max_us: float

    @property
    def lost_rate(self) -> float:
        return self.late / self.periods

    @property
    def keeps_real_time(self) -> bool:
        return self.lost_rate <= LOST_PERIODS_LIMIT

    def __str__(self) -> str:
        return (f"a normal-priority thread woken every {self.period_us} us (build/bin/wakeup_latency) "
                f"started {self.late} of {self.periods} periods ({self.lost_rate:.1%}) more than a "
                f"period late, start p99 {self.start_p99_us:.0f} us, max {self.start_max_us:.0f} us")


def measure_floor(period_s: float, duration_s: float = FLOOR_S) -> Floor:
    """Run wakeup_latency at ``period_s`` for ``duration_s`` at normal priority (policy
    SCHED_OTHER, the engine's 30 us spin)."""
    from hil_bench.installation import find_executable

    period_us = max(int(round(period_s * 1e6)), 1)
    periods = max(int(duration_s / period_s), 10)
    exe = find_executable("wakeup_latency")
    out = json.loads(subprocess.run([str(exe), str(period_us), str(periods), "0"],
                                    capture_output=True, text=True, check=True).stdout)
    return Floor(period_us, periods, int(out["throttled"]), float(out["start_p99_us"]),
                 float(out["start_max_us"]))


def require_real_time(period_s: float) -> Floor:
    """Skip the calling test when the machine cannot keep real time at ``period_s`` now."""
    floor = measure_floor(period_s)
    if not floor.keeps_real_time:
        pytest.skip(f"this machine could not keep real time: {floor} (more than "
                    f"{LOST_PERIODS_LIMIT:.0%}); see hil_bench.perf.loop")
    return floor
