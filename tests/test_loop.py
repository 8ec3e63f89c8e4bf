"""The closed loop end to end: C stub on a pty, lockstep runner, MCAP recording, checker.

These tests run the real stub executable (build/bin/hil_stub, or $HIL_STUB).
"""
from __future__ import annotations

import json
import math
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader

from hil_bench.loop.links import LinkError, open_link
from hil_bench.loop.runner import RunAborted, Runner, run_scenario
from hil_bench.papers.check import check_recording
from hil_bench.record import channels as ch
from hil_bench.record.recorder import partial_path
from hil_bench.record.recording import load_recording
from hil_bench.scenario import load_scenario, parse_scenario
from tests.short_scenario import short_scenario, short_scenario_text

REPO = Path(__file__).resolve().parents[1]
ALL_TOPICS = {ch.PLANT_STATE, ch.PLANT_SENSE, ch.CONTROLLER_TELEMETRY, ch.LINK_FRAMES,
              ch.LINK_STATS, ch.EVENTS, ch.TIMING}


@pytest.fixture(scope="module")
def g2_run(tmp_path_factory):
    """One full G2 run (standstill -> 500 rpm) shared by the tests that read it."""
    out = tmp_path_factory.mktemp("g2") / "g2.mcap"
    result = run_scenario(load_scenario("gong_g2_500rpm"), out_path=out, progress=False)
    return result


def test_closed_loop_starts_and_holds_500rpm(g2_run):
    assert g2_run.ok, g2_run.error
    rec = load_recording(g2_run.recording)
    state = rec.topic(ch.PLANT_STATE)
    telem = rec.topic(ch.CONTROLLER_TELEMETRY)
    t = state["t_s"]
    assert state["speed_rpm"][0] == 0.0                       # from standstill
    last = t >= 1.0
    speed = state["speed_rpm"][last]
    assert np.all(np.abs(speed - 500.0) < 5.0), (speed.min(), speed.max())   # holds 500 rpm
    assert np.all(telem["state"][last] == 3)                 # CLOSED_LOOP, sensorless
    assert np.sqrt(np.mean(telem["pee_rad"][last] ** 2)) < 0.3
    # the controller went through align -> open loop -> closed loop, in that order
    events = rec.topic(ch.EVENTS)
    states = [str(x) for x, k in zip(events["text"], events["kind"]) if k == "controller_state"]
    assert states[:3] == ["ALIGN", "OPEN_LOOP", "CLOSED_LOOP"]


def test_recording_opens_with_crc_validation_and_every_channel_decodes(g2_run):
    """Every message decodes with google.protobuf from the file's own schema, and re-encodes to
    the same bytes with hil_bench.record.channels.encode_row: the C engine's encoder and the Python one
    agree byte for byte on every channel of a real run."""
    seen: dict[str, int] = {}
    with open(g2_run.recording, "rb") as f:
        reader = make_reader(f, validate_crcs=True)
        summary = reader.get_summary()
        assert summary is not None and summary.statistics.message_count > 0
        for schema, channel, message in reader.iter_messages():
            assert schema.encoding == "protobuf" and channel.message_encoding == "protobuf"
            cls = ch.message_class(schema.name, bytes(schema.data))
            msg = cls.FromString(message.data)
            kind = ch.kind_of_topic(channel.topic)
            values = [getattr(msg, n) for n in ch.LAYOUTS[kind].names]
            assert ch.encode_row(kind, values) == message.data, channel.topic
            seen[channel.topic] = seen.get(channel.topic, 0) + 1
        meta = {m.name: m.metadata for m in reader.iter_metadata()}
        attachments = [a.name for a in reader.iter_attachments()]
    assert ALL_TOPICS <= set(seen), seen
    cycles = g2_run.cycles_done
    for topic in (ch.PLANT_STATE, ch.PLANT_SENSE, ch.CONTROLLER_TELEMETRY, ch.TIMING):
        assert seen[topic] == cycles
    assert seen[ch.LINK_FRAMES] == cycles + 1        # + the set-up frames (handshake, config)
    run = meta["run"]
    assert run["git_revision"] and run["scenario"] == "gong_g2_500rpm"
    assert json.loads(run["plant_params"])["rs_ohm"] == pytest.approx(0.6383)
    assert any(a.startswith("scenario/") for a in attachments)
    assert any(a.startswith("profile/") for a in attachments)


