"""A fault that never acts is no pass (issue 19, item 2): validation refuses what can never act
before anything starts (a time at or past the run's last period, counting the rounding to a
cycle; a message in a direction it never travels, or that does not cross mid-run; a probability
so small the run cannot expect one action; more faults than the engine holds), and every run,
not only a campaign's, checks the scenario's faults against the engine's own counts of the
faults that acted and left a trace: one that never acted, or left no trace, makes the run
INVALID naming the fault and why. A delay counts as detected by the round trip only when the
round trip shows it beyond what the same run's fault-free cycles show (a 1 ns delay never)."""
from __future__ import annotations

import json
from pathlib import Path

import pytest

from hil_bench.cli import main as cli_main
from hil_bench.loop.runner import run_scenario
from hil_bench.papers.check import check_recording
from hil_bench.record import channels as ch
from hil_bench.record.integrity import check_integrity, run_result_counters
from hil_bench.record.recording import load_recording
from hil_bench.scenario import ScenarioError, check_against_profile, load_scenario, parse_scenario
from tests.test_faults_engine import BASE, scenario

REPO = Path(__file__).resolve().parents[1]
G2 = (REPO / "bench" / "scenarios" / "gong_g2_500rpm.toml").read_text()

def short(faults: str, duration: float = 0.3, events: str = ""):
    return scenario(faults, duration=duration, events=events)


def short_text(faults: str, duration: float = 0.3, events: str = "", controller: str = "") -> str:
    return BASE.format(duration=duration, faults=faults, events=events, estimator="SMO_TANH",
                       controller=controller, scenario="")


def g2_with(fault: str, tmp_path: Path) -> Path:
    p = tmp_path / "g2_fault.toml"
    p.write_text(G2.replace('name = "gong_g2_500rpm"', 'name = "g2_fault"') + "\n[[faults]]\n" + fault)
    return p


# ---- refused before anything starts --------------------------------------------------------------

NEVER = [
    # the four (G2: 1.5 s at 10 kHz, 15000 periods 0..14999)
    ('kind = "open_phase"\nphase = "b"\nt_s = 1.49996',
     r"faults\[0\]\.t_s: 1\.49996 s is period 15000.* the run's last period is 14999"),
    ('kind = "drop"\ndirection = "from_controller"\nmessage = "DUTY"\nprobability = 1e-12\nt_s = 1.2',
     r"faults\[0\]\.probability: .*expects 3e-09 action"),
    ('kind = "drop"\ndirection = "to_controller"\nmessage = "HELLO"\ncount = 1\nt_s = 1.2',
     r"faults\[0\]\.message: HELLO crosses only during the handshake"),
    ('kind = "drop"\ndirection = "to_controller"\nmessage = "DUTY"\ncount = 1\nt_s = 1.2',
     r"faults\[0\]\.direction: DUTY travels only from the controller"),
    # and their relatives
    ('kind = "drop"\ndirection = "from_controller"\nmessage = "SENSE"\ncount = 1\nt_s = 1.2',
     r"SENSE travels only to the controller"),
    ('kind = "delay"\ndirection = "both"\nmessage = "CONFIG_ACK"\ndelay_s = 0.001\ncount = 1\n'
     't_s = 1.2', r"CONFIG_ACK crosses only during the handshake"),
    ('kind = "drop"\ndirection = "to_controller"\nmessage = "CMD"\ncount = 1\nt_s = 1.2',
     r"no CMD crosses .* between 1\.2 s and the end"),
    ('kind = "drop"\ndirection = "from_controller"\nmessage = "DUTY"\ncount = 1\nt_s = 1.2\n'
     'until_s = 1.20004', r"faults\[0\]\.until_s: .*no period starts between"),
    ('kind = "delay"\ndirection = "from_controller"\nmessage = "TELEM_EMF"\ndelay_s = 0.001\n'
     'count = 1\nt_s = 1.2', None),   # G2 asks for TELEM_EMF: fine (the control case)
]


