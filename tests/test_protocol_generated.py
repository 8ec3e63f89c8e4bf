"""Generated artefacts are current (C codec, vectors, docs), the DBC reads the same in canmatrix, and the
generated C matches the DBC and compiles under the strict flags."""
from __future__ import annotations

import math
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from hil_bench.protocol import dbc, gen_c

ROOT = Path(__file__).resolve().parents[1]
STRICT = ["-std=c99", "-Wall", "-Wextra", "-Werror", "-pedantic", "-Wconversion", "-Wdouble-promotion",
          "-Wfloat-equal", "-Wshadow", "-Wstrict-prototypes", "-Wmissing-prototypes"]


@pytest.mark.parametrize("script", ["protocol/gen_c.py", "protocol/vectors/gen_vectors.py", "protocol/gen_docs.py"])
def test_generated_files_are_current(script):
    r = subprocess.run([sys.executable, str(ROOT / script), "--check"], cwd=ROOT, capture_output=True, text=True)
    assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-2000:]


def test_gen_c_check_detects_a_stale_file(tmp_path):
    for name, text in gen_c.generate().items():
        (tmp_path / name).write_text(text)
    assert gen_c.main(["--check", "--out-dir", str(tmp_path)]) == 0
    path = tmp_path / "hil_msgs.c"
    path.write_text(path.read_text().replace("0.001", "0.002", 1))
    assert gen_c.main(["--check", "--out-dir", str(tmp_path)]) == 1


def test_generated_header_matches_the_dbc():
    header = (ROOT / "protocol/c/hil_msgs.h").read_text()
    assert header.startswith("/* GENERATED FROM hil.dbc")
    assert "DO NOT EDIT" in header.splitlines()[0]
    assert re.search(r"#define HIL_PROTO_VERSION 1u\b", header)
    assert "typedef uint_least8_t hil_octet_t;" in header
    for m in dbc.message_specs():
        assert f"#define HIL_{m.name}_FRAME_ID 0x{m.frame_id:03X}u" in header
        assert f"#define HIL_{m.name}_LENGTH {m.length}u" in header
        p = f"hil_{m.name.lower()}"
        assert f"int {p}_pack(hil_octet_t *dst, const {p}_t *src, size_t size);" in header
        assert f"int {p}_unpack({p}_t *dst, const hil_octet_t *src, size_t size);" in header
        for s in m.signals:
            t = gen_c.c_type(s)
            assert f"    {t} {s.name};" in header
            assert f"{t} {p}_{s.name}_encode(float value);" in header
            assert f"float {p}_{s.name}_decode({t} raw);" in header
            assert f"int {p}_{s.name}_is_in_range({t} raw);" in header
    for t in dbc.value_tables():
        for name, value in t.values.items():
            assert f"    {t.c_prefix}_{name} = {value}" in header
    assert "HIL_PARAM_RS_OHM = 1," in header and "HIL_EST_SMO_SIGN = 1," in header
    assert "#define HIL_DUTY_RAW_OFF 65535u" in header
    assert "typedef struct {\n    uint16_t seq; /*" in header
    assert "int16_t hil_sense_i_a_encode(float value);" in header
    for path in (ROOT / "protocol/c").glob("*.[ch]"):
        assert not re.search(r"(^|[^A-Za-z0-9_])u?int8_t", path.read_text()), path


