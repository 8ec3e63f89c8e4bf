"""Property-based tests (hypothesis) of the Python codecs, protocol/framing.py and
protocol/messages.py, and a differential test of the C deframer (protocol/c/hil_framing.c,
reached through hil_bench.firmware_stub._fw_c) against the Python one on the same random streams.

The streams mix valid frames of random ids and lengths, frames with flipped bits, random
octets, runs of delimiters and over-long chunks, and are fed whole or cut at random points.
The C and Python receivers must deliver the same frames in the same order and the same
counters (frames_ok, crc/cobs/length errors, overruns, bytes_discarded).
The libFuzzer harnesses of the C side are in tests/fuzz/ (tests/fuzz/run.sh).
"""
from __future__ import annotations

import math
import struct

import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from hil_bench.protocol import framing
from hil_bench.protocol.errors import ProtocolError, SignalRangeError
from hil_bench.protocol.messages import BY_ID, MESSAGES, decode

try:
    from hil_bench.firmware_stub._fw_c import ffi, lib
except ImportError:  # pragma: no cover - the native build is part of `make test`
    ffi = lib = None

SETTINGS = settings(max_examples=300, deadline=None,
                    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])

ids = st.integers(0, framing.MAX_ID)
payloads = st.binary(min_size=0, max_size=framing.MAX_DATA)


@st.composite
def frames(draw):
    return draw(ids), draw(payloads)


@st.composite
def corrupted(draw):
    """A valid frame with 1-3 bit flips (the CRC or COBS must reject it, or, rarely, the flips
    hit a delimiter and split it)."""
    fid, data = draw(frames())
    wire = bytearray(framing.encode_frame(fid, data))
    for _ in range(draw(st.integers(1, 3))):
        pos = draw(st.integers(0, len(wire) - 2))
        wire[pos] ^= 1 << draw(st.integers(0, 7))
    return bytes(wire)


pieces = st.one_of(
    frames().map(lambda f: framing.encode_frame(*f)),
    corrupted(),
    st.binary(min_size=1, max_size=40),                       # garbage
    st.binary(min_size=1, max_size=4).map(lambda b: b"\x00" * len(b)),  # idle fill
    st.binary(min_size=71, max_size=160).map(lambda b: bytes(x | 1 for x in b)),  # overrun
)
streams = st.lists(pieces, min_size=0, max_size=12).map(b"".join)


# ------------------------------------------------------------------------------------------
# framing (Python)

@SETTINGS
@given(frames())
def test_frame_roundtrip_and_wire_size(frame):
    fid, data = frame
    wire = framing.encode_frame(fid, data)
    assert wire.endswith(b"\x00") and b"\x00" not in wire[:-1]
    assert len(wire) == len(data) + framing.MAX_RAW - framing.MAX_DATA + 2
    d = framing.Deframer()
    assert d.feed(wire) == [(fid, bytes(data))]
    assert d.counters() == {**dict.fromkeys(framing.Deframer.COUNTERS, 0), "frames_ok": 1}


@SETTINGS
@given(st.binary(max_size=600))
def test_cobs_roundtrip(data):
    enc = framing.cobs_encode(data)
    assert b"\x00" not in enc
    assert framing.cobs_decode(enc) == data


@SETTINGS
@given(streams, st.lists(st.integers(0, 2000), max_size=8))
def test_deframer_does_not_depend_on_how_the_stream_is_cut(stream, cuts):
    whole = framing.Deframer()
    want = whole.feed(stream)
    parts = framing.Deframer()
    got = []
    points = sorted({c % (len(stream) + 1) for c in cuts})
    for a, b in zip([0] + points, points + [len(stream)]):
        got += parts.feed(stream[a:b])
    assert got == want
    assert parts.counters() == whole.counters()


@SETTINGS
@given(streams)
def test_every_chunk_counted_once(stream):
    d = framing.Deframer()
    d.feed(stream)
    c = d.counters()
    chunks = [x for x in stream.split(b"\x00")[:-1] if x]
    tail = stream.split(b"\x00")[-1]
    judged = c["frames_ok"] + c["crc_errors"] + c["cobs_errors"] + c["length_errors"] + c["overruns"]
    assert judged == len(chunks) + (1 if len(tail) > framing.MAX_COBS else 0)


# ------------------------------------------------------------------------------------------
# C deframer vs Python deframer

def c_deframe(stream: bytes) -> tuple[list[tuple[int, bytes]], dict[str, int]]:
    d = ffi.new("hil_deframer_t *")
    out = ffi.new("hil_frame_t *")
    lib.hil_deframer_init(d)
    got = []
    for b in stream:
        if lib.hil_deframer_push(d, b, out):
            got.append((out.id, bytes(out.data[0:out.dlc])))
    return got, {name: getattr(d, name) for name in framing.Deframer.COUNTERS}


