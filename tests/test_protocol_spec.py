"""docs/protocol.md 1.0 and the code agree on what the spec says in words (issue 9, item 10)."""
from __future__ import annotations

import re
from pathlib import Path

import pytest

from hil_bench.protocol import dbc, params
from hil_bench.protocol.messages import HelloStatus, Param

DOC = (Path(__file__).resolve().parents[1] / "docs" / "protocol.md").read_text()


def test_parameter_table_names_exactly_the_dbc_parameters():
    assert [p.name for p in params.PARAMS] == [p.name for p in sorted(Param, key=int)]
    assert all(p.kind in params.KINDS for p in params.PARAMS)
    assert all(p.values for p in params.PARAMS if p.kind == "enum")


def test_mechanical_start_up_parameters_say_so():
    """controller.c: w_mech += IF_ACCEL_RAD_S2 * Ts and compares it with HANDOVER_SPEED_RAD_S."""
    c_source = (Path(__file__).resolve().parents[1] / "firmware_stub/src/controller.c").read_text()
    assert "float w_mech = c->omega_ol_rad_s / k->pole_pairs + k->if_accel_rad_s2 * k->ts_s;" in c_source
    assert "float w_target = k->handover_speed_rad_s;" in c_source
    for name in ("IF_ACCEL_RAD_S2", "HANDOVER_SPEED_RAD_S"):
        assert "mechanical" in params.BY_NAME[name].meaning
        assert re.search(rf"\| {name} \| [^|]+ \| real \| [^|]+ \| [^|]+ \| [^|]+ \| [^|]*mechanical", DOC), name


@pytest.mark.parametrize("name, value, ok", [
    ("POLE_PAIRS", 4.0, True), ("POLE_PAIRS", 4.5, False), ("HARM_COMP_ENABLE", 1.0, True),
    ("HARM_COMP_ENABLE", 0.5, False), ("HARM_COMP_ENABLE", 2.0, False), ("DELAY_COMP_ENABLE", 2.0, True),
    ("DELAY_COMP_ENABLE", 3.0, False), ("RS_OHM", 0.123, True), ("RS_OHM", float("nan"), False),
    ("RS_OHM", 1e39, False), ("SPEED_LOOP_DIV", 10, True),
])
def test_parameter_kinds(name, value, ok):
    assert (params.BY_NAME[name].check(value) is None) == ok


def test_spec_sections_exist_for_every_rule_the_conformance_kit_cites():
    for section in ("6.0", "6.1", "6.2", "6.3", "6.4", "6.5", "6.6", "6.7", "6.8", "6.9", "2.4"):
        assert re.search(rf"^###? {re.escape(section)} ", DOC, re.M), section


def test_hello_status_mode_unsupported_is_specified():
    assert HelloStatus.MODE_UNSUPPORTED == 5
    assert "MODE_UNSUPPORTED" in DOC.split("### 6.1")[1].split("### 6.2")[0]


def test_the_spec_says_when_duties_act_as_the_plant_does():
    plant_h = (Path(__file__).resolve().parents[1] / "plant_rt/c/plant.h").read_text()
    assert "The duties commanded for period k\n * take effect at t_k + t_delay_s" in plant_h
    section = " ".join(DOC.split("### 6.4")[1].split("### 6.5")[0].split())
    assert "The plant applies the duties of DUTY(k) from t_k + t_d to the end of period k" in section
    assert "period k + 1" not in section
    assert "inside period seq" in dbc.message_spec("DUTY").comment


# -- 6.5 / 6.9: the counters a recovered retry produces are the ones the spec lists --------------------

RETRY_SCENARIO = """
[scenario]
name = "retry_counters"
profile = "gong2020"
duration_s = 0.05
[controller]
estimator = "SMO_SIGN"
speed_ref_rpm = 300
[metrics]
window_s = [0.0, 0.05]
{link}
"""


def _corrupting_proxy(corrupt_duty: int, lose: bool = False):
    """The stub behind a proxy that sends the n-th DUTY frame from the controller on with its CRC
    flipped (valid COBS, bad CRC: what line noise on a UART does), or (``lose``) drops it."""
    from hil_bench.protocol.framing import cobs_decode, cobs_encode
    from hil_bench.protocol.messages import MESSAGES
    from tests.pty_proxy import PtyProxy, decode

    seen = {"duties": 0, "corrupted": 0}

    def to_host(chunk: bytes) -> list[bytes]:
        frame = decode(chunk)
        if frame is not None and frame[0] == MESSAGES["DUTY"].frame_id:
            seen["duties"] += 1
            if seen["duties"] == corrupt_duty:
                seen["corrupted"] += 1
                if lose:
                    return []
                raw = bytearray(cobs_decode(chunk))
                raw[-1] ^= 0x01
                return [cobs_encode(bytes(raw))]
        return [chunk]

    return PtyProxy(to_host=to_host), seen