def test_canmatrix_reads_the_same_message_set():
    canmatrix_formats = pytest.importorskip("canmatrix.formats")
    cm = canmatrix_formats.loadp_flat(str(dbc.DBC_PATH))
    assert {f.name for f in cm.frames} == {m.name for m in dbc.message_specs()}
    for m in dbc.message_specs():
        frame = cm.frame_by_name(m.name)
        assert frame.arbitration_id.id == m.frame_id and not frame.arbitration_id.extended
        assert frame.size == m.length
        muxed = {s.name for s in frame.signals if s.multiplex not in (None, "Multiplexor")}
        assert {s.name for s in frame.signals} - muxed == {s.name for s in m.signals} - (
            {"value"} if m.name == "CONFIG" else set())
        for s in m.signals:
            if m.name == "CONFIG" and s.name == "value":   # the multiplexed parameters: below
                continue
            cs = frame.signal_by_name(s.name)
            assert (cs.start_bit, cs.size, cs.is_little_endian, cs.is_signed, cs.is_float) == (
                s.start_bit, s.length_bits, True, s.is_signed, s.is_float), s.qualified_name
            assert float(cs.factor) == s.scale and float(cs.offset) == s.offset, s.qualified_name
            assert float(cs.min) == s.dbc_minimum and float(cs.max) == s.dbc_maximum, s.qualified_name
            assert {int(k): v for k, v in cs.values.items()} == dict(s.choices), s.qualified_name
        # Vector's interaction-layer attributes, by name
        assert frame.attributes.get("GenMsgSendType", "NoMsgSendType") == m.send_type
        assert int(frame.attributes.get("GenMsgCycleTime", 0)) == m.cycle_time_ms
    assert cm.attributes["BusType"] == "CAN"
    assert cm.frame_defines["GenMsgSendType"].values[:1] == ["Cyclic"]
    assert float(cm.frame_by_name("DUTY").signal_by_name("d_a").attributes["HilValidMax"]) == 1.0
    # every CONFIG parameter is a multiplexed signal of its own: unit, range, kind, default, enum values
    config = cm.frame_by_name("CONFIG")
    assert config.signal_by_name("param_id").multiplex == "Multiplexor"
    for p in dbc.param_specs():
        cs = config.signal_by_name(p.name)
        assert cs.multiplex == p.param_id and cs.is_float and (cs.start_bit, cs.size) == (32, 32), p.name
        assert (cs.unit or "-") == p.unit and float(cs.min) == p.minimum and float(cs.max) == p.maximum, p.name
        assert cs.attribute("HilParamKind", cm) == p.kind, p.name
        assert cs.attribute("HilSince", cm) == p.since, p.name
        if p.default is None:
            assert int(cs.attribute("HilParamRequired", cm)) == 1, p.name
        else:
            assert float(cs.attribute("HilParamDefault", cm)) == p.default, p.name
        assert {int(k): v for k, v in cs.values.items()} == dict(p.values), p.name
    enable = config.signal_by_name("INV_COMP_ENABLE")
    assert len(enable.values) == 5 and enable.values[2] == "on, sampled currents"


# ---------------------------------------------------------------------------------------------------------
# The DBC as CAN tools expect it (issue 9, item 11)
# ---------------------------------------------------------------------------------------------------------

def test_dbc_uses_vectors_standard_attributes():
    db = dbc.database()
    send_type = db.dbc.attribute_definitions["GenMsgSendType"]
    assert send_type.type_name == "ENUM"
    # the Vector interaction-layer enum: index 0 Cyclic, 7 IfActive, 8 NoMsgSendType
    assert send_type.choices[0] == "Cyclic" and send_type.choices[7] == "IfActive"
    assert send_type.choices[8] == "NoMsgSendType" and send_type.default_value == "NoMsgSendType"
    assert db.dbc.attribute_definitions["GenMsgCycleTime"].type_name == "INT"
    assert dbc.bus_type() == "CAN"
    for m in dbc.message_specs():
        if m.send_type == "Cyclic":     # time-cyclic messages say their period
            assert m.cycle_time_ms > 0, m.name
        else:                           # per-cycle and event messages: NoMsgSendType, no period
            assert m.send_type == "NoMsgSendType" and m.cycle_time_ms == 0, m.name
    heartbeats = {m.name for m in dbc.message_specs() if m.send_type == "Cyclic"}
    assert heartbeats == {"HEARTBEAT_PLANT", "HEARTBEAT_CTRL"}
    per_cycle = {m.name for m in dbc.message_specs() if m.sent.startswith("EveryControlCycle")}
    assert per_cycle == {"SENSE", "SENSE_AUX", "SENSE_DUAL", "DUTY", "TELEM", "TELEM_EMF"}
    # the documented reason why the per-cycle messages carry no GenMsgCycleTime (the DBC's own comment)
    text = dbc.DBC_PATH.read_text()
    comment = re.search(r'^CM_ "(.*?)";$', text, re.M).group(1)
    assert "HELLO.period_us" in comment and "NoMsgSendType" in comment and "HilSent" in comment


