"""bench replay (docs/replay.md): every input kind, every mode, damaged captures.

The example captures (examples/captures/, tools/make_example_captures.py) are one bench run of
examples/captures/replay_example.toml recorded as MCAP, serial byte capture, candump log and a
5 kHz DAQ CSV; replaying them must give back the recording's own numbers.
"""
from __future__ import annotations

import gzip
import math
import shutil
from pathlib import Path

import numpy as np
import pytest

from hil_bench.plant_rt.profile import load_profile
from hil_bench.protocol.messages import Param
from hil_bench.record.recording import load_recording
from hil_bench.record.serial_capture import MAGIC, RECORD, read_records
from hil_bench.replay import CaptureError, ReplayOptions, read_capture, run_replay

EX = Path(__file__).resolve().parents[1] / "examples" / "captures"
REF = {"SMO_SIGN": {"k_v": 25.0, "wc_rad_s": 300.0}}   # the example scenario's [reference]
N_CYCLES = 500            #: the example run: 0.3 s at Ts = 600 us
WINDOW = (0.22, 0.3)      #: its metrics window (the estimate has settled)
FIRST_DIVERGENCE = 245    #: SMO_K_V 25 -> 35 (docs/replay.md "Tolerances")


def _opts(tmp_path, name, **kw):
    kw.setdefault("estimators", list(REF))
    kw.setdefault("est_config", REF)
    kw.setdefault("profile", "gong2020")
    return ReplayOptions(out=tmp_path / f"{name}.mcap", **kw)


def _ref(path, name="SMO_SIGN"):
    return load_recording(path, topics=[f"/reference/{name}"]).topics[f"/reference/{name}"]


def _same(a, b, fields=("t_s", "seq", "theta_hat_rad", "omega_hat_rad_s", "e_alpha_v",
                        "e_beta_v")):
    return all(np.array_equal(a[f], b[f], equal_nan=True) for f in fields)


# -- offline -------------------------------------------------------------------------------------

def test_mcap_offline_is_bit_identical(tmp_path):
    """A bench recording replayed offline gives its own reference-estimator rows, bit for bit
    (same build), and the new file passes bench check like a live run."""
    cap = read_capture(EX / "example.mcap")
    res = run_replay(cap, ReplayOptions(out=tmp_path / "o.mcap"))   # the scenario's estimators
    assert res.ok and res.cycles == cap.n == N_CYCLES
    a, b = _ref(EX / "example.mcap"), _ref(res.out)
    assert len(a["t_s"]) == len(b["t_s"]) > N_CYCLES - 5
    assert _same(a, b, a.keys())
    from hil_bench.papers.check import check_recording

    rep = check_recording(res.out)
    assert rep.summary["ref_SMO_SIGN_pee_rms_rad"] == pytest.approx(
        check_recording(EX / "example.mcap").summary["ref_SMO_SIGN_pee_rms_rad"], rel=0, abs=0)


@pytest.mark.parametrize("name", ["example.serial.bin", "example.log.gz"])
def test_frame_captures_offline_equal_the_recording(tmp_path, name):
    """The serial byte capture and the candump log of the same run (python-can's Logger wrote
    it) replay offline to the same estimates as the recording, and carry its encoder angle."""
    cap = read_capture(EX / name)
    assert cap.ts_s == pytest.approx(600e-6) and cap.n == N_CYCLES and cap.has_theta
    res = run_replay(cap, _opts(tmp_path, "o", window_s=WINDOW))
    assert res.ok
    assert _same(_ref(EX / "example.mcap"), _ref(res.out))
    m = res.metrics["SMO_SIGN"]       # against the 16-bit encoder angle, not the plant's truth
    mc = run_replay(read_capture(EX / "example.mcap"), _opts(tmp_path, "m", window_s=WINDOW))
    # the same estimates; the truth they are measured against differs by the encoder's 16-bit
    # quantisation (2 pi / 65536 = 9.6e-5 rad) from the plant's angle in the MCAP
    assert m["pee_rms_rad"] == pytest.approx(mc.metrics["SMO_SIGN"]["pee_rms_rad"], abs=9.6e-5)


