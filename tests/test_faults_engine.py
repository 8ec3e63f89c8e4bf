"""Faults applied by the cycle engine (issue 12): link faults in either direction, plant faults and
a controller reset from a scenario's [[faults]], each one acting and leaving its trace; a fault
that leaves none makes the run INVALID; seeded faults are reproducible; the controller's reaction
after its trip is recorded; decimated recordings keep full rate around the faults.

Every run here is lockstep (deterministic: it cannot be late); the real-time side has its own test
in tests/test_realtime.py.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from hil_bench.loop.runner import RunAborted, run_scenario
from hil_bench.papers.check import check_recording
from hil_bench.record import channels as ch
from hil_bench.record.fault_outcomes import outcomes
from hil_bench.record.integrity import check_integrity
from hil_bench.record.recording import load_recording
from hil_bench.scenario import ScenarioError, check_against_profile, parse_scenario

BASE = """
[scenario]
name = "fault_test"
profile = "gong2020"
duration_s = {duration}
{scenario}
[plant]
initial_theta_e_rad = 0.4
t_delay_s = 0.0
[controller]
estimator = "{estimator}"
speed_ref_rpm = 500
{controller}
[controller.params]
IQ_MAX_A = 6.0
ALIGN_I_A = 3.0
ALIGN_TIME_S = 0.2
IF_I_A = 3.0
IF_ACCEL_RAD_S2 = 60.0
HANDOVER_SPEED_RAD_S = 20.0
SMO_M_PER_A = 0.01
{events}
[metrics]
window_s = [0.0, {duration}]
{faults}
"""


def scenario(faults: str, duration: float = 0.3, events: str = "", estimator: str = "SMO_TANH",
             controller: str = "", scenario_extra: str = ""):
    text = BASE.format(duration=duration, faults=faults, events=events, estimator=estimator,
                       controller=controller, scenario=scenario_extra)
    scn = parse_scenario(text, Path("fault_test.toml"))
    check_against_profile(scn)
    return scn


def run(tmp_path: Path, faults: str, link: str = "stub", **kw):
    """Run and load the recording. ``link = "sil"`` where the subject is the plant or the
    controller, not the link: the same rows as the stub's (tests/test_sil.py), no pty."""
    out = tmp_path / "f.mcap"
    result = run_scenario(scenario(faults, **kw), link_spec=link, out_path=out, progress=False,
                          force=True)
    return result, load_recording(out)


def fault_rows(rec) -> list[dict]:
    f = rec.topic(ch.FAULTS)
    keys = ("t_s", "seq", "index", "target", "kind", "direction", "action", "text", "value")
    return [dict(zip(keys, row)) for row in zip(*(f[k] for k in keys))]


def trace_of(rec, index: int = 0) -> dict:
    traces = [r for r in fault_rows(rec) if r["action"] == "trace" and r["index"] == index]
    assert len(traces) == 1, fault_rows(rec)
    return traces[0]


# ---- link faults: each acts on the frames and leaves its trace -----------------------------------

