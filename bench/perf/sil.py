"""Benchmark of software in the loop (``--link sil``) against the pty, in CPU seconds.

    python -m hil_bench.perf.sil [--repeats N] [--no-sweep] [--realtime-s S]

On these shared VMs the wall time of a pty round trip moves 3x with the other core's load, so
everything here is CPU time of every process involved: getrusage(RUSAGE_SELF) of this process
(the engine's thread, the SIL firmware in it, the set-up) plus getrusage(RUSAGE_CHILDREN) of
the processes it started and reaped (the stub, the recorder, pty_pingpong and its peer, Dask's
workers).

1. ``sil_cycles_per_cpu_s``: Gong G2 (the bundled gong_g2_500rpm: 15 000 cycles, one host
   reference estimator) over ``--link sil``, unrecorded (no per-cycle rows). The cost of a cycle
   is the difference between the whole run of 15 000 cycles and the same scenario cut to 1 500
   cycles, divided by 13 500: what every process spends per cycle, the run's fixed set-up
   (handshake, recorder process, metadata) cancelled; ``sil_setup_cpu_s`` is that set-up.
   Pooled over ``--repeats`` pairs (CPU of all long runs minus all short runs, over their
   cycles). Goal (issue 17): >= 300 000 cycles per CPU second.
2. ``sil_recorded_cycles_per_cpu_s``: the same, recorded to MCAP (the recorder process's CPU
   included).
3. ``pty_lockstep_cycles_per_cpu_s``: the same G2 over ``--link stub`` (the C stub on a pty),
   unrecorded: engine, stub and the kernel's pty work.
4. ``pty_pingpong_round_trips_per_cpu_s``: build/bin/pty_pingpong, two C processes exchanging
   one cycle's octets (30 up, 45 down) over a pty and nothing else: the floor under any cycle
   on a pty.
5. ``sweep_runs_per_min_local``: ``bench sweep bench/sweeps/observers_speed_load.toml --quick``
   on the default local Dask cluster, runs per minute of wall time (a sweep is a wall-time
   question: how long until the table is there).
6. real time: G2 over ``--link sil`` at 10 kHz for ``--realtime-s`` seconds, its miss and lost
   rates beside the machine's own floor measured in the same run (build/bin/wakeup_latency: a
   lone SCHED_FIFO thread on the same period; ``throttled`` = periods it started one period or
   more late). The ratio of the engine's rates to the floor's is the figure that means
   something on a shared VM.

The last line printed is one JSON object with every figure.
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from hil_bench.cluster import process_cpu_s as cpu_s

PACKAGE = Path(__file__).resolve().parents[1]     # hil_bench (bench/ in a checkout)
G2 = "gong_g2_500rpm"
SHORT_S = 0.15


def run_cpu(scn, link: str, record: bool, realtime: bool = False) -> tuple[float, object]:
    """CPU seconds of one whole run (every process), and its RunResult."""
    from hil_bench.loop.runner import Runner

    with tempfile.TemporaryDirectory() as tmp:
        c0 = cpu_s()
        result = Runner(scn, link_spec=link, out_path=Path(tmp) / "perf.mcap", progress=False,
                        record=record, realtime=realtime or None).run()
        c1 = cpu_s()
    if result.error and not realtime:
        sys.exit(f"{scn.name} over {link} failed: {result.error}")
    return c1 - c0, result


def per_cycle(link: str, record: bool, repeats: int) -> dict:
    """Marginal CPU per cycle (long run minus short run), and the fixed cost of a run."""
    from hil_bench.scenario import load_scenario

    long_scn = load_scenario(G2)
    short_scn = dataclasses.replace(long_scn, duration_s=SHORT_S)
    run_cpu(short_scn, link, record)     # warm caches, imports, the page cache
    per, whole = [], []
    sums = [0.0, 0.0, 0, 0]      # CPU of the long runs, of the short runs, their cycles
    for _ in range(repeats):
        c_long, r_long = run_cpu(long_scn, link, record)
        c_short, r_short = run_cpu(short_scn, link, record)
        n_long, n_short = r_long.cycles_done, r_short.cycles_done
        per.append((c_long - c_short) / (n_long - n_short))
        whole.append(c_long)
        sums = [sums[0] + c_long, sums[1] + c_short, sums[2] + n_long, sums[3] + n_short]
    # pooled over the pairs: one pair's set-up noise (a few ms) is not a cycle's cost
    slope = (sums[0] - sums[1]) / (sums[2] - sums[3])
    return {"link": link, "record": record, "cycles": n_long,
            "cycles_per_cpu_s": 1.0 / slope if slope > 0 else float("inf"),
            "cpu_us_per_cycle": slope * 1e6,
            "cpu_us_per_cycle_each_pair": [round(p * 1e6, 3) for p in per],
            "setup_cpu_s": (sums[1] - slope * sums[3]) / repeats,
            "whole_run_cpu_s": statistics.median(whole)}


def pingpong(iterations: int) -> dict:
    """hil_bench.perf.loop's pty ceiling, in CPU seconds of both its processes."""
    from .loop import pty_ceiling

    c0 = cpu_s()
    out = pty_ceiling(iterations)
    cpu = cpu_s() - c0
    out["cpu_s"] = cpu
    out["round_trips_per_cpu_s"] = iterations / cpu
    return out


