"""Golden vectors of protocol/vectors/ (the C runner tests/c/test_protocol_vectors.c reads the same files)."""
from __future__ import annotations

import json
import math
import random
import struct
from pathlib import Path

import cantools
import pytest

from hil_bench.protocol import dbc, framing
from hil_bench.protocol.messages import DUTY_RAW_OFF, MESSAGES

VECTORS = Path(__file__).resolve().parents[1] / "protocol" / "vectors"
INDEX = json.loads((VECTORS / "index.json").read_text())["cases"]
CASES = {name: json.loads((VECTORS / f"{name}.json").read_text()) for name in INDEX}
MESSAGE_CASES = sorted(n for n, c in CASES.items() if c["kind"] == "message")
STREAM_CASES = sorted(n for n, c in CASES.items() if c["kind"] == "stream")
DB = cantools.database.load_file(str(dbc.DBC_PATH))


def _bin(name: str) -> bytes:
    return (VECTORS / f"{name}.bin").read_bytes()


def test_index_lists_every_file():
    on_disk = {p.stem for p in VECTORS.glob("*.json")} - {"index"}
    assert on_disk == set(INDEX)
    assert {p.stem for p in VECTORS.glob("*.bin")} == set(INDEX)


def test_coverage_of_the_vectors():
    by_msg = {}
    for n in MESSAGE_CASES:
        by_msg.setdefault(CASES[n]["name"], []).append(CASES[n])
    assert set(by_msg) == set(MESSAGES)
    assert all(len(v) >= 6 for v in by_msg.values())
    ties = {(c["name"], s) for c in (CASES[n] for n in MESSAGE_CASES) for s in c["ties"]}
    assert {("SENSE", "i_a"), ("SENSE", "i_b"), ("DUTY", "d_a"), ("FAULT_PLANT", "detail"),
            ("TELEM", "omega_hat")} <= ties
    physical = [(c["name"], s, v) for c in (CASES[n] for n in MESSAGE_CASES) for s, v in c["physical"].items()]
    assert any(v == "OFF" for _, _, v in physical)
    assert any(isinstance(v, float) and v == 0 and math.copysign(1, v) < 0 for m, s, v in physical if s == "value")
    assert any(isinstance(v, float) and v < 0 for m, s, v in physical if m == "SENSE")
    wraps = {(c["name"], s) for c in (CASES[n] for n in MESSAGE_CASES) for s in c["wraps"]}
    assert {("SENSE_AUX", "theta_enc"), ("TELEM", "theta_hat")} <= wraps
    names = {CASES[n]["name"] for n in STREAM_CASES}
    assert {"one_frame", "back_to_back", "garbage_between", "garbage_glued", "bad_crc", "truncated_length",
            "truncated_cobs", "cobs_invalid", "dlc_mismatch", "oversize", "zero_length", "max_payload",
            "delimiters", "id_above_11_bits"} <= names


@pytest.mark.parametrize("name", MESSAGE_CASES)
def test_message_vector(name):
    case = CASES[name]
    msg = MESSAGES[case["name"]]
    payload = bytes.fromhex(case["payload_hex"])
    assert _bin(name) == payload
    assert (case["frame_id"], case["length"], tuple(case["signals"])) == (msg.frame_id, msg.length,
                                                                          msg.signal_names)
    physical, raw = case["physical"], case["raw"]
    # encode(physical) == payload, decode(payload) == raw exactly and physical within half an LSB
    assert msg.pack(**physical) == payload
    assert msg.unpack_raw(payload) == tuple(raw[n] for n in msg.signal_names)
    decoded = msg.unpack(payload)
    for s in msg.signals:
        p = physical[s.name]
        if p == "OFF":
            assert raw[s.name] == DUTY_RAW_OFF and not msg.raw_in_range(s.name, raw[s.name])
        elif s.is_float:
            assert struct.pack("<f", decoded[s.name]) == struct.pack("<f", p)
        elif s.name in case["wraps"]:   # an angle: equal modulo one turn
            d = (decoded[s.name] - p) % (2 * math.pi)
            assert min(d, 2 * math.pi - d) <= abs(s.scale) / 2 * (1 + 1e-6), s.name
            assert msg.raw_in_range(s.name, raw[s.name])
        else:
            assert abs(decoded[s.name] - p) <= abs(s.scale) / 2 * (1 + 1e-9), s.name
            assert msg.raw_in_range(s.name, raw[s.name])
            if not s.is_identity:
                assert struct.unpack("<f", struct.pack("<f", p))[0] == p  # the C encoder sees the same value


@pytest.mark.parametrize("name", MESSAGE_CASES)
def test_message_vector_against_cantools(name):
    """cantools agrees on every signal but the exact ties, where it rounds half to even, and the angles
    outside [0, 2 pi), which it does not wrap."""
    case = CASES[name]
    ct = dbc.codec_message(case["name"])   # CONFIG: its multiplexed parameters as one value
    payload = bytes.fromhex(case["payload_hex"])
    physical = {s: (0.0 if s in case["wraps"] else v) for s, v in case["physical"].items()}
    ct_raw = ct.decode(ct.encode(physical, strict=False), scaling=False, decode_choices=False)
    for s, raw in case["raw"].items():
        if s in case["wraps"]:
            continue
        if s in case["ties"]:
            # half to even: same as ours when ours is even, else the neighbour toward zero
            assert ct_raw[s] == (raw if raw % 2 == 0 else raw - (1 if raw > 0 else -1)), s
        else:
            assert ct_raw[s] == raw or (isinstance(raw, float) and struct.pack("<f", raw) ==
                                        struct.pack("<f", ct_raw[s])), s
    ct_phys = ct.decode(payload, decode_choices=False)
    ours = MESSAGES[case["name"]].unpack(payload)
    for s in ours:
        assert ours[s] == ct_phys[s] or struct.pack("<f", ours[s]) == struct.pack("<f", ct_phys[s])


@pytest.mark.parametrize("name", STREAM_CASES)
def test_stream_vector(name):
    case = CASES[name]
    stream = _bin(name)
    assert stream.hex() == case["stream_hex"]
    expected = [(f["id"], bytes.fromhex(f["payload_hex"])) for f in case["frames"]]
    for f in case["frames"]:
        assert framing.encode_frame(f["id"], bytes.fromhex(f["payload_hex"])).hex() == f["wire_hex"]
    rng = random.Random(name)
    splits = [[stream], [stream[i:i + 1] for i in range(len(stream))]]
    for _ in range(20):
        cuts = sorted(rng.sample(range(len(stream) + 1), k=min(5, len(stream) + 1)))
        splits.append([stream[a:b] for a, b in zip([0] + cuts, cuts + [len(stream)])])
    for pieces in splits:
        d = framing.Deframer()
        got = [f for p in pieces for f in d.feed(p)]
        assert got == expected
        assert d.counters() == case["counters"]
