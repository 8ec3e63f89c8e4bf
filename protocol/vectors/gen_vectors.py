#!/usr/bin/env python3
"""Write the shared golden vectors of protocol/vectors/ (read by pytest and by the C test runner).

Message cases (``msg_<message>_<case>``): ``.bin`` = the payload; ``.json`` = kind "message", name,
frame_id, payload_hex, physical and raw values per signal, ``ties`` (signals whose value is an exact tie
of the rounding rule: cantools rounds those half-to-even, we round half away from zero), ``wraps`` (angles
outside [0, 2 pi) once rounded: raw = round(angle / scale) mod 65536; they decode to the wrapped angle).
Physical values of scaled and float signals are binary32 numbers, so that the C encoder (which takes a
``float``) sees exactly the value Python encoded.

Stream cases (``stream_<case>``): ``.bin`` = octets fed to a deframer; ``.json`` = kind "stream", the
frames expected (id + payload hex) and the expected counters. The expectations are written down here by
hand (from the framing rules), not computed by the deframer; generation fails if the Python deframer
disagrees.

``index.json`` lists every case. Usage::

    python protocol/vectors/gen_vectors.py           # (re)write the files
    python protocol/vectors/gen_vectors.py --check   # exit 1 if the committed files differ
"""
from __future__ import annotations

import argparse
import json
import math
import struct
import sys
from pathlib import Path

from hil_bench.protocol import dbc, framing
from hil_bench.protocol.messages import DUTY_RAW_OFF, MESSAGES, Message

OUT_DIR = Path(__file__).resolve().parent
COUNTERS = framing.Deframer.COUNTERS


def f32(x: float) -> float:
    """Nearest binary32 value, as a Python float."""
    return struct.unpack("<f", struct.pack("<f", x))[0]


# ---------------------------------------------------------------------------------------------------------
# Message cases
# ---------------------------------------------------------------------------------------------------------

def _representable(s: dbc.SignalSpec, x: float | int | str) -> float | int | str:
    if isinstance(x, str) or s.is_identity and not s.is_float and isinstance(x, int):
        return x
    return f32(float(x))


def _generic_cases(msg: Message) -> dict[str, dict[str, float | int | str]]:
    """zero / DBC min / DBC max / three fractions of the range for every signal."""
    cases: dict[str, dict[str, float | int | str]] = {
        "zero": {s.name: (0 if s.is_identity and not s.is_float else 0.0) if s.raw_min <= 0 <= s.raw_max
                 else s.minimum for s in msg.signals},
        "min": {s.name: s.minimum for s in msg.signals},
        "max": {s.name: s.maximum for s in msg.signals},
    }
    for tag, p in (("frac_a", 0.1234567), ("frac_b", 0.5), ("frac_c", 0.87654321)):
        vals: dict[str, float | int | str] = {}
        for s in msg.signals:
            if s.is_float:
                vals[s.name] = {"frac_a": 3.14159265, "frac_b": -1.5, "frac_c": 123456.789}[tag]
            elif s.is_identity:
                vals[s.name] = int(s.raw_min + (s.raw_max - s.raw_min) * p)
            else:
                vals[s.name] = s.minimum + (s.maximum - s.minimum) * p
        cases[tag] = vals
    return cases


