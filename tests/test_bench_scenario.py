"""Scenario files: the bundled ones load; every kind of bad input names the file and field."""
from pathlib import Path

import pytest

from hil_bench.protocol.messages import Estimator, Param
from hil_bench.scenario import SCENARIO_DIR, ScenarioError, load_scenario, speed_ref_at

GOOD = """
[scenario]
name = "t"
profile = "gong2020"
duration_s = 0.5
claims = ["G2"]
[controller]
estimator = "SMO_SIGN"
speed_ref_rpm = 500
[controller.params]
SMO_K_V = 40
[[events]]
t_s = 0.2
speed_ref_rpm = 600
[metrics]
window_s = [0.3, 0.5]
"""


def write(tmp_path: Path, text: str) -> Path:
    p = tmp_path / "s.toml"
    p.write_text(text)
    return p


@pytest.mark.parametrize("path", sorted(SCENARIO_DIR.glob("*.toml")), ids=lambda p: p.stem)
def test_bundled_scenarios_load(path):
    scn = load_scenario(path)
    assert scn.duration_s > 0
    assert scn.metrics_window_s[1] <= scn.duration_s


def test_good_scenario_fields(tmp_path):
    scn = load_scenario(write(tmp_path, GOOD))
    assert scn.estimator is Estimator.SMO_SIGN
    assert scn.controller_params == {Param.SMO_K_V: 40.0}
    assert speed_ref_at(scn, 0.1) == pytest.approx(500 * 2 * 3.141592653589793 / 60)
    assert speed_ref_at(scn, 0.3) == pytest.approx(600 * 2 * 3.141592653589793 / 60)


def test_bundled_name_resolves():
    assert load_scenario("gong_g2_500rpm").name == "gong_g2_500rpm"


@pytest.mark.parametrize("edit, field", [
    (lambda t: t.replace('profile = "gong2020"\n', ""), "scenario.profile: missing"),
    (lambda t: t.replace("duration_s = 0.5", "duration_s = -1"), "scenario.duration_s: must be > 0"),
    (lambda t: t.replace("duration_s = 0.5", 'duration_s = "long"'), "scenario.duration_s: must be a number"),
    (lambda t: t.replace('estimator = "SMO_SIGN"', 'estimator = "MAGIC"'), "controller.estimator: unknown estimator"),
    (lambda t: t.replace("SMO_K_V = 40", "SMO_K = 40"), "controller.params.SMO_K: unknown controller parameter"),
    (lambda t: t.replace("t_s = 0.2", "t_s = 9.0"), "events[0].t_s: 9 s is after the end"),
    (lambda t: t.replace("speed_ref_rpm = 600", "speed_rpm = 600"), "events[0].speed_rpm: unknown key"),
    (lambda t: t.replace("window_s = [0.3, 0.5]", "window_s = [0.4, 0.3]"), "metrics.window_s: must satisfy"),
    (lambda t: t + "\n[plantt]\nx = 1\n", "plantt: unknown key"),
    (lambda t: t.replace("[metrics]", "[metrics"), "not valid TOML"),
    (lambda t: t + "\n[reference]\nestimators = [\"SMO_SIGN\"]\n[reference.SMO_TANH]\nm = 1\n",
     "reference.SMO_TANH: configuration for an estimator not listed"),
    (lambda t: t + "\n[reference]\nestimators = [\"SMO_SIGN\"]\n[reference.SMO_SIGN]\nk_v = \"x\"\n",
     "reference.SMO_SIGN.k_v: must be a number"),
])
def test_bad_scenarios_name_field(tmp_path, edit, field):
    with pytest.raises(ScenarioError) as exc:
        load_scenario(write(tmp_path, edit(GOOD)))
    assert "s.toml" in str(exc.value)
    assert field in str(exc.value)


def test_missing_file_names_path():
    with pytest.raises(ScenarioError, match="no such scenario file"):
        load_scenario("/nonexistent/dir/x.toml")


# ---------------------------------------------------------------------------------------------------------
# Issue 9, item 13: every value checked against its physical and wire range at load, with file, line,
# field and the allowed range, before any process or device is touched.
# ---------------------------------------------------------------------------------------------------------

G2 = (SCENARIO_DIR / "gong_g2_500rpm.toml").read_text()


def _line(text: str, needle: str) -> int:
    return next(n for n, line in enumerate(text.splitlines(), 1) if needle in line)


