"""The C firmware stub as the controller under test, started by the bench on a link it creates.

``mode`` chooses the link (the stub's stderr is kept either way: last lines shown if it dies):

* ``serial`` (``--link stub``): a pty pair; ``hil_stub --port <slave>``; the bench talks the serial
  framing on the master.
* ``slcan`` (``--link stub-slcan``): a pty pair; the stub gets the master (``--slcan fd:N``) and
  plays a USB-CAN adapter speaking SLCAN with the drive behind it; python-can's slcan interface
  opens the slave by its name (/dev/pts/N), as it would open /dev/ttyACM0.
* ``socketcand`` (``--link stub-socketcand``): the bench listens on a loopback TCP port, hands the
  listening socket to the stub (``--socketcand fd:N``: no port race) and python-can's socketcand
  interface connects to it.
* ``socketcan`` (``--link stub-socketcan:vcan0``): the stub and python-can's socketcan interface on
  the same SocketCAN interface (needs kernel CAN: vcan in CI).

Closing the link ends the stub (it exits on EOF / hang-up); SocketCAN has no end of stream, so
there the stub is stopped with SIGTERM.
"""
from __future__ import annotations

import collections
import os
import socket
import subprocess
import threading
import time
import tty
from pathlib import Path

from hil_bench.installation import find_executable

from hil_bench.protocol.timing import PATIENCE_S

from .base import LinkError, reap
from .serial_link import FdTransport, SerialLink

STUB_SOCKETCAND_BUS = "hil0"   #: the bus name the stub serves as a socketcand server
#: the stub greets within milliseconds of starting, on a quiet host; a busy host may delay its start
#: by seconds, so the bench waits as it waits for any answer (docs/protocol.md 6.5, the patience)
STUB_GREETING_TIMEOUT_S = PATIENCE_S
MODES = ("serial", "slcan", "socketcand", "socketcan")


def stub_path() -> Path:
    """The stub executable: $HIL_STUB if set, else the installed package's bin/hil_stub, else
    build/bin/hil_stub of the checkout (hil_bench.installation)."""
    try:
        return find_executable("hil_stub", env="HIL_STUB")
    except FileNotFoundError as exc:
        raise LinkError(f"firmware stub: {exc}") from None


#: for the stub to open its port ("listening on" on stderr), while its process lives (the patience)
STUB_START_TIMEOUT_S = PATIENCE_S


