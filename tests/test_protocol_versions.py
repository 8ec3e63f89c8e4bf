"""Protocol versions (issue 29, items 1 and 2): the tables are recorded per version and hashed, a change
without a new version fails; the DBC carries everything a generator needs (the C codec regenerates from
it alone); CONFIG's octets are those of 1.0; a 1.0 drive (the stub claiming 1.0, the independent drive
built on the 1.0 DBC) is served by today's host, and a run that needs a 1.1 feature is refused naming it."""
from __future__ import annotations

import shutil
import struct
import subprocess
import sys
from pathlib import Path

import cantools
import numpy as np
import pytest

from hil_bench.protocol import dbc, versions
from hil_bench.protocol.messages import MESSAGES, Estimator, Param

ROOT = Path(__file__).resolve().parents[1]
VECTORS = ROOT / "protocol" / "vectors"


@pytest.fixture
def other_dbc():
    """Read another DBC for the test, then protocol/hil.dbc again."""
    yield dbc.use_dbc
    dbc.use_dbc(ROOT / "protocol" / "hil.dbc")


# ---------------------------------------------------------------------------------------------------------
# every change to the tables is a new version
# ---------------------------------------------------------------------------------------------------------

def test_the_tables_hash_to_the_hash_recorded_for_the_dbc_version():
    tables = versions.current_tables()
    assert tables["version"] == dbc.proto_version_text() == "1.1"
    recorded = versions.recorded_hashes()
    assert recorded.get(tables["version"]) == versions.tables_hash(tables), (
        "protocol/hil.dbc's tables differ from those recorded for its VERSION: a changed table is a new "
        "version (raise VERSION in hil.dbc, then python protocol/versions.py --record)")
    # the snapshot of the DBC's version is its tables, and every snapshot hashes to its record
    for v in versions.versions():
        assert versions.tables_hash(versions.snapshot(v)) == recorded[v], v
    assert versions.snapshot("1.1") == tables


@pytest.mark.parametrize("edit", [
    ('[1e-06|100] "ohm"', '[1e-06|200] "ohm"'),                        # a parameter's range
    ('6 "SMO_STA" ;\nVAL_ 385', '6 "SMO_STA" 7 "NEW_ONE" ;\nVAL_ 385'),  # a value-table entry
    ('BA_ "HilParamDefault" SG_ 48 IQ_MAX_A 5;', 'BA_ "HilParamDefault" SG_ 48 IQ_MAX_A 6;'),  # a default
])
def test_a_table_changed_without_a_new_version_fails_the_check(tmp_path, other_dbc, capsys, edit):
    text = (ROOT / "protocol" / "hil.dbc").read_text()
    assert text.count(edit[0]) == 1
    changed = tmp_path / "hil.dbc"
    changed.write_text(text.replace(edit[0], edit[1]))
    other_dbc(changed)
    assert versions.tables_hash(versions.current_tables()) != versions.recorded_hashes()["1.1"]
    assert versions.main([]) == 1
    assert "a changed table needs a new VERSION" in capsys.readouterr().err
    # and recording it under the same version is refused: a released version never changes
    with pytest.raises(SystemExit, match="a released version never changes"):
        versions.record()


def test_a_reworded_meaning_is_not_a_new_version(tmp_path, other_dbc):
    text = (ROOT / "protocol" / "hil.dbc").read_text()
    changed = tmp_path / "hil.dbc"
    changed.write_text(text.replace('CM_ SG_ 48 RS_OHM "stator phase resistance";',
                                    'CM_ SG_ 48 RS_OHM "stator phase resistance (per phase, star)";'))
    other_dbc(changed)
    assert versions.tables_hash(versions.current_tables()) == versions.recorded_hashes()["1.1"]


def test_each_parameter_says_the_version_that_added_it():
    first = {}
    for v in versions.versions():
        for p in versions.snapshot(v)["params"]:
            first.setdefault(p["name"], v)
    for p in dbc.param_specs():
        assert p.since == first[p.name], p.name
    added = sorted(n for n, v in first.items() if v == "1.1")
    assert added == sorted(["LOOP_ANGLE", "SMO_STA_K1_V", "SMO_STA_K2_V_S", *(
        f"INV_COMP_{s}" for s in ("ENABLE", "DEAD_TIME_S", "V_SWITCH_V", "R_SWITCH_OHM", "V_DIODE_V",
                                  "R_DIODE_OHM", "BAND_A", "SHAPE", "I_BW_RAD_S"))])