def test_every_frame_is_recorded_both_ways(g2_run):
    rec = load_recording(g2_run.recording)
    frames = rec.topic(ch.LINK_FRAMES)
    setup_tx = frames["tx"][0].split()
    assert setup_tx[0].startswith("020#")            # HELLO first
    assert sum(1 for f in setup_tx if f.startswith("030#")) >= 8   # CONFIG: motor + scenario
    tx, rx = frames["tx"][1], frames["rx"][1]
    assert [f.split("#")[0] for f in tx.split()][-2:] == ["101", "100"]   # SENSE_AUX, SENSE last
    assert [f.split("#")[0] for f in rx.split()][-1] == "180"             # DUTY last


def test_check_recomputes_from_the_file_alone(g2_run, tmp_path):
    moved = tmp_path / "moved.mcap"
    moved.write_bytes(Path(g2_run.recording).read_bytes())
    report = check_recording(moved)
    ids = {r.claim.id for r in report.results}
    assert ids == {"G2"}
    measured = {r.quantity.metric: r.measured for r in report.results}
    assert math.isfinite(measured["speed_band_hat_rpm"])
    assert math.isfinite(measured["pee_max_rad"])
    assert report.summary["speed_mean_rpm"] == pytest.approx(500.0, abs=2.0)


@pytest.mark.parametrize("inject, expect", [
    # the silent stub still sends its idle heartbeats: alive, answering no SENSE (issue 19, 7);
    # found after the patience, which this test shortens to 1 s (what it tests is the silence)
    ("silent@500", "no DUTY(500) 1 s (patience_s) after its SENSE and 4 re-sends: "),
    # a controller that died is found at once, whatever the patience
    ("crash@500", "controller stub killed by signal"),
])
def test_dead_or_silent_stub_ends_the_run_naming_why(tmp_path, inject, expect):
    out = tmp_path / "dead.mcap"
    scn = short_scenario(2.0, extra="[link]\npatience_s = 1.0\n")
    result = Runner(scn, out_path=out, progress=False, stub_args=("--inject", inject)).run()
    assert result.error is not None and expect in result.error, result.error
    if inject.startswith("silent"):
        assert "HEARTBEAT_CTRL (the controller is alive, state" in result.error, result.error
    assert "at cycle 500" in result.error
    assert result.cycles_done == 500
    rec = load_recording(out)                         # finalised and readable
    assert rec.truncated is None
    assert len(rec.topic(ch.PLANT_STATE)["t_s"]) == 500
    assert rec.metadata["run_result"]["error"] == result.error


def test_a_late_controller_is_waited_for_and_its_rows_are_the_prompt_ones(tmp_path):
    """docs/protocol.md 6.5, late is not lost: the stub answers every 500th cycle 300 ms late
    (intact; ``--inject late``) at the default patience: the run completes, its recorded plant and
    controller rows are those of a prompt run, the late cycles are timing (late_answers, the /timing
    rows' retries and round trip), not a link problem, and --strict's integrity is clean."""
    from hil_bench.papers.check import check_recording

    prompt, late = tmp_path / "prompt.mcap", tmp_path / "late.mcap"
    assert Runner(short_scenario(0.3), out_path=prompt, progress=False).run().ok
    result = Runner(short_scenario(0.3), out_path=late, progress=False,
                    stub_args=("--inject", "late@100")).run()
    assert result.ok, result.error
    stats = result.link_stats
    # cycles 100, 600, ...: 6 late cycles, each re-sent at 50 and 150 ms and answered 3 times; a
    # busy host may make a prompt answer late too (seen: 13 re-sends beside other test runs):
    # timing as well, so the counts are at least those of the injected cycles
    assert stats["late_answers"] >= 6 and stats["lost_frames"] == 0, stats
    assert stats["retries"] >= 2 * 6 and stats["resend_answers"] >= 2 * 6, stats
    assert stats["duplicates"] == 0 and stats["seq_mismatch"] == 0, stats
    a, b = load_recording(prompt), load_recording(late)
    for topic in (ch.PLANT_STATE, ch.CONTROLLER_TELEMETRY):
        for col, values in a.topic(topic).items():
            np.testing.assert_array_equal(values, b.topic(topic)[col], err_msg=f"{topic}.{col}")
    timing = b.topic(ch.TIMING)
    injected = np.isin(timing["seq"], np.arange(100, 3000, 500))
    assert int(injected.sum()) == 6
    # re-sent at 50 and 150 ms before the 300 ms answer (a host that also stalls the stub may add
    # the next re-send, at 350 ms)
    assert np.all(timing["retries"][injected] >= 2) and np.all(timing["rtt_us"][injected] >= 300e3)
    integrity = check_recording(late).integrity
    assert integrity.ok and not integrity.problems, integrity.problems
    assert integrity.timing["late_answers"] == stats["late_answers"]