def _special_cases() -> dict[str, dict[str, dict[str, float | int | str]]]:
    """Hand-picked values: negative, rounding, exact ties, IEEE corner cases, DUTY OFF, value tables.
    Values not given take the message's zero case."""
    lsb = 2.0 ** -15  # DUTY scale
    return {
        "FAULT_PLANT": {"ties": {"code": 4, "seq": 2.5, "detail": -2.5},
                        "negative": {"code": 13, "seq": 65535, "detail": -1}},
        "FAULT_CTRL": {"ties": {"code": 7, "seq": 65534.5, "detail": 1000000.5}},
        "HELLO": {"session": {"proto_version": 1, "mode": 1, "period_us": 50.0, "estimator": 1,
                              "flags": 3, "session": 0xBEEF},
                  "period_round": {"proto_version": 1, "mode": 0, "period_us": 62.5, "estimator": 4,
                                   "flags": 7, "session": 1},
                  "period_tie": {"proto_version": 1, "period_us": 0.25, "session": 2}},
        "HELLO_ACK": {"refused": {"proto_version": 1, "status": 2, "fw_version": 0x0102,
                                  "estimators": 0b111111, "session": 0xBEEF}},
        "CONFIG": {"rs": {"param_id": 1, "config_seq": 1, "value": 0.35},
                   "neg_zero": {"param_id": 64, "config_seq": 2, "value": -0.0},
                   "tiny": {"param_id": 2, "config_seq": 3, "value": 1e-30},
                   "flt_min": {"param_id": 3, "config_seq": 4, "value": 1.1754943508222875e-38},
                   "big": {"param_id": 50, "config_seq": 65535, "value": -2.5e37}},
        "CONFIG_ACK": {"locked": {"param_id": 41, "config_seq": 9, "status": 3}},
        "CMD": {"speed_ref": {"command": 4, "seq": 10, "value": 104.71975511965977},
                "run": {"command": 1, "seq": 11, "value": 0.0},
                "neg": {"command": 5, "seq": 12, "value": -3.75}},
        "HEARTBEAT_PLANT": {"running": {"counter": 4242, "state": 3, "rx_errors": 1, "rx_frames": 65535}},
        "HEARTBEAT_CTRL": {"fault": {"counter": 1, "state": 4, "rx_errors": 7, "rx_frames": 12}},
        "SENSE": {"negative": {"seq": 3, "i_a": -1.5, "i_b": -0.001, "i_c": -32.0},
                  "rounding": {"seq": 4, "i_a": 1.2345, "i_b": -0.0005, "i_c": 0.0004999},
                  "ties": {"seq": 5, "i_a": 0.0625, "i_b": -0.0625, "i_c": 2.5625}},
        "SENSE_AUX": {"typical": {"seq": 7, "v_dc": 48.0, "theta_enc": 3.14159265, "flags": 2},
                      "ties": {"seq": 8, "v_dc": 0.125, "theta_enc": 0.0001, "flags": 0},
                      "wrap": {"seq": 19, "v_dc": 24.0, "theta_enc": 2 * math.pi - 1e-5, "flags": 3}},
        "SENSE_DUAL": {"negative": {"seq": 9, "i_a2": -10.0, "i_b2": 5.0009, "i_c2": 5.0},
                       "ties": {"seq": 10, "i_a2": -2.5625, "i_b2": 0.0625, "i_c2": 0.1875}},
        "DUTY": {"off_one": {"seq": 11, "d_a": "OFF", "d_b": 0.5, "d_c": 1.0},
                 "off_all": {"seq": 12, "d_a": "OFF", "d_b": "OFF", "d_c": "OFF"},
                 "ties": {"seq": 13, "d_a": 100.5 * lsb, "d_b": 16383.5 * lsb, "d_c": 0.5 * lsb},
                 "rounding": {"seq": 14, "d_a": 0.333333, "d_b": 0.666667, "d_c": 0.999999}},
        "TELEM": {"running": {"seq": 15, "theta_hat": 1.0, "omega_hat": -523.6, "state": 3, "estimator": 1},
                  "ties": {"seq": 16, "theta_hat": 6.0, "omega_hat": -0.25, "state": 6, "estimator": 0},
                  "wrap": {"seq": 20, "theta_hat": -0.5, "omega_hat": 0.0, "state": 3, "estimator": 5}},
        "TELEM_EMF": {"typical": {"seq": 17, "e_alpha": -12.34, "e_beta": 24.68, "i_q_ref": 3.3},
                      "ties": {"seq": 18, "e_alpha": -0.125, "e_beta": 0.375, "i_q_ref": -0.0625}},
    }


#: Raw values of the angles above that wrap at 2 pi (raw 65536 = 0), written by hand.
EXPECTED_WRAPS: dict[tuple[str, str], dict[str, int]] = {
    ("SENSE_AUX", "wrap"): {"theta_enc": 0},       # 2 pi - 1e-5 rounds to raw 65536 = 0
    ("TELEM", "wrap"): {"theta_hat": 60321},       # -0.5 rad = 2 pi - 0.5 = raw 60320.8 -> 60321
}

