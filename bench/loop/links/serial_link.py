"""Serial backend: the HIL frames in COBS/CRC-16 framing (docs/protocol.md) over a byte stream.

The byte stream is either a raw file descriptor (the pty master the bench creates for the stub)
or any pyserial port or URL (a USB UART, ``socket://host:port``, ``rfc2217://...``).
"""
from __future__ import annotations

import os
import select

from hil_bench.protocol import budget
from hil_bench.protocol.framing import Deframer, encode_frame

from .base import Link, LinkError


class FdTransport:
    """Bytes over an already-open file descriptor (non-blocking reads with select)."""

    def __init__(self, fd: int, description: str):
        self.fd = fd
        self.description = description

    def write(self, data: bytes) -> None:
        view = memoryview(data)
        while view:
            try:
                n = os.write(self.fd, view)
            except BlockingIOError:
                select.select([], [self.fd], [], 0.1)
                continue
            except OSError as exc:
                raise LinkError(f"{self.description}: write failed: {exc.strerror}") from None
            view = view[n:]

    def read(self, timeout_s: float) -> bytes:
        r, _, _ = select.select([self.fd], [], [], max(timeout_s, 0.0))
        if not r:
            return b""
        try:
            data = os.read(self.fd, 65536)
        except OSError as exc:
            raise LinkError(f"{self.description}: peer closed the link ({exc.strerror})") from None
        if not data:
            raise LinkError(f"{self.description}: peer closed the link (EOF)")
        return data

    def close(self) -> None:
        try:
            os.close(self.fd)
        except OSError:
            pass


class PySerialTransport:
    """Bytes over a pyserial port or URL."""

    def __init__(self, url: str, baud: int):
        import serial  # imported only when a serial port is chosen

        self.description = f"serial {url} @ {baud} baud"
        try:
            self.port = serial.serial_for_url(url, baudrate=baud, timeout=0)
        except (serial.SerialException, ValueError) as exc:
            raise LinkError(f"cannot open serial port {url!r}: {exc}") from None
        self.baud = baud

    def write(self, data: bytes) -> None:
        import serial

        try:
            self.port.write(data)
        except serial.SerialException as exc:
            raise LinkError(f"{self.description}: write failed: {exc}") from None

    def read(self, timeout_s: float) -> bytes:
        import serial

        try:
            self.port.timeout = max(timeout_s, 0.0)
            first = self.port.read(1)
            if not first:
                return b""
            return first + self.port.read(self.port.in_waiting or 0)
        except serial.SerialException as exc:
            raise LinkError(f"{self.description}: read failed (device gone?): {exc}") from None

    def close(self) -> None:
        try:
            self.port.close()
        except Exception:  # noqa: BLE001 - closing a vanished device must not mask the cause
            pass


class SerialLink(Link):
    """HIL frames over a byte transport with COBS + CRC-16 framing."""

    def __init__(self, transport, baud: int | None = None):
        super().__init__()
        self.transport = transport
        self.baud = baud
        self.description = transport.description
        self.deframer = Deframer()
        #: tap(direction, octets): every octet written (0) or read (1), for a byte capture
        self.tap = None

    def _write_frames(self, frames):
        data = b"".join(encode_frame(fid, payload) for fid, payload in frames)
        self.counters.bytes_tx += len(data)
        self.transport.write(data)
        if self.tap is not None:
            self.tap(0, data)

    def _read_frames(self, timeout_s):
        data = self.transport.read(timeout_s)
        if not data:
            return []
        if self.tap is not None:
            self.tap(1, data)
        self.counters.bytes_rx += len(data)
        return self.deframer.feed(data)

    def _update_extra_counters(self):
        self.counters.extra.update(self.deframer.counters())

    def max_cycle_rate_hz(self, flags):
        if self.baud is None:
            return float("inf")
        return budget.serial_max_rate_hz(self.baud, flags)

    def _close(self):
        self.transport.close()