def test_a_lossy_link_completes_with_its_lost_frames_counted_as_a_link_problem(tmp_path):
    """1 % of the DUTY frames dropped on the way (a [[faults]] drop at probability 0.01): every
    cycle recovered by a re-send, each drop counted in lost_frames (not late), and the run's
    integrity names them a link problem (lost)."""
    from hil_bench.papers.check import check_recording

    text = short_scenario_text(0.3) + (
        "[[faults]]\nkind = \"drop\"\ndirection = \"from_controller\"\nmessage = \"DUTY\"\n"
        "probability = 0.01\ncount = 0\nt_s = 0.05\nuntil_s = 0.3\nseed = 7\n")
    out = tmp_path / "lossy.mcap"
    result = Runner(parse_scenario(text, Path("lossy.toml")), out_path=out, progress=False).run()
    assert result.ok, result.error
    stats = result.link_stats
    dropped = stats["faults_injected"]
    assert dropped >= 10 and stats["lost_frames"] == dropped, stats   # ~1 % of 2500 DUTY
    assert stats["cycles"] == 3000     # late answers: timing, a busy host may add some
    problems = [p for p in check_recording(out).integrity.problems if p.kind == "link"]
    assert [p.name for p in problems] == ["lost_frames"], problems
    assert f"lost_frames = {dropped} (lost)" in problems[0].text


def test_garbage_between_frames_is_counted_and_survived(tmp_path):
    out = tmp_path / "garbage.mcap"
    result = Runner(short_scenario(0.2), out_path=out, progress=False,
                            stub_args=("--inject", "garbage@100")).run()
    assert result.ok, result.error
    stats = result.link_stats
    assert stats["cycles"] == 2000
    assert stats["bytes_discarded"] + stats["cobs_errors"] + stats["crc_errors"] \
        + stats["length_errors"] > 0


def test_out_of_range_duty_is_refused_and_previous_duty_held(tmp_path):
    out = tmp_path / "badduty.mcap"
    result = Runner(short_scenario(0.1), out_path=out, progress=False,
                            stub_args=("--inject", "bad-duty@300")).run()
    assert result.ok, result.error
    assert result.link_stats["bad_duties"] == 1
    rec = load_recording(out)
    telem = rec.topic(ch.CONTROLLER_TELEMETRY)
    k = int(np.flatnonzero(telem["seq"] == 300)[0])
    assert telem["duty_a"][k] == telem["duty_a"][k - 1]      # held, never the bad value
    events = rec.topic(ch.EVENTS)
    assert "bad_duty" in list(events["kind"])


def test_link_budget_refuses_a_rate_that_cannot_fit(tmp_path):
    """Refused before anything starts: no recorder, no recording, the highest rate named."""
    master, slave = os.openpty()
    out = tmp_path / "budget.mcap"
    try:
        runner = Runner(short_scenario(0.1), link_spec=f"serial:{os.ttyname(slave)}@115200",
                        out_path=out, progress=False)
        with pytest.raises(RunAborted, match="10000 Hz control rate needed .* fits at most 154 Hz"):
            runner.run()
    finally:
        os.close(master)
        os.close(slave)
    assert not out.exists() and not partial_path(out).exists()


