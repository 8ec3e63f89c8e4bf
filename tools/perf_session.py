#!/usr/bin/env python3
"""Benchmark of a scripted session (hil_bench.Session) against bench run, in CPU seconds.

    python tools/perf_session.py [--repeats N] [--link sil]

(A checkout's tool, not hil_bench.perf: the Session is the package's top-level API, which the
benchmarks under hil_bench.perf sit below: tools/import_graph.py.)

Gong G2 (the bundled gong_g2_500rpm: 15 000 cycles, recorded, checked) over ``--link sil`` (the
firmware in this process, so that the engine, the firmware and the script are one process's CPU;
the recorder's is added once it is reaped). CPU seconds of every process (getrusage of this
process and of its reaped children), the median of ``--repeats`` after one warm-up round (the
first run imports what the others find loaded):

1. ``run_cpu_s``: ``hil_bench.run`` (bench run and its check), every process.
2. ``session_cpu_s``: a Session closed at once (held before cycle 0, then the whole run and the
   same check), every process: what opening and closing a session adds to a run.
3. The cost of looking, in this process's CPU seconds (``time.process_time``: the engine's
   thread, the firmware in it, the script) over the same 15 000 cycles of one session each:
   ``step_cpu_s`` one ``step`` through them all; ``looks_cpu_s`` ``run_until`` of a condition
   never met, looking every 1 ms of simulated time (1 500 looks: each a hold, a read of the rows
   out of the ring, the condition on them); ``looks_10ms_cpu_s`` every 10 ms (150 looks).
   ``look_cpu_us``: (looks - step) / 1 500, the cost of one look.
4. ``capture_cpu_s``: ``capture`` of the whole run as one DataFrame (15 000 rows), this process.

Wall seconds are printed beside (on a shared machine they say more about its load). The last
line printed is one JSON object with every figure.
"""
from __future__ import annotations

import argparse
import json
import statistics
import tempfile
import time
from pathlib import Path

from hil_bench.cluster import process_cpu_s as cpu_s

G2 = "gong_g2_500rpm"
NEVER = "speed_rpm > 1e9"


def _timed(fn) -> tuple[float, float]:
    c0, w0 = cpu_s(), time.perf_counter()
    fn()
    return cpu_s() - c0, time.perf_counter() - w0


def measure(link: str, tmp: Path, n: int) -> dict[str, tuple[float, float]]:
    import hil_bench
    from hil_bench.session import ConditionNotMet, Session

    out: dict[str, tuple[float, float]] = {}

    def run():
        hil_bench.run(G2, link=link, out=tmp / f"run{n}.mcap", force=True)

    def session():
        Session(G2, link=link, out=tmp / f"s{n}.mcap", force=True).close()

    def own(name: str, body) -> None:
        """This process's CPU (time.process_time) and wall time of body(session) only."""
        s = Session(G2, link=link, out=tmp / f"{name}{n}.mcap", force=True)
        c0, w0 = time.process_time(), time.perf_counter()
        body(s)
        out[name] = (time.process_time() - c0, time.perf_counter() - w0)
        s.close()

    def looks(every_s: float):
        def body(s):
            try:
                s.run_until(NEVER, timeout_s=s.duration_s, every_s=every_s)
            except ConditionNotMet:
                pass
        return body

    def capture(s):
        assert len(s.capture(s.duration_s)) == s.cycles_planned

    out["run"] = _timed(run)
    out["session"] = _timed(session)
    own("step", lambda s: s.step(s.cycles_planned))
    own("looks", looks(1e-3))
    own("looks_10ms", looks(1e-2))
    own("capture", capture)
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--link", default="sil")
    args = ap.parse_args(argv)
    runs = []
    with tempfile.TemporaryDirectory() as tmp:
        measure(args.link, Path(tmp), -1)   # warm-up: imports, the first check's caches
        for n in range(args.repeats):
            runs.append(measure(args.link, Path(tmp), n))
            print(f"repeat {n + 1}: " + ", ".join(f"{k} {c:.3f} s CPU / {w:.2f} s wall"
                                                 for k, (c, w) in runs[-1].items()), flush=True)

    def med(key: str, i: int = 0) -> float:
        return statistics.median(r[key][i] for r in runs)

    cycles = 15000
    figures = {
        "link": args.link, "repeats": args.repeats,
        "run_cpu_s": round(med("run"), 3), "session_cpu_s": round(med("session"), 3),
        "session_over_run": round(med("session") / med("run"), 3),
        "step_cpu_s": round(med("step"), 3), "looks_cpu_s": round(med("looks"), 3),
        "looks_10ms_cpu_s": round(med("looks_10ms"), 3),
        "look_cpu_us": round((med("looks") - med("step")) / (cycles / 10) * 1e6, 1),
        "look_10ms_cpu_us": round((med("looks_10ms") - med("step")) / (cycles / 100) * 1e6, 1),
        "capture_cpu_s": round(med("capture"), 3),
        "run_wall_s": round(med("run", 1), 2), "session_wall_s": round(med("session", 1), 2),
        "step_wall_s": round(med("step", 1), 2), "looks_wall_s": round(med("looks", 1), 2),
    }
    print(json.dumps(figures))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