@pytest.mark.skipif(lib is None, reason="hil_bench.firmware_stub._fw_c not built (make build)")
@SETTINGS
@given(streams)
def test_c_and_python_deframers_agree(stream):
    py = framing.Deframer()
    want = py.feed(stream)
    got, counters = c_deframe(stream)
    assert got == want
    assert counters == py.counters()


@pytest.mark.skipif(lib is None, reason="hil_bench.firmware_stub._fw_c not built (make build)")
@SETTINGS
@given(frames())
def test_c_and_python_encoders_agree(frame):
    fid, data = frame
    buf = ffi.new("hil_octet_t[]", framing.MAX_WIRE)
    src = ffi.new("hil_octet_t[]", max(len(data), 1))
    for k, b in enumerate(data):
        src[k] = b
    n = lib.hil_frame_encode(buf, framing.MAX_WIRE, fid, src, len(data))
    assert bytes(buf[0:n]) == framing.encode_frame(fid, data)
    assert lib.hil_crc16(src, len(data)) == framing.crc16(data)


# ------------------------------------------------------------------------------------------
# messages (Python codec)

def _covered_mask(msg) -> int:
    mask = 0
    for s in msg.signals:
        mask |= ((1 << s.length_bits) - 1) << s.start_bit
    return mask


@SETTINGS
@given(st.sampled_from(sorted(MESSAGES)), st.binary(min_size=8, max_size=8))
def test_any_payload_unpacks_and_packs_back(name, data):
    msg = MESSAGES[name]
    raws = msg.unpack_raw(data)
    if any(s.is_float and not math.isfinite(r) for s, r in zip(msg.signals, raws)):
        # an IEEE signal carrying inf/NaN decodes, but pack_raw refuses it (its type range is
        # the finite binary32 range): a receiver must not assume a decoded float is finite
        with pytest.raises(SignalRangeError):
            msg.pack_raw(raws)
        return
    again = msg.pack_raw(raws)
    mask = _covered_mask(msg)
    as_int = int.from_bytes(data, "little")
    assert int.from_bytes(again, "little") == as_int & mask
    assert msg.unpack_raw(again) == raws
    values = msg.unpack_values(data)
    for s, raw, v in zip(msg.signals, raws, values):
        if s.is_float:
            assert struct.pack("<f", raw) == struct.pack("<f", v) or (math.isnan(raw) and math.isnan(v))
        else:
            assert math.isfinite(v) and v == raw * s.scale + s.offset or v == raw


@SETTINGS
@given(st.integers(0, framing.MAX_ID), st.binary(max_size=12))
def test_decode_never_fails_otherwise_than_with_a_protocol_error(fid, data):
    try:
        msg, values = decode(fid, data)
    except ProtocolError:
        assert fid not in BY_ID or len(data) != BY_ID[fid].length
        return
    assert fid in BY_ID and len(data) == msg.length
    assert set(values) == set(msg.signal_names)


def _f32_inside(x: float, up: bool) -> float:
    """x rounded to binary32, moved inside [min, max] if the rounding went outside."""
    import numpy as np
    y = np.float32(x)
    if up and float(y) < x:
        y = np.nextafter(y, np.float32(np.inf))
    if not up and float(y) > x:
        y = np.nextafter(y, np.float32(-np.inf))
    return float(y)


@st.composite
def message_and_physical(draw):
    msg = MESSAGES[draw(st.sampled_from(sorted(MESSAGES)))]
    vals = []
    for s in msg.signals:
        if s.is_float:
            vals.append(draw(st.floats(_f32_inside(s.minimum, True), _f32_inside(s.maximum, False),
                                       width=32)))
        else:
            raw = draw(st.integers(int(s.raw_min), int(s.raw_max)))
            vals.append(raw * s.scale + s.offset if not s.is_identity else raw)
    return msg, vals


@SETTINGS
@given(message_and_physical())
def test_in_range_values_encode_exactly_to_the_grid(mv):
    msg, vals = mv
    data = msg.pack_values(vals)
    back = msg.unpack_values(data)
    for s, v, b in zip(msg.signals, vals, back):
        if s.is_float:
            assert b == v
        else:
            assert abs(b - v) <= 1e-9 * max(1.0, abs(v)) + 1e-12, s.qualified_name


@SETTINGS
@given(message_and_physical(), st.data())
def test_out_of_range_raises_or_saturates(mv, data):
    msg, vals = mv
    # angles wrap at 2 pi (docs/protocol.md 3): they are never out of range
    ints = [k for k, s in enumerate(msg.signals) if not s.is_float and not s.is_cyclic]
    assume(ints)
    k = data.draw(st.sampled_from(ints))
    s = msg.signals[k]
    span = (s.raw_max - s.raw_min + 1) * abs(s.scale)
    bad = list(vals)
    bad[k] = s.maximum + span
    with pytest.raises(SignalRangeError, match=s.name):
        msg.pack_values(bad)
    sat = msg.unpack_raw(msg.pack_values(bad, saturate=True))
    assert sat[k] == s.raw_max
    bad[k] = math.nan
    with pytest.raises(SignalRangeError):
        msg.pack_values(bad, saturate=True)