def test_unknown_link_spec_is_refused():
    with pytest.raises(LinkError, match="unknown link spec"):
        open_link("carrier-pigeon:1")


def test_ctrl_c_finalises_the_recording(tmp_path):
    out = tmp_path / "interrupted.mcap"
    scn = tmp_path / "long.toml"
    # 600 s of plant time (minutes of wall time): the run cannot end by itself before the Ctrl-C
    scn.write_text(short_scenario_text(600.0))
    # SIGINT at its default in the child whatever this process inherited: a test run started in
    # the background by a shell (`.ci/run &`) ignores SIGINT, the bench would inherit that and
    # Python would not install its KeyboardInterrupt handler (the Ctrl-C would go nowhere)
    proc = subprocess.Popen([sys.executable, "-m", "hil_bench", "run", str(scn), "--out", str(out),
                             "--no-progress"], cwd=REPO, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    # wait until cycles flow (the file grows past its header and first chunk)
    deadline = time.monotonic() + 60
    part = partial_path(out)                      # written under a temporary name until final
    while time.monotonic() < deadline and (not part.exists() or part.stat().st_size < 300_000):
        time.sleep(0.1)
    assert proc.poll() is None, f"the run ended before the Ctrl-C: {proc.communicate()}"
    proc.send_signal(signal.SIGINT)
    stdout, stderr = proc.communicate(timeout=60)
    assert proc.returncode == 130, stderr
    assert "interrupted by the user" in stderr
    rec = load_recording(out)
    assert rec.truncated is None                  # finalised: summary and footer written
    assert len(rec.topic(ch.PLANT_STATE)["t_s"]) > 100
    with open(out, "rb") as f:                    # the seeking reader needs the summary
        assert make_reader(f, validate_crcs=True).get_summary() is not None


def test_truncated_recording_keeps_what_was_written(g2_run, tmp_path):
    data = Path(g2_run.recording).read_bytes()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(data[: len(data) * 2 // 3])
    rec = load_recording(cut)
    assert rec.truncated is not None and "reading stopped at byte" in rec.truncated
    n = len(rec.topic(ch.PLANT_STATE)["t_s"])
    assert 0 < n < g2_run.cycles_done


def test_not_a_recording_is_a_clear_error(tmp_path):
    from hil_bench.record.recording import RecordingError

    bogus = tmp_path / "bogus.mcap"
    bogus.write_bytes(b"this is not an mcap file at all")
    with pytest.raises(RecordingError, match="not an MCAP file") as info:
        load_recording(bogus)
    assert not info.value.damaged      # nothing for `bench recover` to do (issue 19, item 7)


ASAN_STUB = REPO / "build-asan" / "bin" / "hil_stub"


@pytest.mark.skipif(not ASAN_STUB.exists(), reason="no sanitizer build (make sanitize)")
def test_stub_runs_clean_under_asan_and_ubsan(tmp_path, monkeypatch):
    monkeypatch.setenv("HIL_STUB", str(ASAN_STUB))
    monkeypatch.setenv("ASAN_OPTIONS", "abort_on_error=1:detect_leaks=1")
    monkeypatch.setenv("UBSAN_OPTIONS", "halt_on_error=1:print_stacktrace=1")
    runner = Runner(short_scenario(0.3), out_path=tmp_path / "asan.mcap", progress=False,
                            stub_args=("--inject", "garbage@1000"))
    result = runner.run()
    assert result.ok, result.error


def test_reference_estimator_runs_beside_the_controller_on_the_same_samples(g2_run):
    """The host's SMO_TANH (same C, same configuration: the bench sends the controller the
    library's settings, runner.estimator_defaults) sees exactly what the controller saw: its
    angle sits on the controller's telemetry. They are not bit-identical: the controller feeds its
    observer the float32 SVPWM voltage, the host the voltage rebuilt from the wire's 16-bit duties
    and 10 mV bus reading, so the bound is statistical: RMS < 0.01 rad after the hand-over."""
    from hil_bench.papers.metrics import wrap_pi

    rec = load_recording(g2_run.recording)
    telem = rec.topic(ch.CONTROLLER_TELEMETRY)
    ref = rec.topic(ch.REFERENCE_PREFIX + "SMO_TANH")
    idx = np.searchsorted(telem["t_s"], ref["t_s"])
    late = ref["t_s"] > 0.6
    d = wrap_pi(ref["theta_hat_rad"][late] - telem["theta_hat_rad"][idx][late])
    assert np.sqrt(np.mean(d ** 2)) < 0.01
    assert len(ref["t_s"]) >= g2_run.cycles_done - 2   # from the first cycle with two known voltages


def test_unknown_reference_estimator_is_refused_naming_the_field(tmp_path):
    text = short_scenario_text(0.1) + '\n[reference]\nestimators = ["NOPE"]\n'
    with pytest.raises(RunAborted, match="reference.estimators: unknown estimator 'NOPE'"):
        Runner(parse_scenario(text, Path("r.toml")), out_path=tmp_path / "r.mcap")
    text = short_scenario_text(0.1) + ('\n[reference]\nestimators = ["SMO_SIGN"]\n'
                                         '[reference.SMO_SIGN]\nwc_rad_s = 0.0\n')
    with pytest.raises(RunAborted, match="reference.SMO_SIGN: .*invalid configuration"):
        Runner(parse_scenario(text, Path("r.toml")), out_path=tmp_path / "r.mcap")


def test_recording_survives_the_bench_being_killed(tmp_path):
    """SIGKILL the bench mid-run: the recorder process sees its pipe close and finalises the
    file with everything it had received (summary and footer written)."""
    out = tmp_path / "killed.mcap"
    scn = tmp_path / "long.toml"
    scn.write_text(short_scenario_text(30.0))
    proc = subprocess.Popen([sys.executable, "-m", "hil_bench", "run", str(scn), "--out", str(out),
                             "--no-progress"], cwd=REPO, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + 20
    part = partial_path(out)
    while time.monotonic() < deadline and (not part.exists() or part.stat().st_size < 300_000):
        time.sleep(0.1)
    proc.kill()
    proc.wait(timeout=10)
    deadline = time.monotonic() + 20
    while time.monotonic() < deadline and not out.exists():   # the recorder finishes alone
        time.sleep(0.1)
    rec = load_recording(out)
    assert rec.truncated is None
    assert len(rec.topic(ch.PLANT_STATE)["t_s"]) > 100


def test_replay_reproduces_the_recorded_reference_estimator(g2_run):
    """hil_bench.replay rebuilds the reference estimators' inputs from the recorded topics (sensed
    currents, duties, bus voltage, t_d): the same C on the same inputs gives the same outputs."""
    from hil_bench.firmware_stub.estimators import REFERENCE_ESTIMATORS
    from hil_bench.papers.estimator_trace import replay
    from hil_bench.plant_rt.profile import load_profile

    rec = load_recording(g2_run.recording)
    est = REFERENCE_ESTIMATORS["SMO_TANH"](load_profile("gong2020"), 1e-4)
    r = replay(rec, est)
    ref = rec.topic(ch.REFERENCE_PREFIX + "SMO_TANH")
    idx = np.searchsorted(r.t_s, ref["t_s"])
    assert np.max(np.abs(np.angle(np.exp(1j * (r.theta_hat_rad[idx] - ref["theta_hat_rad"]))))) \
        < 1e-6
    assert np.max(np.abs(r.e_alpha_v[idx] - ref["e_alpha_v"])) < 1e-4
    # and what the recording lacks: the observer's current estimate. Gong's m = 0.01 observer
    # works in the linear part of tanh, so i_hat - i = e / (k m): 17.8 V / 19.7 V/A = 0.9 A
    late = r.t_s > 1.0
    d = np.hypot(r.i_hat_alpha_a[late] - r.i_alpha_a[late], r.i_hat_beta_a[late] - r.i_beta_a[late])
    assert np.mean(d) == pytest.approx(17.8 / 19.68, rel=0.05)
