"""Serial backend: the HIL frames in COBS/CRC-16 framing (docs/protocol.md) over a byte stream.

The byte stream is either a raw file descriptor (the pty master the bench creates for the stub)
or any pyserial port or URL (a USB UART, ``socket://host:port``, ``rfc2217://...``).

A USB-serial adapter can hold the drive's answers: FTDI's chips keep received octets until their
*latency timer* expires (16 ms by default; FTDI AN232B-04), which makes every lockstep cycle take
about that long. The link says so (``SerialLink.notes``, printed by ``bench run`` and ``bench
conformance``) in two ways: from the adapter's own setting when the kernel publishes it
(``/sys/bus/usb-serial/devices/<tty>/latency_timer``, ftdi_sio), read when the port is opened; and
for any adapter, from the round trips of the set-up's request/answer pairs (HELLO -> HELLO_ACK,
CONFIG -> CONFIG_ACK) against the time their octets take on the wire (docs/real-drive.md).
"""
from __future__ import annotations

import os
import select
import statistics
import time
from pathlib import Path

from hil_bench.protocol import budget
from hil_bench.protocol.framing import Deframer, encode_frame
from hil_bench.protocol.messages import MESSAGES

from .base import Link, LinkError

#: where Linux's usb-serial drivers publish each port's attributes (ftdi_sio: ``latency_timer``)
USB_SERIAL_SYSFS = Path("/sys/bus/usb-serial/devices")
#: the latency timer a HIL link wants [ms]: FTDI's smallest (the default is 16)
LATENCY_TIMER_WANTED_MS = 1
#: set-up frames and the answer each one asks for: their round trips measure the adapter
_ANSWER_OF = {MESSAGES["HELLO"].frame_id: MESSAGES["HELLO_ACK"].frame_id,
              MESSAGES["CONFIG"].frame_id: MESSAGES["CONFIG_ACK"].frame_id}
#: round trips judged (the first ones; a run's set-up sends about 20 CONFIG, the kit far more)
ROUND_TRIPS_JUDGED = 8
#: spacings between answers needed to judge (an answer to a request sent once the answer before was
#: in; a run's set-up asks one request at a time, so 8 answers give 7)
SPACINGS_JUDGED = 4
#: the answers are called held when even the closest two consecutive ones (the request of the
#: second sent once the first was in) are this far apart and ROUND_TRIP_WIRE_FACTOR x the octets'
#: wire time: far above what the wire and a drive's answer take [s]. Spacings, not round trips:
#: an adapter's timer runs from its last transfer, so the first request finds it at any point and
#: a request the bench sends late after an answer (a busy host) finds it part run; a spacing
#: counts that delay in, and only the bench reading an answer late shortens the next spacing.
#: The closest, because a busy host delays some answers of a prompt drive (a median round trip
#: of 4.1 ms was seen from a prompt stub on a pty beside the load harness), seldom all. Measured
#: beside the load harness, 15 set-ups each (tools/setup_spacings.py): through a 16 ms timer,
#: first round trips 0.2-24.2 ms, later ones from 9.1 ms, closest spacing 9.2-16.1 ms; a prompt
#: stub's closest spacing 0.0-0.1 ms (tests/test_serial_latency.py runs both)
ROUND_TRIP_NOTE_MIN_S = 4e-3
ROUND_TRIP_WIRE_FACTOR = 4.0


def usb_latency_timer_ms(port: str, sysfs: Path | None = None) -> tuple[int, Path] | None:
    """(latency timer [ms], its sysfs file) of the USB-serial adapter behind the device path
    ``port`` (symlinks such as /dev/serial/by-id/... followed); None when the kernel publishes
    none: not a usb-serial port, a driver without the attribute (only ftdi_sio has it), a URL.
    ``setserial <port> low_latency`` reads back as 1 there (ftdi_sio: ASYNC_LOW_LATENCY)."""
    if "://" in port:
        return None
    path = (sysfs or USB_SERIAL_SYSFS) / Path(os.path.realpath(port)).name / "latency_timer"
    try:
        return int(path.read_text().strip()), path
    except (OSError, ValueError):
        return None


def latency_timer_note(port: str, sysfs: Path | None = None) -> str | None:
    """What to say about the adapter's latency timer when it is above LATENCY_TIMER_WANTED_MS."""
    found = usb_latency_timer_ms(port, sysfs)
    if found is None or found[0] <= LATENCY_TIMER_WANTED_MS:
        return None
    ms, path = found
    return (f"serial {port}: the USB adapter's latency timer is {ms} ms ({path}): the adapter "
            f"holds the drive's answers up to {ms} ms, so every lockstep cycle takes about {ms} ms "
            f"and a real-time period shorter than that misses; set it to "
            f"{LATENCY_TIMER_WANTED_MS} ms: `echo {LATENCY_TIMER_WANTED_MS} | sudo tee {path}` "
            f"(or `sudo setserial {port} low_latency`; docs/real-drive.md)")


