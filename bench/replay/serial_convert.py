"""Converters of serial line captures to the ``.serial.bin`` format
(bench/record/serial_capture.py).

From a real UART (the drive on /dev/ttyUSB0, the bench or any host tool on the other side):
``socat -x -v PTY,link=/tmp/hil,raw,echo=0 /dev/ttyUSB0,raw,echo=0,b3000000 2> capture.txt``
puts a pty in the middle and logs both directions with timestamps; ``python -m
hil_bench.replay.serial_convert socat capture.txt capture.serial.bin`` converts it. Two one-way
dumps without time stamps (``cat /dev/ttyUSB0 > rx.bin`` on a tap of each line, a logic
analyser's binary export) convert with ``... raw OUT --tx tx.bin --rx rx.bin``, or, as hex
text (``xxd -p``, ``od -An -tx1 -v``), with ``... hex OUT --tx tx.hex --rx rx.hex``: the
frames of the two streams are interleaved by their seq (:func:`interleave`: DUTY(k) and
TELEM(k) after SENSE(k)), every record at time 0. A logic analyser's async-serial CSV export
(Saleae Logic 2: ``start_time`` and ``data`` columns, one file per line) converts with
``... logic OUT --tx A.csv --rx B.csv`` (merged by time). Other tools' text logs (interceptty,
slsnif) are not read: extract each direction's octets to a raw or hex file first.
"""
from __future__ import annotations

import argparse
import csv
import re
import sys
from datetime import datetime
from pathlib import Path

from hil_bench.record.serial_capture import RX, TX, SerialCaptureDamage, SerialCaptureWriter

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
                # up to 16 octets a line, then (with -v) the text column, which may itself look
                # like hex ("ab"): take the leading tokens, at most what the block still lacks
                taken = 0
                for tok in lines[i].split():
                    if (taken == 16 or len(data) == length
                            or not re.fullmatch(r"[0-9a-fA-F]{2}", tok)):
                        break
                    data.append(int(tok, 16))
                    taken += 1
                i += 1
            if len(data) != length:
                raise SerialCaptureDamage(f"{text_path}: line {i}: socat block says length="
                                          f"{length} but holds {len(data)} octets (use socat -x)")
            direction = (TX if m.group(1) == ">" else RX) if host_left else (
                RX if m.group(1) == ">" else TX)
            w.write(t_ns, direction, bytes(data))
            n += 1
    return n


def _chunks(data: bytes) -> list[bytes]:
    """One direction's octets cut after every 0x00 delimiter: each chunk is one frame's octets
    with its delimiter (or idle fill, noise, a damaged frame), exactly as on the line."""
    out = []
    start = 0
    while start < len(data):
        i = data.find(b"\x00", start)
        end = len(data) if i < 0 else i + 1
        out.append(data[start:end])
        start = end
    return out


def _frame_of(chunk: bytes) -> tuple[int, bytes] | None:
    from hil_bench.protocol.framing import MAX_COBS, decode_chunk

    body = chunk[:-1] if chunk.endswith(b"\x00") else chunk
    if not body or len(body) > MAX_COBS:
        return None
    verdict, frame = decode_chunk(body)
    return frame if verdict == 0 else None


def _seq_of(frame: tuple[int, bytes] | None, ids: set[int]) -> int | None:
    from hil_bench.protocol.messages import BY_ID

    if frame is None or frame[0] not in ids:
        return None
    msg = BY_ID[frame[0]]
    if len(frame[1]) != msg.length:
        return None
    return int(msg.unpack_raw(frame[1])[0])


class _Unwrap:
    """16-bit seq -> a count that does not wrap (steps of less than half the range)."""

    def __init__(self, base: int | None):
        self.prev_seq = base
        self.u = base if base is not None else 0

    def __call__(self, seq: int) -> int:
        if self.prev_seq is None:
            self.prev_seq = seq
            self.u = seq
            return self.u
        self.u += ((seq - self.prev_seq + 0x8000) & 0xFFFF) - 0x8000
        self.prev_seq = seq
        return self.u


