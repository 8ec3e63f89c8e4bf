"""hil_bench.Session (bench/session.py): a lockstep run driven step by step from Python.

Every assertion is on what the run recorded or what the session returned, never on how long
anything took: where the run holds is decided by cycle numbers, so these results are the same
on a loaded machine (slower, never different). The wall-clock bound is tested with a mailbox
that never answers, not with a short wait.
"""
from __future__ import annotations

import numpy as np
import pytest

import hil_bench
from hil_bench.protocol.messages import MESSAGES
from hil_bench.record.recording import load_recording
from hil_bench.scenario import RPM_PER_RAD_S
from hil_bench.session import (
    ConditionNotMet,
    InputRefused,
    Session,
    SessionError,
    SessionTimeout,
)

#: G2 shortened to what the scripts need (its metrics window moved inside)
SHORT = {"scenario.duration_s": 0.8, "metrics.window_s": [0.5, 0.8]}
TS_S = 1e-4
CMD_ID = f"{MESSAGES['CMD'].frame_id:03X}#"
ROWS = ("/plant/state", "/plant/sense", "/controller/telemetry", "/events")


def script(s: Session) -> dict:
    """The scripted test of these tests: start-up, a speed step, a load step, two windows."""
    out = {}
    s.step(100)
    out["after_step"] = (s.cycle, s.latest.name, s.controller_state)
    out["met_s"] = s.run_until("speed_rpm > 450 and state == 'CLOSED_LOOP'", timeout_s=0.7)
    out["held_after_met"] = s.cycle
    s.set_speed_ref_rpm(700)
    out["speed_k"] = s.cycle
    out["speed_window"] = s.capture(0.05)
    s.set_load_torque_nm(0.1)
    out["load_k"] = s.cycle
    out["load_window"] = s.capture(0.05)
    return out


def run_script(link: str, path) -> tuple[Session, dict]:
    with Session("gong_g2_500rpm", link=link, overrides=SHORT, out=path) as s:
        out = script(s)
    return s, out


@pytest.fixture(scope="module")
def scripted(tmp_path_factory):
    """One scripted run on the stub (a pty, the bundled firmware stub)."""
    s, out = run_script("stub", tmp_path_factory.mktemp("session") / "stub.mcap")
    return s, out


def _topic(path, topic):
    return load_recording(path, topics=[topic]).topic(topic)


# -- stepping, holding, windows ------------------------------------------------------------------