@pytest.mark.parametrize("emf", [True, False])
def test_one_recovered_bad_crc_duty_gives_the_counters_the_spec_lists(tmp_path, emf):
    """docs/protocol.md 6.9: a DUTY lost to a bad CRC and recovered by one re-send counts crc_errors 1
    and bytes_discarded 14 (its COBS chunk: 2 + 1 + 8 + 2 octets, +1): corrupt, not also lost; the
    re-send is timing (retries 1), and the cache's telemetry again answers it (no duplicates). A
    scenario allowance written from that passes; one short of it does not."""
    from hil_bench.loop.runner import run_scenario
    from hil_bench.papers.check import check_recording
    from hil_bench.scenario import parse_scenario

    section = " ".join(DOC.split("### 6.9")[1].split("## 7.")[0].split())
    assert ("| DUTY(k) damaged on the wire (e.g. one bad CRC), recovered by one re-send of the SENSE "
            "group | `crc_errors` (or `cobs_errors` / `length_errors`, 2.4) = 1, `bytes_discarded` = the "
            "chunk's octets (14 for a DUTY: COBS of 2 + 1 + 8 + 2 octets, +1); not also lost | "
            "`retries` = 1 |") in section
    assert "n bad-CRC DUTY frames allows `{crc_errors = n, bytes_discarded = 14 n}`" in section
    allow = "[link]\nallow = {crc_errors = 1, bytes_discarded = 14}"
    text = RETRY_SCENARIO.format(link=allow)
    if not emf:
        text = text.replace('speed_ref_rpm = 300', 'speed_ref_rpm = 300\ntelemetry_emf = false')
    proxy, seen = _corrupting_proxy(corrupt_duty=100)
    try:
        result = run_scenario(parse_scenario(text, tmp_path / "retry.toml"), link_spec=f"serial:{proxy.path}",
                              out_path=tmp_path / "retry.mcap", progress=False, allow_slow_link=True)
    finally:
        proxy.close()
    assert seen["corrupted"] == 1 and result.ok, result.error
    report = check_recording(tmp_path / "retry.mcap")
    counters = {k: v for k, v in report.integrity.counters.items() if v}
    assert counters == {"crc_errors": 1, "bytes_discarded": 14}, counters
    # the damaged cycle was re-sent and settled as corrupt, never also late: every late answer is
    # another re-sent cycle's (a busy host's stall re-sends a cycle whose answer then comes late)
    from hil_bench.record import channels as ch
    from hil_bench.record.recording import load_recording

    resent_cycles = sum(1 for r in load_recording(tmp_path / "retry.mcap").topic(ch.TIMING)["retries"]
                        if r > 0)
    assert report.integrity.timing["retries"] >= 1 and resent_cycles >= 1
    assert report.integrity.timing["late_answers"] <= resent_cycles - 1, resent_cycles
    assert report.integrity.ok and all(p.is_allowed for p in report.integrity.problems)
    short = text.replace("bytes_discarded = 14", "bytes_discarded = 13")
    from hil_bench.record.integrity import check_integrity

    assert not check_integrity(report.recording, parse_scenario(short, tmp_path / "s.toml").link.allow,
                               "SMO_SIGN").ok