def test_candump_written_by_python_can_logger_replays(tmp_path):
    """A plain candump .log (python-can's can.Logger) of the frames replays; unknown ids, wrong
    lengths, remote frames and 29-bit ids are counted, never decoded."""
    import can

    src = list(can.LogReader(str(EX / "example.log.gz")))
    out = tmp_path / "bus.log"
    with can.Logger(str(out)) as lg:
        for i, m in enumerate(src):
            lg.on_message_received(m)
            if i == 100:
                lg.on_message_received(can.Message(timestamp=m.timestamp, arbitration_id=0x555,
                                                   data=b"\x01\x02", is_extended_id=False))
                lg.on_message_received(can.Message(timestamp=m.timestamp, arbitration_id=0x100,
                                                   data=b"\x01\x02", is_extended_id=False))
                lg.on_message_received(can.Message(timestamp=m.timestamp,
                                                   arbitration_id=0x18FF0000, data=b"\x00" * 8))
    cap = read_capture(out)
    an = cap.anomalies.as_dict()
    assert an["unknown_ids"] == 1 and cap.anomalies.unknown_id_counts[0x555] == 1
    assert an["wrong_length"] == 1 and an["not_protocol"] == 1
    res = run_replay(cap, _opts(tmp_path, "o"))
    assert res.ok and res.cycles == N_CYCLES
    assert _same(_ref(EX / "example.mcap"), _ref(res.out))


def test_csv_example_matches_its_recording(tmp_path):
    """The 5 kHz DAQ export, resampled onto the 600 us grid, gives the recording's duties exactly,
    its currents within 0.1 A RMS, and its metrics within the stated tolerance (docs/replay.md:
    PEE RMS 20 %, mean estimated speed 5 %, twice the largest differences measured over the
    settled part of the run)."""
    prof = load_profile("gong2020")
    cap = read_capture(EX / "example_daq.csv", mapping=EX / "example_daq.toml", profile=prof)
    assert cap.resampling["daq_rate_hz"] == pytest.approx(5000.0)
    rec = read_capture(EX / "example.mcap")
    i = np.searchsorted(rec.rows["t_s"], cap.rows["t_s"])
    assert np.array_equal(rec.rows["t_s"][i], cap.rows["t_s"])
    assert np.array_equal(rec.rows["duty_raw"][i], cap.rows["duty_raw"])
    err = cap.rows["i_abc_a"] - rec.rows["i_abc_a"][i]
    assert np.sqrt(np.mean(err ** 2)) < 0.1
    a = run_replay(cap, _opts(tmp_path, "csv", window_s=WINDOW)).metrics["SMO_SIGN"]
    b = run_replay(rec, _opts(tmp_path, "rec", window_s=WINDOW)).metrics["SMO_SIGN"]
    assert a["pee_rms_rad"] == pytest.approx(b["pee_rms_rad"], rel=0.20)
    assert a["speed_hat_mean_rpm"] == pytest.approx(b["speed_hat_mean_rpm"], rel=0.05)


def test_mapping_naming_a_missing_column(tmp_path):
    m = (EX / "example_daq.toml").read_text().replace('"Ib [mA]"', '"I_b (mA)"')
    (tmp_path / "m.toml").write_text(m)
    with pytest.raises(CaptureError, match=r"signals\.i_b\.column: column 'I_b \(mA\)' is not in"):
        read_capture(EX / "example_daq.csv", mapping=tmp_path / "m.toml")


# -- into a controller ----------------------------------------------------------------------------

def test_controller_reproduces_the_recorded_duties(tmp_path):
    cap = read_capture(EX / "example.mcap")
    res = run_replay(cap, ReplayOptions(mode="controller", out=tmp_path / "c.mcap"))
    assert res.ok, res.error
    c = res.compare
    assert c["cycles"] == N_CYCLES and "first_divergence" not in c
    assert all(f["differ"] == 0 for f in c["fields"].values())


@pytest.mark.parametrize("name", ["example.mcap", "example.serial.bin", "example.log.gz"])
def test_controller_with_a_changed_gain_diverges(tmp_path, name):
    """The same stub told another observer gain (CONFIG SMO_K_V, as a rebuilt firmware with
    another constant would have it) answers differently: the first divergence is reported, the
    same cycle from each kind of capture of the run (the figure docs/replay.md gives)."""
    cap = read_capture(EX / name)
    res = run_replay(cap, _opts(tmp_path, "c", mode="controller", estimators=None, est_config={},
                                set_params={Param.SMO_K_V: 35.0}))
    assert res.ok, res.error
    fd = res.compare["first_divergence"]
    assert fd["row"] == fd["cycle_seq"] == FIRST_DIVERGENCE and fd["recorded"] != fd["now"]
    assert res.compare["fields"]["duty_a"]["differ"] > 0
    assert res.compare["fields"]["state"]["compared"] == N_CYCLES


