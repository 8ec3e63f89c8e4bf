"""hil_bench.protocol.messages: API, range/NaN rules, rounding, and the fast path against cantools and the generic path."""
from __future__ import annotations

import math
import random
import struct

import cantools
import numpy as np
import pytest

from hil_bench.protocol import dbc
from hil_bench.protocol.messages import (
    BY_ID,
    DUTY_RAW_OFF,
    MESSAGES,
    PROTO_VERSION,
    BitLayout,
    Command,
    ConfigStatus,
    Estimator,
    Fault,
    HelloFlag,
    HelloStatus,
    LengthError,
    Message,
    Mode,
    Param,
    ProtocolError,
    SenseAuxFlag,
    SignalRangeError,
    State,
    UnknownMessageError,
    decode,
)

DB = cantools.database.load_file(str(dbc.DBC_PATH))
SENSE, DUTY, CMD, FAULT = MESSAGES["SENSE"], MESSAGES["DUTY"], MESSAGES["CMD"], MESSAGES["FAULT_PLANT"]


# ---------------------------------------------------------------------------------------------------------
# message set and enums
# ---------------------------------------------------------------------------------------------------------

def test_message_set_matches_the_dbc():
    assert set(MESSAGES) == {m.name for m in DB.messages}
    assert set(BY_ID) == {m.frame_id for m in DB.messages}
    for m in DB.messages:
        ours = MESSAGES[m.name]
        assert BY_ID[m.frame_id] is ours
        assert (ours.frame_id, ours.length) == (m.frame_id, m.length)
        ct = dbc.codec_message(m.name)   # CONFIG: its multiplexed parameters as one value
        assert ours.signal_names == tuple(s.name for s in sorted(ct.signals, key=lambda s: s.start))
        # every message but HELLO / HELLO_ACK (the 1.1 minor version in a nibble) is byte-aligned
        assert ours.uses_struct == (m.name not in ("HELLO", "HELLO_ACK")), m.name


def test_cantools_decodes_config_by_its_parameter_signal():
    """CONFIG in the DBC: param_id multiplexes one signal per parameter, which cantools decodes by name
    with its value table; the octets are what our codec packs."""
    ct = DB.get_message_by_name("CONFIG")
    assert ct.is_multiplexed()
    for name, value in (("RS_OHM", 0.35), ("INV_COMP_ENABLE", 2.0), ("LOOP_ANGLE", 1.0), ("POLE_PAIRS", 4.0)):
        data = MESSAGES["CONFIG"].pack(param_id=int(Param[name]), config_seq=7, value=value)
        assert ct.encode({"param_id": int(Param[name]), "config_seq": 7, name: value}, strict=True) == data
        got = ct.decode(data, decode_choices=False)
        assert got == {"param_id": int(Param[name]), "config_seq": 7, name: pytest.approx(value)}
    assert DB.decode_message(ct.frame_id, MESSAGES["CONFIG"].pack(param_id=90, config_seq=1, value=2.0))[
        "INV_COMP_ENABLE"] == "on, sampled currents"


def test_proto_version_comes_from_the_dbc_version_string():
    assert PROTO_VERSION == 1
    assert DB.version.endswith(f"protocol {PROTO_VERSION}.{dbc.proto_minor()}")
    assert dbc.proto_version_text() == "1.1"


def test_value_table_enums():
    assert Param.RS_OHM == 1 and Param.HARM_COMP_GAIN == 64 and Param["SMO_K_V"] == 40
    assert Estimator.SMO_SIGN == 1 and Estimator.ENCODER == 5
    assert State.IDLE == 0 and State.STOPPED == 6
    assert Fault.NONE == 0 and Fault.HOST_ABORT == 13
    assert Command.SET_SPEED_REF == 4 and Command.SET_CONTROL_MODE == 7
    assert HelloStatus.OK == 0 and HelloStatus.PERIOD_UNSUPPORTED == 4
    assert ConfigStatus.LOCKED == 3
    assert Mode.LOCKSTEP == 0 and Mode.REALTIME == 1
    assert DUTY_RAW_OFF == 65535
    assert HelloFlag.DUAL_SAMPLING == 1 and HelloFlag.TELEM_EMF == 2 and HelloFlag.ENCODER_VALID == 4
    assert SenseAuxFlag.DUAL_FOLLOWS == 1 and SenseAuxFlag.THETA_ENC_VALID == 2
    # every enum is the DBC table, value for value
    for table, enum in ((("CONFIG", "param_id"), Param), (("TELEM", "estimator"), Estimator),
                        (("HEARTBEAT_CTRL", "state"), State), (("FAULT_CTRL", "code"), Fault),
                        (("CMD", "command"), Command), (("HELLO_ACK", "status"), HelloStatus),
                        (("CONFIG_ACK", "status"), ConfigStatus), (("HELLO", "mode"), Mode)):
        choices = DB.get_message_by_name(table[0]).get_signal_by_name(table[1]).choices
        assert {int(k): str(v) for k, v in choices.items()} == {e.value: e.name for e in enum}


