"""The C stub behind a man in the middle: the bench (or the conformance kit) opens ``serial:<path>``,
a thread copies the serial frames both ways between that pty and the stub's, and hooks may change,
drop or add frames on the way, to make a controller that misbehaves in one precise way.

Hooks take one COBS chunk (the octets between two delimiters) and return the chunks to send on
(``[]`` drops it). ``decode(chunk)`` gives (frame id, payload) of a valid frame, else None (a chunk
that fails section 2.4 of docs/protocol.md goes on untouched unless a hook says otherwise);
``encode(frame_id, payload)`` builds a chunk.
"""
from __future__ import annotations

import os
import select
import subprocess
import threading
import tty
from typing import Callable

from hil_bench.loop.links.stub import stub_path
from hil_bench.protocol.framing import decode_chunk, encode_frame

Hook = Callable[[bytes], list[bytes]]


def decode(chunk: bytes) -> tuple[int, bytes] | None:
    verdict, frame = decode_chunk(chunk) if chunk else (1, None)
    return frame if verdict == 0 else None


def encode(frame_id: int, payload: bytes) -> bytes:
    return encode_frame(frame_id, payload)[:-1]


class PtyProxy:
    def __init__(self, to_controller: Hook | None = None, to_host: Hook | None = None,
                 stub_args: tuple[str, ...] = ()):
        self.bench_m, self.bench_s = os.openpty()
        self.stub_m, self.stub_s = os.openpty()
        for fd in (self.bench_m, self.bench_s, self.stub_m, self.stub_s):
            tty.setraw(fd)
        self.path = os.ttyname(self.bench_s)
        self.hooks = {self.bench_m: (self.stub_m, to_controller), self.stub_m: (self.bench_m, to_host)}
        self.pending = {self.bench_m: b"", self.stub_m: b""}
        self.stub = subprocess.Popen([str(stub_path()), "--port", os.ttyname(self.stub_s), "--quiet",
                                      *stub_args])
        self.stop = threading.Event()
        self.thread = threading.Thread(target=self._pump, daemon=True)
        self.thread.start()

    def _pump(self) -> None:
        while not self.stop.is_set():
            ready, _, _ = select.select(list(self.hooks), [], [], 0.05)
            try:
                for src in ready:
                    dst, hook = self.hooks[src]
                    data = os.read(src, 4096)
                    if hook is None:
                        os.write(dst, data)
                        continue
                    *chunks, self.pending[src] = (self.pending[src] + data).split(b"\x00")
                    out = [c + b"\x00" for chunk in chunks for c in (hook(chunk) if chunk else [chunk])]
                    if out:
                        os.write(dst, b"".join(out))
            except OSError:
                return

    def close(self) -> None:
        self.stop.set()
        self.thread.join(5)
        for fd in (self.stub_m, self.bench_m, self.bench_s):
            os.close(fd)
        self.stub.wait(10)
        os.close(self.stub_s)
