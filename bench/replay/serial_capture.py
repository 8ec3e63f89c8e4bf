"""Raw byte captures of the serial link: the ``.serial.bin`` format, its reader, and converters.

Format (little-endian; docs/replay.md "Serial byte capture"):

    file    = magic record*
    magic   = "HILSER01"                                 8 octets
    record  = time_ns:u64  direction:u8  length:u32  octets[length]
              time_ns     when the octets were read or written (CLOCK_MONOTONIC of the capturing
                          host, or any clock: only differences are used)
              direction   0 = host -> controller (what the bench wrote)
                          1 = controller -> host (what the bench read)
              octets      exactly as they crossed the line (COBS frames, delimiters, noise)

The bench writes one beside every serial recording (``<recording>.serial.bin``): the engine
hands every octet it writes or reads to the recorder ring (plant_rt/c/engine_link.h "tap") and
the recorder appends the records to this file; the octets of the handshake, which Python
exchanges before the engine starts, are recorded the same way (bench/links/serial_link.py).

From a real UART (the drive on /dev/ttyUSB0, the bench or any host tool on the other side):
``socat -x -v PTY,link=/tmp/hil,raw,echo=0 /dev/ttyUSB0,raw,echo=0,b3000000 2> capture.txt``
puts a pty in the middle and logs both directions with timestamps; ``python -m
bench.replay.serial_capture socat capture.txt capture.serial.bin`` converts it. Two one-way raw
dumps (``cat /dev/ttyUSB0 > rx.bin`` on a tap of each line, a logic analyser's binary export)
convert with ``... raw --tx tx.bin --rx rx.bin OUT`` (no timestamps: the records keep file
order, each direction as one record), and a logic analyser's async-serial CSV export (Saleae
Logic 2: ``start_time`` and ``data`` columns, one file per line) with ``... logic --tx A.csv
--rx B.csv OUT``.
"""
from __future__ import annotations

import argparse
import csv
import re
import struct
import sys
from dataclasses import dataclass
from datetime import datetime
from pathlib import Path
from typing import BinaryIO, Iterator

MAGIC = b"HILSER01"
RECORD = struct.Struct("<QBI")
TX, RX = 0, 1
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


class SerialCaptureWriter:
    """Writes a ``.serial.bin`` (context manager)."""

    def __init__(self, path: Path):
        self.path = Path(path)
        self.f = open(self.path, "wb")
        write_header(self.f)

    def write(self, t_ns: int, direction: int, data: bytes) -> None:
        write_record(self.f, t_ns, direction, data)

    def close(self) -> None:
        self.f.close()

    def __enter__(self) -> "SerialCaptureWriter":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def read_records(path: Path, damage: list[str]) -> Iterator[SerialRecord]:
    """Every intact record; a truncated or corrupt record stops the reading, and ``damage``
    gets one line naming the file, the byte offset and what is wrong there."""
    path = Path(path)
    with open(path, "rb") as f:
        head = f.read(len(MAGIC))
        if head != MAGIC:
            raise SerialCaptureDamage(f"{path}: byte 0: not a serial capture (magic {head!r}, "
                                      f"expected {MAGIC!r}; convert other formats with python -m "
                                      f"bench.replay.serial_capture)")
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


# -- converters -----------------------------------------------------------------------------------

_SOCAT_HEAD = re.compile(r"^([<>]) (\d{4})/(\d\d)/(\d\d) (\d\d):(\d\d):(\d\d)(?:\.(\d+))?\s+"
                         r"length=(\d+) from=(\d+) to=(\d+)")