class StubProcess:
    """A running hil_stub and ``link``, the bench's end of the link to it."""

    def __init__(self, extra_args: tuple[str, ...] = (), executable: Path | None = None,
                 mode: str = "serial", can_spec=None, capture_path: Path | None = None):
        if mode not in MODES:
            raise LinkError(f"unknown stub link mode {mode!r} (modes: {', '.join(MODES)})")
        if mode != "serial" and can_spec is None:
            raise LinkError(f"stub link mode {mode!r} needs a CAN spec")
        self.executable = executable or stub_path()
        self.controller = f"hil_stub {self.executable}"   # the recording's "controller"
        self.mode = mode
        self.stderr_tail: collections.deque[str] = collections.deque(maxlen=20)
        self._listening = threading.Event()   # the stub said it has its port open
        self.proc: subprocess.Popen | None = None
        self._reader: threading.Thread | None = None
        if mode == "serial":
            self._start_serial(extra_args)
            return
        try:
            bus = getattr(self, f"_start_{mode}")(extra_args, can_spec)
        except LinkError as exc:
            self._abandon()
            raise LinkError(self._why_not_started(exc)) from None
        from .can_link import CanLink

        try:
            self.link = CanLink(bus, can_spec, capture_path,
                                description=f"{mode} {can_spec.channel} (hil_stub pid "
                                            f"{self.proc.pid}), {can_spec.bus_name}")
        except LinkError:
            bus.shutdown()
            self._abandon()
            raise
        self.link.failure_context = self._failure_context

    # -- starting ---------------------------------------------------------------------------------
    def _spawn(self, args: list[str], pass_fds: tuple[int, ...] = ()) -> None:
        self.proc = subprocess.Popen(
            [str(self.executable), *args],
            stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
            text=True, close_fds=True, pass_fds=pass_fds,
            start_new_session=True,  # a terminal's Ctrl-C reaches the bench only; it stops the stub
        )
        self._reader = threading.Thread(target=self._drain_stderr, daemon=True)
        self._reader.start()

    @staticmethod
    def _raw_pty() -> tuple[int, int, str]:
        master, slave = os.openpty()
        tty.setraw(master)
        tty.setraw(slave)
        return master, slave, os.ttyname(slave)

    def _start_serial(self, extra_args: tuple[str, ...]) -> None:
        master, slave, self.slave_name = self._raw_pty()
        self._spawn(["--port", self.slave_name, *extra_args])
        # The stub opens the slave itself; keeping our copy open would hide its exit (no EIO).
        # But close it only once the stub has opened it: a pty with no slave open reads as EIO,
        # which would look like a dead stub to a bench that is quicker than the stub's start-up
        # (a sanitizer build takes a while).
        deadline = time.monotonic() + STUB_START_TIMEOUT_S
        while (not self._listening.wait(0.05) and self.proc.poll() is None
               and time.monotonic() < deadline):
            pass
        os.close(slave)
        self.link = SerialLink(FdTransport(master, f"pty {self.slave_name} (hil_stub pid "
                                                   f"{self.proc.pid})"))

    def _start_slcan(self, extra_args, can_spec):
        from .can_link import open_can_bus

        master, slave, self.slave_name = self._raw_pty()
        try:
            self._spawn(["--slcan", f"fd:{master}", *extra_args], pass_fds=(master,))
        finally:
            os.close(master)   # the stub has it; ours would hide python-can closing the slave
        can_spec.channel = self.slave_name
        can_spec.options.setdefault("sleep_after_open", 0)   # no USB enumeration to wait for
        try:
            return open_can_bus(can_spec)
        finally:
            os.close(slave)    # python-can has its own descriptor now; ours would hide its close

    def _start_socketcand(self, extra_args, can_spec):
        from .can_link import open_can_bus

        # The listening socket is shared with the stub: python-can's connection waits in its backlog
        # (no port race), and while ours stays open a stub that died at start-up shows as a missing
        # greeting (after STUB_GREETING_TIMEOUT_S), not as python-can retrying refused
        # connections for 10 s.
        with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as listener:
            listener.bind(("127.0.0.1", 0))
            listener.listen(1)
            port = listener.getsockname()[1]
            self._spawn(["--socketcand", f"fd:{listener.fileno()}", "--bus", STUB_SOCKETCAND_BUS,
                         *extra_args], pass_fds=(listener.fileno(),))
            can_spec.channel = STUB_SOCKETCAND_BUS
            can_spec.options.update(host="127.0.0.1", port=port)
            can_spec.options.setdefault("tcp_tune", True)
            return open_can_bus(can_spec, handshake_timeout_s=STUB_GREETING_TIMEOUT_S)

    def _start_socketcan(self, extra_args, can_spec):
        from .can_link import open_can_bus

        self._spawn(["--socketcan", can_spec.channel, *extra_args])
        return open_can_bus(can_spec)

    def _why_not_started(self, exc: LinkError) -> str:
        """The stub's own words first when it exited (e.g. "no CAN interface vcan0")."""
        if self.proc is None:
            return str(exc)
        try:
            self.proc.wait(timeout=0.5)
        except subprocess.TimeoutExpired:
            return str(exc)
        return f"{exc}; " + self.death_message()

    def _abandon(self) -> None:
        if self.proc is None:
            return
        if self.proc.poll() is None:
            self.proc.terminate()
        try:
            self.proc.wait(timeout=2.0)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()
        if self._reader is not None:
            self._reader.join(timeout=1.0)

    # -- running ----------------------------------------------------------------------------------
    def _failure_context(self) -> str | None:
        """When the link fails: if the stub is dying, that is the cause (wait a moment for it)."""
        try:
            self.proc.wait(timeout=0.5)
        except subprocess.TimeoutExpired:
            return None
        return self.death_message()

    def _drain_stderr(self) -> None:
        assert self.proc is not None and self.proc.stderr is not None
        for line in self.proc.stderr:
            self.stderr_tail.append(line.rstrip())
            if "listening on" in line:
                self._listening.set()
        self._listening.set()   # exited: nobody to wait for

    def alive(self) -> bool:
        return self.proc.poll() is None

    def death_message(self) -> str:
        """Why the stub is gone, with its last stderr lines."""
        code = self.proc.poll()
        self._reader.join(timeout=0.5)
        tail = "\n    ".join(self.stderr_tail) or "(no output)"
        if code is None:
            return f"controller stub (pid {self.proc.pid}) stopped answering; stderr:\n    {tail}"
        how = f"killed by signal {-code}" if code < 0 else f"exited with code {code}"
        return f"controller stub {how}; its last stderr lines:\n    {tail}"

    def stop(self, timeout_s: float = 2.0) -> int | None:
        """Close the link (the stub exits on EOF), then terminate/kill if it lingers."""
        self.link.close()
        if self.mode == "socketcan" and self.proc.poll() is None:
            self.proc.terminate()   # no end of stream on a CAN bus: the stub exits 0 on SIGTERM
        try:
            return reap(self.proc, timeout_s)
        finally:
            self._reader.join(timeout=1.0)
