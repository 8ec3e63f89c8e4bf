"""Real-time mode: the plant paced by the wall clock, on the same C engine as lockstep.

These tests assert what the loop does (speed reached and held, misses counted, the watchdog, the
recorder never blocking the engine), never how fast: the machines are shared and noisy. Timing
figures come from the benchmark (python -m bench.perf.loop, docs/performance.md). Where a test
must survive the noise of a loaded CI machine it says how (a tolerant miss limit).
"""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from bench import channels as ch
from bench.recorder import partial_path
from bench.recording import load_recording
from bench.runner import RunAborted, Runner, run_scenario
from bench.scenario import parse_scenario

REPO = Path(__file__).resolve().parents[1]

G2_RT = """
[scenario]
name = "g2_rt"
profile = "gong2020"
duration_s = {duration}
mode = "realtime"
[plant]
initial_theta_e_rad = 0.4
{plant}
[controller]
estimator = "SMO_SIGN"
speed_ref_rpm = 500
[controller.params]
IQ_MAX_A = 6.0
ALIGN_I_A = 3.0
ALIGN_TIME_S = 0.2
IF_I_A = 3.0
IF_ACCEL_RAD_S2 = 60.0
HANDOVER_SPEED_RAD_S = 20.0
SMO_K_V = 25.0
SMO_WC_RAD_S = 300.0
[realtime]
duty_update = "{update}"
max_consecutive_misses = {misses}
{extra}
[metrics]
window_s = [{w0}, {duration}]
"""


def rt_scenario(update="on_arrival", duration=1.5, rate_hz=10000, misses=1000, extra=""):
    plant = "" if rate_hz == 10000 else f"ts_s = {1.0 / rate_hz!r}"
    text = G2_RT.format(duration=duration, update=update, misses=misses, extra=extra,
                        plant=plant, w0=max(duration - 0.3, 0.0))
    return parse_scenario(text, Path("g2_rt.toml"))


#: a run in which more than this fraction of the periods were lost -- the bench itself was
#: descheduled for a whole period (rt_overruns), or the stub's answer came after its deadline
#: (missed_duty) -- says nothing about the loop: on a shared VM the hypervisor stops the guest
#: for milliseconds at a time (bench/perf/wakeup_latency: a lone SCHED_FIFO thread woken up to
#: 10 ms late) and a sensorless loop that loses 10 % of its duty updates degrades, as it would on
#: a drive. Such a run is repeated once, then skipped with its figures printed; the benchmark
#: (python -m bench.perf.loop) measures the machine. What the bench does with misses and lost
#: periods (counted, duties held, the watchdog) is asserted unconditionally below.
LOST_PERIODS_LIMIT = 0.01


def run_real_time(scn, out: Path, **kwargs):
    for attempt in (1, 2):
        if attempt == 2:
            out.unlink(missing_ok=True)
        result = run_scenario(scn, out_path=out, progress=False, force=True, **kwargs)
        t = result.timing
        lost = (t.get("overruns", 0) + t.get("missed", 0)) / max(result.cycles_done, 1)
        if lost <= LOST_PERIODS_LIMIT:
            return result
    pytest.skip(f"this machine could not keep real time: {lost:.1%} of the periods were lost "
                f"({t.get('overruns')} bench overruns, {t.get('missed')} missed duties; jitter "
                f"p99 {t.get('jitter_p99_us', 0):.0f} us) twice; see bench.perf.loop"
                + (f"; the run ended: {result.error}" if result.error else ""))