def test_controller_fault_in_a_replay_is_named(tmp_path):
    """With SMO_K_V = 30 the stub's estimate loses the recorded rotor and its stall check trips
    (the recorded current at the limit, its own speed estimate making no progress): the replay
    ends there and says which fault, at which cycle, with its detail, as a closed-loop run does."""
    cap = read_capture(EX / "example.mcap")
    res = run_replay(cap, _opts(tmp_path, "c", mode="controller", estimators=None, est_config={},
                                set_params={Param.SMO_K_V: 30.0}))
    assert not res.ok and res.cycles < N_CYCLES
    assert "controller reported fault STALL at seq" in res.error, res.error
    assert res.compare["first_divergence"]["row"] == FIRST_DIVERGENCE


def test_controller_compares_telemetry_and_emf(tmp_path):
    """A run with TELEM_EMF replayed into the same build: state, estimator and the EMF fields
    are compared in every cycle and equal; with another gain the EMF differs too."""
    from hil_bench.loop.runner import run_scenario
    from hil_bench.scenario import load_scenario

    scn = (EX / "replay_example.toml").read_text().replace("telemetry_emf = false",
                                                           "telemetry_emf = true")
    scn = scn.replace("duration_s = 0.3", "duration_s = 0.2").replace("[0.22, 0.3]", "[0.1, 0.2]")
    (tmp_path / "emf.toml").write_text(scn)
    run = run_scenario(load_scenario(tmp_path / "emf.toml"), out_path=tmp_path / "emf.mcap",
                       progress=False)
    assert run.ok, run.error
    cap = read_capture(tmp_path / "emf.mcap")
    same = run_replay(cap, ReplayOptions(mode="controller", out=tmp_path / "same.mcap"))
    assert same.ok, same.error
    f = same.compare["fields"]
    n = same.compare["cycles"]
    for name in ("state", "estimator", "e_alpha", "e_beta", "i_q_ref"):
        assert f[name]["compared"] == n and f[name]["differ"] == 0, name
    other = run_replay(cap, ReplayOptions(mode="controller", out=tmp_path / "other.mcap",
                                          set_params={Param.SMO_K_V: 30.0}))
    assert other.compare["fields"]["e_alpha"]["differ"] > 0


# -- into the plant -------------------------------------------------------------------------------

def test_plant_reproduces_the_recorded_currents(tmp_path):
    res = run_replay(read_capture(EX / "example.mcap"),
                     ReplayOptions(mode="plant", out=tmp_path / "p.mcap"))
    assert res.ok
    assert all(p["rms_error_a"] == 0.0 for p in res.compare["phases"].values())


def test_plant_from_a_can_log_and_another_motor(tmp_path):
    """From the CAN log (initial angle from its encoder) the plant follows closely; a plant with
    another resistance does not (the comparison can fail)."""
    cap = read_capture(EX / "example.log.gz")
    good = run_replay(cap, _opts(tmp_path, "p1", mode="plant", estimators=None, est_config={}))
    assert max(p["rms_error_a"] for p in good.compare["phases"].values()) < 0.01
    prof = tmp_path / "other.toml"
    prof.write_text((Path(load_profile("gong2020").path)).read_text()
                    .replace("rs_ohm = 0.6383", "rs_ohm = 1.2"))
    bad = run_replay(cap, _opts(tmp_path, "p2", mode="plant", estimators=None, est_config={},
                                profile=str(prof)))
    assert max(p["rms_error_a"] for p in bad.compare["phases"].values()) > 0.05


# -- timing ---------------------------------------------------------------------------------------

def test_paced_replay_reports_the_pacing_error(tmp_path):
    cap = read_capture(EX / "example.mcap")
    res = run_replay(cap, _opts(tmp_path, "r", rate=1.0))
    assert res.ok
    assert res.pacing["pace_s"] == pytest.approx(600e-6)
    assert math.isfinite(res.pacing["start_err_p99_us"]) and res.wall_s >= 0.29
    st = load_recording(res.out, topics=["/timing"]).topics["/timing"]
    assert np.isfinite(st["start_err_us"]).all()


def _subset(cap, keep):
    """The capture with only the rows ``keep`` (a gap where rows are left out)."""
    cap.rows = cap.rows[keep]
    cap.telem = {k: v[keep] for k, v in cap.telem.items()}
    if cap.state is not None:
        cap.state = {k: v[keep] for k, v in cap.state.items()}
    if cap.frames_text is not None:
        cap.frames_text = tuple([x[i] for i in keep] for x in cap.frames_text)
    return cap


