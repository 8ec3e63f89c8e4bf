"""An incomplete or damaged run never passes (issue 9, item 2): completeness and link integrity in the
verdict, on real recordings that are killed, cut and corrupted here."""
from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from bench import channels as ch
from bench.check import check_recording
from bench.cli import main as cli_main
from bench.integrity import LINK_COUNTERS, check_integrity
from bench.recorder import partial_path
from bench.recording import Recording, load_recording
from bench.runner import Runner, run_scenario
from bench.scenario import load_scenario, parse_scenario

REPO = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def g2(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("g2") / "g2.mcap"
    result = run_scenario(load_scenario("gong_g2_500rpm"), out_path=out, progress=False)
    assert result.ok, result.error
    return out


def _copy(src: Path, dst: Path) -> Path:
    shutil.copyfile(src, dst)
    return dst


def test_a_complete_run_is_intact_and_its_claims_have_verdicts(g2, capsys):
    report = check_recording(g2)
    integ = report.integrity
    assert integ.ok and not integ.problems and integ.estimator_mismatch == 0
    assert integ.cycles_done == integ.cycles_planned == 15000
    assert set(integ.counters) == set(LINK_COUNTERS) and not any(integ.counters.values())
    assert {r.verdict for r in report.results} <= {"PASS", "COMPARED"}
    cli_main(["check", str(g2)])
    assert "integrity: complete (15000/15000 cycles), link clean" in capsys.readouterr().out


def test_a_recording_cut_at_90_percent_is_incomplete(g2, tmp_path, capsys):
    cut = _copy(g2, tmp_path / "cut.mcap")
    size = cut.stat().st_size
    with open(cut, "r+b") as f:
        f.truncate(int(size * 0.9))
    report = check_recording(cut)
    names = {p.name for p in report.integrity.unallowed}
    assert "truncated" in names and "run_result" in names, names
    assert not report.all_pass
    assert all(r.verdict == "INVALID" for r in report.results)
    assert cli_main(["check", str(cut), "--strict"]) == 1
    out = " ".join(capsys.readouterr().out.split())
    assert "recording damaged" in out and "bench recover" in out and "integrity: NOT OK" in out


def test_eight_corrupted_bytes_at_95_percent_are_damage(g2, tmp_path):
    bad = _copy(g2, tmp_path / "bad.mcap")
    data = bytearray(bad.read_bytes())
    at = int(len(data) * 0.95)
    for i in range(8):
        data[at + i] ^= 0xFF
    bad.write_bytes(bytes(data))
    report = check_recording(bad)
    assert not report.integrity.ok
    assert any(p.name in ("truncated", "unreadable_chunks") for p in report.integrity.unallowed)
    assert cli_main(["check", str(bad), "--strict"]) == 1


def test_a_bench_killed_mid_run_leaves_a_recording_that_never_passes(tmp_path):
    out = tmp_path / "killed.mcap"
    proc = subprocess.Popen([sys.executable, "-m", "bench", "run", "gong_g2_500rpm", "--no-progress",
                             "--out", str(out)], cwd=REPO, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + 30
    part = partial_path(out)                      # the recording's name until it is final
    while time.monotonic() < deadline and (not part.exists() or part.stat().st_size < 300_000):
        time.sleep(0.05)
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    # the recorder process sees the pipe close and finalises the file: wait for it
    rec = None
    while time.monotonic() < deadline:
        try:
            rec = load_recording(out)
            if not rec.truncated:
                break
        except Exception:  # noqa: BLE001 - still being written
            pass
        time.sleep(0.1)
    assert rec is not None
    report = check_recording(out)
    names = {p.name for p in report.integrity.unallowed}
    assert "run_result" in names, report.integrity.problems
    assert report.integrity.cycles_planned == 15000
    assert all(r.verdict == "INVALID" for r in report.results) and not report.all_pass
    assert cli_main(["check", str(out), "--strict"]) == 1


SHORT = """
[scenario]
name = "noisy"
profile = "gong2020"
duration_s = 0.2
[controller]
estimator = "SMO_SIGN"
speed_ref_rpm = 300
[controller.params]
ALIGN_TIME_S = 0.05
IF_ACCEL_RAD_S2 = 200.0
[metrics]
window_s = [0.0, 0.2]
{link}
"""


@pytest.mark.parametrize("link, ok", [("", False), ("[link]\nallow = {crc_errors = 100000, "
                                                   "cobs_errors = 100000, bytes_discarded = 100000000, "
                                                   "length_errors = 100000, overruns = 100000, telem_missing = 100000}", True)])
def test_link_errors_are_problems_unless_the_scenario_allows_them(tmp_path, link, ok):
    scn = parse_scenario(SHORT.format(link=link), tmp_path / "noisy.toml")
    out = tmp_path / "noisy.mcap"
    result = Runner(scn, out_path=out, progress=False, stub_args=("--inject", "garbage@100")).run()
    assert result.ok, result.error
    report = check_recording(out)
    integ = report.integrity
    link_problems = [p for p in integ.problems if p.kind == "link"]
    assert link_problems, integ.counters      # line noise before every answer: framing errors
    assert all(p.is_allowed for p in link_problems) == ok
    assert integ.ok == ok and report.all_pass == ok


class _Rec(Recording):
    pass


def test_estimator_mismatch_from_the_telemetry_makes_claims_invalid():
    rec = _Rec(Path("fake.mcap"))
    rec.metadata = {"run": {"estimator": "SMO_SIGN", "cycles_planned": "4"},
                    "run_result": {"cycles_done": "4", "cycles_planned": "4", "error": "",
                                   "interrupted": "False"}}
    rec.topics = {ch.PLANT_STATE: {"t_s": np.arange(4.0)},
                  ch.CONTROLLER_TELEMETRY: {"estimator": np.array([1.0, 5.0, 5.0, np.nan])},
                  ch.LINK_STATS: {"crc_errors": np.array([0.0, 0.0])}}
    integ = check_integrity(rec, {}, "SMO_SIGN")
    assert integ.estimator_mismatch == 2 and not integ.ok
    assert "reported estimator ENCODER in 2 cycles while SMO_SIGN was asked for" in integ.invalid_reason
    # the engine's own count on /link/stats counts too, even without telemetry
    rec.topics[ch.CONTROLLER_TELEMETRY] = {"estimator": np.array([1.0, 1.0, 1.0, 1.0])}
    rec.topics[ch.LINK_STATS]["estimator_mismatch"] = np.array([0.0, 3.0])
    integ = check_integrity(rec, {}, "SMO_SIGN")
    assert integ.estimator_mismatch == 3 and "estimator_mismatch = 3" in integ.invalid_reason
    # rows missing from the recording are a completeness problem
    rec.topics[ch.PLANT_STATE] = {"t_s": np.arange(3.0)}
    assert "rows" in {p.name for p in check_integrity(rec, {}, "SMO_SIGN").unallowed}