@pytest.mark.parametrize("rate_hz", [10000, 5000])
@pytest.mark.parametrize("update", ["on_arrival", "next_period"])
def test_real_time_closes_the_loop_and_holds_500_rpm(tmp_path, rate_hz, update):
    """The stub answers each SENSE (its ISR on SENSE arrival). A loaded CI machine may make the
    stub miss a deadline now and then: the miss limit is set high (1000) so the assertion is on
    the loop, and every miss is counted in the recording."""
    out = tmp_path / "rt.mcap"
    result = run_real_time(rt_scenario(update, rate_hz=rate_hz), out)
    assert result.ok, result.error
    assert result.mode == "realtime" and result.cycles_done == result.cycles_planned
    rec = load_recording(out)
    state = rec.topic(ch.PLANT_STATE)
    late = state["t_s"] >= 1.2
    speed = state["speed_rpm"][late]
    # held: the mean within 10 rpm and 90 % of the window within 20 rpm of 500 (a host stall of
    # a few ms that the loss limit lets through can still dip the speed briefly)
    assert abs(np.mean(speed) - 500.0) < 10.0, (speed.min(), speed.max())
    assert np.percentile(np.abs(speed - 500.0), 90) < 20.0, (speed.min(), speed.max())
    timing = rec.topic(ch.TIMING)
    assert len(timing["t_s"]) + result.timing["overruns"] == result.cycles_planned
    assert np.nanmedian(timing["rtt_us"]) > 0.0
    assert rec.run["mode"] == "realtime" and rec.run["duty_update"] == update


def test_free_running_controller_closes_the_loop(tmp_path):
    """The stub's ISR on its own timer (a drive's PWM interrupt), using the latest SENSE. The
    timer starts 40 us after the first SENSE arrives; a pty carries a frame one way in about
    20-60 us here, so at 5 kHz SENSE(k) is in before the tick and DUTY(k) back well before the
    period's deadline (at 10 kHz the two pty trips and the phase leave no room on this
    machine)."""
    out = tmp_path / "timer.mcap"
    scn = rt_scenario(rate_hz=5000, extra='stub_isr = "timer"\nstub_phase_us = 40')
    result = run_real_time(scn, out)
    assert result.ok, result.error
    speed = load_recording(out).topic(ch.PLANT_STATE)["speed_rpm"][-2000:]
    assert abs(np.mean(speed) - 500.0) < 10.0


def test_late_answers_are_counted_and_the_last_duties_held(tmp_path):
    """From cycle 1000 every answer comes 1.5 periods late (the stub falls further behind with
    each): every later period is a miss, the answers that come one period late are counted as
    late, the duties hold. The watchdog is set out of reach (it has its own test)."""
    out = tmp_path / "slow.mcap"
    for attempt in (1, 2):
        out.unlink(missing_ok=True)
        result = run_scenario(rt_scenario(duration=0.2, misses=1_000_000), out_path=out,
                              progress=False, force=True, stub_args=("--inject", "slow@1000"))
        timing = load_recording(out).topic(ch.TIMING)
        before = timing["seq"] < 1000
        lost = (np.count_nonzero(timing["missed"][before]) + result.timing["overruns"]) / 1000
        if result.ok or lost <= LOST_PERIODS_LIMIT:
            break
    else:
        pytest.skip(f"this machine could not keep real time before the injection: {lost:.1%} "
                    f"of the first 1000 periods lost twice ({result.error})")
    assert result.ok, result.error
    assert result.timing["late"] > 0 and result.timing["missed"] > 0
    rec = load_recording(out)
    timing = rec.topic(ch.TIMING)
    # the stub counts its own cycles: periods the bench lost (overruns) move its cycle 1000
    # later in seq; from the first miss after it on, every period is missed
    seq, missed = timing["seq"].astype(np.int64), timing["missed"].astype(bool)
    answered = seq[~missed]
    last_in_time = int(answered.max()) if len(answered) else -1
    assert last_in_time <= 1000 + result.timing["overruns"] + 1
    assert np.count_nonzero(seq > last_in_time) >= 100        # the rest of the run: all missed
    assert int(rec.topic(ch.LINK_STATS)["late_duty"][-1]) == result.timing["late"]


