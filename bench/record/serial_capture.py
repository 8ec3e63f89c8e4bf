"""Raw byte captures of the serial link: the ``.serial.bin`` format, its writer and its reader.

Format (little-endian; docs/replay.md "Serial byte capture"):

    file    = magic record* end
    magic   = "HILSER01"                                 8 octets
    record  = time_ns:u64  direction:u8  length:u32  octets[length]
              time_ns     when the octets were read or written (CLOCK_MONOTONIC of the capturing
                          host, or any clock: only differences are used)
              direction   0 = host -> controller (what the bench wrote)
                          1 = controller -> host (what the bench read)
              octets      exactly as they crossed the line (COBS frames, delimiters, noise)
    end     = a record with direction 2: the writer closed the capture; its octets are a UTF-8
              note saying how ("end of the run", or that the bench went away first). A file
              without one was cut: its writer was killed, or the disk filled

The bench writes one beside every serial recording (``<recording>.serial.bin``): the engine
hands every octet it writes or reads to the recorder ring (plant_rt/c/engine_link.h "tap") and
the recorder appends the records to this file; the octets of the handshake, which Python
exchanges before the engine starts, are recorded the same way (bench/loop/links/serial_link.py).

Captures of other tools (socat, raw and hex dumps, a logic analyser's CSV) convert to this
format with ``python -m hil_bench.replay.serial_convert`` (bench/replay/serial_convert.py).
"""
from __future__ import annotations

import struct
from dataclasses import dataclass
from pathlib import Path
from typing import BinaryIO, Iterator

MAGIC = b"HILSER01"
RECORD = struct.Struct("<QBI")
TX, RX, END = 0, 1, 2
#: the end record's note when the bench closed the capture at the end of its run
END_OF_RUN = "end of the run: the bench closed the capture"
MAX_RECORD_OCTETS = 1 << 20   #: a longer record is a damaged length field, not data


@dataclass
class SerialRecord:
    t_ns: int
    direction: int
    data: bytes
    offset: int      # byte offset of the record in the file


class SerialCaptureDamage(Exception):
    """Where a serial capture stops being readable (file, byte offset, what)."""


def write_header(f: BinaryIO) -> None:
    f.write(MAGIC)


def write_record(f: BinaryIO, t_ns: int, direction: int, data: bytes) -> None:
    f.write(RECORD.pack(int(t_ns), int(direction), len(data)))
    f.write(data)


def write_end(f: BinaryIO, t_ns: int, note: str) -> None:
    """The end record: the capture is closed, nothing was lost after the last record."""
    write_record(f, t_ns, END, note.encode("utf-8"))


class SerialCaptureWriter:
    """Writes a ``.serial.bin`` (context manager)."""

    def __init__(self, path: Path, end_note: str = "converted: the converter closed the capture"):
        self.path = Path(path)
        self.f = open(self.path, "wb")
        self.end_note = end_note
        self._t_last = 0
        write_header(self.f)

    def write(self, t_ns: int, direction: int, data: bytes) -> None:
        write_record(self.f, t_ns, direction, data)
        self._t_last = t_ns

    def close(self) -> None:
        if not self.f.closed:
            write_end(self.f, self._t_last, self.end_note)
            self.f.close()

    def __enter__(self) -> "SerialCaptureWriter":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def read_records(path: Path, damage: list[str],
                 end: list[str] | None = None) -> Iterator[SerialRecord]:
    """Every intact record; a truncated or corrupt record stops the reading, and ``damage``
    gets one line naming the file, the byte offset and what is wrong there. ``end`` gets the end
    record's note (nothing if the file has none: it was cut); records after it are damage."""
    path = Path(path)
    with open(path, "rb") as f:
        head = f.read(len(MAGIC))
        if head != MAGIC:
            raise SerialCaptureDamage(f"{path}: byte 0: not a serial capture (magic {head!r}, "
                                      f"expected {MAGIC!r}; convert other formats with python -m "
                                      f"hil_bench.replay.serial_convert)")
        offset = len(MAGIC)
        while True:
            hdr = f.read(RECORD.size)
            if not hdr:
                return
            if len(hdr) < RECORD.size:
                damage.append(f"{path}: byte {offset}: truncated record header ({len(hdr)} of "
                              f"{RECORD.size} octets); the capture ends there")
                return
            t_ns, direction, length = RECORD.unpack(hdr)
            if direction == END and length <= MAX_RECORD_OCTETS:
                note = f.read(length)
                if end is not None:
                    end.append(note.decode("utf-8", errors="replace"))
                rest = len(f.read())
                if rest:
                    damage.append(f"{path}: byte {offset + RECORD.size + length}: {rest} octets "
                                  f"after the end record; not read")
                return
            if direction not in (TX, RX) or length > MAX_RECORD_OCTETS:
                damage.append(f"{path}: byte {offset}: corrupt record header (direction "
                              f"{direction}, length {length}); nothing after it is read")
                return
            data = f.read(length)
            if len(data) < length:
                damage.append(f"{path}: byte {offset}: truncated record ({len(data)} of {length} "
                              f"octets); its octets are used, the capture ends there")
                if data:
                    yield SerialRecord(t_ns, direction, data, offset)
                return
            yield SerialRecord(t_ns, direction, data, offset)
            offset += RECORD.size + length