@pytest.mark.parametrize("fault,match", NEVER, ids=[f"case{i}" for i in range(len(NEVER))])
def test_a_fault_that_can_never_act_is_refused_at_load(tmp_path, fault, match):
    p = g2_with(fault, tmp_path)
    if match is None:
        load_scenario(p)
        return
    with pytest.raises(ScenarioError, match=match) as info:
        load_scenario(p)
    assert "g2_fault.toml:" in str(info.value)


def test_telem_emf_without_the_flag_and_cmd_with_an_event_in_the_window():
    with pytest.raises(ScenarioError, match="TELEM_EMF crosses only when"):
        scn = parse_scenario(short_text(
            '[[faults]]\nkind = "drop"\ndirection = "from_controller"\nmessage = "TELEM_EMF"\n'
            'count = 1\nt_s = 0.2', controller="telemetry_emf = false"), Path("v.toml"))
        check_against_profile(scn)
    # a CMD does cross when an event sends one inside the window
    short('[[faults]]\nkind = "drop"\ndirection = "to_controller"\nmessage = "CMD"\ncount = 1\n'
          't_s = 0.2', events="[[events]]\nt_s = 0.25\nspeed_ref_rpm = 400")


def test_the_probability_rule_counts_the_frames_of_the_window():
    """p x (matching frames the window is sure to carry) >= 1: DUTY once a period, 'any' from the
    controller three frames a period (TELEM, TELEM_EMF, DUTY)."""
    f = ('[[faults]]\nkind = "drop"\ndirection = "from_controller"\nmessage = "{m}"\n'
         'probability = {p}\nt_s = 0.2\nuntil_s = 0.21')   # 100 periods
    short(f.format(m="DUTY", p=0.01))                         # expects 1.0
    with pytest.raises(ScenarioError, match=r"expects 0\.99 action"):
        short(f.format(m="DUTY", p=0.0099))
    short(f.format(m="any", p=0.004))                         # 300 frames: 1.2
    with pytest.raises(ScenarioError, match="HEARTBEAT_CTRL"):
        # a frame the bench cannot count on (the controller sends it when it likes)
        short(f.format(m="HEARTBEAT_CTRL", p=0.01))


def test_more_faults_than_the_engine_holds_are_refused_at_load(tmp_path):
    """64 link faults passed validation and failed after the controller had started (item 5)."""
    from hil_bench.plant_rt import engine as eng

    many = "".join(f'[[faults]]\nkind = "drop"\ndirection = "from_controller"\nmessage = "DUTY"\n'
                   f'count = 1\nt_s = {0.1 + i * 0.002:.3f}\n' for i in range(64))
    with pytest.raises(ScenarioError, match=rf"64 link faults: the cycle engine holds at most "
                                            rf"{eng.MAX_LINK_FAULTS}"):
        short(many)
    plant = "".join(f'[[faults]]\nkind = "load_torque"\ntorque_nm = 0.1\nt_s = {0.1 + i * 0.001:.3f}\n'
                    f'until_s = {0.1005 + i * 0.001:.4f}\n' for i in range(60))
    events = "".join(f"[[events]]\nt_s = {0.01 + i * 0.001:.3f}\nspeed_ref_rpm = 500\n"
                     f"load_torque_nm = 0.1\n" for i in range(80))
    with pytest.raises(ScenarioError, match=rf"280 engine events.*at most {eng.MAX_EVENTS}"):
        short(plant, events=events)


# ---- checked in every run ------------------------------------------------------------------------

