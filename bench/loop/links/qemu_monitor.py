"""QEMU's human monitor (HMP) on the emulator's stdin/stdout, as ``--link pil-qemu`` drives it.

Why HMP and not QMP: QEMU 7.2 runs a QMP monitor in a thread of its own (``mon_iothread``), and
under ``-icount`` every bottom half the CPU thread schedules (``qemu_bh_schedule`` ->
``icount_notify_exit`` -> ``qemu_clock_notify``) wakes every event loop that has a timer list,
that thread's too. Each register read of the STM32's USART schedules one (its
``qemu_chr_fe_accept_input``), so the QMP thread woke about twice per octet of the link:
measured on G2 cut to 1 s (10 000 cycles, load average 15-17 on the 2 cores), QEMU used 1.21-1.30
ms of CPU per cycle with QMP and 0.72-0.76 ms with HMP, and 88-144 context switches per cycle
against 42-53 (docs/performance.md, "The Cortex-M target"). An HMP monitor has no thread.

The bench uses four commands, each answered before the next ``(qemu) `` prompt: ``info
chardev``, ``cont``, ``xp`` and ``quit``. The monitor echoes what it is sent with terminal
editing sequences; a reply is the text after the echoed line, those sequences removed.
"""
from __future__ import annotations

import collections
import os
import queue
import re
import struct
import subprocess
import threading

from .base import LinkError

PROMPT = b"(qemu) "
TIMEOUT_S = 5.0
_ESCAPES = re.compile(r"\x1b\[[0-9;]*[A-Za-z]")
_CHARDEV_LINE = re.compile(r"^(?P<label>[^:\s]+): filename=(?P<filename>.*)$")


class HumanMonitor:
    """One command at a time; the reply is the monitor's text up to its next prompt."""

    def __init__(self, proc: subprocess.Popen, what: str = "QEMU"):
        self.proc = proc
        self.what = what
        self.replies: queue.Queue[str | None] = queue.Queue()
        #: what QEMU printed that was no reply (kept for the error messages)
        self.other_lines: collections.deque[str] = collections.deque(maxlen=20)
        self._lock = threading.Lock()
        self._reader = threading.Thread(target=self._read, daemon=True, name="qemu-monitor")
        self._reader.start()

    def _read(self) -> None:
        pending = b""
        fd = self.proc.stdout.fileno()
        while True:
            try:
                data = os.read(fd, 65536)
            except OSError:
                data = b""
            if not data:
                break
            pending += data
            while PROMPT in pending:
                reply, _, pending = pending.partition(PROMPT)
                self.replies.put(reply.decode("utf-8", "replace"))
        if pending.strip():
            self.other_lines.extend(_ESCAPES.sub("", pending.decode("utf-8", "replace")).splitlines())
        self.replies.put(None)   # end of stream: QEMU has gone

    def _get(self, timeout_s: float, what: str) -> str:
        try:
            reply = self.replies.get(timeout=timeout_s)
        except queue.Empty:
            raise LinkError(f"{self.what} did not answer {what} within {timeout_s:g} s") from None
        if reply is None:
            self.replies.put(None)
            raise LinkError(f"{self.what} closed its monitor (waiting for {what})")
        return reply

    def greeting(self, timeout_s: float) -> str:
        """The banner up to the first prompt."""
        text = self._get(timeout_s, "the monitor's first prompt")
        self.other_lines.extend(line for line in _ESCAPES.sub("", text).splitlines() if line)
        return text

    def command(self, line: str, timeout_s: float = TIMEOUT_S, expect_reply: bool = True) -> str:
        """Send one command line; its output lines (the echo dropped), joined by newlines."""
        with self._lock:
            try:
                self.proc.stdin.write(line.encode() + b"\n")
                self.proc.stdin.flush()
            except (BrokenPipeError, OSError, ValueError):
                raise LinkError(f"{self.what} is gone (monitor command {line!r})") from None
            if not expect_reply:
                return ""
            reply = self._get(timeout_s, f"the monitor command {line!r}")
        _, _, output = reply.partition("\r\n")          # the first line is the echo
        return "\n".join(_ESCAPES.sub("", out).rstrip("\r") for out in output.split("\r\n")).strip()

    def chardev_filenames(self) -> dict[str, str]:
        """``info chardev``: label -> filename (``disconnected:unix:...`` until a client came)."""
        out = {}
        for line in self.command("info chardev").splitlines():
            m = _CHARDEV_LINE.match(line.strip())
            if m:
                out[m["label"]] = m["filename"]
        return out

    def read_memory(self, addr: int, n_words: int) -> bytes:
        """Guest physical memory, through ``xp`` (no file involved)."""
        text = self.command(f"xp /{n_words}wx {addr:#x}")
        words: list[int] = []
        for line in text.splitlines():
            head, sep, values = line.partition(":")
            if not sep:
                continue
            try:
                int(head, 16)
                words += [int(v, 16) for v in values.split()]
            except ValueError:
                raise LinkError(f"{self.what}: unexpected reply to xp at {addr:#x}: {text!r}") from None
        if len(words) < n_words:
            raise LinkError(f"{self.what} read {len(words)} of {n_words} words at {addr:#x}: {text!r}")
        return struct.pack(f"<{n_words}I", *words[:n_words])