def from_socat(text_path: Path, out: Path, host_left: bool = True) -> int:
    """socat ``-x -v`` log -> .serial.bin. ``>`` is data from socat's first address to its second:
    with the bench (or the host tool) on the first address, ``>`` is host -> controller."""
    n = 0
    with open(text_path, encoding="latin-1") as f, SerialCaptureWriter(out) as w:
        lines = f.read().splitlines()
        i = 0
        while i < len(lines):
            m = _SOCAT_HEAD.match(lines[i])
            i += 1
            if not m:
                continue
            y, mo, d, hh, mi, ss = (int(m.group(j)) for j in range(2, 8))
            frac = m.group(8) or "0"
            t = datetime(y, mo, d, hh, mi, ss)
            t_ns = int(t.timestamp()) * 1_000_000_000 + int(frac.ljust(9, "0")[:9])
            length = int(m.group(9))
            data = bytearray()
            while i < len(lines) and lines[i].strip() != "--" and not _SOCAT_HEAD.match(lines[i]):
                hexpart = lines[i].strip()
                for tok in hexpart.split():
                    if re.fullmatch(r"[0-9a-fA-F]{2}", tok):
                        data.append(int(tok, 16))
                    else:
                        break
                i += 1
            if len(data) != length:
                raise SerialCaptureDamage(f"{text_path}: line {i}: socat block says length="
                                          f"{length} but holds {len(data)} octets (use socat -x)")
            direction = (TX if m.group(1) == ">" else RX) if host_left else (
                RX if m.group(1) == ">" else TX)
            w.write(t_ns, direction, bytes(data))
            n += 1
    return n


def from_raw(out: Path, tx: Path | None, rx: Path | None) -> int:
    """One-way raw dumps (no timestamps): each becomes one record, host -> controller first."""
    n = 0
    with SerialCaptureWriter(out) as w:
        for direction, p in ((TX, tx), (RX, rx)):
            if p is not None:
                w.write(0, direction, Path(p).read_bytes())
                n += 1
    return n


def from_logic_csv(out: Path, tx: Path | None, rx: Path | None) -> int:
    """Logic analyser async-serial CSV exports (a ``start_time`` [s] and a ``data`` column, one
    octet per row, e.g. Saleae Logic 2), one file per direction, merged by time."""
    events: list[tuple[int, int, int]] = []
    for direction, p in ((TX, tx), (RX, rx)):
        if p is None:
            continue
        with open(p, newline="") as f:
            reader = csv.DictReader(f)
            cols = {c.lower().strip(): c for c in (reader.fieldnames or [])}
            tcol = cols.get("start_time") or cols.get("time [s]")
            dcol = cols.get("data") or cols.get("value")
            if tcol is None or dcol is None:
                raise SerialCaptureDamage(f"{p}: line 1: needs a start_time (or 'Time [s]') and a "
                                          f"data (or 'Value') column; has {reader.fieldnames}")
            for line, row in enumerate(reader, start=2):
                try:
                    t_ns = int(round(float(row[tcol]) * 1e9))
                    v = row[dcol].strip()
                    octet = int(v, 16) if v.lower().startswith("0x") else int(v)
                except (ValueError, TypeError):
                    raise SerialCaptureDamage(f"{p}: line {line}: unreadable row {row}") from None
                events.append((t_ns, direction, octet))
    events.sort(key=lambda e: (e[0], e[1]))   # two files: merged by time (each keeps its order)
    n = 0
    with SerialCaptureWriter(out) as w:
        run: list[int] = []
        run_dir, run_t = None, 0
        for t_ns, direction, octet in events:
            if direction != run_dir and run:
                w.write(run_t, run_dir, bytes(run))
                n += 1
                run = []
            if not run:
                run_dir, run_t = direction, t_ns
            run.append(octet)
        if run:
            w.write(run_t, run_dir, bytes(run))
            n += 1
    return n


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m bench.replay.serial_capture",
                                description="convert serial line captures to .serial.bin")
    sub = p.add_subparsers(dest="what", required=True)
    s = sub.add_parser("socat", help="socat -x -v log")
    s.add_argument("log", type=Path)
    s.add_argument("out", type=Path)
    s.add_argument("--host-right", action="store_true",
                   help="the host is socat's second address ('<' is host -> controller)")
    for name, text in (("raw", "one-way raw binary dumps"),
                       ("logic", "logic analyser async-serial CSV exports")):
        r = sub.add_parser(name, help=text)
        r.add_argument("out", type=Path)
        r.add_argument("--tx", type=Path, help="host -> controller")
        r.add_argument("--rx", type=Path, help="controller -> host")
    a = p.parse_args(argv)
    try:
        if a.what == "socat":
            n = from_socat(a.log, a.out, host_left=not a.host_right)
        elif a.what == "raw":
            n = from_raw(a.out, a.tx, a.rx)
        else:
            n = from_logic_csv(a.out, a.tx, a.rx)
    except (OSError, SerialCaptureDamage) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    print(f"wrote {a.out}: {n} records")
    return 0


if __name__ == "__main__":
    sys.exit(main())
