"""Software in the loop (``--link sil``): the firmware's C (controller, estimators, protection,
HIL session: firmware_stub/src) linked into this process behind its SIL port
(firmware_stub/port/sil/sil_port.h), and called from the cycle engine's own thread.

No pty, no second process, no Python per cycle: the engine writes its serial octets (COBS +
CRC-16, the same encoder as on a pty) straight into the firmware's deframer, and deframes the
firmware's answer octets as it would read them from a descriptor (plant_rt/c/engine_link.h,
``eng_link_peer_t``). Before the run, the bench's handshake and CONFIG go through the same octets
from Python (``SilTransport`` under a ``SerialLink``), so every frame of the run, set-up included,
crosses the same codecs as with ``--link stub``.

The firmware here is the one built into ``hil_bench.plant_rt._plant_c`` from the same sources
as ``build/bin/hil_stub`` (tests/test_sil.py proves both answer byte for byte alike).
"""
from __future__ import annotations

import time

from .base import LinkError

#: the stub options the SIL port has an equivalent for (the rest are the stub's own I/O)
SIL_STUB_ARGS = ("--heartbeat-always",)
_READ_CHUNK = 4096


class SilTransport:
    """The firmware's SIL port as a byte transport (what a UART driver would be)."""

    def __init__(self, hb_always: bool = False):
        from hil_bench.plant_rt._plant_c import ffi, lib

        self._ffi, self._lib = ffi, lib
        self.port = ffi.new("sil_port_t *")
        lib.sil_port_init(self.port, 1 if hb_always else 0, time.monotonic_ns())
        self._buf = ffi.new(f"uint8_t[{_READ_CHUNK}]")
        self.description = "sil (firmware_stub/src in the engine's process)"

    def write(self, data: bytes) -> None:
        self._lib.sil_port_write(self.port, data, len(data), time.monotonic_ns())

    def read(self, timeout_s: float) -> bytes:
        """What the firmware sent; it answers at once, so waiting only ever finds heartbeats."""
        deadline = time.monotonic() + max(timeout_s, 0.0)
        while True:
            n = self._lib.sil_port_read(self.port, self._buf, _READ_CHUNK, time.monotonic_ns())
            if n:
                return bytes(self._ffi.buffer(self._buf, n))
            left = deadline - time.monotonic()
            if left <= 0:
                return b""
            time.sleep(min(left, 0.002))

    def stats(self) -> dict[str, int]:
        """The firmware session's counters (what the stub prints at exit)."""
        s = self.port.session.stats
        out = {k: int(getattr(s, k)) for k in ("frames_rx", "cycles", "unknown_ids",
                                                "length_errors", "seq_errors", "config_rejected",
                                                "not_ready", "repeats", "cmd_seq_gaps")}
        out.update(rx_errors=int(self._lib.sil_port_rx_errors(self.port)),
                   tx_overflows=int(self.port.tx_overflows), restarts=int(self.port.restarts))
        return out

    def close(self) -> None:
        pass


def open_sil_link(stub_args: tuple[str, ...] = ()):
    """A SerialLink to a fresh in-process firmware (power-up state)."""
    from .serial_link import SerialLink

    other = [a for a in stub_args if a not in SIL_STUB_ARGS]
    if other:
        raise LinkError(f"--link sil: the stub options {' '.join(other)} have no meaning in "
                        f"process (the SIL port has {', '.join(SIL_STUB_ARGS)} only); use "
                        f"--link stub for them")
    return SerialLink(SilTransport(hb_always="--heartbeat-always" in stub_args))