def wakeup_floor(period_us: int, periods: int) -> dict:
    from hil_bench.installation import find_executable

    try:
        exe = find_executable("wakeup_latency")
    except FileNotFoundError as exc:
        sys.exit(str(exc))
    out = json.loads(subprocess.run([str(exe), str(period_us), str(periods)], capture_output=True,
                                    text=True, check=True).stdout)
    out["lost_rate"] = out["throttled"] / periods
    return out


def realtime_sil(duration_s: float) -> dict:
    from hil_bench.scenario import load_scenario

    scn = load_scenario(G2)
    scn = dataclasses.replace(scn, duration_s=duration_s,
                              realtime=dataclasses.replace(scn.realtime,
                                                           max_consecutive_misses=1_000_000))
    cpu, result = run_cpu(scn, "sil", record=False, realtime=True)
    tm = result.timing
    return {"cycles": result.cycles_done, "cpu_s": cpu, "error": result.error,
            "miss_rate": tm.get("miss_rate"), "lost_rate": tm.get("lost_rate"),
            "missed": tm.get("missed"), "overruns": tm.get("overruns"),
            "jitter_p99_us": tm.get("jitter_p99_us"), "jitter_p999_us": tm.get("jitter_p999_us"),
            "sense_to_duty_p50_us": tm.get("cycle_p50_us"),
            "realtime_notes": result.realtime_notes}