def test_the_changelog_names_what_changed_since_1_0():
    rows = dict(versions.changes(versions.snapshot("1.0"), versions.snapshot("1.1")))
    assert rows["HELLO.estimator"] == "value table: new 6 SMO_STA"
    assert rows["CMD.command"] == "value table: new 8 RESTART"
    assert rows["CONFIG 37 LOOP_ANGLE"].startswith("new parameter: enum")
    assert rows["HELLO.proto_minor"] == "new signal: bits 44..47"
    assert rows["HELLO_ACK.proto_minor"] == "new signal: bits 12..15"
    assert len([w for w in rows if w.startswith("CONFIG ")]) == 13   # 12 new, RS_OHM's range
    doc = (ROOT / "docs" / "protocol.md").read_text()
    assert "| CMD.command | value table: new 8 RESTART |" in doc


# ---------------------------------------------------------------------------------------------------------
# everything a generator needs is in the DBC
# ---------------------------------------------------------------------------------------------------------

def test_cantools_lists_every_parameter_with_unit_range_kind_default_and_values():
    db = cantools.database.load_file(str(ROOT / "protocol" / "hil.dbc"), strict=True)
    config = db.get_message_by_name("CONFIG")
    enable = config.get_signal_by_name("INV_COMP_ENABLE")
    assert enable.multiplexer_ids == [90] and enable.is_float
    assert dict(enable.choices)[0] == "off" and len(enable.choices) == 5
    assert enable.dbc.attributes["HilParamKind"].value == 3          # "enum"
    assert enable.dbc.attributes["HilSince"].value == "1.1"
    rs = config.get_signal_by_name("RS_OHM")
    assert (rs.unit, rs.minimum, rs.maximum) == ("ohm", 1e-06, 100)
    assert rs.dbc.attributes["HilParamRequired"].value == 1
    names = {s.name for s in config.signals if s.multiplexer_ids}
    assert names == {p.name for p in Param}