def test_pacing_follows_the_recorded_times(tmp_path):
    """Paced, a row starts at its recorded time / rate: a gap of 300 cycles in the capture is a
    pause of 0.18 s / rate, not of one period (a lower bound of the wall time: a loaded machine
    only makes it longer)."""
    cap = read_capture(EX / "example.mcap")
    cap = _subset(cap, np.r_[0:100, 400:cap.n])
    span = float(cap.rows["t_s"][-1] - cap.rows["t_s"][0])
    res = run_replay(cap, _opts(tmp_path, "r", rate=2.0))
    assert res.ok and res.cycles == 200
    assert res.wall_s >= span / 2.0


def test_plant_steps_through_a_gap(tmp_path):
    """A cycle missing in the capture: the plant steps through it with the last duties held
    (counted as a missed duty, said in the notes), so the rows after the gap keep the recorded
    times; before the gap the currents are the recorded ones exactly."""
    import json

    cap = read_capture(EX / "example.mcap")
    cap = _subset(cap, np.r_[0:200, 201:cap.n])
    res = run_replay(cap, ReplayOptions(mode="plant", out=tmp_path / "p.mcap"))
    assert res.ok, res.error
    assert any("1 cycle(s) missing" in n for n in res.notes)
    rp = load_recording(res.out, topics=["/replay/plant"]).topics["/replay/plant"]
    assert len(rp["t_s"]) == N_CYCLES
    assert np.isnan(rp["i_a_rec_a"][200]) and np.isfinite(rp["i_a_a"][200])
    rec = np.isfinite(rp["i_a_rec_a"])
    assert np.array_equal(rp["t_s"][rec], cap.rows["t_s"])
    assert np.array_equal(rp["i_a_a"][:200], rp["i_a_rec_a"][:200])
    counters = json.loads(load_recording(res.out, topics=()).metadata["run_result"]["counters"])
    assert counters["missed_duty"] == 1


# -- damaged captures -----------------------------------------------------------------------------

