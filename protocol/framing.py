"""Serial framing of the HIL link: COBS + CRC-16/CCITT-FALSE, 0x00 delimited (docs/protocol.md).

Wire format of one frame::

    COBS( id_lo id_hi | dlc | data[dlc] | crc_lo crc_hi ) 0x00

* id: 11-bit CAN id as little-endian u16 (bits 11..15 zero), dlc: 0..64 data octets;
* CRC-16/CCITT-FALSE (poly 0x1021, init 0xFFFF, not reflected, xorout 0) over id, dlc and data, sent
  little-endian (check value of b"123456789" = 0x29B1). ``binascii.crc_hqx`` computes exactly this CRC;
* COBS (Cheshire & Baker 1999) removes every 0x00 so 0x00 only ever delimits frames.

``Deframer`` has exactly the semantics of the C deframer (protocol/c/hil_framing.c); both are checked
against the stream vectors of protocol/vectors/. The input is split on 0x00 with bytes operations; the
only Python loop runs over COBS blocks, not over bytes.

Counters (each rejected chunk increments exactly one of the first four; chunk = the octets between two
delimiters; empty chunks, i.e. repeated 0x00, are idle fill and count nowhere):

* ``overruns``: more than ``MAX_COBS`` (70) octets without a delimiter; everything up to the next 0x00
  is then discarded;
* ``cobs_errors``: a COBS code octet points past the end of the chunk;
* ``length_errors``: the decoded frame is shorter than 5 octets, has dlc > 64, its length is not
  5 + dlc (e.g. a truncated frame), or (checked after the CRC) its id has bits above bit 10 set;
* ``crc_errors``: the CRC does not match;
* ``bytes_discarded``: octets (delimiters excluded) of every rejected chunk;
* ``frames_ok``: frames delivered.
"""
from __future__ import annotations

import binascii
import struct

from .errors import FramingError

__all__ = ["MAX_DATA", "MAX_RAW", "MAX_COBS", "MAX_WIRE", "MAX_ID", "crc16", "cobs_encode", "cobs_decode",
           "encode_frame", "decode_chunk", "Deframer", "FramingError"]

MAX_DATA = 64  #: largest payload (dlc) in octets
MAX_ID = 0x7FF  #: largest (11-bit) id
MAX_RAW = MAX_DATA + 5  #: id(2) + dlc(1) + data + crc(2), before COBS
MAX_COBS = MAX_RAW + MAX_RAW // 254 + 1  #: worst-case COBS-encoded frame, delimiter excluded (70)
MAX_WIRE = MAX_COBS + 1  #: worst-case octets on the wire incl. the 0x00 delimiter (71)

_CODES = tuple(bytes((n,)) for n in range(256))
_OK, _COBS, _LENGTH, _BAD_CRC = 0, 1, 2, 3
_HEADER = struct.Struct("<HB")
_CRC = struct.Struct("<H")


def crc16(data: bytes | bytearray | memoryview, crc: int = 0xFFFF) -> int:
    """CRC-16/CCITT-FALSE of ``data`` (poly 0x1021, init 0xFFFF, no reflection, xorout 0)."""
    return binascii.crc_hqx(data, crc)


def cobs_encode(data: bytes | bytearray) -> bytes:
    """COBS-encode ``data`` (no delimiter appended). A run of 254 non-zero octets ends a 0xFF block."""
    blocks = bytes(data).split(b"\x00")
    if len(data) < 254:  # no block can reach 254 octets: one code octet per block
        return b"".join([_CODES[len(b) + 1] + b for b in blocks])
    out = []
    for block in blocks:
        while len(block) >= 254:
            out.append(b"\xff")
            out.append(block[:254])
            block = block[254:]
        out.append(_CODES[len(block) + 1])
        out.append(block)
    return b"".join(out)


def cobs_decode(chunk: bytes) -> bytes | None:
    """Decode one COBS chunk; None if it is empty, holds a 0x00 or a code octet points past its end."""
    n = len(chunk)
    if n == 0 or chunk.find(0) >= 0:
        return None
    buf = bytearray(chunk)
    code = buf[0]
    i = code
    while i < n:  # each code octet after the first stands for a 0x00 (unless the block before was 0xFF)
        if code == 0xFF:
            return _cobs_decode_blocks(chunk)
        code = buf[i]
        buf[i] = 0
        i += code
    if i != n:
        return None
    del buf[0]
    return bytes(buf)