LINK_CASES = [
    # (fault table, the action recorded, a counter its trace must show)
    # a drop's and a stall's evidence is the frame that never arrived (lost_frames); the re-send
    # that recovers it (retries) is timing, as a busy host's late answers are: no evidence
    ('kind = "drop"\ndirection = "from_controller"\nmessage = "DUTY"\ncount = 1', "drop",
     "lost_frames"),
    ('kind = "drop"\ndirection = "to_controller"\nmessage = "SENSE"\ncount = 1', "drop",
     "lost_frames"),
    ('kind = "duplicate"\ndirection = "from_controller"\nmessage = "DUTY"\ncount = 1', "duplicate",
     "duplicates"),
    ('kind = "duplicate"\ndirection = "to_controller"\nmessage = "SENSE"\ncount = 1', "duplicate",
     "duplicates"),
    ('kind = "reorder"\ndirection = "from_controller"\nmessage = "TELEM_EMF"\ncount = 1', "reorder",
     "stale_frames"),
    ('kind = "bitflip"\ndirection = "from_controller"\nmessage = "DUTY"\ncount = 1', "bitflip",
     "_errors"),   # crc_errors, cobs_errors or length_errors: where the flipped bit fell
    ('kind = "bitflip"\ndirection = "to_controller"\nmessage = "SENSE"\ncount = 1', "bitflip",
     "ctrl_rx_errors"),
    # ten delayed cycles: one 0.5 ms late frame is within what a loaded host's fault-free round
    # trips show often enough (docs/faults.md "rtt_over_delay"), ten in a row are not
    ('kind = "delay"\ndirection = "from_controller"\nmessage = "DUTY"\ndelay_s = 0.0005\ncount = 10',
     "delay", "rtt_over_delay"),
    ('kind = "delay"\ndirection = "to_controller"\nmessage = "SENSE"\ndelay_s = 0.0005\ncount = 10',
     "delay", "rtt_over_delay"),
    ('kind = "stall"\nstall_periods = 20', "stall", "lost_frames"),
    ('kind = "garbage"\ndirection = "from_controller"\nburst = 40', "garbage", "bytes_discarded"),
    ('kind = "garbage"\ndirection = "to_controller"\nburst = 40', "garbage", "ctrl_rx_errors"),
]


@pytest.mark.parametrize("fault,action,counter", LINK_CASES,
                         ids=[f"{c[1]}-{'to' if 'to_controller' in c[0] else 'from'}"
                              for c in LINK_CASES])
def test_each_link_fault_acts_and_leaves_its_trace(tmp_path, fault, action, counter):
    result, rec = run(tmp_path, f"[[faults]]\nt_s = 0.2\n{fault}")
    assert result.ok, result.error
    rows = fault_rows(rec)
    acted = [r for r in rows if r["action"] == action]
    assert acted, rows
    assert acted[0]["target"] == "link" and abs(acted[0]["t_s"] - 0.2) < 1e-9
    if action not in ("stall", "garbage"):
        assert acted[0]["seq"] == 2000              # the cycle's own frame, named by its seq
    trace = trace_of(rec)
    assert counter in trace["text"], trace
    assert np.isfinite(trace["value"]) and trace["value"] < 0.05   # evidence within 50 ms
    (o,) = outcomes(rec)
    assert o.detected and o.t_on_s == pytest.approx(0.2)
    stats = rec.topic(ch.LINK_STATS)
    assert int(stats["faults_injected"][-1]) >= 1 and int(stats["faults_untraced"][-1]) == 0


def test_a_controller_reset_is_seen_and_ends_the_lockstep_run(tmp_path):
    """CMD RESTART with the frames of cycle 2000: the stub restarts (no session) before it reads
    that cycle's SENSE; its HEARTBEAT_CTRL counter starts over (a restart, counted), and a
    restarted controller answers no SENSE before a new HELLO, so the run ends at once (not after
    the patience) saying the bench restarted the controller. tests/test_controller_restart.py:
    the same cycle whatever the load."""
    result, rec = run(tmp_path, '[[faults]]\nkind = "controller_reset"\nt_s = 0.2')
    assert result.end == "NO_DUTY" and result.cycles_done == 2000
    assert "the bench restarted the controller at this cycle" in result.error
    trace = trace_of(rec)
    assert "ctrl_resets +1" in trace["text"], trace
    assert "the controller restarted while the host waited for DUTY(2000)" in result.error
    events = rec.topic(ch.EVENTS)
    assert "controller_restart" in list(events["kind"])