def test_dbc_comments_describe_the_flag_bits():
    hello = DB.get_message_by_name("HELLO").get_signal_by_name("flags").comment
    aux = DB.get_message_by_name("SENSE_AUX").get_signal_by_name("flags").comment
    for flags, comment in ((dbc.flag_table("HelloFlag").bits, hello),
                           (dbc.flag_table("SenseAuxFlag").bits, aux)):
        for f in flags:
            assert f"bit{f.bit}" in comment


def test_duty_off_is_in_the_dbc_for_every_leg():
    for leg in ("d_a", "d_b", "d_c"):
        sig = DB.get_message_by_name("DUTY").get_signal_by_name(leg)
        assert dict(sig.choices) == {65535: "OFF"}
        assert "OFF" in sig.comment


# ---------------------------------------------------------------------------------------------------------
# encode / decode
# ---------------------------------------------------------------------------------------------------------

def test_sense_round_trip_and_layout():
    data = SENSE.pack_values((1, 1.5, -0.75, -0.75))
    assert data == bytes.fromhex("0100dc0512fd12fd")
    assert SENSE.unpack(data) == {"seq": 1, "i_a": 1.5, "i_b": -0.75, "i_c": -0.75}
    assert SENSE.unpack_raw(data) == (1, 1500, -750, -750)
    assert SENSE.pack(seq=1, i_a=1.5, i_b=-0.75, i_c=-0.75) == data
    msg, values = decode(0x100, data)
    assert msg is SENSE and values["i_a"] == 1.5


def test_duty_off_and_choice_names():
    data = DUTY.pack(seq=1, d_a="OFF", d_b=0.5, d_c=1.0)
    assert DUTY.unpack_raw(data) == (1, DUTY_RAW_OFF, 16384, 32768)
    assert not DUTY.raw_in_range("d_a", DUTY_RAW_OFF)
    assert DUTY.raw_in_range("d_a", 32768) and not DUTY.raw_in_range("d_a", 32769)
    assert CMD.pack(command=Command.RUN, seq=1, value=0.0)[0] == 1
    assert CMD.pack(command="SET_IQ_REF", seq=1, value=0.0)[0] == 5
    with pytest.raises(SignalRangeError, match="DUTY.d_a.*'ON'"):
        DUTY.pack(seq=1, d_a="ON", d_b=0.5, d_c=1.0)
    with pytest.raises(SignalRangeError, match="SENSE.i_a"):
        SENSE.pack(seq=1, i_a="OFF", i_b=0.0, i_c=0.0)


def test_out_of_range_raises_naming_signal_and_value():
    with pytest.raises(SignalRangeError, match=r"SENSE\.i_a = 40\.0 is outside \[-32\.768, 32\.767\]"):
        SENSE.pack_values((1, 40.0, 0.0, 0.0))
    with pytest.raises(SignalRangeError, match=r"DUTY\.d_b = 1\.01"):
        DUTY.pack_values((1, 0.5, 1.01, 0.5))
    with pytest.raises(SignalRangeError, match=r"SENSE\.seq = 65536"):
        SENSE.pack_values((65536, 0.0, 0.0, 0.0))
    with pytest.raises(SignalRangeError, match=r"CMD\.value"):
        CMD.pack_values((1, 1, 1e39))
    assert issubclass(SignalRangeError, ProtocolError) and issubclass(ProtocolError, ValueError)


def test_saturate_clamps_to_the_dbc_range():
    data = SENSE.pack_values((70000, 40.0, -1e9, math.inf), saturate=True)
    assert SENSE.unpack_raw(data) == (65535, 32767, -32768, 32767)
    assert DUTY.unpack_raw(DUTY.pack_values((0, 1.2, -0.1, 0.5), saturate=True)) == (0, 32768, 0, 16384)
    assert CMD.unpack_values(CMD.pack_values((1, 1, -math.inf), saturate=True))[2] == pytest.approx(-3.4e38, rel=1e-7)


@pytest.mark.parametrize("saturate", [False, True])
def test_nan_always_raises(saturate):
    for msg, values, i in ((SENSE, [1, 0.0, 0.0, 0.0], 1), (SENSE, [1, 0.0, 0.0, 0.0], 0),
                           (CMD, [1, 1, 0.0], 2), (DUTY, [1, 0.0, 0.0, 0.0], 3)):
        values[i] = math.nan
        with pytest.raises(SignalRangeError, match="NaN"):
            msg.pack_values(values, saturate=saturate)