def test_every_value_table_entry_lies_inside_the_declared_range():
    """CAN tools flag a value description outside [min|max]: DUTY OFF (raw 65535) is inside the declared
    range, outside the valid range (attribute HilValidMax)."""
    for m in dbc.message_specs():
        for s in m.signals:
            for raw in s.choices:
                assert s.dbc_minimum <= s.physical_of(raw) <= s.dbc_maximum, (s.qualified_name, raw)
    d_a = dbc.message_spec("DUTY").signal("d_a")
    assert (d_a.raw_min, d_a.raw_max, d_a.dbc_maximum) == (0, 32768, 65535 * 2.0 ** -15)


def test_angle_maximum_is_exactly_the_largest_raw_value():
    """A tool that computes raw = max / scale (and truncates) must find raw 65535 in range."""
    for name in (("SENSE_AUX", "theta_enc"), ("TELEM", "theta_hat")):
        s = dbc.message_spec(name[0]).signal(name[1])
        assert s.is_cyclic and s.dbc_maximum / s.scale == 65535.0 and s.raw_max == 65535
        assert s.scale * 65536 == 2 * math.pi


def test_flag_bytes_have_value_tables_naming_every_combination():
    for table in dbc.flag_tables():
        s = dbc.message_spec(table.message).signal(table.signal)
        assert len(s.choices) == 1 << len(table.bits)
        assert s.choices[0] == "NONE"
        full = sum(b.mask for b in table.bits)
        assert s.choices[full] == "+".join(b.name for b in table.bits)
    assert [b.name for b in dbc.flag_table("HelloFlag").bits] == ["DUAL_SAMPLING", "TELEM_EMF", "ENCODER_VALID"]
    assert [b.name for b in dbc.flag_table("SenseAuxFlag").bits] == ["DUAL_FOLLOWS", "THETA_ENC_VALID"]


@pytest.mark.skipif(shutil.which("cc") is None, reason="no C compiler")
def test_cantools_generated_c_compiles_under_the_strict_flags_and_truncates(tmp_path):
    """`cantools generate_c_source hil.dbc` compiles warning-free; its *_encode() truncates where the
    protocol rounds (docs/protocol.md section 3): shown on two values, against our generated codec."""
    r = subprocess.run([sys.executable, "-m", "cantools", "generate_c_source", "--database-name", "ct",
                        str(dbc.DBC_PATH)], cwd=tmp_path, capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    (tmp_path / "main.c").write_text(r"""
#include <stdio.h>
#include "ct.h"
#include "hil_msgs.h"
int main(void)
{
    printf("%d %d %u %u\n", (int)ct_sense_i_a_encode(0.0019999), (int)hil_sense_i_a_encode(0.0019999f),
           (unsigned)ct_duty_d_a_encode(0.99999), (unsigned)hil_duty_d_a_encode(0.99999f));
    return 0;
}
""")
    exe = tmp_path / "a.out"
    r = subprocess.run(["cc", *STRICT, "-I", str(tmp_path), "-I", str(ROOT / "protocol/c"), str(tmp_path / "ct.c"),
                        str(tmp_path / "main.c"), str(ROOT / "protocol/c/hil_msgs.c"), "-lm", "-o", str(exe)],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    got = subprocess.run([str(exe)], capture_output=True, text=True, check=True).stdout.split()
    assert got == ["1", "2", "32767", "32768"]   # cantools truncates 1.9999 -> 1, we round to 2


@pytest.mark.skipif(shutil.which("cc") is None, reason="no C compiler")
@pytest.mark.parametrize("calc_float", [False, True])
def test_protocol_c_compiles_under_the_strict_flags(tmp_path, calc_float):
    sources = [ROOT / "protocol/c/hil_msgs.c", ROOT / "protocol/c/hil_framing.c", ROOT / "protocol/c/hil_msgs_reflect.c"]
    defs = ["-DHIL_MSGS_CALC_FLOAT"] if calc_float else []
    for src in sources:
        r = subprocess.run(["cc", *STRICT, *defs, "-c", str(src), "-o", str(tmp_path / (src.stem + ".o"))],
                           capture_output=True, text=True)
        assert r.returncode == 0, r.stderr