@pytest.mark.parametrize("edit, needle, expect", [
    (lambda t: t.replace("duration_s = 1.5", "duration_s = 1e9"), "duration_s =",
     "scenario.duration_s: 1e+09 s is outside [0, 3600] s"),
    (lambda t: t.replace("duration_s = 1.5", "duration_s = 1e-9").replace("[1.0, 1.5]", "[0.0, 1e-9]"),
     "duration_s =", "scenario.duration_s: 1e-09 s is shorter than one control period (Ts = 100 us"),
    (lambda t: t.replace("speed_ref_rpm = 500", "speed_ref_rpm = 1e40"), "speed_ref_rpm =",
     "controller.speed_ref_rpm: 1e+40 rpm (1.047e+39 rad/s) does not fit the binary32 CMD.value"),
    (lambda t: t.replace("speed_ref_rpm = 500", "speed_ref_rpm = 9000"), "speed_ref_rpm =",
     "controller.speed_ref_rpm: 9000 rpm is outside the range the protocol carries (|speed| <= 7823 rpm: "
     "TELEM.omega_hat"),
    (lambda t: t + "\n[[events]]\nt_s = 0.5\nload_torque_nm = 0.1\n[[events]]\nt_s = 0.2\n"
                   "speed_ref_rpm = 1e40\n", "speed_ref_rpm = 1e40", "events[1].speed_ref_rpm: 1e+40 rpm"),
    (lambda t: t + "\n[[events]]\nt_s = 0.6\nspeed_ref_rpm = -8000\n", "speed_ref_rpm = -8000",
     "events[0].speed_ref_rpm: -8000 rpm is outside the range the protocol carries"),
    (lambda t: t + "\n[[events]]\nt_s = 0.6\niq_ref_a = 40\n", "iq_ref_a = 40",
     "events[0].iq_ref_a: 40 A is outside [-32.768, 32.767] A (the range SENSE.i_a..i_c can report"),
    (lambda t: t.replace('claims = ["G2"]', 'claims = ["G99"]'), "claims =",
     "scenario.claims: unknown claim 'G99' (known: Y1, Y2"),
    (lambda t: t.replace("IQ_MAX_A = 6.0", "IQ_MAX_A = 6.0\nPOLE_PAIRS = 4.5"), "POLE_PAIRS",
     "controller.params.POLE_PAIRS: is an integer parameter: must be a whole number, got 4.5"),
    (lambda t: t.replace("SMO_M_PER_A = 0.01", "SMO_M_PER_A = 1e39"), "SMO_M_PER_A =",
     "controller.params.SMO_M_PER_A: 1e+39 does not fit a binary32 CONFIG value"),
    (lambda t: t.replace('name = "gong_g2_500rpm"', 'name = "../../escaped"'), "name =",
     "scenario.name: '../../escaped' must be 1-100 letters"),
    (lambda t: t.replace("initial_theta_e_rad = 0.4", "initial_theta_e_rad = 0.4\nts_s = 1.23456e-4"),
     "ts_s =", "plant.ts_s: Ts = 123.456 us: HELLO.period_us carries 0.1 .. 6553.5 us in steps of 0.1 us"),
    (lambda t: t.replace("initial_theta_e_rad = 0.4", "initial_theta_e_rad = 0.4\ndead_time_s = -1"),
     "dead_time_s =", "plant.dead_time_s"),
    (lambda t: t.replace('profile = "gong2020"', 'profile = "nosuchmotor"'), "profile =",
     "scenario.profile: "),
    (lambda t: t + "\n[link]\nallow = {crc_errors = 5, crc = 3}\n", "allow =",
     "link.allow.crc: not a link counter; known: crc_errors"),
    (lambda t: t + "\n[link]\nmax_retries = 3\n", "max_retries",
     "link.max_retries: is gone: the host re-sends an unanswered lockstep cycle with back-off"),
    (lambda t: t + "\n[link]\nallow = {retries = 1}\n", "allow =",
     "link.allow.retries: is not a link problem (late is not lost"),
    (lambda t: t + "\n[link]\npatience_s = 0.01\n", "patience_s", "link.patience_s: 0.01 s is outside"),
    (lambda t: t + "\n[link]\nretry_timeout_s = 2\npatience_s = 1\n", "patience_s",
     "link.patience_s: 1 s is not longer than retry_timeout_s = 2 s"),
    (lambda t: t + "\n[link]\nretry_timeout_s = 0\n", "retry_timeout_s", "link.retry_timeout_s: 0 s is outside"),
        (lambda t: t + "\n[realtime]\nstub_isr = \"interrupt\"\n", "stub_isr",
         "realtime.stub_isr: must be 'sense' or 'timer'"),
    (lambda t: t.replace('claims = ["G2"]', 'claims = ["G2"]\nmode = "realtime"') + "\n[realtime]\n"
                                                                                     "duty_update = \"now\"\n",
     "duty_update", "realtime.duty_update: must be one of on_arrival, next_period"),
    (lambda t: t.replace('estimator = "SMO_TANH"', 'estimator = "ENCODER"\nsend_encoder_angle = false'),
     "send_encoder_angle", "controller.send_encoder_angle: the ENCODER estimator needs the encoder angle"),
    # plant values against their wire and physical ranges (issue 9 audit, finding 6)
    (lambda t: t.replace("initial_theta_e_rad = 0.4", "initial_theta_e_rad = 0.4\nv_dc_v = 1e6"), "v_dc_v =",
     "plant.v_dc_v: 1e+06 V is outside (0, 655.35] V: the bus voltage SENSE_AUX.v_dc carries (protocol/hil.dbc)"),
    (lambda t: t.replace("initial_theta_e_rad = 0.4", "initial_theta_e_rad = 0.4\nadc_model = true\n"
                                                      "adc_vdc_offset_v = 400.0"), "adc_vdc_offset_v =",
     "plant.adc_vdc_offset_v: the sensed 710 V (v_dc_v 310 V"),
    (lambda t: t.replace("initial_theta_e_rad = 0.4", "initial_theta_e_rad = 0.4\nload_torque_nm = 1e30"),
     "load_torque_nm =", "plant.load_torque_nm: 1e+30 N m is outside the load a run can have (|load| <= 23.81 N m"),
    (lambda t: t + "\n[[events]]\nt_s = 0.6\nload_torque_nm = -1e30\n", "load_torque_nm",
     "events[0].load_torque_nm: -1e+30 N m is outside the load a run can have"),
    (lambda t: t.replace("initial_theta_e_rad = 0.4", "initial_theta_e_rad = 0.4\nload_profile = \"table\"\n"
                                                      "load_table_t_s = [0.0, 1.0]\nload_table_nm = [0.0, 1e9]"),
     "load_table_nm =", "plant.load_table_nm: 1e+09 N m is outside the load a run can have"),
    (lambda t: t.replace("initial_theta_e_rad = 0.4", "initial_theta_e_rad = 0.4\ndyno = true\n"
                                                      "dyno_speed_rad_s = 5000"), "dyno_speed_rad_s =",
     "plant.dyno_speed_rad_s: 47746.5 rpm is outside the range the protocol carries"),
    (lambda t: t.replace("initial_theta_e_rad = 0.4", "initial_theta_e_rad = 1e300"), "initial_theta_e_rad =",
     "plant.initial_theta_e_rad: 1e+300 rad is outside [-6.28319, 6.28319] rad"),
    (lambda t: t.replace('profile = "gong2020"', 'profile = "../../etc/passwd"'), "profile =",
     "scenario.profile: '../../etc/passwd': give the name of a bundled motor profile (gong2020, hou2021, "
     "yuan2020) or the path of a .toml profile file"),
    (lambda t: t.replace('profile = "gong2020"', 'profile = "nosuchmotor"'), "profile =",
     "scenario.profile: no bundled motor profile 'nosuchmotor' (bundled: gong2020, hou2021, yuan2020"),
    (lambda t: t.replace('profile = "gong2020"', 'profile = "/nonexistent/motor.toml"'), "profile =",
     "scenario.profile: /nonexistent/motor.toml: no such profile file"),
])
def test_bad_values_name_file_line_field_and_range(tmp_path, edit, needle, expect):
    text = edit(G2)
    with pytest.raises(ScenarioError) as exc:
        load_scenario(write(tmp_path, text))
    msg = str(exc.value)
    assert expect in msg
    assert msg.startswith(f"{tmp_path / 's.toml'}:{_line(text, needle)}: ") or \
        msg.startswith(f"s.toml:{_line(text, needle)}: "), msg


