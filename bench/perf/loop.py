"""Benchmark: lockstep cycles per second over the pty beside the raw pty round trip, and over CAN.

    python -m bench.perf.loop [--cycles 20000] [--repeat 3] [--no-can]

Measured in one run, on one machine, so the ratio is what to compare:

1. ``pty_pingpong``: two C processes exchange one cycle's worth of bytes each way over a pty
   (the floor under any lockstep cycle on this machine);
2. the bench's lockstep loop against the C firmware stub, recording to MCAP (what `bench run`
   does);
3. the same loop with the recorder writing to /dev/null's equivalent (its cost isolated);
4. the CAN paths (unless ``--no-can``): the same loop, recording, with the stub behind python-can's
   slcan interface (SLCAN on a pty) and its socketcand interface (loopback TCP), and over the serial
   pty on the same scenario for the ratio. The 10 kHz scenario of 2. does not fit classic CAN at
   1 Mbit/s, so these runs use the period the bus fits (budget.can_fit_period_us: 600 us, TELEM_EMF
   off, as bench/scenarios/gong_g2_500rpm_can.toml); the work per cycle is the same.

Prints JSON lines and a table. Figures in docs/performance.md come from this script.
"""
from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from protocol import budget
from protocol.messages import HelloFlag

REPO = Path(__file__).resolve().parents[2]
SCENARIO = """
[scenario]
name = "perf_loop"
profile = "gong2020"
duration_s = {duration}
[controller]
estimator = "SMO_SIGN"
speed_ref_rpm = 500
[metrics]
window_s = [0.0, {duration}]
"""

#: the CAN runs: the period classic CAN at 1 Mbit/s carries, 4 frames per cycle (no TELEM_EMF)
CAN_TS_S = budget.can_fit_period_us(1_000_000, 0) * 1e-6
CAN_LINKS = ("stub", "stub-slcan", "stub-socketcand")
SCENARIO_CAN = """
[scenario]
name = "perf_loop_can"
profile = "gong2020"
duration_s = {duration}
[plant]
ts_s = {ts_s!r}
[controller]
estimator = "SMO_SIGN"
speed_ref_rpm = 500
telemetry_emf = false
[metrics]
window_s = [0.0, {duration}]
"""


def pty_round_trips(iterations: int, nbytes: int) -> dict:
    exe = REPO / "build" / "bin" / "pty_pingpong"
    if not exe.exists():
        sys.exit(f"{exe} not found: run `make build`")
    out = subprocess.run([str(exe), str(iterations), str(nbytes)], capture_output=True, text=True,
                         check=True).stdout
    return json.loads(out)


def lockstep(cycles: int, record: bool, link: str | None = None) -> dict:
    """One lockstep run; ``link`` None: the 10 kHz scenario on the pty; else the CAN-rate scenario on
    that link spec."""
    from bench import runner as runner_mod
    from bench.runner import Runner
    from bench.scenario import parse_scenario

    if link is None:
        scn = parse_scenario(SCENARIO.format(duration=cycles * 1e-4), Path("perf_loop.toml"))
    else:
        scn = parse_scenario(SCENARIO_CAN.format(duration=cycles * CAN_TS_S, ts_s=CAN_TS_S),
                             Path("perf_loop_can.toml"))
    with tempfile.TemporaryDirectory() as tmp:
        original = runner_mod.ProcessRecorder
        if not record:
            runner_mod.ProcessRecorder = _NullRecorder
        try:
            r = Runner(scn, link_spec=link or "stub", out_path=Path(tmp) / "perf.mcap",
                               progress=False)
            t0 = time.perf_counter()
            result = r.run()
            wall = time.perf_counter() - t0
        finally:
            runner_mod.ProcessRecorder = original
    if result.error:
        sys.exit(f"lockstep run over {link or 'stub'} failed: {result.error}")
    loop_s = r.cycle_wall_ns.sum() / 1e9
    return {"cycles": result.cycles_done, "record": record, "link": link or "stub",
            "cycles_per_s": result.cycles_done / loop_s,
            "p50_us": result.link_stats["cycle_wall_p50_us"],
            "p99_us": result.link_stats["cycle_wall_p99_us"],
            "max_us": result.link_stats["cycle_wall_max_us"], "wall_s_incl_setup": wall}


