"""Fault campaigns (issue 12, item 4): a campaign file is checked whole before anything runs, each
run is judged against the file's limits, the table says what happened, and only the recordings of
the runs that did not pass are kept."""
from __future__ import annotations

import csv
from pathlib import Path

import pytest

from hil_bench.cli import main as cli_main
from hil_bench.faults.campaign import CampaignError, load_campaign, run_campaign, write_report

REPO = Path(__file__).resolve().parents[1]

MINI = """
[campaign]
name = "mini"
base = "gong_g2_500rpm"
duration_s = 0.35

[campaign.overrides]
"reference.estimators" = []

[recording]
decimate = 5

[limits]
detection_time_s = 0.05
peak_current_a = 32.0
duties_after_trip = 0

[[runs]]
label = "one DUTY lost"
faults = [{kind = "drop", direction = "from_controller", message = "DUTY", count = 1, t_s = 0.3}]
allow = {lost_frames = 1}

[[runs]]
label = "leg stuck"
faults = [{kind = "leg_stuck", phase = "a", level = "high", t_s = 0.3}]

[[runs]]
label = "leg stuck, impossible limit"
faults = [{kind = "leg_stuck", phase = "a", level = "high", t_s = 0.3}]
limits = {detection_time_s = 1e-6}
"""


def write(tmp_path: Path, text: str) -> Path:
    p = tmp_path / "camp.toml"
    p.write_text(text)
    return p


def test_a_campaign_runs_judges_and_keeps_only_the_failures(tmp_path):
    camp = load_campaign(write(tmp_path, MINI))
    assert [c.name for c in camp.cases] == ["00_one_DUTY_lost", "01_leg_stuck",
                                            "02_leg_stuck_impossible_limit"]
    out = tmp_path / "report"
    results = run_campaign(camp, out)
    by = {r.case.name: r for r in results}
    drop, leg, strict = (by["00_one_DUTY_lost"], by["01_leg_stuck"],
                         by["02_leg_stuck_impossible_limit"])
    assert drop.verdict == "PASS", drop.reasons
    (o,) = drop.outcomes
    # the drop's own trace: the frame that never arrived (a loaded host may add late re-sends)
    assert o.detected and "lost_frames +1" in o.detected_by
    assert leg.verdict == "PASS", leg.reasons
    (o,) = leg.outcomes
    assert o.detected_by == "FAULT_CTRL OVERCURRENT" and 0 < o.detection_s < 0.05
    assert o.duties_after_trip == 0 and o.state_after == "FAULT"
    assert strict.verdict == "FAIL" and "detected after" in strict.reasons[0]
    # the passing runs' recordings are gone, the failing one's kept
    assert drop.recording is None and leg.recording is None
    assert strict.recording is not None and strict.recording.exists()
    assert sorted(p.name for p in (out / "recordings").iterdir()) == [
        "02_leg_stuck_impossible_limit.mcap", "02_leg_stuck_impossible_limit.serial.bin"]
    md = write_report(camp, results, out, 1.0)
    text = md.read_text()
    assert "3 runs" in text and "2 PASS, 1 FAIL, 0 INVALID" in text
    assert "FAULT_CTRL OVERCURRENT" in text and "`detection_time_s = 1e-06`" in text
    rows = list(csv.DictReader(open(out / "results.csv")))
    assert [r["verdict"] for r in rows] == ["PASS", "PASS", "FAIL"]
    assert rows[1]["fault"] == "leg_stuck" and float(rows[1]["peak_current_a"]) > 25.0


def test_the_command_exits_1_when_a_run_does_not_pass(tmp_path, capsys):
    p = write(tmp_path, MINI.split("[[runs]]")[0] + "[[runs]]" + MINI.split("[[runs]]")[3])
    assert cli_main(["campaign", str(p), "--out", str(tmp_path / "r")]) == 1
    assert "FAIL" in capsys.readouterr().out


@pytest.mark.parametrize("edit,match", [
    (("[limits]", "[limits]\nspeed = 3"), r"camp.toml:\d+: limits.speed: unknown limit"),
    (('base = "gong_g2_500rpm"', 'base = "nope"'), "neither a bundled scenario"),
    (('kind = "leg_stuck", phase = "a", level = "high", t_s = 0.3}]\n\n',
      'kind = "leg_stuck", phase = "a", level = "up", t_s = 0.3}]\n\n'),
     r"run 01_leg_stuck .*faults\[0\]\.level: must be 'high'"),
    (("allow = {lost_frames = 1}", "allow = {retry = 1}"), "not a link counter"),
    (("[[runs]]\nlabel = \"one DUTY lost\"", "[[grid]]\nphase = [\"a\"]\n[[runs]]\nlabel = \"x\""),
     r"grid\[0\]\.kind: missing"),
])
def test_a_bad_campaign_is_refused_before_anything_runs(tmp_path, edit, match):
    a, b = edit
    assert a in MINI
    with pytest.raises(CampaignError, match=match):
        load_campaign(write(tmp_path, MINI.replace(a, b, 1)))


def test_a_grid_is_every_combination():
    camp = load_campaign(REPO / "bench" / "campaigns" / "g2_protection.toml")
    grid = [c for c in camp.cases if c.faults[0]["kind"] == "sensor_offset"]
    assert sorted((c.faults[0]["phase"], c.faults[0]["offset_a"]) for c in grid) == [
        ("a", -3.0), ("a", 2.0), ("b", -3.0), ("b", 2.0)]
    # the bundled campaign covers every link fault kind, a controller restart and the plant
    kinds = {f["kind"] for c in camp.cases for f in c.faults}
    assert {"drop", "duplicate", "reorder", "bitflip", "delay", "stall", "garbage",
            "controller_reset", "open_phase", "leg_stuck", "bus_voltage"} <= kinds