def test_a_fault_that_leaves_no_trace_makes_the_run_invalid(tmp_path):
    """TELEM held behind TELEM_EMF: both still arrive before DUTY, which completes the cycle; the
    engine takes a cycle's frames by id (docs/protocol.md 6.6), so nothing shows. The bench
    cannot tell what such a run tested: INVALID, and --strict fails."""
    result, rec = run(tmp_path, '[[faults]]\nkind = "reorder"\ndirection = "from_controller"\n'
                                'message = "TELEM"\ncount = 1\nt_s = 0.2')
    assert result.ok
    assert trace_of(rec)["text"].startswith("no trace")
    integ = check_integrity(rec)
    assert not integ.ok and any(p.kind == "fault" and p.name == "untraced" for p in integ.problems)
    (o,) = outcomes(rec)
    assert not o.detected and o.untraced
    report = check_recording(result.recording)
    assert not report.integrity.ok


def test_seeded_faults_are_reproducible(tmp_path):
    """A fault on 2 % of the DUTY frames, twice with the same seed: the same frames, the second time
    on a busy host whose stalls of the stub make cycles late and re-sent (each frame's draw comes
    from the seed, the cycle and the frame's place in it, never from how many frames a busy host's
    re-sends added before it: found under load, the drops moved by one cycle); another seed:
    others. What is compared is the cycles' own DUTY frames (place 0); a busy host may add draws
    for the answers to its re-sends (place 1 and on), which only exist under it."""
    from tests.host_load import CONTROLLER_PATTERN, HostLoad

    def dropped(seed: int) -> list[int]:
        _, rec = run(tmp_path, f'[[faults]]\nkind = "drop"\ndirection = "from_controller"\n'
                               f'message = "DUTY"\nprobability = 0.02\nuntil_s = 0.25\nt_s = 0.2\n'
                               f'seed = {seed}')
        return [int(r["seq"]) for r in fault_rows(rec) if r["action"] == "drop" and r["value"] == 0]

    a = dropped(7)
    with HostLoad(pause_pattern=CONTROLLER_PATTERN, every_s=(0.05, 0.3)):
        b = dropped(7)
    c = dropped(8)
    assert a == b and len(a) >= 3 and a != c


def test_link_faults_refused_where_they_cannot_be_emulated(tmp_path):
    scn = scenario('[[faults]]\nkind = "bitflip"\ndirection = "to_controller"\nmessage = "SENSE"\n'
                   'count = 1\nt_s = 0.2')
    with pytest.raises(RunAborted, match="bus's CRC"):
        run_scenario(scn, link_spec="stub-socketcand", out_path=tmp_path / "can.mcap",
                     progress=False, allow_slow_link=True)


# ---- plant faults: switched on (and off) at their time, acting on the plant ----------------------

def _state(rec):
    return rec.topic(ch.PLANT_STATE)


PLANT_CASES = {
    "open_phase": ('phase = "b"', lambda rec, on: np.all(np.abs(_state(rec)["i_b_a"][on][5:]) < 1e-6)),
    # leg a tied to the - rail: duty 0, the lowest of the three, so v_a (common mode removed)
    # is the lowest phase voltage (the rows carry the average of the period that ended at t_k)
    "leg_stuck": ('phase = "a"\nlevel = "low"',
                  lambda rec, on: np.all(_state(rec)["v_a_v"][on][1:] <= np.minimum(
                      _state(rec)["v_b_v"][on][1:], _state(rec)["v_c_v"][on][1:]) + 1e-9)),
    "sensor_stuck": ('phase = "a"\nreading_a = 1.5',
                     lambda rec, on: np.allclose(rec.topic(ch.PLANT_SENSE)["i_a_a"][on], 1.5)),
    "sensor_offset": ('phase = "a"\noffset_a = 0.25',
                      lambda rec, on: np.allclose(rec.topic(ch.PLANT_SENSE)["i_a_a"][on] -
                                                  _state(rec)["i_a_a"][on], 0.25, atol=1e-3)),
    "sensor_gain": ('phase = "a"\ngain_error = 0.5',
                    lambda rec, on: np.allclose(rec.topic(ch.PLANT_SENSE)["i_a_a"][on],
                                                1.5 * _state(rec)["i_a_a"][on], atol=2e-3)),
    "sensor_dropout": ('phase = "c"', lambda rec, on: np.all(rec.topic(ch.PLANT_SENSE)["i_c_a"][on] == 0)),
    "bus_voltage": ("v_dc_v = 200.0", lambda rec, on: np.allclose(_state(rec)["v_dc_v"][on][1:], 200.0)),
    "locked_rotor": ("", lambda rec, on: np.all(_state(rec)["omega_m_rad_s"][on][1:] == 0.0)),
    "load_torque": ("torque_nm = 1.5", lambda rec, on: np.allclose(_state(rec)["torque_load_nm"][on][1:], 1.5)),
    # while both legs are driven the stiff averaged bus hides a resistive short from the machine,
    # and zero-vector sampling from the sensors (plant_fault.h): nothing in the recorded channels
    # shows it; tests/test_plant_faults.py checks its network solution
    "phase_short": ('phase = "a"\nphase2 = "b"\nresistance_ohm = 0.5', None),
    "encoder_loss": ("", lambda rec, on: np.all(np.isnan(rec.topic(ch.PLANT_SENSE)["theta_enc_rad"][on]))),
    "encoder_stuck": ("", lambda rec, on: np.ptp(rec.topic(ch.PLANT_SENSE)["theta_enc_rad"][on][:20]) == 0),
}