def _cobs_decode_blocks(chunk: bytes) -> bytes | None:
    """Block-by-block COBS decoder (handles 0xFF blocks, which carry no implicit 0x00)."""
    n = len(chunk)
    parts = []
    i = 0
    while i < n:
        code = chunk[i]
        end = i + code
        if end > n:
            return None
        parts.append(chunk[i + 1:end])
        i = end
        if code != 0xFF and i < n:
            parts.append(b"\x00")
    return b"".join(parts)


def encode_frame(frame_id: int, payload: bytes | bytearray | memoryview) -> bytes:
    """One frame on the wire: COBS(id, dlc, payload, crc) + b"\\x00"."""
    dlc = len(payload)
    if not 0 <= frame_id <= MAX_ID:
        raise FramingError(f"frame id 0x{frame_id:X} is not an 11-bit id (0..0x7FF)")
    if dlc > MAX_DATA:
        raise FramingError(f"frame 0x{frame_id:03X}: {dlc} data octets, at most {MAX_DATA}")
    raw = _HEADER.pack(frame_id, dlc) + payload
    raw += _CRC.pack(binascii.crc_hqx(raw, 0xFFFF))
    return b"".join([_CODES[len(b) + 1] + b for b in raw.split(b"\x00")]) + b"\x00"  # < 254 octets


def decode_chunk(chunk: bytes) -> tuple[int, tuple[int, bytes] | None]:
    """Validate one non-empty chunk (the octets between two delimiters, at most MAX_COBS).

    Returns (verdict, frame): verdict 0 = ok, 1 = COBS error, 2 = length/format error, 3 = CRC error.
    The checks run in this order: COBS, length (>= 5, dlc <= 64, length == 5 + dlc), CRC, id."""
    raw = cobs_decode(chunk)
    if raw is None:
        return _COBS, None
    n = len(raw)
    if n < 5 or raw[2] > MAX_DATA or n != 5 + raw[2]:
        return _LENGTH, None
    if binascii.crc_hqx(raw[:-2], 0xFFFF) != raw[-2] | (raw[-1] << 8):
        return _BAD_CRC, None
    frame_id = raw[0] | (raw[1] << 8)
    if frame_id > MAX_ID:
        return _LENGTH, None
    return _OK, (frame_id, raw[3:-2])


class Deframer:
    """Incremental receiver: ``feed(data)`` returns the frames completed by ``data`` as (id, payload)."""

    __slots__ = ("frames_ok", "crc_errors", "cobs_errors", "length_errors", "overruns", "bytes_discarded",
                 "_pending", "_discarding")

    COUNTERS = ("frames_ok", "crc_errors", "cobs_errors", "length_errors", "overruns", "bytes_discarded")

    def __init__(self) -> None:
        self.reset()

    def reset(self) -> None:
        """Drop any partial frame and zero the counters."""
        self.frames_ok = self.crc_errors = self.cobs_errors = 0
        self.length_errors = self.overruns = self.bytes_discarded = 0
        self._pending = b""
        self._discarding = False

    def counters(self) -> dict[str, int]:
        return {name: getattr(self, name) for name in self.COUNTERS}

    def _append(self, part: bytes) -> None:
        """Add octets that are not yet delimited to the pending chunk (or discard them)."""
        if self._discarding:
            self.bytes_discarded += len(part)
            return
        pending = self._pending + part if self._pending else part
        if len(pending) > MAX_COBS:
            self.overruns += 1
            self.bytes_discarded += len(pending)
            self._pending = b""
            self._discarding = True
        else:
            self._pending = pending

    def _reject(self, verdict: int, chunk: bytes) -> None:
        if verdict == _COBS:
            self.cobs_errors += 1
        elif verdict == _LENGTH:
            self.length_errors += 1
        else:
            self.crc_errors += 1
        self.bytes_discarded += len(chunk)

    def feed(self, data: bytes | bytearray | memoryview) -> list[tuple[int, bytes]]:
        """Consume ``data``; return the valid frames it completed, in order, as (id, payload)."""
        parts = bytes(data).split(b"\x00")
        frames: list[tuple[int, bytes]] = []
        first = parts[0]
        if first:
            self._append(first)
        if len(parts) == 1:
            return frames
        for part in parts[1:]:
            # a delimiter: judge the pending chunk, then start the next one with `part`
            chunk = self._pending
            if self._discarding:
                self._discarding = False
            elif chunk:
                verdict, frame = decode_chunk(chunk)
                if verdict == _OK:
                    self.frames_ok += 1
                    frames.append(frame)  # type: ignore[arg-type]
                else:
                    self._reject(verdict, chunk)
            if len(part) <= MAX_COBS:
                self._pending = part
            else:
                self._pending = b""
                self._append(part)
        return frames
