"""A busy host on demand: CPU-bound processes beside the bench, and the controller's process stopped
now and then (SIGSTOP, then SIGCONT after 50-500 ms), as a loaded or descheduling host does to it.

Used by ``tools/load.py`` (the command that proves "a busy host makes a lockstep run slower, never
different", docs/performance.md) and by the tests that run part of the suite under load
(``tests/test_under_load.py``). Only processes descended from this one are ever stopped, so other
work on the machine is left alone.

    with HostLoad(hogs=4, pause_pattern=r"hil_stub|qemu-system-arm") as load:
        ...                        # run the bench here
    print(load.summary())          # pauses made, their total and longest
"""
from __future__ import annotations

import multiprocessing as mp
import os
import random
import re
import signal
import threading
import time
from dataclasses import dataclass, field

#: the processes a lockstep run's controller lives in: the host stub, QEMU running the firmware
CONTROLLER_PATTERN = r"(^|/)(hil_stub|qemu-system-arm) "
#: the bench's own process (software in the loop: the controller runs in it; a stall of the host)
BENCH_PATTERN = r"-m hil_bench |/bin/bench "


def _spin(stop) -> None:   # pragma: no cover - runs in a child process
    os.nice(0)
    x = 0
    while not stop.is_set():
        for _ in range(100_000):
            x = (x * 1103515245 + 12345) & 0x7FFFFFFF


def _descendants(root: int) -> dict[int, str]:
    """pid -> command line of every live process below ``root`` (from /proc)."""
    parent: dict[int, int] = {}
    cmd: dict[int, str] = {}
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        pid = int(entry)
        try:
            with open(f"/proc/{pid}/stat", "rb") as f:
                stat = f.read().decode(errors="replace")
            with open(f"/proc/{pid}/cmdline", "rb") as f:
                cmd[pid] = f.read().replace(b"\0", b" ").decode(errors="replace").strip()
        except OSError:
            continue
        # the state and ppid follow the command name, which is in parentheses and may hold spaces
        rest = stat[stat.rfind(")") + 2:].split()
        if rest and rest[0] != "Z":
            parent[pid] = int(rest[1])
    out = {}
    for pid in parent:
        p, hops = pid, 0
        while p in parent and p != root and hops < 64:
            p, hops = parent[p], hops + 1
        if p == root and pid != root:
            out[pid] = cmd.get(pid, "")
    return out


@dataclass
class PauseLog:
    pauses: list[tuple[int, str, float]] = field(default_factory=list)   # pid, command, seconds

    def summary(self) -> str:
        if not self.pauses:
            return "no controller process was paused"
        total = sum(s for _, _, s in self.pauses)
        longest = max(s for _, _, s in self.pauses)
        procs = sorted({c.split()[0].rsplit("/", 1)[-1] for _, c, _ in self.pauses if c})
        return (f"{len(self.pauses)} pauses of {', '.join(procs)}: {total:.2f} s in all, the longest "
                f"{longest * 1e3:.0f} ms")


class HostLoad:
    """``hogs`` CPU-bound processes (default: 2 per CPU this process may use) and, when
    ``pause_pattern`` is given, a thread that every ``every_s`` (uniform) SIGSTOPs each descendant
    process whose command line matches and SIGCONTs it ``pause_s`` (uniform) later. Seeded: the
    same seed gives the same sequence of draws (what the host does with them is not repeatable)."""

    def __init__(self, hogs: int | None = None, pause_pattern: str | None = CONTROLLER_PATTERN,
                 pause_s: tuple[float, float] = (0.05, 0.5), every_s: tuple[float, float] = (0.3, 1.5),
                 seed: int = 1):
        self.hogs = 2 * len(os.sched_getaffinity(0)) if hogs is None else int(hogs)
        self.pattern = re.compile(pause_pattern) if pause_pattern else None
        self.pause_s, self.every_s = pause_s, every_s
        self.rng = random.Random(seed)
        self.log = PauseLog()
        self._stop = mp.Event()
        self._procs: list[mp.Process] = []
        self._thread: threading.Thread | None = None
        self._halt = threading.Event()

    def __enter__(self) -> "HostLoad":
        ctx = mp.get_context("fork")
        for _ in range(self.hogs):
            p = ctx.Process(target=_spin, args=(self._stop,), daemon=True)
            p.start()
            self._procs.append(p)
        if self.pattern is not None:
            self._thread = threading.Thread(target=self._pauser, name="host-load-pauser", daemon=True)
            self._thread.start()
        return self

    def _pauser(self) -> None:
        me = os.getpid()
        while not self._halt.wait(self.rng.uniform(*self.every_s)):
            targets = {pid: c for pid, c in _descendants(me).items() if self.pattern.search(c)}
            if not targets:
                continue
            hold = self.rng.uniform(*self.pause_s)
            stopped = []
            for pid in targets:
                try:
                    os.kill(pid, signal.SIGSTOP)
                    stopped.append(pid)
                except ProcessLookupError:
                    pass
            time.sleep(hold)
            for pid in stopped:
                try:
                    os.kill(pid, signal.SIGCONT)
                except ProcessLookupError:
                    pass
                self.log.pauses.append((pid, targets[pid], hold))

    def __exit__(self, *exc) -> None:
        self._halt.set()
        if self._thread is not None:
            self._thread.join(timeout=5.0)
        self._stop.set()
        for p in self._procs:
            p.join(timeout=5.0)
            if p.is_alive():
                p.kill()

    def summary(self) -> str:
        return f"{self.hogs} CPU-bound processes; {self.log.summary()}"