@pytest.mark.parametrize("kind", sorted(PLANT_CASES))
def test_each_plant_fault_is_switched_by_the_engine(tmp_path, kind):
    """On at the first period at/after t_s, off at until_s; the plant shows it in between (the
    physics of each fault is checked against independent models in tests/test_plant_faults.py)."""
    fields, acting = PLANT_CASES[kind]
    extra = 'send_encoder_angle = true' if kind.startswith("encoder") else ""
    result, rec = run(tmp_path, f'[[faults]]\nkind = "{kind}"\n{fields}\nt_s = 0.2\nuntil_s = 0.22\n'
                                f'detect_within_s = 0.0',
                      link="sil", controller=extra, scenario_extra="post_trip_s = 0.02")
    rows = fault_rows(rec)
    on = [r for r in rows if r["action"] == "on"]
    assert len(on) == 1 and on[0]["t_s"] == pytest.approx(0.2) and on[0]["target"] == "plant", rows
    if result.ok:   # the controller may trip on it (a later test measures that)
        off = [r for r in rows if r["action"] == "off"]
        assert len(off) == 1 and off[0]["t_s"] == pytest.approx(0.22)
    t = _state(rec)["t_s"]
    window = (t >= 0.2 - 1e-9) & (t < min(0.22, t[-1]) - 1e-9)
    assert window.sum() >= 20
    if acting is not None:
        assert acting(rec, window), kind


def test_a_fault_the_plant_cannot_take_is_refused_at_load():
    with pytest.raises(ScenarioError, match=r"faults\[0\].*phase_short.*inverter"):
        text = BASE.format(duration=0.3, events="", estimator="SMO_TANH", controller="",
                           scenario="", faults='[[faults]]\nkind = "phase_short"\nphase = "a"\n'
                                               'phase2 = "b"\nresistance_ohm = 1.0\nt_s = 0.1')
        scn = parse_scenario(text.replace("t_delay_s = 0.0", "t_delay_s = 0.0\ninverter_nonlinear = true"),
                             Path("x.toml"))
        check_against_profile(scn)


