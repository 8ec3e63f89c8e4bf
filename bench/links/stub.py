"""The C firmware stub as the controller under test, on a pseudo-terminal the bench creates.

The bench opens a pty pair, puts both ends in raw mode, starts ``hil_stub --port <slave>`` and
talks serial framing on the master. The stub's stderr is kept (last lines shown if it dies).
"""
from __future__ import annotations

import collections
import os
import subprocess
import threading
import tty
from pathlib import Path

from .base import LinkError
from .serial_link import FdTransport, SerialLink

REPO_ROOT = Path(__file__).resolve().parents[2]


def stub_path() -> Path:
    """The stub executable: $HIL_STUB if set, else build/bin/hil_stub of this checkout."""
    env = os.environ.get("HIL_STUB")
    path = Path(env) if env else REPO_ROOT / "build" / "bin" / "hil_stub"
    if not path.is_file() or not os.access(path, os.X_OK):
        raise LinkError(f"firmware stub not found at {path}: run `make build` first "
                        f"(or point $HIL_STUB at an hil_stub executable)")
    return path


class StubProcess:
    """A running hil_stub on the slave side of a pty; ``link`` is the master side."""

    def __init__(self, extra_args: tuple[str, ...] = (), executable: Path | None = None):
        self.executable = executable or stub_path()
        master, slave = os.openpty()
        tty.setraw(master)
        tty.setraw(slave)
        self.slave_name = os.ttyname(slave)
        self._master = master
        self._slave = slave
        self.stderr_tail: collections.deque[str] = collections.deque(maxlen=20)
        self.proc = subprocess.Popen(
            [str(self.executable), "--port", self.slave_name, *extra_args],
            stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
            text=True, close_fds=True,
            start_new_session=True,  # a terminal's Ctrl-C reaches the bench only; it stops the stub
        )
        # The stub opens the slave itself; keeping our copy open would hide its exit (no EIO).
        os.close(slave)
        self._reader = threading.Thread(target=self._drain_stderr, daemon=True)
        self._reader.start()
        self.link = SerialLink(FdTransport(master, f"pty {self.slave_name} (hil_stub pid "
                                                   f"{self.proc.pid})"))

    def _drain_stderr(self) -> None:
        assert self.proc.stderr is not None
        for line in self.proc.stderr:
            self.stderr_tail.append(line.rstrip())

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
        try:
            return self.proc.wait(timeout=timeout_s)
        except subprocess.TimeoutExpired:
            self.proc.terminate()
            try:
                return self.proc.wait(timeout=timeout_s)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                return self.proc.wait()
        finally:
            self._reader.join(timeout=1.0)
