"""The host's own share of a round trip: an echo through the same kind of link, in this process.

The conformance kit measures a controller's answer time from the instant it writes SENSE(k) to the instant
it has read DUTY(k). On a busy host part of that is the host's own: the kit's thread waking up late, the
kernel's tty layer, a pause of this process. :class:`HostLoopback` measures exactly that part, in the same
run and under the same load: a thread of this process echoes what the kit writes into the other end of a
link of the same kind (a pty pair for serial and SLCAN links, a local socket pair for the others), answering
a burst of the uplink's size with a burst of the downlink's size. The controller's own share is then the
answer time less the loopback's at the same quantile (docs/protocol.md section 9).
"""
from __future__ import annotations

import os
import select
import socket
import threading
import time
import tty


class HostLoopback:
    """An echo partner in a thread of this process: ``round_trip_s(up, down)`` writes ``up`` octets, the
    thread answers with ``down`` octets, and the time until they have been read is returned."""

    def __init__(self, kind: str = "pty"):
        self.kind = kind
        if kind == "pty":
            self._near, self._far = os.openpty()
            for fd in (self._near, self._far):
                tty.setraw(fd)
        else:
            a, b = socket.socketpair()
            self._socks = (a, b)
            self._near, self._far = a.fileno(), b.fileno()
        self._stop = threading.Event()
        self._down = 0
        self._thread = threading.Thread(target=self._echo, name="host-loopback", daemon=True)
        self._thread.start()

    def _echo(self) -> None:
        while not self._stop.is_set():
            ready, _, _ = select.select([self._far], [], [], 0.2)
            if not ready:
                continue
            try:
                data = os.read(self._far, 4096)
            except OSError:
                return
            if not data:
                return
            # one answer per burst: the octet 0x00 ends a burst, as the frame delimiter does
            for _ in range(data.count(0)):
                os.write(self._far, b"\x55" * (self._down - 1) + b"\x00")

    def round_trip_s(self, up_octets: int, down_octets: int) -> float | None:
        """Seconds from writing ``up_octets`` to having read ``down_octets`` back; None if the echo did
        not come within 5 s (the thread is gone)."""
        self._down = max(int(down_octets), 1)
        t0 = time.monotonic()
        os.write(self._near, b"\x55" * (max(int(up_octets), 1) - 1) + b"\x00")
        got = 0
        end = t0 + 5.0
        while got < self._down:
            left = end - time.monotonic()
            if left <= 0:
                return None
            ready, _, _ = select.select([self._near], [], [], left)
            if ready:
                got += len(os.read(self._near, 4096))
        return time.monotonic() - t0

    def close(self) -> None:
        self._stop.set()
        if self.kind == "pty":
            for fd in (self._near, self._far):
                try:
                    os.close(fd)
                except OSError:
                    pass
        else:
            for s in self._socks:
                s.close()
        self._thread.join(timeout=1.0)

    def __enter__(self) -> "HostLoopback":
        return self

    def __exit__(self, *exc) -> None:
        self.close()
