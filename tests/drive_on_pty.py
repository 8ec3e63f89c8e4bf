"""The C stub as a drive on a port the bench opens by name, as it would open /dev/ttyUSB0 or an
SLCAN adapter's /dev/ttyACM0 (docs/real-drive.md's commands run against it: tests/test_real_drive.py).

``StubOnPty``: the stub on the master end of a pty (``hil_stub --port fd:N``, or ``--slcan fd:N``:
a USB-CAN adapter speaking SLCAN with the drive behind it); the bench opens the slave's path. Nothing
in between: the octets move as fast as the kernel moves them.

``EmulatedAdapter``: the stub behind an emulated USB-serial adapter: a pty the bench opens by name
(``serial:<path>@<baud>``), the stub on a second pty, and between them what the wire and the
adapter do to the octets:

* the wire: 8N1 at ``baud`` both ways (10 bits per octet, one octet after the other per
  direction), so a cycle takes at least the time protocol/budget.py counts;
* the adapter's receive side (drive -> host): octets held until the adapter's *latency timer*
  expires or a USB packet is full (62 data octets), as FTDI's chips do (FTDI AN232B-04: "the
  latency timer counts from the last time data was sent back to the PC"; 16 ms by default).

The host -> drive direction has no latency here (a real full-speed adapter adds up to a USB frame,
1 ms). Used by the tests of the bench's latency warning and by ``python tools/serial_adapter.py``
(docs/real-drive.md's figures of a lockstep cycle through an adapter). Pacing is done with sleeps
in Python threads: right to about 0.1-0.3 ms on a loaded machine, not to the bit.

    with EmulatedAdapter(baud=1_000_000, latency_ms=16) as adapter:
        bench run ... --link serial:{adapter.path}@1000000
"""
from __future__ import annotations

import os
import select
import subprocess
import threading
import time
import tty

from hil_bench.loop.links.stub import stub_path

#: data octets in one full-speed USB packet of an FTDI chip (64 less its 2 status octets)
USB_PACKET_DATA_OCTETS = 62
BITS_PER_OCTET = 10   # 8N1
MODES = {"serial": "--port", "slcan": "--slcan"}


class StubOnPty:
    """The stub on the master end of a pty (``mode`` "serial": the HIL framing; "slcan": an SLCAN
    adapter with the drive behind it); ``path`` is the slave the bench opens. Our copy of the
    slave stays open until ``close``, so the bench may close and open the port again (one command
    after another) without the stub seeing a hang-up; each bench run starts a new session."""

    def __init__(self, mode: str = "serial", stub_args: tuple[str, ...] = ()):
        master, self.slave = os.openpty()
        tty.setraw(master)
        tty.setraw(self.slave)
        self.path = os.ttyname(self.slave)
        self.stub = subprocess.Popen([str(stub_path()), MODES[mode], f"fd:{master}", "--quiet",
                                      *stub_args], pass_fds=(master,))
        os.close(master)

    def __enter__(self) -> "StubOnPty":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def close(self) -> int | None:
        """Hang up (the stub reads EIO and exits); its exit status, None if it had to be killed."""
        os.close(self.slave)
        try:
            return self.stub.wait(10)
        except subprocess.TimeoutExpired:
            self.stub.kill()
            self.stub.wait()
            return None


class EmulatedAdapter:
    """The stub (``hil_stub --port``) behind an emulated wire and USB-serial adapter; ``path`` is
    the port the bench opens. ``baud`` None: no pacing; ``latency_ms`` 0: no hold."""

    def __init__(self, baud: int | None = None, latency_ms: float = 0.0,
                 stub_args: tuple[str, ...] = ()):
        self.baud = baud
        self.latency_s = latency_ms * 1e-3
        self.bench_m, self.bench_s = os.openpty()
        self.stub_m, self.stub_s = os.openpty()
        for fd in (self.bench_m, self.bench_s, self.stub_m, self.stub_s):
            tty.setraw(fd)
        # our copy of the bench's end stays open: the bench may close and open it again (one
        # command after another) without the drive seeing a hang-up
        self.path = os.ttyname(self.bench_s)
        self.stub = subprocess.Popen([str(stub_path()), "--port", os.ttyname(self.stub_s),
                                      "--quiet", *stub_args])
        self.stop = threading.Event()
        self._threads = [threading.Thread(target=self._to_drive, daemon=True),
                         threading.Thread(target=self._to_host, daemon=True)]
        for t in self._threads:
            t.start()

    def __enter__(self) -> "EmulatedAdapter":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    # -- the wire --------------------------------------------------------------------------------
    def _paced(self, n: int, free_at: float) -> float:
        """Sleep until ``n`` octets that could start at ``free_at`` (or now) are off the wire;
        returns when the wire is free again."""
        if not self.baud:
            return 0.0
        done = max(time.monotonic(), free_at) + n * BITS_PER_OCTET / self.baud
        while (left := done - time.monotonic()) > 0:
            time.sleep(left)
        return done

    def _to_drive(self) -> None:
        free_at = 0.0
        while not self.stop.is_set():
            ready, _, _ = select.select([self.bench_m], [], [], 0.05)
            if not ready:
                continue
            try:
                data = os.read(self.bench_m, 4096)
                free_at = self._paced(len(data), free_at)
                os.write(self.stub_m, data)
            except OSError:
                return

    def _to_host(self) -> None:
        free_at = 0.0
        held = b""
        tick = time.monotonic() + self.latency_s
        while not self.stop.is_set():
            wait = max(0.0, tick - time.monotonic()) if self.latency_s else 0.05
            ready, _, _ = select.select([self.stub_m], [], [], min(wait, 0.05))
            try:
                if ready:
                    data = os.read(self.stub_m, 4096)
                    free_at = self._paced(len(data), free_at)
                    if not self.latency_s:
                        os.write(self.bench_m, data)
                        continue
                    held += data
                    while len(held) >= USB_PACKET_DATA_OCTETS:   # a full packet goes at once
                        os.write(self.bench_m, held[:USB_PACKET_DATA_OCTETS])
                        held = held[USB_PACKET_DATA_OCTETS:]
                        tick = time.monotonic() + self.latency_s
                now = time.monotonic()
                if self.latency_s and now >= tick:                # the latency timer expired
                    if held:
                        os.write(self.bench_m, held)
                        held = b""
                    tick = now + self.latency_s
            except OSError:
                return

    def close(self) -> int | None:
        """Stop the pumps and the stub; its exit status (None if it had to be killed)."""
        self.stop.set()
        for t in self._threads:
            t.join(5)
        for fd in (self.stub_m, self.bench_m, self.bench_s):
            os.close(fd)
        try:
            status = self.stub.wait(10)
        except subprocess.TimeoutExpired:
            self.stub.kill()
            self.stub.wait()
            status = None
        os.close(self.stub_s)
        return status