def test_silent_controller_drives_the_inverter_to_its_safe_state(tmp_path):
    """N = 10 consecutive misses: all gates off, FAULT_PLANT on the wire, the run ended within
    N + 1 periods of the controller going silent, the recording finalised. On a machine that
    stalls for N periods before the injected silence (a shared VM does), the watchdog trips on
    that streak instead: everything but the cycle it ended at is asserted the same way."""
    out = tmp_path / "silent.mcap"
    result = run_scenario(rt_scenario(duration=1.0, misses=10), out_path=out, progress=False,
                          stub_args=("--inject", "silent@1000"))
    assert result.end == "WATCHDOG", result.error
    assert "10 consecutive periods without a DUTY in time" in result.error
    assert "FAULT_PLANT WATCHDOG sent" in result.error
    rec = load_recording(out)
    assert rec.truncated is None and rec.unreadable_chunks == 0
    missed = rec.topic(ch.TIMING)["missed"].astype(bool)
    assert missed[-10:].all() and (len(missed) == 10 or not missed[-11])   # the streak: 10
    if result.cycles_done >= 1000:
        # periods the bench itself lost (overruns) count as cycles done but are no exchange
        assert 1010 <= result.cycles_done <= 1000 + 10 + 1 + result.timing["overruns"]
    frames = rec.topic(ch.LINK_FRAMES)
    assert any(f.startswith("010#") for f in str(frames["tx"][-1]).split())   # FAULT_PLANT
    telem = rec.topic(ch.CONTROLLER_TELEMETRY)
    assert telem["duty_a"][-1] == telem["duty_b"][-1] == telem["duty_c"][-1] == -1.0
    events = rec.topic(ch.EVENTS)
    assert "watchdog" in list(events["kind"])


@pytest.mark.parametrize("mode", ["realtime", "lockstep"])
def test_a_stopped_recorder_never_blocks_the_engine(tmp_path, mode):
    """SIGSTOP the recorder with a small ring: the engine goes on, counts every row it had to
    drop, and the recording says so."""
    scn = rt_scenario(duration=1.0)
    runner = Runner(scn, out_path=tmp_path / "stop.mcap", progress=False,
                    realtime=(mode == "realtime"), ring_bytes=1 << 20)
    stopped = {}

    def stopper():
        deadline = time.monotonic() + 20
        while time.monotonic() < deadline and (getattr(runner, "engine", None) is None
                                               or runner.engine.cycles_done < 500):
            time.sleep(0.001)
        pid = runner.rec.pid
        os.kill(pid, signal.SIGSTOP)
        stopped["at"] = runner.engine.cycles_done
        while runner.engine.running() and runner.engine.cycles_done < stopped["at"] + 3000:
            time.sleep(0.005)
        stopped["went_on_to"] = runner.engine.cycles_done
        os.kill(pid, signal.SIGCONT)

    th = threading.Thread(target=stopper)
    th.start()
    result = runner.run()
    th.join()
    if not result.ok and mode == "realtime":
        lost = (result.timing["missed"] + result.timing["overruns"]) / max(result.cycles_done, 1)
        if lost > LOST_PERIODS_LIMIT:
            pytest.skip(f"this machine could not keep real time: {lost:.1%} of the periods lost "
                        f"and the loop ended ({result.error}); see bench.perf.loop")
    assert result.ok, result.error
    assert stopped["went_on_to"] >= stopped["at"] + 3000 or result.cycles_done == 10000
    assert result.link_stats["rows_dropped"] > 0
    rec = load_recording(result.recording)
    assert int(rec.metadata["run_result"]["rows_dropped"]) == result.link_stats["rows_dropped"]
    assert len(rec.topic(ch.PLANT_STATE)["t_s"]) < result.cycles_done


