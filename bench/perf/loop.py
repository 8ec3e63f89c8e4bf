"""Benchmark of the cycle engine: lockstep against the pty's own round trip, real time, recorder.

    python -m hil_bench.perf.loop [--quick] [--no-can] [--engine-cpu N] [--stub-cpu N]
    python -m hil_bench.perf.loop --soak 10          # 10-minute lockstep run: memory of every process
    python -m hil_bench.perf.loop --soak-realtime 10 # 10 minutes real time (5 kHz): memory, every miss explained
    python -m hil_bench.perf.loop --quick --tuned    # adds 10 kHz real time with the tuned set-up

Everything is measured in one run on one machine, and compared as ratios:

1. ``pty_ceiling_per_s``: two C processes exchange one cycle's bytes over a pty (30 octets up:
   SENSE_AUX + SENSE; 45 down: TELEM + TELEM_EMF + DUTY) -- the floor under any lockstep cycle;
2. lockstep on the engine against the C stub, G2 scenario (10 kHz, one reference estimator),
   recording on (``lockstep_recorded_per_s``) and off (``lockstep_unrecorded_per_s``); the rate
   is cycles over the engine's own wall time (set-up excluded);
3. real time at 5, 10 and 20 kHz against the stub (its ISR on SENSE arrival), G2 scenario,
   recording on, the default CPU layout: the period start error (jitter) percentiles and the
   deadline-miss rate; then 5 kHz once more with the recorder on the stub's CPU instead of the
   engine's (the layout the default replaced);
4. ``recorder_msgs_per_s``: how fast the recorder process turns ring records into MCAP messages
   (G2 rows, alone on the machine's second core);
5. the CAN paths (unless --no-can): lockstep over python-can's slcan and socketcand interfaces
   through the engine's bridge, at the period classic CAN carries (600 us).

6. with ``--tuned``, 10 kHz real time once more with the set-up of docs/realtime.md: engine and
   stub each pinned to a core, the engine spinning through the whole period, both polling
   without sleeping (``busy_wait``), and, when run as root, the kernel's real-time throttling
   lifted for the run (``/proc/sys/kernel/sched_rt_runtime_us`` = -1, restored afterwards).

``--quick`` keeps the whole run under a minute (real-time runs of 3 s); the full run uses 60 s
real-time runs. The last line printed is one JSON object with every figure. The figures in
docs/performance.md come from this script, with the date, the machine and the command.
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

from hil_bench.protocol import budget
from hil_bench.protocol.messages import HelloFlag

G2 = """
[scenario]
name = "perf_loop"
profile = "gong2020"
duration_s = {duration}
mode = "{mode}"
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
[reference]
estimators = ["SMO_SIGN"]
[reference.SMO_SIGN]
k_v = 25.0
wc_rad_s = 300.0
[realtime]
max_consecutive_misses = 1000000
{realtime}
[metrics]
window_s = [0.0, {duration}]
"""

#: the CAN runs: the period classic CAN at 1 Mbit/s carries, 4 frames per cycle (no TELEM_EMF)
CAN_TS_S = budget.can_fit_period_us(1_000_000, 0) * 1e-6
CAN_LINKS = ("stub-slcan", "stub-socketcand")


def scenario(duration_s: float, mode: str = "lockstep", rate_hz: float = 10000.0,
             realtime: str = "", telemetry_emf: bool = True, estimator: str = "SMO_SIGN",
             params: str = "", speed_rpm: float = 500.0):
    from hil_bench.scenario import parse_scenario

    plant = "" if rate_hz == 10000.0 else f"ts_s = {1.0 / rate_hz!r}"
    text = G2.format(duration=duration_s, mode=mode, plant=plant, realtime=realtime)
    if estimator != "SMO_SIGN":
        text = text.replace('estimator = "SMO_SIGN"', f'estimator = "{estimator}"')
    if params:
        text = text.replace("[controller.params]", f"[controller.params]\n{params}")
    if not telemetry_emf:
        text = text.replace('speed_ref_rpm = 500', 'speed_ref_rpm = 500\ntelemetry_emf = false')
    if speed_rpm != 500.0:
        text = text.replace("speed_ref_rpm = 500", f"speed_ref_rpm = {speed_rpm!r}")
    return parse_scenario(text, Path("perf_loop.toml"))


def pty_ceiling(iterations: int) -> dict:
    from hil_bench.installation import find_executable

    try:
        exe = find_executable("pty_pingpong")
    except FileNotFoundError as exc:
        sys.exit(str(exc))
    up = budget.serial_frame_bytes(8) * 2                        # SENSE_AUX + SENSE
    down = budget.serial_frame_bytes(8) * 3                      # TELEM + TELEM_EMF + DUTY
    out = subprocess.run([str(exe), str(iterations), str(up), str(down)], capture_output=True,
                         text=True, check=True).stdout
    return json.loads(out)


def run(scn, *, link: str = "stub", record: bool = True, cpu: int | None = None,
        stub_args: tuple[str, ...] = (), watch=None,
        recorder_cpus: tuple[int, ...] | None = None, stop_ok: bool = False) -> dict:
    from hil_bench.loop.runner import Runner

    with tempfile.TemporaryDirectory() as tmp:
        r = Runner(scn, link_spec=link, out_path=Path(tmp) / "perf.mcap", progress=False,
                   record=record, cpu=cpu, stub_args=stub_args, recorder_cpus=recorder_cpus)
        if watch is not None:
            th = threading.Thread(target=watch, args=(r,), daemon=True)
            th.start()
        result = r.run()
        size = result.recording.stat().st_size if result.recording.exists() else 0
    if result.error and scn.mode != "realtime" and not (stop_ok and result.end == "STOPPED"):
        sys.exit(f"{scn.mode} run over {link} failed: {result.error}")
    out = {"cycles": result.cycles_done, "engine_s": result.engine_s, "error": result.error,
           "cycles_per_s": result.cycles_done / result.engine_s, "record": record,
           "link": link, "mode": result.mode, "file_bytes": size,
           "rows_dropped": result.link_stats.get("rows_dropped", 0),
           "realtime_notes": result.realtime_notes, "engine_cpu": r.cpu,
           "stub_cpu": r._stub_cpu(), "recorder_cpus": list(r._recorder_cpus())}
    out.update(result.timing)
    return out


def recorder_rate(messages: int) -> dict:
    """Messages per second the recorder process writes: G2 rows pushed into the ring as fast as
    Python can, while the recorder drains them; time until the file is finalised."""
    from hil_bench.record import channels as ch
    from hil_bench.record.recorder import ProcessRecorder

    rows = {
        "PLANT_STATE": ch.encode_row("PLANT_STATE", [0.1234] * len(ch.PLANT_STATE_VALUES)),
        "SENSE": ch.encode_row("SENSE", (0.1, 7, 1.1, -0.5, -0.6, 310.0, float("nan"))),
        "TELEMETRY": ch.encode_row("TELEMETRY", (0.1, 7, 1.2, 200.0, 500.0, 3, 1, 1.0, 2.0, 0.5,
                                                 0.5, 0.4, 0.6, 0.01)),
        "TIMING": ch.encode_row("TIMING", {"t_s": 0.1, "seq": 7, "rtt_us": 20.0,
                                           "cycle_us": 30.0}),
        "REFERENCE": ch.encode_row("REFERENCE", (0.1, 7, 1.2, 200.0, 500.0, 1.0, 2.0, 0.01)),
        "FRAMES": ch.encode_row("FRAMES", (0.1, 7, "101#07009479000000 100#0700E803A2FEA2FE",
                                           "181#0700A312F1FF0300 182#0700E8030A000A00 "
                                           "180#07000040004000C0")),
    }
    from hil_bench.plant_rt._plant_c import lib

    with tempfile.TemporaryDirectory() as tmp:
        rec = ProcessRecorder(Path(tmp) / "rate.mcap", ring_capacity=256 << 20)
        chans = {k: rec.channel(t) for k, t in (("PLANT_STATE", ch.PLANT_STATE),
                                               ("SENSE", ch.PLANT_SENSE),
                                               ("TELEMETRY", ch.CONTROLLER_TELEMETRY),
                                               ("TIMING", ch.TIMING),
                                               ("REFERENCE", ch.REFERENCE_PREFIX + "X"),
                                               ("FRAMES", ch.LINK_FRAMES))}
        order = [(chans[k].index, rows[k]) for k in chans]
        t0 = time.perf_counter()
        n = 0
        ring = rec.ring
        while n < messages:
            for index, data in order:
                while lib.rec_ring_write(ring, index, n * 100000, data, len(data)) != 0:
                    time.sleep(0.0005)
                n += 1
        rec.close()
        wall = time.perf_counter() - t0
        written = rec.messages
    return {"messages": written, "wall_s": wall, "msgs_per_s": written / wall}


RT_RUNTIME = Path("/proc/sys/kernel/sched_rt_runtime_us")

#: docs/realtime.md's tuned set-up: the engine spins through the whole period (no timer wake-up
#: latency); not busy_wait: on two cores a stub that never sleeps starves the kernel's workers
#: that carry the pty's bytes (runs stall for up to 100 ms)
TUNED = """spin_us = 95.0
guard_us = 5.0"""


def tuned_run(rt_s: float) -> dict:
    """10 kHz real time with the tuned set-up; lifts RT throttling for the run if root."""
    old = None
    try:
        old = RT_RUNTIME.read_text().strip()
        if old != "-1":
            RT_RUNTIME.write_text("-1")
    except OSError as e:
        print(f"tuned: real-time throttling left on ({e.strerror}: {RT_RUNTIME}); a task "
              f"spinning through the whole period is stopped for 50 ms a second", file=sys.stderr)
        old = None
    try:
        out = run(scenario(rt_s, "realtime", 10000.0, TUNED))
    finally:
        if old is not None and old != "-1":
            RT_RUNTIME.write_text(old)
    out["rt_throttling_lifted"] = old is not None
    return out


def rss_kb(pid: int) -> int:
    try:
        for line in Path(f"/proc/{pid}/status").read_text().splitlines():
            if line.startswith("VmRSS:"):
                return int(line.split()[1])
    except OSError:
        pass
    return -1


def memory_watch(samples: list, stop: threading.Event, stop_after_s: float | None = None):
    """A Runner watcher for the soaks: once the engine has run 1000 cycles, the resident memory
    of the bench, the recorder and the stub every 5 s into ``samples`` as (s, {name: kB});
    with ``stop_after_s`` it asks the engine to stop once that much wall time has passed."""
    def watch(r):
        while not stop.is_set() and (getattr(r, "engine", None) is None
                                     or r.engine.cycles_done < 1000):
            time.sleep(0.05)
        t0 = time.monotonic()
        while not stop.is_set() and r.engine.running():
            pids = {"bench": os.getpid(), "recorder": r.rec.pid, "stub": r.opened.stub.proc.pid}
            samples.append((time.monotonic() - t0, {k: rss_kb(p) for k, p in pids.items()}))
            if stop_after_s is not None and time.monotonic() - t0 >= stop_after_s:
                r.engine.request_stop()
                break
            stop.wait(5.0)
    return watch


def print_rss_rows(first: dict, last: dict, out: dict) -> None:
    """A soak's memory table (one row a process: kB at the first and last sample, change), and
    the same figures into ``out`` as rss_<process>_start_kb / _end_kb / _change."""
    for k in first:
        change = (last[k] - first[k]) / first[k]
        print(f"{k:10s} {first[k]:13d} {last[k]:11d} {change:+8.1%}")
        out[f"rss_{k}_start_kb"] = first[k]
        out[f"rss_{k}_end_kb"] = last[k]
        out[f"rss_{k}_change"] = change


def soak(minutes: float) -> int:
    """Lockstep for ``minutes`` of wall time; resident memory of every process at start and end."""
    samples: list[tuple[float, dict]] = []
    stop = threading.Event()
    # plan more cycles than `minutes` can run (3x the rate of a short probe) and stop the engine
    # at the end of the cycle in which `minutes` of wall time have passed
    probe = run(scenario(0.5))
    cycles = int(3.0 * probe["cycles_per_s"] * minutes * 60.0)
    scn = scenario(cycles * 1e-4)

    watch = memory_watch(samples, stop, stop_after_s=minutes * 60.0)
    result = run(scn, watch=watch, stop_ok=True)
    stop.set()
    if len(samples) < 2:
        sys.exit(f"soak: the run lasted {result['engine_s']:.1f} s, too short for two memory "
                 f"samples 5 s apart: ask for at least 0.5 minutes")
    # the first sample is taken at cycle 1000, before the recorder's buffers have filled: the
    # start figure is the one 5 s later
    first, last = samples[1][1], samples[-1][1]
    print(f"soak: {result['cycles']} lockstep cycles in {result['engine_s'] / 60:.1f} min "
          f"({result['cycles_per_s']:.0f}/s), recording {result['file_bytes'] / 1e6:.0f} MB, "
          f"rows dropped {result['rows_dropped']}")
    print(f"{'process':10s} {'RSS start kB':>13s} {'RSS end kB':>11s} {'change':>8s}")
    out = {"soak_minutes": result["engine_s"] / 60, "soak_cycles": result["cycles"]}
    print_rss_rows(first, last, out)
    print(json.dumps(out))
    return 0


def classify_misses(timing: dict, period_us: float) -> dict[str, int]:
    """Every missed DUTY of a real-time recording, by what explains it (docs/realtime.md):

    * ``host_stall``: inside a streak of >= 3 periods lost in a row (misses or periods the bench
      itself lost), or within 10 periods after one (the link's backlog): the host stopped
      scheduling the bench or the stub for a while; or followed by a period the bench itself
      lost (the engine was descheduled across this period's deadline);
    * ``late_start``: the period started more than a quarter period late (the engine woke late),
      leaving the round trip less than its budget;
    * ``late_answer``: the DUTY did come, after its deadline (counted late within 10 periods):
      a round trip longer than the budget -- the pty's and the scheduler's latency tail;
    * ``unanswered``: none of these: no answer ever came although the period started on time --
      a lost frame or a controller that skipped a SENSE. Unexplained.
    """
    import numpy as np

    missed = np.asarray(timing["missed"]).astype(bool)
    overrun = np.asarray(timing["overrun"]).astype(bool)
    start = np.asarray(timing["start_err_us"], dtype=float)
    late = np.asarray(timing["late_total"], dtype=float)
    lost = missed | overrun
    stall = np.zeros(len(lost), dtype=bool)
    k = 0
    while k < len(lost):
        if lost[k]:
            j = k
            while j < len(lost) and lost[j]:
                j += 1
            if j - k >= 3:
                stall[k:min(j + 10, len(lost))] = True
            k = j
        else:
            k += 1
    later = np.concatenate([late[10:], np.repeat(late[-1:], min(10, len(late)))]) if len(late) else late
    answered_late = later > late
    out = {"missed": int(missed.sum()), "host_stall": 0, "late_start": 0, "late_answer": 0,
           "unanswered": 0}
    stall[:-1] |= overrun[1:]
    for i in np.flatnonzero(missed):
        if stall[i]:
            out["host_stall"] += 1
        elif start[i] > 0.25 * period_us:
            out["late_start"] += 1
        elif answered_late[i]:
            out["late_answer"] += 1
        else:
            out["unanswered"] += 1
    return out


def soak_realtime(minutes: float, rate_hz: float, keep: Path | None = None) -> int:
    """Real time for ``minutes`` at ``rate_hz``, recording on: resident memory of every process
    at start and end, and every miss explained (classify_misses). The soak measures the bench
    (timing, recorder, memory), not the drive's protection, so the controller rides through
    this VM's host stalls: it closes its loop on the encoder (a sensorless loop does not survive
    ten minutes of 5 ms stalls several times a second, docs/realtime.md; the reference SMO still
    runs on the host every cycle), and its over-current trip (1000 A) and current-sum check (off)
    are out of the way: a stall of the stub or the bench holds the duties for several periods
    and the currents swing past 30 A (measured: OVERCURRENT at 6.5 min with the sensorless loop
    and the 30 A trip; with the encoder, a current-sum SENSOR_FAULT at 2.9 s with a 100 A trip --
    the ADC clipped -- and OVERCURRENT at 7.8 s at 150 rpm with the defaults). SOAK_RPM and
    SOAK_PARAMS override the speed and these parameters."""
    from hil_bench.loop.runner import Runner
    from hil_bench.record import channels as ch
    from hil_bench.record.recording import load_recording

    samples: list[tuple[float, dict]] = []
    stop = threading.Event()
    scn = scenario(minutes * 60.0, "realtime", rate_hz, estimator="ENCODER",
                   speed_rpm=float(os.environ.get("SOAK_RPM", "500")),
                   params=os.environ.get("SOAK_PARAMS", "I_MAX_TRIP_A = 1000.0\nPROT_SUM_MAX_A = 0.0"))

    watch = memory_watch(samples, stop)
    with tempfile.TemporaryDirectory() as tmp:
        out = keep if keep is not None else Path(tmp) / "soak_rt.mcap"
        r = Runner(scn, out_path=out, progress=False)
        th = threading.Thread(target=watch, args=(r,), daemon=True)
        th.start()
        result = r.run()
        stop.set()
        size = out.stat().st_size if out.exists() else 0
        fields = ["t_s", "missed", "overrun", "start_err_us", "late_total"]
        timing = load_recording(out, topics=[ch.TIMING], fields={ch.TIMING: fields}).topic(ch.TIMING)
    if len(samples) < 2:
        sys.exit(f"soak: the run ended after {result.cycles_done} cycles, too short for two memory "
                 f"samples: {result.error}")
    t = result.timing
    why = classify_misses(timing, 1e6 / rate_hz)
    # real time fills the recorder's buffers far more slowly than lockstep: its memory is
    # compared from the first sample after a minute (or a tenth of the run) to the end
    settle = min(60.0, 0.1 * minutes * 60.0)
    first_t, first = next(((t0, m) for t0, m in samples if t0 >= settle), samples[1])
    last = samples[-1][1]
    print("memory samples [s: kB bench/recorder/stub]: " + ", ".join(
        f"{t0:.0f}: {m['bench']}/{m['recorder']}/{m['stub']}"
        for t0, m in samples[:: max(1, len(samples) // 8)]))
    print(f"soak (real time, {rate_hz / 1000:g} kHz): {result.cycles_done} of "
          f"{result.cycles_planned} periods in {result.engine_s / 60:.1f} min, recording "
          f"{size / 1e6:.0f} MB, rows dropped {result.link_stats.get('rows_dropped', 0)}"
          + (f"; ended: {result.error}" if result.error else ""))
    print(f"period start error p50 {t['jitter_p50_us']:.1f} us, p99 {t['jitter_p99_us']:.1f} us, "
          f"p99.9 {t['jitter_p999_us']:.1f} us, max {t['jitter_max_us']:.1f} us; "
          f"{t['overruns']} periods lost by the bench")
    print(f"missed duties {why['missed']} (rate {why['missed'] / max(result.cycles_done, 1):.2e}): "
          f"{why['host_stall']} in host stalls, {why['late_start']} after a late start, "
          f"{why['late_answer']} answered after the deadline, {why['unanswered']} unexplained")
    print(f"{'process':10s} {'RSS at ' + format(first_t, '.0f') + ' s kB':>13s} {'RSS end kB':>11s} "
          f"{'change':>8s}")
    out_json = {"soak_rt_minutes": result.engine_s / 60, "soak_rt_cycles": result.cycles_done,
                "soak_rt_rate_hz": rate_hz, "soak_rt_error": result.error or "",
                **{f"soak_rt_{k}": v for k, v in why.items()},
                "soak_rt_overruns": t["overruns"], "soak_rt_jitter_p99_us": t["jitter_p99_us"],
                "soak_rt_rows_dropped": result.link_stats.get("rows_dropped", 0)}
    print_rss_rows(first, last, out_json)
    print(json.dumps(out_json))
    return 0


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="the whole run under a minute")
    ap.add_argument("--no-can", action="store_true", help="skip the CAN paths")
    ap.add_argument("--engine-cpu", type=int, default=None, help="real time: engine thread's CPU")
    ap.add_argument("--stub-cpu", type=int, default=None, help="real time: the stub's CPU")
    ap.add_argument("--tuned", action="store_true",
                    help="also 10 kHz real time with docs/realtime.md's tuned set-up")
    ap.add_argument("--soak", type=float, default=None, metavar="MINUTES",
                    help="only the lockstep soak: memory of every process at start and end")
    ap.add_argument("--soak-keep", type=Path, default=None, metavar="MCAP",
                    help="keep the real-time soak's recording here (to look at its misses)")
    ap.add_argument("--soak-realtime", type=float, default=None, metavar="MINUTES",
                    help="only the real-time soak: memory, and every missed duty explained")
    ap.add_argument("--soak-rate", type=float, default=5000.0, metavar="HZ",
                    help="control rate of the real-time soak (default 5000)")
    args = ap.parse_args(argv)
    if args.soak is not None:
        return soak(args.soak)
    if args.soak_realtime is not None:
        return soak_realtime(args.soak_realtime, args.soak_rate, args.soak_keep)
    quick = args.quick
    cycles = 20000 if quick else 50000
    repeat = 1 if quick else 3
    rt_s = 3.0 if quick else 60.0
    rows: dict[str, list[dict]] = {"pty": [], "lockstep_recorded": [], "lockstep_unrecorded": []}
    for _ in range(repeat):
        rows["pty"].append(pty_ceiling(cycles))
        rows["lockstep_recorded"].append(run(scenario(cycles * 1e-4)))
        rows["lockstep_unrecorded"].append(run(scenario(cycles * 1e-4), record=False))
    rt_extra = "" if args.stub_cpu is None else f"stub_cpu = {args.stub_cpu}"
    for rate in (5000, 10000, 20000):
        rows[f"rt_{rate // 1000}khz"] = [run(scenario(rt_s, "realtime", rate, rt_extra),
                                             cpu=args.engine_cpu)]
    # the same 5 kHz run with the recorder on the stub's CPU instead of the engine's: why the
    # default layout puts it with the engine (docs/realtime.md, "Where everything runs")
    r5 = rows["rt_5khz"][0]
    if r5["stub_cpu"] is not None:
        rows["rt_5khz_recorder_apart"] = [run(scenario(rt_s, "realtime", 5000, rt_extra),
                                              cpu=args.engine_cpu,
                                              recorder_cpus=(r5["stub_cpu"],))]
    if args.tuned:
        rows["rt_10khz_tuned"] = [tuned_run(rt_s)]
    rows["recorder"] = [recorder_rate(200_000 if quick else 1_000_000)]
    if not args.no_can:
        for spec in ("stub",) + CAN_LINKS:
            scn = scenario(cycles * (0.1 if quick else 0.25) * CAN_TS_S,
                           rate_hz=1.0 / CAN_TS_S, telemetry_emf=False)
            rows[f"can_{spec}"] = [run(scn, link=spec)]
    for name, rs in rows.items():
        for r in rs:
            print(json.dumps({"case": name, **r}))

    def med(name: str, key: str) -> float:
        return statistics.median(r[key] for r in rows[name])

    ceiling = med("pty", "round_trips_per_s")
    rec_rate = med("lockstep_recorded", "cycles_per_s")
    unrec_rate = med("lockstep_unrecorded", "cycles_per_s")
    print()
    print(f"machine: {platform.node()}, {os.cpu_count()} CPUs, {platform.platform()}")
    print(f"{'case':44s} {'per s':>9s} {'ratio':>6s} {'p50 us':>8s} {'p99 us':>8s}")
    print(f"{'raw pty round trip, 2 C processes':44s} {ceiling:9.0f} {1.0:6.2f} "
          f"{med('pty', 'p50_us'):8.1f} {med('pty', 'p99_us'):8.1f}")
    for name, label, rate in (("lockstep_recorded", "lockstep, engine + recording + 1 reference",
                               rec_rate),
                              ("lockstep_unrecorded", "lockstep, engine, recording off", unrec_rate)):
        print(f"{label:44s} {rate:9.0f} {rate / ceiling:6.2f} {med(name, 'cycle_p50_us'):8.1f} "
              f"{med(name, 'cycle_p99_us'):8.1f}")
    r10 = rows["rt_10khz"][0]
    print(f"\nreal time against the stub, {rt_s:g} s each, recording on (engine CPU "
          f"{r10['engine_cpu']}, recorder CPUs {r10['recorder_cpus']}, stub CPU "
          f"{r10['stub_cpu']}):")
    print(f"{'rate':8s} {'jitter p50':>10s} {'p99':>8s} {'p99.9':>8s} {'max':>9s} {'missed':>7s} "
          f"{'miss rate':>10s} {'overruns':>9s} {'lost rate':>10s} {'RTT p50':>8s} "
          f"{'RTT p99':>8s} {'dropped':>8s}")
    for rate, case in ((5, "rt_5khz"), (10, "rt_10khz"), (20, "rt_20khz"),
                       (5, "rt_5khz_recorder_apart"), (10, "rt_10khz_tuned")):
        if case not in rows:
            continue
        r = rows[case][0]
        if case.endswith("apart"):
            print(f"recorder on the stub's CPU {r['recorder_cpus']} instead of the engine's:")
        if case.endswith("tuned"):
            print(f"tuned set-up (docs/realtime.md; RT throttling lifted: "
                  f"{r['rt_throttling_lifted']}):")
        print(f"{rate:3d} kHz  {r['jitter_p50_us']:10.1f} {r['jitter_p99_us']:8.1f} "
              f"{r['jitter_p999_us']:8.1f} {r['jitter_max_us']:9.1f} {r['missed']:7d} "
              f"{r['miss_rate']:10.2e} {r['overruns']:9d} {r['lost_rate']:10.2e} "
              f"{r['cycle_p50_us']:8.1f} {r['cycle_p99_us']:8.1f} {r['rows_dropped']:8d}")
        if r["realtime_notes"]:
            print(f"         real-time setup not obtained: {r['realtime_notes']}")
        if r["error"]:
            print(f"         run ended early after {r['cycles']} cycles: {r['error']}")
    print(f"\nrecorder: {med('recorder', 'msgs_per_s'):.0f} messages/s written to MCAP "
          f"(G2 needs {6 * 10000} at 10 kHz: 6 messages a cycle)")
    if not args.no_can:
        print(f"\nCAN-rate scenario (Ts {CAN_TS_S * 1e6:g} us, 4 frames a cycle), lockstep, "
              f"recording on:")
        for spec in ("stub",) + CAN_LINKS:
            r = rows[f"can_{spec}"][0]
            print(f"  {spec:20s} {r['cycles_per_s']:8.0f} cycles/s "
                  f"(real time at this period: {1 / CAN_TS_S:.0f})")
    summary = {
        "pty_ceiling_per_s": ceiling,
        "lockstep_recorded_per_s": rec_rate, "ratio_recorded": rec_rate / ceiling,
        "lockstep_unrecorded_per_s": unrec_rate, "ratio_unrecorded": unrec_rate / ceiling,
        "rt_5khz_p99_jitter_us": rows["rt_5khz"][0]["jitter_p99_us"],
        "rt_5khz_miss_rate": rows["rt_5khz"][0]["miss_rate"],
        "rt_5khz_lost_rate": rows["rt_5khz"][0]["lost_rate"],
        "rt_10khz_p99_jitter_us": rows["rt_10khz"][0]["jitter_p99_us"],
        "rt_10khz_p999_jitter_us": rows["rt_10khz"][0]["jitter_p999_us"],
        "rt_10khz_max_jitter_us": rows["rt_10khz"][0]["jitter_max_us"],
        "rt_10khz_miss_rate": rows["rt_10khz"][0]["miss_rate"],
        "rt_10khz_overruns": rows["rt_10khz"][0]["overruns"],
        "rt_10khz_lost_rate": rows["rt_10khz"][0]["lost_rate"],
        "rt_10khz_rows_dropped": rows["rt_10khz"][0]["rows_dropped"],
        "rt_20khz_miss_rate": rows["rt_20khz"][0]["miss_rate"],
        "rt_20khz_lost_rate": rows["rt_20khz"][0]["lost_rate"],
        **({"rt_5khz_recorder_apart_miss_rate": rows["rt_5khz_recorder_apart"][0]["miss_rate"]}
           if "rt_5khz_recorder_apart" in rows else {}),
        "recorder_msgs_per_s": med("recorder", "msgs_per_s"),
        **({"rt_10khz_tuned_p99_jitter_us": rows["rt_10khz_tuned"][0]["jitter_p99_us"],
            "rt_10khz_tuned_p999_jitter_us": rows["rt_10khz_tuned"][0]["jitter_p999_us"],
            "rt_10khz_tuned_miss_rate": rows["rt_10khz_tuned"][0]["miss_rate"],
            "rt_10khz_tuned_rtt_p50_us": rows["rt_10khz_tuned"][0]["cycle_p50_us"]}
           if args.tuned else {}),
        "rt_seconds": rt_s, "lockstep_cycles": cycles, "repeats": repeat,
    }
    if not args.no_can:
        summary.update({f"can_{spec.replace('-', '_')}_per_s": rows[f"can_{spec}"][0]["cycles_per_s"]
                        for spec in ("stub",) + CAN_LINKS})
    print(json.dumps(summary))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