def test_rounding_is_half_away_from_zero_and_differs_from_cantools_only_on_ties():
    lsb = 2.0 ** -15
    assert SENSE.unpack_raw(SENSE.pack_values((2.5, 0.0625, -0.0625, 2.5625))) == (3, 63, -63, 2563)
    assert DUTY.unpack_raw(DUTY.pack_values((0, 100.5 * lsb, 0.5 * lsb, 16383.5 * lsb))) == (0, 101, 1, 16384)
    assert FAULT.unpack_raw(FAULT.pack_values((1, 2.5, -2.5)))[1:] == (3, -3)
    # cantools (Python's round) goes to even on the same ties
    sense = DB.get_message_by_name("SENSE")
    ct = sense.decode(sense.encode({"seq": 2.5, "i_a": 0.0625, "i_b": -0.0625, "i_c": 2.5625}), scaling=False)
    assert (ct["seq"], ct["i_a"], ct["i_b"], ct["i_c"]) == (2, 62, -62, 2562)
    # just below / above a tie both agree
    assert SENSE.unpack_raw(SENSE.pack_values((0, 0.0624999, -0.0625001, 0.0)))[1:3] == (62, -63)


def test_in_range_is_about_the_rounded_raw_value():
    assert SENSE.in_range("i_a", 32.767) and SENSE.in_range("i_a", 32.7674)  # rounds to 32767
    assert not SENSE.in_range("i_a", 32.7676) and not SENSE.in_range("i_a", math.nan)
    assert not DUTY.in_range("d_a", "OFF") and DUTY.in_range("d_a", 1.0) and not DUTY.in_range("d_a", 1.0001)
    theta_max = MESSAGES["TELEM"].unpack_values(MESSAGES["TELEM"].pack_raw((0, 65535, 0, 0, 0)))[1]
    assert MESSAGES["TELEM"].in_range("theta_hat", theta_max)  # what we decode we can encode again
    with pytest.raises(ProtocolError, match="no signal 'i_d'"):
        SENSE.in_range("i_d", 0.0)


def test_pack_argument_errors():
    with pytest.raises(ProtocolError, match=r"missing signals \['i_c'\]"):
        SENSE.pack(seq=1, i_a=0.0, i_b=0.0)
    with pytest.raises(ProtocolError, match=r"unknown signals \['i_d'\]"):
        SENSE.pack(seq=1, i_a=0.0, i_b=0.0, i_c=0.0, i_d=0.0)
    with pytest.raises(ProtocolError, match="expected 4 values"):
        SENSE.pack_values((1, 0.0, 0.0))
    with pytest.raises(ProtocolError, match="expected 4 values"):
        SENSE.pack_values(None)  # type: ignore[arg-type]
    with pytest.raises(SignalRangeError, match="raw 32769"):
        SENSE.pack_raw((0, 32769, 0, 0))


def test_decode_errors_name_the_id_and_the_lengths():
    with pytest.raises(UnknownMessageError, match="0x7FF"):
        decode(0x7FF, bytes(8))
    with pytest.raises(LengthError, match=r"0x100 SENSE: expected 8 octets, got 7"):
        decode(0x100, bytes(7))
    with pytest.raises(LengthError, match=r"0x100 SENSE: expected 8 octets, got 9"):
        decode(0x100, bytes(9))
    with pytest.raises(LengthError, match=r"SENSE \(0x100\): need 8 octets, got 3"):
        SENSE.unpack(bytes(3))
    assert SENSE.unpack_raw(bytes(10)) == (0, 0, 0, 0)  # like C unpack: extra octets ignored
    assert isinstance(UnknownMessageError("x"), ValueError)


def test_float_signals_keep_binary32_bits():
    for value in (-0.0, 1e-30, 3.4e38, -1.5):
        data = CMD.pack_values((1, 2, value))
        got = CMD.unpack_values(data)[2]
        assert struct.pack("<f", got) == struct.pack("<f", value) == data[4:]
    assert CMD.pack_values((1, 2, -0.0))[4:] == b"\x00\x00\x00\x80"


def test_numpy_scalars_encode_like_python_floats():
    for v in (0.1234, -3.3, 32.7):
        ref = SENSE.pack_values((1, v, -v, 0.0))
        assert SENSE.pack_values((np.int64(1), np.float64(v), np.float64(-v), np.float32(0.0))) == ref
    v32 = np.float32(1.2345)  # encoded from its exact binary32 value, as the C encoder would
    assert SENSE.pack_values((1, v32, 0.0, 0.0)) == SENSE.pack_values((1, float(v32), 0.0, 0.0))


# ---------------------------------------------------------------------------------------------------------
# fast path == generic path == cantools
# ---------------------------------------------------------------------------------------------------------