def test_a_rate_the_link_cannot_carry_in_real_time_is_refused(tmp_path):
    master, slave = os.openpty()
    out = tmp_path / "budget.mcap"
    try:
        with pytest.raises(RunAborted, match="fits at most 154 Hz.*a real-time run cannot be "
                                             "slowed down"):
            run_scenario(rt_scenario(duration=0.1), link_spec=f"serial:{os.ttyname(slave)}@115200",
                         out_path=out, progress=False, allow_slow_link=True)
    finally:
        os.close(master)
        os.close(slave)
    assert not out.exists() and not partial_path(out).exists()


def test_real_time_setup_it_cannot_get_is_said_once_and_the_run_goes_on(tmp_path):
    """A CPU that does not exist: the engine says so (realtime_notes, an /events row) and runs."""
    out = tmp_path / "nocpu.mcap"
    result = run_scenario(rt_scenario(duration=0.2), out_path=out, progress=False, cpu=1023)
    assert result.ok, result.error
    assert "CPU pinning" in result.realtime_notes
    events = load_recording(out).topic(ch.EVENTS)
    notes = [t for k, t in zip(events["kind"], events["text"]) if k == "realtime_setup"]
    assert len(notes) == 1 and "CPU pinning" in notes[0]


def test_a_suspended_bench_ends_the_run_instead_of_pretending(tmp_path):
    """SIGSTOP the whole bench for 0.3 s (more than 100 periods): the engine does not fast-forward
    through the lost time as if nothing happened; it ends the run saying why."""
    scn = tmp_path / "rt.toml"
    scn.write_text(G2_RT.format(duration=3.0, update="on_arrival", misses=1000, extra="",
                                plant="", w0=2.0))
    out = tmp_path / "suspended.mcap"
    proc = subprocess.Popen([sys.executable, "-m", "bench", "run", str(scn), "--out", str(out),
                             "--no-progress"], cwd=REPO, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    part = partial_path(out)
    deadline = time.monotonic() + 20
    while time.monotonic() < deadline and (not part.exists() or part.stat().st_size < 200_000):
        time.sleep(0.05)
    proc.send_signal(signal.SIGSTOP)
    time.sleep(0.3)
    proc.send_signal(signal.SIGCONT)
    stdout, stderr = proc.communicate(timeout=30)
    assert proc.returncode == 1, stderr
    assert "the clock jumped or the engine was suspended" in stderr
    rec = load_recording(out)
    assert rec.truncated is None


def test_real_time_cpu_layout(monkeypatch):
    """Engine (and recorder) on the last allowed CPU, the stub on the first; what the scenario
    sets is kept; one CPU pins nothing (docs/realtime.md, "Where everything runs")."""
    from bench import runner as runner_mod

    monkeypatch.setattr(runner_mod.os, "sched_getaffinity", lambda pid: {0, 1, 2, 3})
    assert runner_mod.realtime_cpus(None, None) == (3, 0)
    assert runner_mod.realtime_cpus(2, None) == (2, 0)
    assert runner_mod.realtime_cpus(0, None) == (0, 1)
    assert runner_mod.realtime_cpus(None, 3) == (0, 3)
    assert runner_mod.realtime_cpus(1, 2) == (1, 2)
    monkeypatch.setattr(runner_mod.os, "sched_getaffinity", lambda pid: {5})
    assert runner_mod.realtime_cpus(None, None) == (None, None)
    scn = rt_scenario(duration=0.1)
    monkeypatch.setattr(runner_mod.os, "sched_getaffinity", lambda pid: {0, 1})
    r = Runner(scn, progress=False)
    assert r.cpu == 1 and r._recorder_cpus() == (1,) and r._stub_cpu() == 0
    lock = Runner(parse_scenario(G2_RT.format(duration=0.1, update="on_arrival", misses=10,
                                              extra="", plant="", w0=0.0)
                                 .replace('mode = "realtime"', 'mode = "lockstep"'),
                                 Path("lock.toml")), progress=False)
    assert lock.cpu is None and lock._recorder_cpus() == () and lock._stub_cpu() is None