@pytest.mark.parametrize("bad,match", [
    ('kind = "melt"\nt_s = 0.1', "unknown fault 'melt'"),
    ('kind = "open_phase"\nt_s = 0.1', r"faults\[0\]\.phase: missing"),
    ('kind = "open_phase"\nphase = "d"\nt_s = 0.1', "must be 'a', 'b' or 'c'"),
    ('kind = "open_phase"\nphase = "a"\nt_s = 5.0', "not before the end of the run"),
    ('kind = "drop"\nmessage = "DUTY"\ncount = 1\nt_s = 0.1', r"direction: missing"),
    ('kind = "drop"\ndirection = "up"\nmessage = "DUTY"\ncount = 1\nt_s = 0.1', "must be one of"),
    ('kind = "drop"\ndirection = "both"\nmessage = "DUTYY"\ncount = 1\nt_s = 0.1', "unknown message"),
    ('kind = "drop"\ndirection = "both"\nmessage = "DUTY"\nt_s = 0.1', "every matching frame"),
    ('kind = "stall"\nt_s = 0.1', "stall_periods"),
    ('kind = "sensor_offset"\nphase = "a"\noffset_a = 99.0\nt_s = 0.1', "outside"),
    ('kind = "bus_voltage"\nv_dc_v = 1000.0\nt_s = 0.1', "outside"),
    ('kind = "delay"\ndirection = "both"\nmessage = "DUTY"\ncount = 1\nt_s = 0.1', "delay_s"),
    ('kind = "open_phase"\nphase = "a"\nt_s = 0.1\ncolour = "red"', "unknown key"),
])
def test_bad_fault_entries_are_refused_naming_line_and_field(bad, match):
    text = BASE.format(duration=0.3, events="", estimator="SMO_TANH", controller="", scenario="",
                       faults=f"[[faults]]\n{bad}")
    with pytest.raises(ScenarioError, match=match) as info:
        scn = parse_scenario(text, Path("bad.toml"))
        check_against_profile(scn)
    assert "bad.toml:" in str(info.value)


# ---- the controller's reaction, recorded after its trip -------------------------------------------

LOADED = "[[events]]\nt_s = 0.9\nload_torque_nm = 2.0"


def test_the_reaction_after_a_trip_is_recorded(tmp_path):
    """A 2 A offset on sensor a under load: the stub's sum check trips (SENSOR_FAULT); the run
    goes on for post_trip_s, every duty after the trip is all legs OFF, the table says so."""
    result, rec = run(tmp_path, '[[faults]]\nkind = "sensor_offset"\nphase = "a"\noffset_a = 2.0\n'
                                't_s = 1.2', link="sil", duration=1.4, events=LOADED)
    assert result.end == "CONTROLLER_FAULT" and "SENSOR_FAULT" in result.error
    (o,) = outcomes(rec)
    assert o.detected and o.trip_code == "SENSOR_FAULT" and 0.0 < o.detection_s < 0.01
    assert o.duties_after_trip == 0 and o.state_after == "FAULT"
    telem = rec.topic(ch.CONTROLLER_TELEMETRY)
    after = telem["t_s"] > 1.2 + o.trip_s + 1e-4
    assert after.sum() >= 400                                  # ~50 ms recorded after the trip
    assert np.all(telem["duty_a"][after] == -1.0) and np.all(telem["duty_c"][after] == -1.0)
    assert o.peak_current_a < 10.0


# ---- decimated recordings with full rate around the faults ----------------------------------------

def test_decimated_recording_keeps_full_rate_around_the_fault(tmp_path):
    result, rec = run(tmp_path, '[recording]\ndecimate = 10\npre_trigger_s = 0.01\n'
                                'post_trigger_s = 0.02\n[[faults]]\nkind = "drop"\n'
                                'direction = "from_controller"\nmessage = "DUTY"\ncount = 1\nt_s = 0.2\n'
                                '[link]\nallow = {lost_frames = 1}')
    assert result.ok, result.error
    t = _state(rec)["t_s"]
    k = np.round(t / 1e-4).astype(int)
    full = (k >= 1900) & (k < 2200)
    assert np.array_equal(k[full], np.arange(1900, 2200))            # every cycle in the window
    assert np.all(k[~full] % 10 == 0)                                # every 10th elsewhere
    assert len(t) < 3000 * 0.25
    integ = check_integrity(rec, {"lost_frames": 1})
    assert integ.ok, integ.problems                                   # fewer rows, by design
