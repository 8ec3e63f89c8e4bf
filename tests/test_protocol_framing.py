"""hil_bench.protocol.framing: CRC, COBS, frame encoding and the deframer (incl. a seeded fuzz test)."""
from __future__ import annotations

import random

import pytest

from hil_bench.protocol import framing
from hil_bench.protocol.framing import (
    Deframer,
    FramingError,
    cobs_decode,
    cobs_encode,
    crc16,
    encode_frame,
)


def crc16_bitwise(data: bytes) -> int:
    """Textbook CRC-16/CCITT-FALSE, independent of binascii."""
    crc = 0xFFFF
    for b in data:
        crc ^= b << 8
        for _ in range(8):
            crc = ((crc << 1) ^ 0x1021) & 0xFFFF if crc & 0x8000 else (crc << 1) & 0xFFFF
    return crc


def cobs_encode_reference(data: bytes) -> bytes:
    """The pointer-based encoder of the COBS paper (the C implementation does the same)."""
    out = bytearray([0])
    code_at, code = 0, 1
    for b in data:
        if b == 0:
            out[code_at] = code
            code_at, code = len(out), 1
            out.append(0)
        else:
            out.append(b)
            code += 1
            if code == 0xFF:
                out[code_at] = code
                code_at, code = len(out), 1
                out.append(0)
    out[code_at] = code
    return bytes(out)


def test_crc_check_value_and_reference():
    assert crc16(b"123456789") == 0x29B1
    rng = random.Random(1)
    for n in range(0, 80):
        data = rng.randbytes(n)
        assert crc16(data) == crc16_bitwise(data)


def test_cobs_round_trip_and_reference_encoder():
    rng = random.Random(2)
    cases = [b"", b"\x00", b"\x00\x00", b"\x01", bytes(range(1, 255)), bytes(range(1, 256)),
             bytes([1]) * 254 + b"\x00", bytes([1]) * 600]
    cases += [bytes(rng.choice((0, rng.randrange(256))) for _ in range(rng.randrange(0, 700))) for _ in range(300)]
    for data in cases:
        enc = cobs_encode(data)
        assert 0 not in enc
        assert enc == cobs_encode_reference(data)
        assert len(enc) <= len(data) + len(data) // 254 + 1
        assert cobs_decode(enc) == data


def test_cobs_decode_rejects_bad_chunks():
    assert cobs_decode(b"") is None
    assert cobs_decode(b"\x05\x01\x02") is None  # code points past the end
    assert cobs_decode(b"\x02\x00") is None  # a zero inside a chunk
    assert cobs_decode(b"\x01") == b""
    assert cobs_decode(b"\x01\x01") == b"\x00"


def test_encode_frame_layout():
    wire = encode_frame(0x100, bytes.fromhex("0100dc0512fd12fd"))
    assert wire == bytes.fromhex("010401080109dc0512fd12fd095500")
    assert encode_frame(0x7FF, b"") == bytes.fromhex("03ff0703689a00")
    raw = cobs_decode(wire[:-1])
    assert raw[:3] == b"\x00\x01\x08" and crc16(raw[:-2]) == int.from_bytes(raw[-2:], "little")
    for n in range(65):
        assert len(encode_frame(0x123, bytes(n))) == n + 7
    assert len(encode_frame(0x1FF, bytes(range(1, 65)))) == framing.MAX_WIRE == 71


def test_encode_frame_errors():
    with pytest.raises(FramingError, match="0x800"):
        encode_frame(0x800, b"")
    with pytest.raises(FramingError):
        encode_frame(-1, b"")
    with pytest.raises(FramingError, match="65 data octets"):
        encode_frame(0x100, bytes(65))


def test_deframer_counters_and_chunked_feeding():
    stream = (b"\x00\x00" + encode_frame(0x100, b"abc") + b"\x13\x37\x00" + encode_frame(0x101, b"")
              + b"\x55" * 100 + b"\x00" + encode_frame(0x7FF, bytes(64)))
    expected = [(0x100, b"abc"), (0x101, b""), (0x7FF, bytes(64))]
    counters = {"frames_ok": 3, "crc_errors": 0, "cobs_errors": 1, "length_errors": 0, "overruns": 1,
                "bytes_discarded": 102}
    rng = random.Random(3)
    for _ in range(200):
        d = Deframer()
        got, i = [], 0
        while i < len(stream):
            n = rng.randint(1, 40)
            piece = stream[i:i + n]
            got += d.feed(rng.choice((bytes, bytearray, memoryview))(piece))
            i += n
        assert got == expected
        assert d.counters() == counters
    d.reset()
    assert d.counters() == dict.fromkeys(Deframer.COUNTERS, 0)


def test_deframer_rejections_never_leak_a_frame():
    d = Deframer()
    good = encode_frame(0x100, bytes(8))
    raw = cobs_decode(good[:-1])
    bad_crc = cobs_encode(raw[:-1] + bytes([raw[-1] ^ 1])) + b"\x00"
    assert d.feed(bad_crc) == [] and d.crc_errors == 1
    assert d.feed(good[:5] + b"\x00") == [] and d.length_errors + d.cobs_errors == 1
    assert d.feed(good) == [(0x100, bytes(8))]


def test_fuzz_garbage_and_frames():
    """Seeded random garbage around valid frames: feed never raises, never yields a frame that was not
    sent, and every frame that follows a delimiter is received."""
    rng = random.Random(20240611)
    for trial in range(60):
        d = Deframer()
        stream = bytearray()
        sent: list[tuple[int, bytes]] = []
        must_receive: list[tuple[int, bytes]] = []
        for _ in range(rng.randint(1, 60)):
            kind = rng.random()
            if kind < 0.4:  # garbage, any octets (zeros included)
                stream += rng.randbytes(rng.randint(1, 120))
            elif kind < 0.5:  # a corrupted copy of a frame
                f = bytearray(encode_frame(rng.randrange(0x800), rng.randbytes(rng.randint(0, 64))))
                f[rng.randrange(len(f))] ^= 1 << rng.randrange(8)
                stream += f
            else:
                frame = (rng.randrange(0x800), rng.randbytes(rng.choice((0, 8, rng.randint(0, 64)))))
                after_delimiter = not stream or stream[-1] == 0
                stream += encode_frame(*frame)
                sent.append(frame)
                if after_delimiter:
                    must_receive.append(frame)
        got = []
        i = 0
        while i < len(stream):
            n = rng.randint(1, 300)
            got += d.feed(bytes(stream[i:i + n]))
            i += n
        assert d.frames_ok == len(got)
        remaining = list(sent)
        for frame in got:  # in order, a subsequence of what was sent
            assert frame in remaining, (trial, frame)
            remaining = remaining[remaining.index(frame) + 1:]
        for frame in must_receive:
            assert frame in got, (trial, frame)
        total_rejected = d.crc_errors + d.cobs_errors + d.length_errors + d.overruns
        assert d.bytes_discarded >= total_rejected