def test_binary_garbage_names_the_file(tmp_path):
    p = tmp_path / "garbage.toml"
    p.write_bytes(bytes(range(256)) * 4)
    with pytest.raises(ScenarioError, match=r"garbage.toml:2: not a scenario file: octet 0x80 at offset 128 "
                                            r"is not UTF-8 text"):
        load_scenario(p)


def test_new_keys_and_their_defaults(tmp_path):
    scn = load_scenario(write(tmp_path, G2))
    assert (scn.mode, scn.send_encoder_angle, scn.encoder_angle_sent) == ("lockstep", False, False)
    assert (scn.link.retry_timeout_s, scn.link.patience_s, scn.link.allow) == (0.05, 10.0, {})
    assert (scn.realtime.duty_update, scn.realtime.max_consecutive_misses, scn.realtime.cpu) == (
        "on_arrival", 10, None)
    assert scn.hello_flags(dual_sampling=False) == 0x02          # TELEM_EMF only: no encoder angle
    text = G2.replace('claims = ["G2"]', 'claims = ["G2"]\nmode = "realtime"').replace(
        'speed_ref_rpm = 500', 'speed_ref_rpm = 500\nsend_encoder_angle = true')
    text += ("\n[realtime]\nduty_update = \"next_period\"\nmax_consecutive_misses = 4\ncpu = 1\n"
             "[link]\nretry_timeout_s = 0.02\npatience_s = 5\nallow = {crc_errors = 5, lost_frames = 10}\n")
    scn = load_scenario(write(tmp_path, text))
    assert scn.mode == "realtime" and scn.encoder_angle_sent
    assert scn.realtime == scn.realtime.__class__("next_period", 4, 1)
    assert (scn.link.retry_timeout_s, scn.link.patience_s, scn.link.allow) == (0.02, 5.0, {"crc_errors": 5,
                                                                                            "lost_frames": 10})
    assert scn.hello_flags(dual_sampling=True) == 0x07
    enc = load_scenario(write(tmp_path, G2.replace('estimator = "SMO_TANH"', 'estimator = "ENCODER"')))
    assert enc.encoder_angle_sent and enc.hello_flags(False) & 0x04