#: Raw values the rounding rule must give on the exact ties above (half away from zero), written by hand.
EXPECTED_TIES: dict[tuple[str, str], dict[str, int]] = {
    ("FAULT_PLANT", "ties"): {"seq": 3, "detail": -3},
    ("FAULT_CTRL", "ties"): {"seq": 65535, "detail": 1000001},
    ("HELLO", "period_tie"): {"period_us": 3},
    ("SENSE", "ties"): {"i_a": 63, "i_b": -63, "i_c": 2563},
    ("SENSE_AUX", "ties"): {"v_dc": 13},
    ("SENSE_DUAL", "ties"): {"i_a2": -2563, "i_b2": 63, "i_c2": 188},
    ("DUTY", "ties"): {"d_a": 101, "d_b": 16384, "d_c": 1},
    ("TELEM", "ties"): {"omega_hat": -3},
    ("TELEM_EMF", "ties"): {"e_alpha": -13, "e_beta": 38, "i_q_ref": -63},
}


def _wraps(s: dbc.SignalSpec, value: float | int | str) -> bool:
    """An angle outside [0, 2 pi) once rounded: its raw value is taken modulo one turn."""
    if not s.is_cyclic or isinstance(value, str):
        return False
    return not -0.5 <= value / s.scale < s.type_max + 0.5


def _is_tie(s: dbc.SignalSpec, value: float | int | str) -> bool:
    if s.is_float or isinstance(value, str):
        return False
    q = (value - s.offset) / s.scale
    return abs(q - math.trunc(q)) == 0.5


def message_cases() -> dict[str, dict]:
    special = _special_cases()
    out: dict[str, dict] = {}
    for msg in MESSAGES.values():
        generic = _generic_cases(msg)
        cases = dict(generic)
        for tag, given in special.get(msg.name, {}).items():
            unknown = set(given) - set(msg.signal_names)
            if unknown:
                raise SystemExit(f"gen_vectors: {msg.name}.{tag}: unknown signals {unknown}")
            cases[tag] = {**generic["zero"], **given}
        for tag, values in cases.items():
            physical = {s.name: _representable(s, values[s.name]) for s in msg.signals}
            payload = msg.pack(**physical)
            raw = dict(zip(msg.signal_names, msg.unpack_raw(payload)))
            ties = [s.name for s in msg.signals if _is_tie(s, physical[s.name])]
            wraps = [s.name for s in msg.signals if _wraps(s, physical[s.name])]
            want_wraps = EXPECTED_WRAPS.get((msg.name, tag), {})
            if set(wraps) != set(want_wraps) or any(raw[n] != v for n, v in want_wraps.items()):
                raise SystemExit(f"gen_vectors: {msg.name}.{tag}: wrapped angles {wraps} raw "
                                 f"{ {n: raw[n] for n in wraps} }, expected {want_wraps}")
            expected = EXPECTED_TIES.get((msg.name, tag), {})
            for name, want in expected.items():
                if raw[name] != want:
                    raise SystemExit(f"gen_vectors: {msg.name}.{tag}.{name}: raw {raw[name]}, expected {want}")
            if tag == "ties" and not set(expected) <= set(ties):
                raise SystemExit(f"gen_vectors: {msg.name}.ties: {set(expected) - set(ties)} are not ties")
            name = f"msg_{msg.name.lower()}_{tag}"
            out[name] = {
                "kind": "message", "name": msg.name, "case": tag,
                "frame_id": msg.frame_id, "frame_id_hex": f"0x{msg.frame_id:03X}", "length": msg.length,
                "payload_hex": payload.hex(), "signals": list(msg.signal_names),
                "physical": physical, "raw": raw, "ties": ties, "wraps": wraps,
                "bin": payload,
            }
    return out


# ---------------------------------------------------------------------------------------------------------
# Stream cases
# ---------------------------------------------------------------------------------------------------------