@pytest.mark.parametrize("emf", [True, False])
def test_one_lost_duty_gives_the_counters_the_spec_lists(tmp_path, emf):
    """6.9's row for a DUTY lost outright (its TELEM and TELEM_EMF arrived): one re-send recovers it;
    the cache's telemetry again answers the re-send (not duplicates): lost_frames 1 (a link problem,
    named lost), retries 1 (timing). A scenario allowance written from the row passes; none does
    not."""
    from hil_bench.loop.runner import run_scenario
    from hil_bench.papers.check import check_recording
    from hil_bench.record.integrity import check_integrity
    from hil_bench.scenario import parse_scenario

    section = " ".join(DOC.split("### 6.9")[1].split("## 7.")[0].split())
    assert ("| DUTY(k) lost outright (it never arrives; TELEM(k) and TELEM_EMF(k) did), recovered by one "
            "re-send | `lost_frames` = 1 | `retries` = 1 (the cache's TELEM / TELEM_EMF again are answers "
            "to the re-send, not duplicates) |") in section
    assert "n lost DUTY frames" in section and "allow `{lost_frames = n}`" in section
    allow = "[link]\nallow = {lost_frames = 1}"
    emf_off = "" if emf else "\ntelemetry_emf = false"
    text = RETRY_SCENARIO.format(link=allow).replace("speed_ref_rpm = 300", "speed_ref_rpm = 300" + emf_off)
    proxy, seen = _corrupting_proxy(corrupt_duty=100, lose=True)
    try:
        result = run_scenario(parse_scenario(text, tmp_path / "lost.toml"), link_spec=f"serial:{proxy.path}",
                              out_path=tmp_path / "lost.mcap", progress=False, allow_slow_link=True)
    finally:
        proxy.close()
    assert seen["corrupted"] == 1 and result.ok, result.error
    report = check_recording(tmp_path / "lost.mcap")
    counters = {k: v for k, v in report.integrity.counters.items() if v}
    assert counters == {"lost_frames": 1}, counters
    (problem,) = report.integrity.problems
    assert problem.is_allowed and problem.text == "lost_frames = 1 (lost) (scenario allows 1)"
    assert not check_integrity(report.recording, {}, "SMO_SIGN").ok


def test_the_encoder_flag_is_per_cycle_in_the_dbc_and_the_spec():
    """A plant encoder fault clears THETA_ENC_VALID in the cycles it affects (engine_cycle.c sends the flag
    only with a valid sample): nothing may say it is set 'exactly when' the HELLO flag was."""
    engine_c = (Path(__file__).resolve().parents[1] / "plant_rt/c/engine_cycle.c").read_text()
    assert "if (cfg->send_encoder && c->smp.enc_valid) {" in engine_c
    comment = dbc.message_spec("SENSE_AUX").signal("flags").comment
    assert "the per-cycle flag decides" in comment and "exactly when" not in comment
    assert "exactly when HELLO flag" not in DOC
    assert "The **per-cycle flag decides**" in DOC


def test_the_spec_says_claims_are_invalid_when_the_true_angle_was_sent():
    from hil_bench.record.integrity import ENCODER_SENT_TEXT

    section = " ".join(DOC.split("### 6.8")[1].split("### 6.9")[0].split())
    assert ENCODER_SENT_TEXT in section


def test_the_stated_defaults_kinds_and_enum_values_are_the_stubs():
    """Issue 19, point 8: docs/protocol.md 6.2 states every parameter's default (protocol/params.py, the
    one definition; the table is generated from it). The stub's controller starts every session with
    exactly those (read back with ctrl_param_get), has no value for the required ones (0: not set,
    and CONFIG cannot set 0), takes only whole values for the integer, boolean and enum kinds and
    exactly the listed enum values."""
    import numpy as np

    from hil_bench.firmware_stub._binding import ffi, lib

    assert "| 1 | RS_OHM | ohm | real | 1e-06 .. 100 | **required** | 1.0 |" in DOC and \
        "| 24 | IQ_MAX_A | A | real | 0 .. 1000 | 5 | 1.0 |" in DOC
    c = ffi.new("controller_t *")
    lib.ctrl_init(c)
    cfg = ffi.addressof(c[0], "cfg")
    got = ffi.new("float *")
    for p in params.PARAMS:
        pid = int(Param[p.name])
        assert lib.ctrl_param_get(cfg, pid, got) == 0, p.name
        if p.required:
            assert got[0] == 0.0 and lib.ctrl_param_set(cfg, pid, 0.0) == 2, p.name
            continue
        assert got[0] == np.float32(p.default), (p.name, got[0], p.default)
        if p.kind != "real":
            assert lib.ctrl_param_set(cfg, pid, float(p.default) + 0.5) == 2, p.name
        allowed = {0, 1} if p.kind == "boolean" else {v for v, _ in p.values} if p.kind == "enum" else None
        if allowed is not None:
            for v in range(-1, max(allowed) + 2):
                assert (lib.ctrl_param_set(cfg, pid, float(v)) == 0) == (v in allowed), (p.name, v)
            lib.ctrl_param_set(cfg, pid, float(p.default))