def test_truncated_serial_capture(tmp_path):
    data = (EX / "example.serial.bin").read_bytes()
    cut = tmp_path / "cut.serial.bin"
    cut.write_bytes(data[: len(data) // 2 + 5])
    cap = read_capture(cut)
    assert any("truncated record" in p and str(cut) in p and "byte" in p for p in cap.problems)
    assert 0.4 * N_CYCLES < cap.n < 0.6 * N_CYCLES
    res = run_replay(cap, _opts(tmp_path, "o"))
    a, b = _ref(EX / "example.mcap"), _ref(res.out)
    n = len(b["t_s"])
    assert all(np.array_equal(a[f][:n], b[f], equal_nan=True) for f in ("theta_hat_rad", "t_s"))


def test_corrupt_serial_capture(tmp_path):
    """Octets flipped inside one record: the frames there fail their CRC (counted with the byte
    offset), the cycles around them replay; a corrupt record header stops the reading there."""
    data = bytearray((EX / "example.serial.bin").read_bytes())
    recs = list(read_records(EX / "example.serial.bin", []))
    victim = recs[len(recs) // 3]
    for j in range(RECORD.size + 3, RECORD.size + 9):
        data[victim.offset + j] ^= 0x5A
    bad = tmp_path / "bad.serial.bin"
    bad.write_bytes(bytes(data))
    cap = read_capture(bad)
    an = cap.anomalies.as_dict()
    assert an["damaged"] >= 1 and (an["drops"] + an["gaps"]) >= 1
    assert any(f"byte {victim.offset}" in t for _k, _t, t in cap.anomalies.details)
    assert cap.n >= N_CYCLES - 10
    last = recs[2 * len(recs) // 3]
    data[last.offset + 8] = 7      # direction 7: not a record header
    bad.write_bytes(bytes(data))
    cap = read_capture(bad)
    assert any(f"byte {last.offset}: corrupt record header" in p for p in cap.problems)
    assert run_replay(cap, _opts(tmp_path, "o2")).ok


def test_truncated_and_corrupt_candump(tmp_path):
    """A bad line in a candump log costs that line only (python-can's reader resumes after it,
    the line number is reported); a last line cut in the middle is said and left out."""
    text = gzip.decompress((EX / "example.log.gz").read_bytes()).decode().splitlines()
    n_bad = 1000
    bad = text[:n_bad] + ["(1795503179.0) hil0 10#ZZZZ R"] + text[n_bad:]
    bad[-1] = bad[-1][:25]       # the last line cut in the middle
    p = tmp_path / "bad.log"
    p.write_text("\n".join(bad))
    cap = read_capture(p)
    assert any(str(p) in x and "1 damaged line(s)" in x and f"line {n_bad + 1})" in x
               for x in cap.problems)
    assert any(f"file ends inside line {len(bad)}" in x for x in cap.problems)
    assert cap.anomalies.as_dict()["damaged"] == 2
    assert cap.n == N_CYCLES        # the cut line is the last DUTY: the cycle is there, its DUTY not
    assert run_replay(cap, _opts(tmp_path, "o")).ok


def test_truncated_mcap_replays_what_is_intact(tmp_path):
    data = (EX / "example.mcap").read_bytes()
    p = tmp_path / "cut.mcap"
    p.write_bytes(data[: int(len(data) * 0.6)])
    cap = read_capture(p)
    assert cap.problems and str(p) in cap.problems[0] and "byte" in cap.problems[0]
    assert 0 < cap.n < N_CYCLES
    res = run_replay(cap, ReplayOptions(out=tmp_path / "o.mcap"))
    a, b = _ref(EX / "example.mcap"), _ref(res.out)
    n = len(b["t_s"])
    assert n > 0 and all(np.array_equal(a[f][:n], b[f], equal_nan=True) for f in a)


def test_not_a_capture(tmp_path):
    p = tmp_path / "x.log"
    p.write_text("(1.0) can0 555#0102\n(1.1) can0 7FF#\n")
    with pytest.raises(CaptureError, match="no control cycle") as e:
        read_capture(p)
    assert "unknown_ids 2" in str(e.value)


def test_gaps_duplicates_out_of_order_counted(tmp_path):
    """A SENSE group dropped, one repeated and one moved back: each counted per kind."""
    import can

    msgs = list(can.LogReader(str(EX / "example.log.gz")))
    sense = [i for i, m in enumerate(msgs) if m.arbitration_id == 0x100]
    drop = set(range(sense[200] - 1, sense[200] + 3))        # AUX, SENSE, TELEM, DUTY of a cycle
    out = []
    for i, m in enumerate(msgs):
        if i in drop:
            continue
        out.append(m)
        if i == sense[300]:
            out.append(m)                                     # SENSE again (a re-send)
        if i == sense[400]:
            out.append(msgs[sense[390]])                      # an old SENSE, late
    p = tmp_path / "g.log"
    with can.Logger(str(p)) as lg:
        for m in out:
            lg.on_message_received(m)
    cap = read_capture(p)
    an = cap.anomalies.as_dict()
    assert an["gaps"] == 1 and an["cycles_missing"] == 1
    assert an["duplicates"] >= 1 and an["out_of_order"] >= 1
    assert cap.n == N_CYCLES - 1
    res = run_replay(cap, _opts(tmp_path, "o"))
    ev = load_recording(res.out, topics=["/events"]).topics["/events"]
    kinds = set(ev["kind"])
    assert {"capture_gaps", "capture_duplicates", "capture_out_of_order"} <= kinds


def test_cli_replay(tmp_path, capsys):
    from hil_bench.cli import main

    rc = main(["replay", str(EX / "example.serial.bin"), "--profile", "gong2020",
               "--estimators", "SMO_SIGN", "--est-config", "SMO_SIGN.k_v=25",
               "--est-config", "SMO_SIGN.wc_rad_s=300", "--out", str(tmp_path / "o.mcap")])
    assert rc == 0
    out = capsys.readouterr().out
    assert f"replayed {N_CYCLES}/{N_CYCLES} cycles (offline)" in out and "SMO_SIGN" in out
    assert main(["replay", str(EX / "example.serial.bin"), "--out", str(tmp_path / "o.mcap")]) == 2


def test_readme_replay_commands(tmp_path, monkeypatch, capsys):
    """Every `bench replay` command of the README's "Replaying captures", as written, run from
    examples/captures (only --out added): each succeeds, and the figure the README gives (the
    first divergence) is what the controller replay reports."""
    import shlex

    from hil_bench.cli import main

    text = (EX.parents[1] / "README.md").read_text()
    sec = text[text.index("## Replaying captures"):]
    start = sec.index("```sh") + len("```sh")
    block = sec[start:sec.index("```", start)].replace("\\\n", " ")
    cmds = [shlex.split(line.partition("  #")[0]) for line in block.splitlines()
            if "bench replay" in line]
    assert len(cmds) == 5
    monkeypatch.chdir(EX)
    for i, c in enumerate(cmds):
        assert c[:2] == ["../../.venv/bin/bench", "replay"], c
        assert main(c[1:] + ["--out", str(tmp_path / f"{i}.mcap")]) == 0, c
    out = capsys.readouterr().out
    assert f"first divergence at cycle seq {FIRST_DIVERGENCE}" in out
    assert "SMO_SIGN: the capture's CONFIG: k_v = 25, wc_rad_s = 300" in out.replace("\n", " ")