def raw_frame(id_u16: int, dlc_field: int, data: bytes, crc: int | None = None, xor_crc: int = 0) -> bytes:
    """A frame built by hand (may be invalid on purpose): COBS(id, dlc, data, crc) + 0x00."""
    body = struct.pack("<HB", id_u16, dlc_field) + data
    crc = framing.crc16(body) if crc is None else crc
    return framing.cobs_encode(body + struct.pack("<H", crc ^ xor_crc)) + b"\x00"


def _msg_frame(name: str, **physical: object) -> tuple[bytes, dict]:
    msg = MESSAGES[name]
    payload = msg.pack(**physical)
    return framing.encode_frame(msg.frame_id, payload), _frame_json(msg.frame_id, payload)


def _frame_json(frame_id: int, payload: bytes) -> dict:
    """Expected frame: id, payload and (for the encoders) its encoding on the wire."""
    return {"id": frame_id, "payload_hex": payload.hex(), "wire_hex": framing.encode_frame(frame_id, payload).hex()}


def _counters(**given: int) -> dict[str, int]:
    unknown = set(given) - set(COUNTERS)
    if unknown:
        raise ValueError(unknown)
    return {c: given.get(c, 0) for c in COUNTERS}


def stream_cases() -> dict[str, dict]:
    sense, sense_f = _msg_frame("SENSE", seq=1, i_a=1.5, i_b=-0.75, i_c=-0.75)
    aux, aux_f = _msg_frame("SENSE_AUX", seq=1, v_dc=48.0, theta_enc=0.5, flags=3)
    dual, dual_f = _msg_frame("SENSE_DUAL", seq=1, i_a2=1.25, i_b2=-0.5, i_c2=-0.75)
    telem, telem_f = _msg_frame("TELEM", seq=1, theta_hat=0.25, omega_hat=100.0, state=3, estimator=1)
    emf, emf_f = _msg_frame("TELEM_EMF", seq=1, e_alpha=1.0, e_beta=-2.0, i_q_ref=0.5)
    duty, duty_f = _msg_frame("DUTY", seq=1, d_a=0.5, d_b="OFF", d_c=0.25)
    hb, hb_f = _msg_frame("HEARTBEAT_CTRL", counter=0x0101, state=0, rx_errors=0, rx_frames=0x0202)

    cases: list[tuple[str, str, bytes, list[dict], dict[str, int]]] = []

    def case(name: str, description: str, stream: bytes, frames: list[dict], counters: dict[str, int]) -> None:
        cases.append((name, description, stream, frames, counters))

    case("one_frame", "a single SENSE frame", sense, [sense_f], _counters(frames_ok=1))
    case("back_to_back", "one full cycle, every optional frame: SENSE_AUX SENSE_DUAL SENSE TELEM TELEM_EMF DUTY",
         aux + dual + sense + telem + emf + duty, [aux_f, dual_f, sense_f, telem_f, emf_f, duty_f],
         _counters(frames_ok=6))
    g1, g2 = b"\x13\x37\xaa", b"\x01\x01\x01"
    case("garbage_between", "garbage before and between frames, each ended by a 0x00: a COBS error "
         "(code 0x13 past the end) and a chunk decoding to 2 octets (length error)",
         g1 + b"\x00" + sense + g2 + b"\x00" + duty, [sense_f, duty_f],
         _counters(frames_ok=2, cobs_errors=1, length_errors=1, bytes_discarded=len(g1) + len(g2)))
    g3 = b"\x7f\x7f"
    case("garbage_glued", "garbage directly before a frame (no delimiter): that frame is lost with the "
         "garbage (code 0x7F points past the end), the next one is received",
         g3 + sense + duty, [duty_f],
         _counters(frames_ok=1, cobs_errors=1, bytes_discarded=len(g3) + len(sense) - 1))
    bad = raw_frame(0x100, 8, MESSAGES["SENSE"].pack(seq=2, i_a=1.0, i_b=2.0, i_c=-3.0), xor_crc=0x0001)
    case("bad_crc", "a SENSE frame whose CRC has one bit flipped, then a good frame",
         bad + duty, [duty_f], _counters(frames_ok=1, crc_errors=1, bytes_discarded=len(bad) - 1))
    # truncation on a COBS block boundary: the chunk decodes, but to fewer octets than 5 + dlc
    zeros, _ = _msg_frame("SENSE", seq=256, i_a=0.0, i_b=0.0, i_c=0.0)  # many one-octet COBS blocks
    blocks_end = _block_boundary(zeros[:-1], min_len=9)
    cut = zeros[:blocks_end] + b"\x00"
    assert 5 <= len(framing.cobs_decode(zeros[:blocks_end]) or b"") < 13
    case("truncated_length", "a SENSE frame cut short on a COBS block boundary (delimiter too early): "
         "it decodes, to fewer octets than 5 + dlc", cut + duty, [duty_f],
         _counters(frames_ok=1, length_errors=1, bytes_discarded=blocks_end))
    cut2 = telem[:3] + b"\x00"
    assert framing.cobs_decode(telem[:3]) is None
    case("truncated_cobs", "a TELEM frame cut inside a COBS block (delimiter too early)", cut2 + duty,
         [duty_f], _counters(frames_ok=1, cobs_errors=1, bytes_discarded=3))
    inv = b"\x02\x11\x09\x22\x00"
    case("cobs_invalid", "a chunk whose second code octet (9) points past its end", inv + sense, [sense_f],
         _counters(frames_ok=1, cobs_errors=1, bytes_discarded=4))
    short = raw_frame(0x100, 8, bytes(range(1, 8)))
    long_ = raw_frame(0x100, 7, bytes(range(1, 9)))
    case("dlc_mismatch", "valid CRC but dlc 8 with 7 data octets, then dlc 7 with 8 data octets",
         short + long_ + sense, [sense_f],
         _counters(frames_ok=1, length_errors=2, bytes_discarded=len(short) - 1 + len(long_) - 1))
    huge = raw_frame(0x100, 200, b"\x01\x02\x03")
    case("dlc_over_64", "dlc field 200 with 3 data octets (length error), then a frame with dlc 65 and 65 "
         "data octets: 71 COBS octets, more than the 70 a valid frame can have (overrun)",
         huge + raw_frame(0x123, 65, bytes((i % 255) + 1 for i in range(65))) + sense, [sense_f],
         _counters(frames_ok=1, length_errors=1, overruns=1, bytes_discarded=len(huge) - 1 + 71))
    noise = bytes([0x55]) * 100
    case("oversize", "100 non-zero octets without a delimiter (overrun), a 0x00, then a good frame",
         noise + b"\x00" + sense, [sense_f], _counters(frames_ok=1, overruns=1, bytes_discarded=100))
    noise2 = bytes([0x55]) * 80
    case("oversize_glued", "80 non-zero octets run into a frame (both discarded as one overrun), then a "
         "good frame", noise2 + sense + duty, [duty_f],
         _counters(frames_ok=1, overruns=1, bytes_discarded=80 + len(sense) - 1))
    empty = framing.encode_frame(0x7FF, b"")
    case("zero_length", "a frame with dlc 0 and the largest id 0x7FF", empty + sense,
         [_frame_json(0x7FF, b""), sense_f], _counters(frames_ok=2))
    big_payload = bytes([0x00, 0xFF, 0x01, 0x00, 0x00]) + bytes(range(2, 61))
    assert len(big_payload) == 64
    big = framing.encode_frame(0x1FF, big_payload)
    nz_payload = bytes(range(1, 65))
    nz = framing.encode_frame(0x1FF, nz_payload)
    assert len(nz) == framing.MAX_WIRE or b"\x00" in nz_payload
    case("max_payload", "two 64-octet frames (the largest): one full of zeros and 0xFF, one without zeros "
         "(71 octets on the wire)", big + nz,
         [_frame_json(0x1FF, big_payload), _frame_json(0x1FF, nz_payload)],
         _counters(frames_ok=2))
    case("delimiters", "leading and doubled 0x00 delimiters are idle fill",
         b"\x00\x00" + sense + b"\x00" + hb + b"\x00\x00", [sense_f, hb_f], _counters(frames_ok=2))
    id_bad1 = raw_frame(0x0900, 8, MESSAGES["SENSE"].pack(seq=3, i_a=0.0, i_b=0.0, i_c=0.0))
    id_bad2 = raw_frame(0xF100, 0, b"")
    case("id_above_11_bits", "valid CRC but ids 0x0900 and 0xF100 (bits above bit 10 set): length errors",
         id_bad1 + id_bad2 + sense, [sense_f],
         _counters(frames_ok=1, length_errors=2, bytes_discarded=len(id_bad1) - 1 + len(id_bad2) - 1))
    case("trailing_partial", "a frame, then half a frame with no delimiter yet: nothing counted for it",
         sense + duty[: len(duty) // 2], [sense_f], _counters(frames_ok=1))
    short_chunk = framing.cobs_encode(b"\x00\x01\x08\x00") + b"\x00"
    case("too_short", "a chunk decoding to 4 octets (less than id + dlc + crc)", short_chunk + sense, [sense_f],
         _counters(frames_ok=1, length_errors=1, bytes_discarded=len(short_chunk) - 1))

    out = {}
    for name, description, stream, frames, counters in cases:
        _verify_stream(name, stream, frames, counters)
        out[f"stream_{name}"] = {"kind": "stream", "name": name, "description": description,
                                 "stream_hex": stream.hex(), "frames": frames, "counters": counters,
                                 "bin": stream}
    return out


def _block_boundary(chunk: bytes, min_len: int) -> int:
    """First COBS block boundary at or after ``min_len`` octets (the prefix is itself valid COBS)."""
    i = 0
    while i < len(chunk):
        i += chunk[i]
        if i >= min_len:
            return i
    raise ValueError("no block boundary")


def _verify_stream(name: str, stream: bytes, frames: list[dict], counters: dict[str, int]) -> None:
    """The Python deframer must agree with the hand-written expectation (fed at once and octet by octet)."""
    for chunks in ([stream], [stream[i:i + 1] for i in range(len(stream))]):
        d = framing.Deframer()
        got = [f for c in chunks for f in d.feed(c)]
        got_j = [_frame_json(i, p) for i, p in got]
        if got_j != frames or d.counters() != counters:
            raise SystemExit(f"gen_vectors: stream_{name}: deframer gives {got_j} {d.counters()}, "
                             f"expected {frames} {counters}")


# ---------------------------------------------------------------------------------------------------------
# Files
# ---------------------------------------------------------------------------------------------------------

def _json_text(case: dict) -> str:
    data = {k: v for k, v in case.items() if k != "bin"}
    return json.dumps(data, indent=1, allow_nan=False) + "\n"


def generate() -> dict[str, bytes]:
    """File name -> content of every vector file."""
    cases = {**message_cases(), **stream_cases()}
    files: dict[str, bytes] = {}
    for name, case in cases.items():
        files[f"{name}.json"] = _json_text(case).encode()
        files[f"{name}.bin"] = case["bin"]
    index = {"comment": "generated by protocol/vectors/gen_vectors.py; DUTY raw OFF = "
             f"{DUTY_RAW_OFF}", "cases": list(cases)}
    files["index.json"] = (json.dumps(index, indent=1) + "\n").encode()
    return files


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description="generate protocol/vectors/")
    ap.add_argument("--check", action="store_true", help="compare with the committed files, do not write")
    args = ap.parse_args(argv)
    files = generate()
    existing = {p.name for p in OUT_DIR.iterdir() if p.suffix in (".json", ".bin")}
    if args.check:
        bad = sorted(n for n, data in files.items()
                     if not (OUT_DIR / n).exists() or (OUT_DIR / n).read_bytes() != data)
        extra = sorted(existing - set(files))
        for n in bad:
            print(f"stale or missing: protocol/vectors/{n}")
        for n in extra:
            print(f"not generated any more: protocol/vectors/{n}")
        return 1 if bad or extra else 0
    for n in sorted(existing - set(files)):
        (OUT_DIR / n).unlink()
    for n, data in files.items():
        path = OUT_DIR / n
        if not path.exists() or path.read_bytes() != data:
            path.write_bytes(data)
    print(f"protocol/vectors: {len(files)} files ({len(files) // 2} cases)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
