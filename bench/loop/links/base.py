"""The link abstraction: one class, a hook per backend (python-can's BusABC style).

A link moves (frame_id, payload) pairs of the message set in ``protocol/hil.dbc``. The public
methods do the common work (counting, timeouts); backends implement ``_write_frames`` and
``_read_frames``.
"""
from __future__ import annotations

import subprocess
import time
from abc import ABC, abstractmethod
from dataclasses import dataclass, field

from hil_bench.errors import BenchError


class LinkError(BenchError, RuntimeError):
    """The link failed (device vanished, peer closed, timeout on a required answer)."""


@dataclass
class LinkCounters:
    frames_tx: int = 0
    frames_rx: int = 0
    bytes_tx: int = 0
    bytes_rx: int = 0
    extra: dict[str, int] = field(default_factory=dict)

    def as_dict(self) -> dict[str, int]:
        d = {"frames_tx": self.frames_tx, "frames_rx": self.frames_rx,
             "bytes_tx": self.bytes_tx, "bytes_rx": self.bytes_rx}
        d.update(self.extra)
        return d


class Link(ABC):
    """A bidirectional frame link to the controller under test."""

    #: human-readable description, e.g. "serial pty /dev/pts/4"
    description: str = "link"

    def __init__(self) -> None:
        self.counters = LinkCounters()
        self._pending: list[tuple[int, bytes]] = []

    # -- public API -----------------------------------------------------------------------
    def send(self, frames: list[tuple[int, bytes]]) -> None:
        """Send frames in order (one write where the backend allows it)."""
        self._write_frames(frames)
        self.counters.frames_tx += len(frames)

    def recv(self, timeout_s: float) -> list[tuple[int, bytes]]:
        """Frames that arrived within timeout_s (possibly none). Returns as soon as any arrive."""
        if self._pending:
            out, self._pending = self._pending, []
            return out
        frames = self._read_frames(timeout_s)
        self.counters.frames_rx += len(frames)
        return frames

    def recv_until(self, predicate, timeout_s: float, on_frame=None) -> tuple[int, bytes] | None:
        """Receive until predicate(frame_id, payload) is true; other frames go to on_frame.

        Returns the matching frame or None on timeout. Frames after the match stay queued.
        """
        deadline = time.monotonic() + timeout_s
        while True:
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                return None
            frames = self.recv(remaining)
            for i, (fid, payload) in enumerate(frames):
                if predicate(fid, payload):
                    self._pending = frames[i + 1:] + self._pending
                    return fid, payload
                if on_frame is not None:
                    on_frame(fid, payload)

    def stats(self) -> dict[str, int]:
        """Counters: frames and bytes both ways plus the backend's error counters."""
        self._update_extra_counters()
        return self.counters.as_dict()

    def max_cycle_rate_hz(self, flags: int) -> float:
        """Highest control rate this link can carry with the HELLO ``flags``' frame set
        (protocol/budget.py); inf if unlimited (a pty)."""
        return float("inf")

    def close(self) -> None:
        self._close()

    def __enter__(self) -> "Link":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    # -- backend hooks -------------------------------------------------------------------
    @abstractmethod
    def _write_frames(self, frames: list[tuple[int, bytes]]) -> None: ...

    @abstractmethod
    def _read_frames(self, timeout_s: float) -> list[tuple[int, bytes]]: ...

    def _update_extra_counters(self) -> None:
        pass

    def _close(self) -> None:
        pass


def reap(proc: subprocess.Popen, timeout_s: float) -> int:
    """Wait for a controller process the bench owns (the stub, QEMU) to exit; terminate it, then
    kill it, if it lingers past ``timeout_s`` each time. Returns its exit status."""
    try:
        return proc.wait(timeout=timeout_s)
    except subprocess.TimeoutExpired:
        proc.terminate()
        try:
            return proc.wait(timeout=timeout_s)
        except subprocess.TimeoutExpired:
            proc.kill()
            return proc.wait()