def interleave(tx: bytes, rx: bytes) -> list[tuple[int, bytes]]:
    """Two one-way streams without time stamps -> (direction, octets) in the order the protocol
    exchanges them (docs/protocol.md 6.4): the host's octets as they are, and after each
    SENSE(k) the controller's answers to cycle k (TELEM(k) [TELEM_EMF(k)] DUTY(k), with whatever
    the controller sent between its answers to cycle k-1 and these: heartbeats, acks, damaged
    frames); the controller's octets before its first answer (handshake replies) go after the
    host's set-up, before the first cycle. Nothing is dropped or altered: every octet of both
    streams is in the output once, each stream in its own order."""
    from .capture import _SENSE, DOWNLINK_CYCLE, UPLINK_CYCLE

    tx_chunks = _chunks(tx)
    rx_chunks = _chunks(rx)
    tx_frames = [_frame_of(c) for c in tx_chunks]
    first_sense = next((_seq_of(f, {_SENSE.frame_id}) for f in tx_frames
                        if f is not None and f[0] == _SENSE.frame_id), None)
    un_rx = _Unwrap(first_sense)
    groups: list[tuple[int | None, list[bytes]]] = []
    cur_seq: int | None = None
    cur: list[bytes] = []
    for c in rx_chunks:
        seq = _seq_of(_frame_of(c), DOWNLINK_CYCLE)
        if seq is not None:
            u = un_rx(seq)
            if u != cur_seq:
                if cur:
                    groups.append((cur_seq, cur))
                cur = []
            cur_seq = u
        cur.append(c)
    if cur:
        groups.append((cur_seq, cur))
    out: list[tuple[int, bytes]] = []
    gi = 0

    def emit_rx(upto: int | None) -> None:
        nonlocal gi
        while gi < len(groups) and (upto is None or groups[gi][0] is None
                                    or groups[gi][0] <= upto):
            out.extend((RX, c) for c in groups[gi][1])
            gi += 1

    un_tx = _Unwrap(first_sense)
    cycles_started = False
    for c, f in zip(tx_chunks, tx_frames):
        if not cycles_started and f is not None and f[0] in UPLINK_CYCLE:
            cycles_started = True
            while gi < len(groups) and groups[gi][0] is None:     # the handshake's replies
                out.extend((RX, x) for x in groups[gi][1])
                gi += 1
        out.append((TX, c))
        seq = _seq_of(f, {_SENSE.frame_id})
        if seq is not None:
            emit_rx(un_tx(seq))
    emit_rx(None)
    return out


def _write_interleaved(out: Path, tx: bytes, rx: bytes) -> int:
    n = 0
    with SerialCaptureWriter(out) as w:
        run: list[bytes] = []
        run_dir = None
        for direction, chunk in interleave(tx, rx):
            if direction != run_dir and run:
                w.write(0, run_dir, b"".join(run))
                n += 1
                run = []
            run_dir = direction
            run.append(chunk)
        if run:
            w.write(0, run_dir, b"".join(run))
            n += 1
    return n


def from_raw(out: Path, tx: Path | None, rx: Path | None) -> int:
    """Two one-way raw binary dumps (no time stamps) -> .serial.bin, the frames of both
    interleaved by seq (:func:`interleave`); every record has time 0."""
    return _write_interleaved(out, Path(tx).read_bytes() if tx else b"",
                              Path(rx).read_bytes() if rx else b"")


_HEX_TOKEN = re.compile(r"(?:0[xX])?([0-9a-fA-F]{2})")


def read_hex_dump(path: Path) -> bytes:
    """A one-way hex dump: per line either one run of hex digits (``xxd -p``) or octets as
    whitespace-separated two-digit tokens, optionally 0x-prefixed (``od -An -tx1 -v``,
    ``hexdump -v -e '16/1 "%02x " "\n"'``). Anything else is an error naming the line."""
    data = bytearray()
    with open(path, encoding="latin-1") as f:
        for n, line in enumerate(f, start=1):
            s = line.strip()
            if not s:
                continue
            if re.fullmatch(r"[0-9a-fA-F]+", s) and len(s) % 2 == 0:
                data += bytes.fromhex(s)
                continue
            for tok in s.split():
                m = _HEX_TOKEN.fullmatch(tok)
                if m is None:
                    raise SerialCaptureDamage(f"{path}: line {n}: {tok!r} is not a hex octet "
                                              f"(expected xxd -p runs or two-digit tokens)")
                data.append(int(m.group(1), 16))
    return bytes(data)


def from_hex(out: Path, tx: Path | None, rx: Path | None) -> int:
    """Two one-way hex dumps (:func:`read_hex_dump`, no time stamps) -> .serial.bin, interleaved
    as :func:`from_raw`."""
    return _write_interleaved(out, read_hex_dump(tx) if tx else b"",
                              read_hex_dump(rx) if rx else b"")


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
    p = argparse.ArgumentParser(prog="python -m hil_bench.replay.serial_convert",
                                description="convert serial line captures to .serial.bin")
    sub = p.add_subparsers(dest="what", required=True)
    s = sub.add_parser("socat", help="socat -x -v log")
    s.add_argument("log", type=Path)
    s.add_argument("out", type=Path)
    s.add_argument("--host-right", action="store_true",
                   help="the host is socat's second address ('<' is host -> controller)")
    for name, text in (("raw", "two one-way raw binary dumps (interleaved by seq)"),
                       ("hex", "two one-way hex dumps: xxd -p, od -An -tx1 (interleaved by seq)"),
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
        elif a.what == "hex":
            n = from_hex(a.out, a.tx, a.rx)
        else:
            n = from_logic_csv(a.out, a.tx, a.rx)
    except (OSError, SerialCaptureDamage) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    print(f"wrote {a.out}: {n} records")
    return 0


if __name__ == "__main__":
    sys.exit(main())