@pytest.mark.parametrize("estimator, given, starts", [
    ("SMO_SIGN", (), False), ("SMO_SIGN", params.MOTOR, True), ("SMO_SIGN", params.MOTOR[1:], False),
    ("SMO_TANH", params.MOTOR, False), ("SMO_TANH", (*params.MOTOR, "SMO_K_V"), True),
])
def test_an_incomplete_configuration_is_what_the_spec_says(estimator, given, starts):
    """docs/protocol.md 6.3: RUN with a required parameter unset (the motor's; SMO_K_V for the sigmoid
    and tanh SMOs) is CONFIG_INVALID; with them set, the defaults run."""
    from hil_bench.firmware_stub._binding import ffi, lib
    from hil_bench.protocol.messages import Estimator

    assert all(params.BY_NAME[n].required for n in params.MOTOR)
    assert "**required**" in params.BY_NAME["SMO_K_V"].meaning
    value = {"RS_OHM": 0.6383, "LD_H": 2e-3, "LQ_H": 2e-3, "PSI_F_WB": 0.085, "POLE_PAIRS": 4.0, "J_KGM2": 1e-4,
             "V_DC_NOM_V": 310.0, "SMO_K_V": 500.0}
    c = ffi.new("controller_t *")
    lib.ctrl_init(c)
    c.cfg.estimator = float(Estimator[estimator])
    for name in given:
        assert lib.ctrl_param_set(ffi.addressof(c[0], "cfg"), int(Param[name]), value[name]) == 0
    assert (lib.ctrl_start(c) == 0) == starts
    assert c.state == (4 if not starts else c.state)     # FAULT (HIL_STATE_FAULT) when refused


@pytest.mark.parametrize("name, count", [("gong_g2_500rpm", 20), ("yuan_y2_improved", 32)])
def test_the_host_sends_exactly_the_parameters_the_spec_lists(tmp_path, name, count):
    """Issue 19, point 8: 6.2 said "the host sends every parameter it knows" while it sent 20 of 62.
    It now says which: the motor's 8, CTRL_DELAY_S, the reference observer's settings (sigmoid and
    tanh SMOs), the trip below an ADC's full scale, [controller.inverter_comp]'s INV_COMP_* estimate,
    the scenario's [controller.params]; nothing else.
    The CONFIG frames a run records are exactly that set."""
    from hil_bench.firmware_stub.est_smo import smo_sigmoid_for, smo_tanh_for
    from hil_bench.loop.runner import SMO_CONFIG_PARAMS, inverter_comp_settings, run_scenario
    from hil_bench.plant_rt.profile import load_profile
    from hil_bench.protocol.messages import MESSAGES, Estimator
    from hil_bench.record import channels as ch
    from hil_bench.record.recording import load_recording
    from hil_bench.scenario import derive_scenario

    section = " ".join(DOC.split("### 6.2")[1].split("### 6.3")[0].split())
    assert "sends every parameter it knows" not in DOC
    assert f"{name} ({'SMO_TANH' if name.startswith('gong') else 'SMO_SIGMOID'}) sends {count}" in section \
        or f"{name} (SMO_SIGMOID) {count}" in section, section[:2000]
    scn = derive_scenario(name, f"{name}@params", (("scenario.duration_s", 0.002), ("events", []),
                                                     ("metrics.window_s", [0.0, 0.002])))
    res = run_scenario(scn, out_path=tmp_path / "p.mcap", progress=False)
    assert res.ok, res.error
    setup = load_recording(tmp_path / "p.mcap").topic(ch.LINK_FRAMES)["tx"][0].split()
    sent = {Param(MESSAGES["CONFIG"].unpack(bytes.fromhex(f.split("#")[1]))["param_id"]).name
            for f in setup if f.startswith("030#")}
    profile = load_profile(scn.profile)
    factory = smo_tanh_for if scn.estimator is Estimator.SMO_TANH else smo_sigmoid_for
    observer = {p.name for f, p in SMO_CONFIG_PARAMS.items() if f in factory(profile, 1e-4).config}
    inv_comp = {p.name for p in inverter_comp_settings(scn.inverter_comp, {})[0]}   # its keys only
    expected = ({*params.MOTOR, "B_NMS", "CTRL_DELAY_S"} | observer | inv_comp
                | {p.name for p in scn.controller_params})
    assert sent == expected and len(sent) == count, (sorted(sent ^ expected), len(sent))