def _random_physical(rng: random.Random, s: dbc.SignalSpec) -> float | int:
    """A value in the DBC range whose quotient is at least 0.05 LSB away from a rounding tie."""
    if s.is_float:
        while True:
            v = struct.unpack("<f", struct.pack("<I", rng.getrandbits(32)))[0]
            if math.isfinite(v) and s.minimum <= v <= s.maximum:
                return v
    raw = rng.randint(int(s.raw_min), int(s.raw_max))
    if s.is_identity and rng.random() < 0.5:
        return raw
    v = (raw + rng.uniform(-0.45, 0.45)) * s.scale + s.offset
    return min(max(v, s.minimum), s.maximum)


@pytest.mark.parametrize("name", sorted(MESSAGES))
def test_fast_path_matches_cantools_on_random_values(name):
    msg, ct = MESSAGES[name], dbc.codec_message(name)
    rng = random.Random(1234 + msg.frame_id)
    for _ in range(3000):
        values = [_random_physical(rng, s) for s in msg.signals]
        ours = msg.pack_values(values)
        assert ours == ct.encode(dict(zip(msg.signal_names, values)), strict=True), values
        assert ours == msg.generic_pack_values(values)
        decoded = ct.decode(ours, decode_choices=False)
        for got, s in zip(msg.unpack_values(ours), msg.signals):
            want = decoded[s.name]
            assert got == want and type(got) is type(want), (s.name, got, want)


@pytest.mark.parametrize("name", sorted(MESSAGES))
def test_unpack_matches_cantools_on_random_payloads(name):
    msg, ct = MESSAGES[name], dbc.codec_message(name)
    rng = random.Random(99 + msg.frame_id)
    for _ in range(2000):
        data = rng.randbytes(msg.length)
        want = ct.decode(data, decode_choices=False)
        for got, s in zip(msg.unpack_values(data), msg.signals):
            w = want[s.name]
            assert got == w or (math.isnan(got) and math.isnan(w)), (s.name, got, w)
        want_raw = ct.decode(data, decode_choices=False, scaling=False)
        for got, s in zip(msg.unpack_raw(data), msg.signals):
            w = want_raw[s.name]
            assert got == w or (math.isnan(got) and math.isnan(w)), (s.name, got, w)


@pytest.mark.parametrize("name", sorted(MESSAGES))
def test_compiled_pack_values_equals_the_generic_encoders_on_odd_inputs(name):
    msg = MESSAGES[name]
    rng = random.Random(7)
    odd = [0, 1, -1, 2.5, -2.5, 1e9, -1e9, math.inf, -math.inf, True, np.float32(0.5), np.int16(3), "OFF",
           "IDLE", None, "1.5"]
    for _ in range(400):
        values = [rng.choice(odd) if rng.random() < 0.5 else _random_physical(rng, s) for s in msg.signals]
        for saturate in (False, True):
            try:
                want = msg.generic_pack_values(values, saturate)
            except ProtocolError as e:
                with pytest.raises(type(e)):
                    msg.pack_values(values, saturate)
                continue
            assert msg.pack_values(values, saturate) == want, values


@pytest.mark.parametrize("name", sorted(MESSAGES))
def test_struct_layout_equals_generic_bit_layout(name):
    msg = MESSAGES[name]
    layout = BitLayout(msg.spec)
    rng = random.Random(5)
    for _ in range(500):
        data = rng.randbytes(msg.length)
        raws = msg.unpack_raw(data)
        assert layout.unpack_from(data) == raws or any(isinstance(r, float) and math.isnan(r) for r in raws)
        assert layout.pack(*raws) == msg.pack_raw(raws)


ODD_DBC = '''VERSION "odd layout test"
BU_: A B
BO_ 291 ODD: 8 A
 SG_ flag : 0|1@1+ (1,0) [0|1] "" B
 SG_ mode : 1|3@1+ (1,0) [0|7] "" B
 SG_ temp : 4|12@1- (0.5,-10) [-1034|1013.5] "degC" B
 SG_ speed : 16|20@1- (0.25,0) [-131072|131071.75] "rad/s" B
 SG_ level : 36|27@1+ (1,0) [0|134217727] "" B
'''


def test_generic_bit_layout_on_a_non_byte_aligned_message_matches_cantools():
    db = cantools.database.load_string(ODD_DBC, database_format="dbc")
    (spec,) = dbc.specs_from_database(db)
    msg = Message(spec)
    ct = db.get_message_by_name("ODD")
    assert not msg.uses_struct
    rng = random.Random(3)
    for _ in range(2000):
        values = [_random_physical(rng, s) for s in msg.signals]
        data = msg.pack_values(values)
        assert data == ct.encode(dict(zip(msg.signal_names, values)))
        want = ct.decode(data, decode_choices=False)
        assert msg.unpack_values(data) == tuple(want[n] for n in msg.signal_names)
        payload = rng.randbytes(8)
        assert msg.unpack_raw(payload) == tuple(ct.decode(payload, scaling=False)[n] for n in msg.signal_names)