def test_bench_run_refuses_a_bad_scenario_before_touching_a_process(tmp_path, monkeypatch, capsys):
    from hil_bench import cli
    from hil_bench.loop.links import stub

    def touched(*a, **k):
        raise AssertionError("a process was started for a bad scenario")

    monkeypatch.setattr(stub.StubProcess, "__init__", touched)
    for bad in ("duration_s = 1e9", "duration_s = 1e-9"):
        p = write(tmp_path, G2.replace("duration_s = 1.5", bad).replace("[1.0, 1.5]", "[0.0, 1e-9]"))
        assert cli.main(["run", str(p), "--no-progress", "--out", str(tmp_path / "x.mcap")]) == 2
        assert "scenario.duration_s" in capsys.readouterr().err
    assert not (tmp_path / "x.mcap").exists()


def test_plant_values_are_refused_before_any_process_starts(tmp_path, monkeypatch):
    """`bench run` with a bad plant value: the error, no stub started, no file written."""
    from hil_bench.cli import main as cli_main
    from hil_bench.loop import runner

    started = []
    monkeypatch.setattr(runner, "open_link", lambda *a, **k: started.append(a) or (_ for _ in ()).throw(
        AssertionError("a link was opened")))
    scn = write(tmp_path, G2.replace("initial_theta_e_rad = 0.4", "initial_theta_e_rad = 0.4\nv_dc_v = 1e6"))
    out = tmp_path / "never.mcap"
    assert cli_main(["run", str(scn), "--out", str(out), "--no-progress"]) == 2
    assert not started and not list(tmp_path.glob("*.mcap*")) and not list(tmp_path.glob(".*partial"))


def test_a_bundled_load_within_the_limit_loads(tmp_path):
    """The limit is far above every bundled load (2 N m at G8, 6.5 N m at Hou's full load)."""
    from hil_bench.plant_rt.profile import load_profile
    from hil_bench.scenario import load_torque_limit_nm

    assert load_torque_limit_nm(load_profile("gong2020"), 1.5, 819.175) == pytest.approx(23.81, abs=0.01)
    load_scenario(write(tmp_path, G2.replace("initial_theta_e_rad = 0.4",
                                             "initial_theta_e_rad = 0.4\nload_torque_nm = 20.0")))