def test_the_run_holds_where_the_script_says(scripted):
    s, out = scripted
    assert out["after_step"][0] == 100
    assert out["after_step"][1] == pytest.approx(99 * TS_S)     # the last row: cycle 99
    assert out["after_step"][2] == "ALIGN"
    # run_until looks every 1 ms (10 cycles): it met at a row, and holds at the end of that look
    met_k = round(out["met_s"] / TS_S)
    assert out["held_after_met"] == (met_k // 10 + 1) * 10
    assert out["speed_k"] == out["held_after_met"]
    assert out["load_k"] == out["speed_k"] + 500
    assert s.result is not None and s.closed
    assert s.result.run.cycles_done == s.result.run.cycles_planned == 8000
    assert s.result.run.error is None


def test_run_until_met_where_the_recording_says(scripted):
    s, out = scripted
    st = _topic(s.recording, "/plant/state")
    tel = _topic(s.recording, "/controller/telemetry")
    ok = (np.asarray(st["speed_rpm"]) > 450) & (np.asarray(tel["state"]) == 3)   # CLOSED_LOOP
    assert out["met_s"] == pytest.approx(float(np.asarray(st["t_s"])[np.argmax(ok)]), abs=1e-12)


def test_a_window_is_the_recordings_rows_of_its_cycles(scripted):
    s, out = scripted
    w = out["load_window"]
    k0 = out["load_k"]
    assert len(w) == 500 and w.index.name == "t_s"
    assert w.index[0] == pytest.approx(k0 * TS_S)
    assert w.index[-1] == pytest.approx((k0 + 499) * TS_S)
    st = _topic(s.recording, "/plant/state")
    t = np.asarray(st["t_s"])
    sel = (t >= w.index[0] - 1e-9) & (t <= w.index[-1] + 1e-9)
    for col in ("speed_rpm", "i_q_a", "theta_e_rad", "torque_load_nm", "v_dc_v"):
        assert np.array_equal(np.asarray(st[col])[sel], w[col].to_numpy()), col
    tel = _topic(s.recording, "/controller/telemetry")
    assert np.array_equal(np.asarray(tel["pee_rad"])[sel], w["pee_rad"].to_numpy())
    assert np.array_equal(np.asarray(tel["e_alpha_v"])[sel], w["e_alpha_hat_v"].to_numpy())
    assert set(w["state"].astype(str)) == {"CLOSED_LOOP"}
    assert (w["torque_load_nm"] == 0.1).all()


# -- inputs: applied at the cycle held before, recorded there ------------------------------------

def test_inputs_are_events_at_their_cycles(scripted):
    s, out = scripted
    ev = _topic(s.recording, "/events")
    rows = [(float(t), str(k), str(x), float(v)) for t, k, x, v in
            zip(ev["t_s"], ev["kind"], ev["text"], ev["value"]) if k == "script"]
    ks, kl = out["speed_k"], out["load_k"]
    assert rows == [
        (pytest.approx(ks * TS_S), "script", f"script: speed reference 700 rpm (cycle {ks})",
         pytest.approx(700 / RPM_PER_RAD_S)),
        (pytest.approx(kl * TS_S), "script", f"script: load torque 0.1 N m (cycle {kl})",
         pytest.approx(0.1))]
    notes = [str(x) for k, x in zip(ev["kind"], ev["text"]) if k == "script_note"]
    assert any(n.startswith("script: run_until speed_rpm > 450 and state == 'CLOSED_LOOP': met")
               for n in notes), notes
    assert any(n.startswith(f"script: capture 500 cycles from cycle {kl}") for n in notes), notes


def test_the_speed_reference_goes_out_with_its_cycles_sense(scripted):
    s, out = scripted
    fr = _topic(s.recording, "/link/frames")
    t = np.asarray(fr["t_s"])
    tx = list(map(str, fr["tx"]))
    k = out["speed_k"]
    i = int(np.flatnonzero(np.isclose(t, k * TS_S))[0])
    assert CMD_ID in tx[i] and CMD_ID not in tx[i - 1], (tx[i - 1], tx[i])


def test_the_load_acts_from_its_cycle(scripted):
    s, out = scripted
    st = _topic(s.recording, "/plant/state")
    k = np.rint(np.asarray(st["t_s"]) / TS_S).astype(int)
    load = np.asarray(st["torque_load_nm"])
    assert (load[k < out["load_k"]] == 0.0).all() and (load[k >= out["load_k"]] == 0.1).all()


def test_a_steered_run_is_not_the_scenarios_run(scripted):
    """As for a live view's operator inputs: an integrity problem, every claim INVALID; and
    bench check (hil_bench.check) says the same from the file alone."""
    s, _ = scripted
    r = s.result
    assert not r.integrity.ok
    assert any(p.startswith("script: 2 script input(s) during the run (hil_bench.Session)")
               for p in r.integrity.problems), r.integrity.problems
    assert r.claims and all(c.verdict == "INVALID" for c in r.claims)
    again = hil_bench.check(s.recording)
    assert [(c.quantity, c.verdict, c.note) for c in again.claims] == \
        [(c.quantity, c.verdict, c.note) for c in r.claims]
    assert again.report.integrity.invalid_note == "script input during the run: see integrity"


def test_a_scripted_recording_replays_into_the_controller(scripted, tmp_path):
    """bench replay --mode controller sends the recorded frames of each cycle, the script's CMD
    among them, to a fresh controller: its answers are the recorded ones."""
    from hil_bench.replay import ReplayOptions, read_capture, run_replay

    s, _ = scripted
    res = run_replay(read_capture(s.recording),
                     ReplayOptions(mode="controller", out=tmp_path / "replay.mcap"))
    assert res.ok, res.error
    assert res.compare["cycles"] == 8000 and "first_divergence" not in res.compare
    assert all(f["differ"] == 0 for f in res.compare["fields"].values())


# -- deterministic: the same script, the same rows ---------------------------------------------

def _same_rows(a, b) -> list[str]:
    differ = []
    for topic in ROWS:
        ra, rb = _topic(a, topic), _topic(b, topic)
        for k in ra:
            x, y = np.asarray(ra[k]), np.asarray(rb[k])
            same = (np.array_equal(x, y, equal_nan=True) if x.dtype.kind == "f"
                    else np.array_equal(x, y))
            if not same:
                differ.append(f"{topic}.{k}")
    return differ


def test_the_same_script_gives_the_same_rows_run_to_run_and_on_sil(scripted, tmp_path):
    s, out = scripted
    again, out2 = run_script("stub", tmp_path / "again.mcap")
    sil, out3 = run_script("sil", tmp_path / "sil.mcap")
    for other, o in ((again, out2), (sil, out3)):
        assert (o["met_s"], o["speed_k"], o["load_k"]) == (out["met_s"], out["speed_k"],
                                                          out["load_k"])
        assert o["speed_window"].equals(out["speed_window"])
        assert _same_rows(s.recording, other.recording) == []


def test_a_script_without_inputs_gives_bench_runs_rows_and_claims(tmp_path):
    """Holding, reading windows and waiting for conditions change nothing of the run: the
    recording and the claims are bench run's (SIL: the controller in the engine's thread)."""
    ran = hil_bench.run("gong_g2_500rpm", link="sil", out=tmp_path / "run.mcap")
    with Session("gong_g2_500rpm", link="sil", out=tmp_path / "session.mcap") as s:
        s.run_until("state == 'CLOSED_LOOP'", timeout_s=1.0)
        s.step(1234)
        w = s.capture(0.1)
        s.note("looked")
    assert len(w) == 1000
    assert _same_rows(ran.recording, s.recording) == ["/events.t_s", "/events.kind",
                                                      "/events.text", "/events.value"]
    ev = _topic(s.recording, "/events")
    kinds = set(map(str, ev["kind"]))
    assert "script" not in kinds and "script_note" in kinds
    other = [(t, k, x) for t, k, x in zip(ev["t_s"], ev["kind"], ev["text"]) if k != "script_note"]
    ev0 = _topic(ran.recording, "/events")
    assert other == list(zip(ev0["t_s"], ev0["kind"], ev0["text"]))
    assert s.result.integrity.ok, s.result.summary()
    assert [(c.quantity, c.measured, c.verdict) for c in s.result.claims] == \
        [(c.quantity, c.measured, c.verdict) for c in ran.claims]


# -- conditions, refusals, errors --------------------------------------------------------------

def test_a_condition_not_met_in_time_says_where_the_run_was(tmp_path):
    with Session("gong_g2_500rpm", link="sil", overrides=SHORT, out=tmp_path / "c.mcap") as s:
        with pytest.raises(ConditionNotMet) as err:
            s.run_until("speed_rpm > 5000", timeout_s=0.05)
        assert isinstance(err.value, AssertionError)
        msg = str(err.value)
        assert msg.startswith("run_until(speed_rpm > 5000): not met within 0.05 s of simulated "
                              "time (t = 0 s to 0.05 s); at t = 0.0499 s: speed_rpm = "), msg
        assert s.cycle == 500
        # a callable condition, one boolean per row, and a streak it must hold for
        t = s.run_until(lambda w: w.state == "CLOSED_LOOP", timeout_s=0.7, hold_for_s=0.01)
        first = s.events[s.events.kind == "controller_state"].index.max()
        assert t == pytest.approx(first + 0.01, abs=1.5 * TS_S)
        with pytest.raises(SessionError, match=r"run_until\(<lambda>\): the condition gave"):
            s.run_until(lambda w: [True, False], timeout_s=0.01)


def test_refusals_and_bad_inputs_are_clear(tmp_path):
    s = Session("gong_g2_500rpm", link="sil", out=tmp_path / "r.mcap",
                overrides={**SHORT, "plant.inverter_nonlinear": True})
    s.step(10)
    with pytest.raises(ValueError, match=r"Session.fault_on\('open_phase'\): phase: missing"):
        s.fault_on("open_phase")
    with pytest.raises(ValueError, match=r"did you mean open_phase"):
        s.fault_on("open_phas", phase="a")
    with pytest.raises(ValueError, match=r"drop is a link or controller fault"):
        s.fault_on("drop")
    with pytest.raises(ValueError, match=r"v_dc_v: 1000 V is outside"):
        s.set_bus_voltage_v(1000.0)
    with pytest.raises(SessionError, match=r"docs/protocol.md 6.2 .* LOCKED.*"
                                           r"controller.params.SMO_K_V"):
        s.set_param("SMO_K_V", 30.0)
    with pytest.raises(ValueError, match="did you mean SMO_K_V"):
        s.set_param("SMO_KV", 30.0)
    with pytest.raises(ValueError, match="'speed' or 'current'"):
        s.set_control_mode("torque")
    with pytest.raises(ValueError, match="a finite number"):
        s.set_load_torque_nm(float("nan"))
    with pytest.raises(SessionError, match=r"the run has 8000 cycles \(0.8 s"):
        s.step(8000)
    # the plant refuses a phase short beside a non-ideal inverter: the engine says so
    with pytest.raises(InputRefused, match=r"script: fault on: phase_short, phase a, to b through "
                                           r"0.1 ohm: refused: kind: phase_short needs the ideal "
                                           r"inverter .* \(cycle 10\) \(t = 0.001 s\)"):
        s.fault_on("phase_short", phase="a", phase2="b", resistance_ohm=0.1)
    assert s.cycle == 10
    ev = s.events
    assert list(ev[ev.kind == "script_refused"].index) == [pytest.approx(10 * TS_S)]
    assert not (ev.kind == "script").any()
    s.stop()
    assert s.closed and s.result is None
    with pytest.raises(SessionError, match=r"step\(1\): the session is closed"):
        s.step(1)


def test_plant_faults_and_the_bus_voltage_from_a_script(tmp_path):
    with Session("gong_g2_500rpm", link="sil", overrides=SHORT, out=tmp_path / "f.mcap") as s:
        s.run_until("state == 'CLOSED_LOOP'", timeout_s=0.7)
        s.set_bus_voltage_v(250.0)
        k = s.cycle
        low = s.capture(0.01)
        s.restore_bus_voltage()
        back = s.capture(0.01)
        s.fault_on("sensor_offset", phase="a", offset_a=0.5)
        offset = s.capture(0.01)
        s.fault_off("sensor_offset")
    assert (low.v_dc_v == 250.0).all() and low.index[0] == pytest.approx(k * TS_S)
    assert (back.v_dc_v == back.v_dc_v.iloc[0]).all() and back.v_dc_v.iloc[0] > 300.0
    sense = _topic(s.recording, "/plant/sense")
    t = np.asarray(sense["t_s"])
    sel = (t >= offset.index[0] - 1e-9) & (t <= offset.index[-1] + 1e-9)
    # what the controller was sent: the true current plus 0.5 A (to the wire's 1 mA)
    assert np.allclose(np.asarray(sense["i_a_a"])[sel], offset.i_a_a + 0.5, atol=1e-3)
    texts = [str(x) for k_, x in zip(s.events.kind, s.events.text) if k_ == "script"]
    assert texts[0] == f"script: fault on: bus_voltage, 250 V (cycle {k})"
    assert texts[1].startswith("script: fault off: bus_voltage (cycle ")
    assert texts[2].startswith("script: fault on: sensor_offset, phase a, 0.5 A (cycle ")


def test_the_wall_clock_bound_is_an_error_naming_it(tmp_path):
    """A mailbox that never answers stands for a run that no longer moves: the call ends with
    SessionTimeout naming the bound, and the recording says why the run ended."""
    from hil_bench.loop.mailbox import News

    s = Session("gong_g2_500rpm", link="sil", overrides=SHORT, out=tmp_path / "w.mcap",
                wall_timeout_s=0.2)
    s.step(100)
    s._box.news = lambda: News(0, -1, 0, 0)        # nothing ever answered, never held
    with pytest.raises(SessionTimeout, match=r"wall-clock safety bound of 0.2 s "
                                             r"\(Session\(wall_timeout_s=...\)\) was exceeded"):
        s.step(10)
    with pytest.raises(SessionError, match="wall-clock safety bound"):
        s.step(10)
    result = s.close()
    assert result.run.error == ("at cycle 100: the wall-clock safety bound of 0.2 s "
                                "(Session(wall_timeout_s=...)) was exceeded")
    assert result.run.cycles_done == 100 and not result.integrity.ok


def test_a_failing_script_ends_the_run_and_keeps_its_recording(tmp_path):
    out = tmp_path / "fail.mcap"
    with pytest.raises(AssertionError, match="the drive is too slow"):
        with Session("gong_g2_500rpm", link="sil", overrides=SHORT, out=out) as s:
            s.step(250)
            raise AssertionError("the drive is too slow")
    assert out.is_file() and not list(tmp_path.glob(".*partial"))
    rec = load_recording(out, topics=["/plant/state"])
    result = rec.metadata["run_result"]
    assert result["cycles_done"] == "250"
    assert result["error"] == ("the script ended the run at cycle 250 (t = 0.025 s) of 8000: "
                               "AssertionError: the drive is too slow")
    assert s.result is None and s.closed


def test_a_session_runs_in_lockstep_only(tmp_path):
    from hil_bench.loop.runner import RunAborted

    with pytest.raises(RunAborted, match="a scripted session runs in lockstep"):
        Session("gong_g2_500rpm", overrides={**SHORT, "scenario.mode": "realtime"},
                out=tmp_path / "rt.mcap")
    assert not (tmp_path / "rt.mcap").exists()


def test_the_names_are_on_the_package():
    assert hil_bench.Session is Session
    assert hil_bench.SessionError is SessionError
    assert issubclass(hil_bench.ConditionNotMet, AssertionError)
    assert callable(hil_bench.signals.settles)


# -- the pytest fixture, in a downstream project -------------------------------------------------

@pytest.mark.parametrize("link", ["stub", "sil"])
def test_the_example_projects_scripted_test_passes(tmp_path, link):
    """examples/firmware_ci's scripted test (hil_session, signals) on the stub and in SIL, as a
    downstream pytest run with the plugin; the closed session's figures are JUnit properties."""
    import shutil
    import subprocess
    import sys
    import xml.etree.ElementTree as ET
    from pathlib import Path

    project = tmp_path / "firmware_ci"
    shutil.copytree(Path(__file__).resolve().parents[1] / "examples" / "firmware_ci", project)
    proc = subprocess.run(
        [sys.executable, "-m", "pytest", "-p", "no:cacheprovider", "-q", "--hil-link", link,
         "--hil-recordings", str(tmp_path / "recs"), "--junitxml", str(tmp_path / "j.xml"),
         "tests/test_scripted.py"], cwd=project, capture_output=True, text=True, timeout=900)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    props = {p.get("name"): p.get("value") for p in ET.parse(tmp_path / "j.xml").iter("property")}
    rec = Path(props["gong_g2_500rpm/recording"])
    assert rec.is_file() and rec.parent == tmp_path / "recs"
    assert props["gong_g2_500rpm/integrity"].startswith("script: 2 script input(s)")


def test_hil_session_ends_a_failed_tests_run_where_it_holds(tmp_path):
    """A test that fails with its session open: the fixture stops the run where it holds (not
    run to its end), the recording is finalised and named in the failure's report."""
    import subprocess
    import sys

    (tmp_path / "test_fails.py").write_text(
        "def test_fails(hil_session):\n"
        "    s = hil_session('gong_g2_500rpm', overrides={'scenario.duration_s': 0.3,\n"
        "                                                 'metrics.window_s': [0.1, 0.3]})\n"
        "    s.step(100)\n"
        "    assert s.controller_state == 'CLOSED_LOOP', s.controller_state\n")
    proc = subprocess.run(
        [sys.executable, "-m", "pytest", "-p", "no:cacheprovider", "--hil-link", "sil",
         "--hil-recordings", str(tmp_path / "recs"), "test_fails.py"],
        cwd=tmp_path, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 1, proc.stdout + proc.stderr
    assert "AssertionError: ALIGN" in proc.stdout, proc.stdout
    rec = tmp_path / "recs" / "test_fails.py_test_fails-s1.mcap"
    assert "hil-bench recordings" in proc.stdout and str(rec) in proc.stdout, proc.stdout
    result = load_recording(rec, topics=["/plant/state"]).metadata["run_result"]
    assert result["cycles_done"] == "100"
    assert result["error"] == ("the script ended the run at cycle 100 (t = 0.01 s) of 3000: "
                               "the test failed")