def test_a_fault_that_never_acted_fails_run_and_check_strict(tmp_path, capsys):
    """A FAULT_CTRL the healthy controller never sends: validation cannot know, the run does. Both
    `bench run --strict` and `bench check --strict` exit 1 and say which fault and why."""
    p = tmp_path / "never.toml"
    p.write_text(short_text('[[faults]]\nkind = "drop"\ndirection = "from_controller"\n'
                            'message = "FAULT_CTRL"\ncount = 1\nt_s = 0.2'))
    out = tmp_path / "never.mcap"
    assert cli_main(["run", str(p), "--strict", "--no-progress", "--out", str(out)]) == 1
    text = capsys.readouterr().out
    assert "faults[0] (drop" in text and "never acted" in text
    assert "0 FAULT_CTRL frames from the controller crossed" in text, text
    assert cli_main(["check", str(out), "--strict"]) == 1
    assert "never acted" in capsys.readouterr().out
    rec = load_recording(out)
    counters = run_result_counters(rec)
    assert counters["faults_acted"] == 0 and counters["faults_traced"] == 0
    integ = check_integrity(rec, scenario_faults=check_recording(out).scenario.faults)
    (bad,) = [p for p in integ.problems if p.kind == "fault"]
    assert bad.name == "never_acted" and not integ.ok


def test_the_engine_counts_the_faults_that_acted_and_left_a_trace(tmp_path):
    out = tmp_path / "two.mcap"
    scn = short('[[faults]]\nkind = "drop"\ndirection = "from_controller"\nmessage = "DUTY"\n'
                'count = 1\nt_s = 0.1\n[[faults]]\nkind = "reorder"\ndirection = "from_controller"\n'
                'message = "TELEM"\ncount = 1\nt_s = 0.2\n[link]\nallow = {lost_frames = 1}')
    run_scenario(scn, out_path=out, progress=False)
    rec = load_recording(out)
    counters = run_result_counters(rec)
    assert counters["faults_acted"] == 2 and counters["faults_traced"] == 1
    per = {f["index"]: f for f in json.loads(rec.metadata["run_result"]["faults"])}
    assert per[0]["acted_cycle"] == 1000 and per[0]["evidence_cycle"] >= 1000
    assert per[1]["acted_cycle"] == 2000 and per[1]["evidence_cycle"] == -1
    report = check_recording(out)
    (bad,) = [p for p in report.integrity.problems if p.kind == "fault"]
    assert bad.name == "untraced" and "faults[1] (reorder" in bad.text


def test_a_one_nanosecond_delay_is_not_detected_by_the_round_trip(tmp_path):
    """Every round trip is longer than 1 ns: counting those was no evidence. Evidence is a round trip
    the fault-free cycles of the same run do not show (docs/faults.md)."""
    out = tmp_path / "ns.mcap"
    scn = short('[[faults]]\nkind = "delay"\ndirection = "from_controller"\nmessage = "DUTY"\n'
                'delay_s = 1e-9\nt_s = 0.2\nuntil_s = 0.25')
    result = run_scenario(scn, out_path=out, progress=False)
    assert result.ok, result.error
    rec = load_recording(out)
    f = rec.topic(ch.FAULTS)
    (trace,) = [t for t, a in zip(f["text"], f["action"]) if a == "trace"]
    assert trace.startswith("no trace") and "rtt_over_delay" not in trace.split(";")[0], trace
    assert "500 delayed cycles" in trace, trace
    report = check_recording(out)
    assert not report.integrity.ok and not report.all_pass


def test_a_campaign_run_whose_fault_never_acted_says_which_and_why(tmp_path):
    from hil_bench.faults.campaign import load_campaign, run_campaign

    p = tmp_path / "camp.toml"
    p.write_text('[campaign]\nname = "never"\nbase = "gong_g2_500rpm"\nduration_s = 0.3\n'
                 '[campaign.overrides]\n"reference.estimators" = []\n'
                 '[[runs]]\nlabel = "a FAULT_CTRL lost"\nfaults = [{kind = "drop", direction = '
                 '"from_controller", message = "FAULT_CTRL", count = 1, t_s = 0.2}]\n')
    (r,) = run_campaign(load_campaign(p), tmp_path / "out")
    assert r.verdict == "INVALID"
    assert r.reasons[0].startswith("faults[0] (drop") and "never acted: 0 FAULT_CTRL frames" in r.reasons[0]