def test_the_c_codec_regenerates_from_the_dbc_alone(tmp_path):
    """Byte-identical: protocol/gen_c.py run on a copy of hil.dbc in an empty folder writes the committed
    hil_msgs.[ch] and hil_msgs_reflect.[ch], parameter table included (kinds, ranges, defaults, since)."""
    alone = tmp_path / "dbc"
    alone.mkdir()
    shutil.copy(ROOT / "protocol" / "hil.dbc", alone / "hil.dbc")
    out = tmp_path / "out"
    out.mkdir()
    run = subprocess.run([sys.executable, str(ROOT / "protocol" / "gen_c.py"), "--dbc", str(alone / "hil.dbc"),
                          "--out-dir", str(out)], capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stderr
    for name in ("hil_msgs.h", "hil_msgs.c", "hil_msgs_reflect.h", "hil_msgs_reflect.c"):
        assert (out / name).read_bytes() == (ROOT / "protocol" / "c" / name).read_bytes(), name
    header = (out / "hil_msgs.h").read_text()
    assert "#define HIL_PARAM_INV_COMP_ENABLE_KIND HIL_PARAM_KIND_ENUM" in header
    assert "#define HIL_PARAM_INV_COMP_ENABLE_MAX 4.0f" in header
    assert "#define HIL_PARAM_RS_OHM_REQUIRED 1u" in header
    assert "#define HIL_PARAM_LOOP_ANGLE_SINCE_MINOR 1u" in header


def test_the_config_octets_are_those_of_1_0():
    """Every shared CONFIG vector is what protocol 1.0's DBC (CONFIG not multiplexed) encodes: the wire is
    unchanged."""
    old = cantools.database.load_file(str(ROOT / "protocol" / "versions" / "1.0.dbc"), strict=True)
    ct = old.get_message_by_name("CONFIG")
    cases = sorted(VECTORS.glob("msg_config_*.json"))
    cases = [c for c in cases if not c.name.startswith("msg_config_ack")]
    assert len(cases) >= 10
    import json
    for path in cases:
        case = json.loads(path.read_text())
        payload = bytes.fromhex(case["payload_hex"])
        assert (VECTORS / path.name.replace(".json", ".bin")).read_bytes() == payload
        raw = case["raw"]
        assert ct.encode(raw, scaling=False, strict=False) == payload, path.name
        assert MESSAGES["CONFIG"].pack_raw([raw[s] for s in MESSAGES["CONFIG"].signal_names]) == payload


# ---------------------------------------------------------------------------------------------------------
# a 1.0 drive against today's host
# ---------------------------------------------------------------------------------------------------------

def test_the_stub_claiming_1_0_knows_only_what_1_0_knows():
    from hil_bench.loop.host_session import HostSession
    from hil_bench.loop.links import LinkError, open_link

    opened = open_link("stub", ("--proto", "1.0"))
    try:
        s = HostSession(opened.link)
        ack = s.handshake(period_s=1e-4, estimator=int(Estimator.SMO_SIGN), flags=0)
        assert int(ack["proto_minor"]) == 0 and s.version_text == "1.0"
        assert not int(ack["estimators"]) >> int(Estimator.SMO_STA) & 1
        s.configure({Param.RS_OHM: 0.5})
        with pytest.raises(LinkError, match="LOOP_ANGLE = 0.0: UNKNOWN_PARAM"):
            s.configure({Param.LOOP_ANGLE: 0.0})
        s2 = HostSession(opened.link)
        with pytest.raises(LinkError, match="SMO_STA was asked for; the controller speaks protocol 1.0, and "
                                            "SMO_STA came with 1.1"):
            s2.handshake(period_s=1e-4, estimator=int(Estimator.SMO_STA), flags=0)
    finally:
        opened.close()


def test_a_1_0_drive_runs_g2_against_todays_host_as_a_1_1_drive_does(tmp_path):
    """gong_g2_500rpm needs nothing of 1.1: the stub claiming 1.0 runs it to the end, the run says it was
    served as 1.0, and the recorded rows are those of the stub speaking 1.1."""
    from hil_bench.loop.runner import run_scenario
    from hil_bench.record import channels as ch
    from hil_bench.record.recording import load_recording
    from hil_bench.scenario import load_scenario

    scn = load_scenario("gong_g2_500rpm")
    old = run_scenario(scn, "stub", tmp_path / "v10.mcap", progress=False, stub_args=("--proto", "1.0"))
    new = run_scenario(scn, "stub", tmp_path / "v11.mcap", progress=False)
    assert old.ok and new.ok and old.cycles_done == new.cycles_done == 15000, (old.error, new.error)
    assert "the controller speaks protocol 1.0 (the bench 1.1): served as 1.0" in old.protocol_note
    assert new.protocol_note == ""
    a, b = load_recording(tmp_path / "v10.mcap"), load_recording(tmp_path / "v11.mcap")
    for topic in (ch.PLANT_STATE, ch.PLANT_SENSE, ch.CONTROLLER_TELEMETRY):
        ta, tb = a.topic(topic), b.topic(topic)
        for key in ta:
            np.testing.assert_array_equal(np.asarray(ta[key]), np.asarray(tb[key]), err_msg=f"{topic}.{key}")


@pytest.mark.parametrize("scenario, words", [
    ("yuan_y1_improved", "LOOP_ANGLE = 1 (added in 1.1). Run it against a controller of protocol 1.1"),
    ("hou_h1_smo", "SMO_STA was asked for; the controller speaks protocol 1.0, and SMO_STA came with 1.1"),
])
def test_a_run_that_needs_a_1_1_feature_is_refused_before_any_cycle(tmp_path, capsys, scenario, words):
    from hil_bench.cli import main as cli_main
    from hil_bench.loop.runner import run_scenario
    from hil_bench.scenario import load_scenario

    result = run_scenario(load_scenario(scenario), "stub", tmp_path / "x.mcap", progress=False,
                          stub_args=("--proto", "1.0"))
    assert not result.ok and result.cycles_done == 0
    assert words in " ".join(result.error.split()), result.error
    assert "Traceback" not in capsys.readouterr().err
    del cli_main


def test_the_kit_checks_a_1_0_drive_against_1_0():
    from hil_bench.conformance import run_conformance

    result = run_conformance("stub", ("--proto", "1.0"), cycles=60)
    assert result.passed, result.text()
    assert "the controller speaks protocol 1.0: checked against that version's tables" in result.version_note
    flat = " ".join(result.text().split())
    assert "CONFIG of every parameter of the table (62, protocol 1.0)" in flat
    assert "HELLO_ACK.proto_minor: the session's version, at most the host's 1: protocol 1.0" in flat


def test_the_stub_refuses_a_version_it_cannot_speak():
    from hil_bench.loop.links.stub import stub_path

    run = subprocess.run([str(stub_path()), "--port", "/dev/null", "--proto", "1.7"], capture_output=True,
                         text=True, timeout=10)
    assert run.returncode == 2 and "this stub speaks protocol 1.0 to 1.1" in run.stderr


def test_struct_of_hello_with_a_1_0_peer():
    """A 1.0 controller's HELLO_ACK (status in the whole octet, 0..5) reads as proto_minor 0; a 1.0 host's
    HELLO (flags 0..7 in the whole octet) as proto_minor 0."""
    ack_10 = struct.pack("<BBHHH", 1, 0, 0x0100, 0x3E, 0x1234)
    v = MESSAGES["HELLO_ACK"].unpack(ack_10)
    assert (v["status"], v["proto_minor"], v["session"]) == (0, 0, 0x1234)
    hello_10 = struct.pack("<BBHBBH", 1, 0, 1000, 3, 0x07, 0x4321)
    v = MESSAGES["HELLO"].unpack(hello_10)
    assert (v["flags"], v["proto_minor"]) == (7, 0)
