"""Generated artefacts are current (C codec, vectors, docs), the DBC reads the same in canmatrix, and the
generated C matches the DBC and compiles under the strict flags."""
from __future__ import annotations

import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from protocol import dbc, gen_c

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
        assert {s.name for s in frame.signals} == {s.name for s in m.signals}
        for s in m.signals:
            cs = frame.signal_by_name(s.name)
            assert (cs.start_bit, cs.size, cs.is_little_endian, cs.is_signed, cs.is_float) == (
                s.start_bit, s.length_bits, True, s.is_signed, s.is_float), s.qualified_name
            assert float(cs.factor) == s.scale and float(cs.offset) == s.offset, s.qualified_name
            assert float(cs.min) == s.minimum and float(cs.max) == s.maximum, s.qualified_name
            assert {int(k): v for k, v in cs.values.items()} == dict(s.choices), s.qualified_name


@pytest.mark.skipif(shutil.which("cc") is None, reason="no C compiler")
@pytest.mark.parametrize("calc_float", [False, True])
def test_protocol_c_compiles_under_the_strict_flags(tmp_path, calc_float):
    sources = [ROOT / "protocol/c/hil_msgs.c", ROOT / "protocol/c/hil_framing.c", ROOT / "protocol/c/hil_msgs_reflect.c"]
    defs = ["-DHIL_MSGS_CALC_FLOAT"] if calc_float else []
    for src in sources:
        r = subprocess.run(["cc", *STRICT, *defs, "-c", str(src), "-o", str(tmp_path / (src.stem + ".o"))],
                           capture_output=True, text=True)
        assert r.returncode == 0, r.stderr