class _NullChannel:
    def write(self, t_s, message):
        pass

    def write_values(self, t_s, values):
        pass


class _NullRecorder:
    """Stands in for the MCAP recorder to isolate its cost (benchmark only)."""

    def __init__(self, path):
        self.path = path

    def channel(self, topic, schema, fields=None):
        return _NullChannel()

    def metadata(self, name, data):
        pass

    def attachment(self, name, media_type, data):
        pass

    def close(self):
        pass

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        pass


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--cycles", type=int, default=20000)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--no-can", action="store_true", help="skip the CAN paths")
    args = ap.parse_args(argv)
    flags = int(HelloFlag.TELEM_EMF)
    per_cycle = budget.serial_bytes_per_cycle(flags)
    nbytes = per_cycle // 2
    rows = {"pty": [], "lockstep_recorded": [], "lockstep_unrecorded": []}
    can_links = () if args.no_can else CAN_LINKS
    rows.update({f"can_{spec}": [] for spec in can_links})
    for _ in range(args.repeat):
        rows["pty"].append(pty_round_trips(args.cycles, nbytes))
        rows["lockstep_recorded"].append(lockstep(args.cycles, record=True))
        rows["lockstep_unrecorded"].append(lockstep(args.cycles, record=False))
        for spec in can_links:
            rows[f"can_{spec}"].append(lockstep(args.cycles, record=True, link=spec))
    for name, rs in rows.items():
        for r in rs:
            print(json.dumps({"case": name, **r}))

    def med(name: str, key: str) -> float:
        return statistics.median(r[key] for r in rows[name])

    pty_rate = med("pty", "round_trips_per_s")
    print()
    print(f"{'case':34s} {'per s (median)':>15s} {'p50 us':>8s} {'p99 us':>8s} {'ratio to pty':>13s}")
    print(f"{'raw pty round trip, 2 C processes':34s} {pty_rate:15.0f} {med('pty', 'p50_us'):8.1f} "
          f"{med('pty', 'p99_us'):8.1f} {1.0:13.2f}")
    for name, label in (("lockstep_recorded", "lockstep + MCAP recording"),
                        ("lockstep_unrecorded", "lockstep, recorder disabled")):
        rate = med(name, "cycles_per_s")
        print(f"{label:34s} {rate:15.0f} {med(name, 'p50_us'):8.1f} {med(name, 'p99_us'):8.1f} "
              f"{rate / pty_rate:13.2f}")
    print(f"\n({args.repeat} repeats of {args.cycles} cycles; {nbytes} bytes each way per pty round "
          f"trip = one cycle's frames with TELEM_EMF, {per_cycle} bytes both ways)")
    if can_links:
        same = med("can_stub", "cycles_per_s")
        print(f"\nCAN-rate scenario (Ts {CAN_TS_S * 1e6:g} us, 4 frames per cycle), recording to MCAP:")
        print(f"{'link':34s} {'cycles/s (median)':>17s} {'p50 us':>8s} {'p99 us':>8s} "
              f"{'ratio to pty':>13s} {'to pty loop':>12s}")
        labels = {"stub": "serial pty (COBS framing)", "stub-slcan": "SLCAN on a pty (python-can slcan)",
                  "stub-socketcand": "socketcand on loopback TCP"}
        for spec in can_links:
            name = f"can_{spec}"
            rate = med(name, "cycles_per_s")
            print(f"{labels[spec]:34s} {rate:17.0f} {med(name, 'p50_us'):8.1f} {med(name, 'p99_us'):8.1f} "
                  f"{rate / pty_rate:13.2f} {rate / same:12.2f}")
        print(f"(real time at this period is {1 / CAN_TS_S:.0f} cycles/s)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