def sweep_rate() -> dict:
    """The bundled quick sweep on the default local cluster (a fresh folder: nothing resumed)."""
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.monotonic()
        c0 = cpu_s()
        proc = subprocess.run([sys.executable, "-m", "hil_bench", "sweep",
                               str(PACKAGE / "sweeps" / "observers_speed_load.toml"),
                               "--quick", "--out", tmp, "--no-progress"],
                              capture_output=True, text=True)
        wall = time.monotonic() - t0
        cpu = cpu_s() - c0
        if proc.returncode not in (0, 1):
            sys.exit(f"bench sweep failed ({proc.returncode}):\n{proc.stderr[-2000:]}")
        import pyarrow.parquet as pq

        table = pq.read_table(Path(tmp) / "results.parquet")
        runs = table.num_rows
        run_cpu_s = table.column("cpu_s").to_pylist()
    return {"runs": runs, "wall_s": wall, "cpu_s_all_processes": cpu,
            "runs_per_min": runs / wall * 60.0,
            "run_cpu_s_median": statistics.median(run_cpu_s) if run_cpu_s else None}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m hil_bench.perf.sil", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repeats", type=int, default=5, help="long/short run pairs (default 5)")
    ap.add_argument("--realtime-s", type=float, default=5.0,
                    help="seconds of the real-time SIL run and of the floor (default 5)")
    ap.add_argument("--no-sweep", action="store_true", help="skip the bundled quick sweep")
    args = ap.parse_args(argv)

    figures: dict = {}
    sil = per_cycle("sil", False, args.repeats)
    print(f"SIL G2 unrecorded: {sil['cycles_per_cpu_s']:,.0f} cycles per CPU second "
          f"({sil['cpu_us_per_cycle']:.2f} us per cycle, each pair: {sil['cpu_us_per_cycle_each_pair']}); "
          f"set-up of a run {sil['setup_cpu_s'] * 1e3:.0f} ms CPU; the whole 15 000-cycle run "
          f"{sil['whole_run_cpu_s'] * 1e3:.0f} ms CPU", flush=True)
    sil_rec = per_cycle("sil", True, args.repeats)
    print(f"SIL G2 recorded: {sil_rec['cycles_per_cpu_s']:,.0f} cycles per CPU second "
          f"({sil_rec['cpu_us_per_cycle']:.2f} us); set-up {sil_rec['setup_cpu_s'] * 1e3:.0f} ms",
          flush=True)
    pty = per_cycle("stub", False, args.repeats)
    print(f"pty lockstep G2 unrecorded (engine + stub): {pty['cycles_per_cpu_s']:,.0f} cycles per "
          f"CPU second ({pty['cpu_us_per_cycle']:.2f} us)", flush=True)
    pp = pingpong(20000)
    print(f"pty_pingpong: {pp['round_trips_per_cpu_s']:,.0f} round trips per CPU second "
          f"({pp['round_trips_per_s']:,.0f} per wall second)", flush=True)
    figures.update(sil_cycles_per_cpu_s=round(sil["cycles_per_cpu_s"]),
                   sil_recorded_cycles_per_cpu_s=round(sil_rec["cycles_per_cpu_s"]),
                   pty_lockstep_cycles_per_cpu_s=round(pty["cycles_per_cpu_s"]),
                   pty_pingpong_round_trips_per_cpu_s=round(pp["round_trips_per_cpu_s"]),
                   sil_setup_cpu_s=round(sil["setup_cpu_s"], 4),
                   sil_g2_run_cpu_s=round(sil["whole_run_cpu_s"], 4),
                   sil_goal_met=sil["cycles_per_cpu_s"] >= 300_000,
                   sil_vs_pty=round(sil["cycles_per_cpu_s"] / pty["cycles_per_cpu_s"], 1))
    if args.realtime_s > 0:
        floor = wakeup_floor(100, int(args.realtime_s * 10_000))
        rt = realtime_sil(args.realtime_s)
        ratio = (rt["lost_rate"] / floor["lost_rate"]) if floor["lost_rate"] > 0 else None
        print(f"real time 10 kHz over sil: miss rate {rt['miss_rate']:.2e}, lost rate "
              f"{rt['lost_rate']:.2e} ({rt['missed']} missed, {rt['overruns']} periods lost by "
              f"the bench); the machine's floor (wakeup_latency, same period): "
              f"{floor['throttled']} of {floor['periods']} periods one period late "
              f"({floor['lost_rate']:.2e}), start p99.9 {floor['start_p999_us']:.0f} us; "
              f"lost rate / floor = {ratio if ratio is None else round(ratio, 2)}", flush=True)
        figures.update(rt_sil_miss_rate=rt["miss_rate"], rt_sil_lost_rate=rt["lost_rate"],
                       rt_floor_lost_rate=floor["lost_rate"],
                       rt_floor_start_p999_us=floor["start_p999_us"],
                       rt_lost_over_floor=ratio)
    if not args.no_sweep:
        sw = sweep_rate()
        print(f"bench sweep observers_speed_load --quick on the local cluster: {sw['runs']} runs in "
              f"{sw['wall_s']:.1f} s ({sw['runs_per_min']:.0f} runs/min); median run "
              f"{sw['run_cpu_s_median']:.2f} s CPU", flush=True)
        figures.update(sweep_runs_per_min_local=round(sw["runs_per_min"], 1),
                       sweep_runs=sw["runs"], sweep_wall_s=round(sw["wall_s"], 1),
                       sweep_run_cpu_s_median=sw["run_cpu_s_median"])
    print(json.dumps(figures))
    return 0


if __name__ == "__main__":
    sys.exit(main())