def round_trip_note(description: str, round_trips_s: list[float], spacings_s: list[float],
                    baud: int | None) -> str | None:
    """What to say when the set-up's answers came far further apart than their octets take on the
    wire (a request and its answer, one 8-octet frame each, 8N1 at ``baud``); None when they did
    not, or too few were seen to judge. ``round_trips_s``: request to answer; ``spacings_s``: one
    answer to the next, for each request sent once the answer before it was in."""
    if len(round_trips_s) < ROUND_TRIPS_JUDGED or len(spacings_s) < SPACINGS_JUDGED:
        return None
    closest_s = min(spacings_s)
    median_s = statistics.median(round_trips_s)
    wire_s = (2 * budget.serial_frame_bytes(8) * budget.BITS_PER_UART_BYTE / baud) if baud else 0.0
    if closest_s < max(ROUND_TRIP_NOTE_MIN_S, ROUND_TRIP_WIRE_FACTOR * wire_s):
        return None
    wire = f"{wire_s * 1e3:.2f} ms on the wire at {baud} baud" if baud else "no baud rate known"
    return (f"{description}: the drive's answers to the set-up ({len(round_trips_s)} HELLO/CONFIG, "
            f"each asked for once the one before was in) came {closest_s * 1e3:.1f} ms or more "
            f"apart (request to answer: median {median_s * 1e3:.1f} ms; a request and its answer "
            f"take {wire}): something holds them, most often a USB adapter's latency timer (FTDI: "
            f"16 ms by default), else a slow drive; every lockstep cycle will take about as long "
            f"(docs/real-drive.md, 'The adapter's latency timer')")


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
        #: the adapter's latency timer, when the kernel publishes it and it is above 1 ms
        self.latency_note = latency_timer_note(url)

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
        #: what the user should know about this link (the adapter's latency): said once each
        self.notes: list[str] = [n for n in (getattr(transport, "latency_note", None),) if n]
        #: round trips [s] of the set-up's requests (HELLO, CONFIG) to their answers
        self.round_trips_s: list[float] = []
        #: one set-up answer to the next [s], for each request sent once the answer before was in
        self.answer_spacings_s: list[float] = []
        self._last_answer_s: float | None = None
        self._asked: dict[int, float] = {}    # answer id -> when its request was first sent
        # timed on a port the user named only (a stub's pty or QEMU's socket is the bench's own)
        self._judged = not isinstance(transport, PySerialTransport)

    def _write_frames(self, frames):
        data = b"".join(encode_frame(fid, payload) for fid, payload in frames)
        self.counters.bytes_tx += len(data)
        self.transport.write(data)
        if not self._judged:
            now = time.monotonic()
            for fid, _ in frames:
                if fid in _ANSWER_OF:
                    self._asked.setdefault(_ANSWER_OF[fid], now)
        if self.tap is not None:
            self.tap(0, data)

    def _read_frames(self, timeout_s):
        data = self.transport.read(timeout_s)
        if not data:
            return []
        if self.tap is not None:
            self.tap(1, data)
        self.counters.bytes_rx += len(data)
        frames = self.deframer.feed(data)
        if self._asked and frames:
            self._time_answers(frames)
        return frames

    def _time_answers(self, frames) -> None:
        now = time.monotonic()
        for fid, _ in frames:
            asked = self._asked.pop(fid, None)
            if asked is None:
                continue
            self.round_trips_s.append(now - asked)
            if self._last_answer_s is not None and asked >= self._last_answer_s:
                self.answer_spacings_s.append(now - self._last_answer_s)
            self._last_answer_s = now
        if len(self.round_trips_s) >= ROUND_TRIPS_JUDGED:
            self._judged = True
            self._asked.clear()
            note = round_trip_note(self.description, self.round_trips_s, self.answer_spacings_s,
                                   self.baud)
            if note and not self._latency_known():
                self.notes.append(note)

    def _latency_known(self) -> bool:
        """The adapter's own setting was reported already: the measurement would say it again."""
        return bool(getattr(self.transport, "latency_note", None))

    def _update_extra_counters(self):
        self.counters.extra.update(self.deframer.counters())

    def max_cycle_rate_hz(self, flags):
        if self.baud is None:
            return float("inf")
        return budget.serial_max_rate_hz(self.baud, flags)

    def _close(self):
        self.transport.close()
