"""An incomplete or damaged run never passes (issue 9, item 2): completeness and link integrity in the
verdict, on real recordings that are killed, cut and corrupted here."""
from __future__ import annotations

import ast
import importlib
import inspect
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from hil_bench.cli import main as cli_main
from hil_bench.loop.runner import Runner, run_scenario
from hil_bench.papers.check import check_recording
from hil_bench.record import channels as ch
from hil_bench.record.integrity import LINK_COUNTERS, check_integrity
from hil_bench.record.recorder import partial_path
from hil_bench.record.recording import Recording, load_recording
from hil_bench.scenario import load_scenario
from tests.short_scenario import short_scenario

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
    proc = subprocess.Popen([sys.executable, "-m", "hil_bench", "run", "gong_g2_500rpm", "--no-progress",
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


@pytest.mark.parametrize("link, ok", [("", False), ("[link]\nallow = {crc_errors = 100000, "
                                                   "cobs_errors = 100000, bytes_discarded = 100000000, "
                                                   "length_errors = 100000, overruns = 100000, telem_missing = 100000}", True)])
def test_link_errors_are_problems_unless_the_scenario_allows_them(tmp_path, link, ok):
    scn = short_scenario(0.2, "noisy", extra=link + "\n", source=str(tmp_path / "noisy.toml"))
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


# -- the plant's true angle sent to a sensorless controller (issue 9 audit, finding 1) ----------------


def _strict_and_text(path: Path, capsys) -> tuple[int, str]:
    capsys.readouterr()
    rc = cli_main(["check", str(path), "--strict"])
    return rc, " ".join(capsys.readouterr().out.split())


def test_a_lying_drive_given_the_true_angle_gets_no_verdict(tmp_path, capsys):
    """tests/third_party_drive.py --cheat lie closes its loop on SENSE_AUX.theta_enc and reports
    SMO_SIGN: nothing on the wire shows it, so the run itself (encoder angle sent, sensorless
    estimator asked for) makes every claim INVALID, with the reason, and --strict fails."""
    from tests.test_third_party import G2_SIGN, run_g2

    scenario = tmp_path / "gong_g2_500rpm.toml"
    scenario.write_text(G2_SIGN.replace('estimator = "SMO_SIGN"',
                                        'estimator = "SMO_SIGN"\nsend_encoder_angle = true', 1))
    rc, seen, out = run_g2(tmp_path, "lie", str(scenario))
    assert seen["encoder_valid_cycles"] > 0          # it had the angle, and (we know) it used it
    report = check_recording(out)
    assert report.integrity.estimator_mismatch == 0  # it lied: TELEM.estimator says SMO_SIGN
    assert not report.integrity.ok and not report.all_pass
    assert report.results and all(r.verdict == "INVALID" for r in report.results)
    assert report.integrity.invalid_reason.startswith(
        "the plant's true angle was sent to a sensorless controller: its estimator cannot be verified")
    rc, text = _strict_and_text(out, capsys)
    assert rc == 1 and "INVALID estimator: the plant's true angle was sent to a sensorless controller" in text


def test_the_honest_stub_given_the_true_angle_gets_no_verdict_either(tmp_path, capsys):
    """The same rule for a controller that does not cheat: whether it did cannot be verified."""
    from hil_bench.scenario import derive_scenario

    scn = derive_scenario("gong_g2_500rpm", "gong_g2_500rpm",
                          [("controller.send_encoder_angle", True)])
    out = tmp_path / "stub_enc.mcap"
    result = run_scenario(scn, out_path=out, progress=False)
    assert result.ok, result.error
    report = check_recording(out)
    problems = [p for p in report.integrity.problems if p.kind == "estimator"]
    assert [p.name for p in problems] == ["encoder_angle_sent"] and not problems[0].is_allowed
    assert report.results and all(r.verdict == "INVALID" for r in report.results)
    assert "true angle sent to a sensorless controller" in report.results[0].note
    rc, text = _strict_and_text(out, capsys)
    assert rc == 1 and "its estimator cannot be verified" in text


def test_the_encoder_estimator_may_have_the_angle():
    rec = _Rec(Path("fake.mcap"))
    rec.metadata = {"run": {"estimator": "ENCODER", "cycles_planned": "2", "encoder_angle_sent": "true"},
                    "run_result": {"cycles_done": "2", "cycles_planned": "2", "error": "",
                                   "interrupted": "False"}}
    rec.topics = {ch.PLANT_STATE: {"t_s": np.arange(2.0)}}
    assert check_integrity(rec, {}, "ENCODER").ok
    rec.metadata["run"]["estimator"] = "SMO_TANH"
    integ = check_integrity(rec, {}, "SMO_TANH")
    assert not integ.ok and "encoder_angle_sent" in {p.name for p in integ.unallowed}
    # no scenario can allow it
    assert not check_integrity(rec, {"encoder_angle_sent": 10**9}, "SMO_TANH").ok


# -- counters the ring itself may have dropped (finding 9) ---------------------------------------------


def test_rows_dropped_comes_from_the_run_result_when_the_stats_row_was_dropped():
    rec = _Rec(Path("fake.mcap"))
    rec.metadata = {"run": {"estimator": "SMO_SIGN", "cycles_planned": "3"},
                    "run_result": {"cycles_done": "3", "cycles_planned": "3", "error": "",
                                   "interrupted": "False", "rows_dropped": "7",
                                   "counters": '{"crc_errors": 2, "rows_dropped": 4, "cycles": 3}'}}
    # the last /link/stats row (the one that would say 7) went through the ring and was dropped
    rec.topics = {ch.PLANT_STATE: {"t_s": np.arange(3.0)},
                  ch.LINK_STATS: {"rows_dropped": np.array([0.0, 1.0]), "crc_errors": np.array([0.0, 0.0])}}
    integ = check_integrity(rec, {}, "SMO_SIGN")
    assert integ.counters["rows_dropped"] == 7 and integ.counters["crc_errors"] == 2
    assert {"rows_dropped", "crc_errors"} <= {p.name for p in integ.unallowed}
    # and the larger of the two when the stats row has more (it never does, but max is max)
    rec.topics[ch.LINK_STATS]["rows_dropped"] = np.array([0.0, 9.0])
    assert check_integrity(rec, {}, "SMO_SIGN").counters["rows_dropped"] == 9


# -- damage bench check must not take for something else (finding 8) -----------------------------------


def _chunk_offsets(path: Path) -> list[int]:
    from mcap.reader import make_reader

    with open(path, "rb") as f:
        return [ci.chunk_start_offset for ci in make_reader(f).get_summary().chunk_indexes]


def test_a_zeroed_chunk_opcode_is_damage_with_its_offset(g2, tmp_path, capsys):
    bad = _copy(g2, tmp_path / "zero_opcode.mcap")
    at = _chunk_offsets(bad)[len(_chunk_offsets(bad)) // 2]
    data = bytearray(bad.read_bytes())
    data[at] = 0x00
    bad.write_bytes(bytes(data))
    rec = load_recording(bad)
    assert rec.damaged and [r[:2] for r in rec.unknown_records] == [(at, 0)]
    report = check_recording(bad)
    assert "damage" in {p.name for p in report.integrity.unallowed} and not report.all_pass
    rc, text = _strict_and_text(bad, capsys)
    assert rc == 1 and f"recording damaged" in text and f"byte {at} (opcode 0x00" in text
    assert "bench recover" in text


def test_a_corrupted_chunk_length_keeps_the_run_result_found_after_it(g2, tmp_path, capsys):
    import struct

    at = _chunk_offsets(g2)[len(_chunk_offsets(g2)) // 2]
    # a huge length: the stream stops there; the run_result record (written last) is still read
    # from the summary section, so the run is not called unfinished
    huge = _copy(g2, tmp_path / "huge_len.mcap")
    data = bytearray(huge.read_bytes())
    data[at + 1:at + 9] = struct.pack("<Q", 2**40)
    huge.write_bytes(bytes(data))
    report = check_recording(huge)
    names = {p.name for p in report.integrity.unallowed}
    assert "truncated" in names and "run_result" not in names, report.integrity.problems
    assert report.integrity.cycles_done == 15000 and not report.all_pass
    rc, text = _strict_and_text(huge, capsys)
    assert rc == 1 and "did not finish" not in text and "bench recover" in text
    # a small one: the chunk still parses, but its length field is wrong: damage all the same
    small = _copy(g2, tmp_path / "small_len.mcap")
    data = bytearray(small.read_bytes())
    data[at + 1:at + 9] = struct.pack("<Q", 100)
    small.write_bytes(bytes(data))
    report = check_recording(small)
    assert "damage" in {p.name for p in report.integrity.unallowed}
    rc, text = _strict_and_text(small, capsys)
    assert rc == 1 and f"record at byte {at} (opcode 0x06): length field 100" in text


def test_a_run_result_lost_to_damage_is_not_called_an_unfinished_run():
    rec = _Rec(Path("fake.mcap"))
    rec.metadata = {"run": {"estimator": "SMO_SIGN", "cycles_planned": "3"}}
    rec.truncated = "reading stopped at byte 100 of 200: EndOfFile"
    text = next(p.text for p in check_integrity(rec, {}, "SMO_SIGN").problems if p.name == "run_result")
    assert text.startswith("run_result record not read (damage before it: reading stopped at byte 100")
    rec.truncated = None
    text = next(p.text for p in check_integrity(rec, {}, "SMO_SIGN").problems if p.name == "run_result")
    assert "the bench did not finish the run" in text


def test_checking_a_missing_file_says_so(tmp_path, capsys):
    assert cli_main(["check", str(tmp_path / "nope.mcap")]) == 2
    # whitespace dropped: the console wraps a long path anywhere (a worker's tmp_path is longer)
    err = "".join(capsys.readouterr().err.split())
    assert "nope.mcap:nosuchfile" in err and "recover" not in err


# -- bench check keeps only what its metrics read (finding 2) ---------------------------------------------


def test_a_long_window_is_checked_without_keeping_unused_fields(tmp_path):
    """Memory per second of window is the columns in CHECK_FIELDS, nothing else: a G2 run with its
    window over the whole run (1.5 s, 10 kHz) keeps exactly those fields, float64, one row per cycle
    per topic, and no /timing, /link/frames (no dual sampling) or /replay/* at all."""
    from hil_bench.papers.check import CHECK_FIELDS, read_for_check
    from hil_bench.scenario import derive_scenario

    scn = derive_scenario("gong_g2_500rpm", "gong_g2_500rpm", [("metrics.window_s", [0.0, 1.5])])
    out = tmp_path / "long_window.mcap"
    assert run_scenario(scn, out_path=out, progress=False).ok
    rec = read_for_check(out)
    per_cycle = {t: c for t, c in rec.topics.items() if t not in (ch.LINK_STATS, ch.EVENTS)}
    assert set(per_cycle) == {ch.PLANT_STATE, ch.PLANT_SENSE, ch.CONTROLLER_TELEMETRY, "/reference/SMO_TANH"}
    rows = {}
    for topic, cols in per_cycle.items():
        key = topic if topic in CHECK_FIELDS else "/reference/*"
        assert set(cols) == set(CHECK_FIELDS[key]), topic
        rows[topic] = len(cols["t_s"])
        assert all(len(v) == rows[topic] and v.itemsize == 8 for v in cols.values()), topic
    assert rows[ch.PLANT_STATE] == rows[ch.CONTROLLER_TELEMETRY] == 15000
    assert rows["/reference/SMO_TANH"] <= 15000
    kept = sum(v.nbytes for cols in per_cycle.values() for v in cols.values())
    assert sum(len(cols) for cols in per_cycle.values()) == 28
    assert kept == 8 * sum(len(cols) * rows[t] for t, cols in per_cycle.items())
    assert kept / 1.5 <= 28 * 8 * 10_000                  # 2.24 MB per second of window at 10 kHz
    full = load_recording(out)
    everything = sum(v.nbytes for t in per_cycle for v in full.topics[t].values())
    assert kept < 0.6 * everything   # and the topics it does not read at all come on top
    assert rec.estimator_counts == {3: 15000}             # SMO_TANH counted over the whole run


def test_check_fields_cover_every_field_the_metrics_name():
    """A metric that reads a field bench check does not keep would see it missing (the metric is
    then 'not measured'): every string in the modules that compute the check that names a field of
    a per-cycle topic is kept for that topic, or listed here with the reason it is not needed."""

    from hil_bench.papers.check import CHECK_FIELDS

    not_needed = {  # (topic key, field): why a literal of that name does not read this topic
        (ch.PLANT_STATE, "e_alpha_v"): "EMF metrics read the estimate (telemetry/reference)",
        (ch.PLANT_STATE, "e_beta_v"): "as e_alpha_v",
        (ch.PLANT_STATE, "i_b_a"): "phase b/c currents are read from /plant/sense (dual samples)",
        (ch.PLANT_STATE, "i_c_a"): "as i_b_a",
        (ch.PLANT_STATE, "v_dc_v"): "read from /plant/sense (estimator replay)",
        (ch.PLANT_STATE, "v_alpha_v"): "computed by estimator_trace from duties, not read",
        (ch.PLANT_STATE, "v_beta_v"): "as v_alpha_v",
        (ch.CONTROLLER_TELEMETRY, "estimator"): "counted over the whole run while streaming",
        (ch.CONTROLLER_TELEMETRY, "seq"): "no metric matches telemetry by seq",
        (ch.CONTROLLER_TELEMETRY, "state"): "no metric reads the controller state",
        ("/reference/*", "seq"): "no metric matches references by seq",
        (ch.PLANT_STATE, "torque_e_nm"): "read only in runs with [[faults]] (check.FAULT_FIELDS)",
    }
    literals = set()
    for module in ("claims", "metrics", "estimator_trace", "check"):
        source = inspect.getsourcefile(importlib.import_module(f"hil_bench.papers.{module}"))
        tree = ast.parse(Path(source).read_text())
        literals |= {n.value for n in ast.walk(tree) if isinstance(n, ast.Constant) and isinstance(n.value, str)}
    kinds = {ch.PLANT_STATE: "PLANT_STATE", ch.PLANT_SENSE: "SENSE", ch.CONTROLLER_TELEMETRY: "TELEMETRY",
             "/reference/*": "REFERENCE", ch.LINK_FRAMES: "FRAMES"}
    missing = [(topic, f) for topic, kind in kinds.items() for f in ch.LAYOUTS[kind].names
               if f in literals and f not in CHECK_FIELDS[topic] and (topic, f) not in not_needed]
    assert not missing, f"bench check does not keep {missing}: add them to CHECK_FIELDS"
