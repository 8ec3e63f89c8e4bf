"""Benchmark of `bench check`: resident memory and time against the length of the run.

    python -m hil_bench.perf.check [--seconds 60] [--short 15]

Records gong_g2_500rpm stretched to ``--seconds`` and to ``--short`` of simulated time (10 kHz,
lockstep, one reference estimator: the recordings a long paper run makes), then runs
`bench check` on each in a fresh process and prints its wall time and peak resident memory
(getrusage of the child). Goal (issue 9, item 8): memory below 300 MB at any length and time
linear in the file; the ratios between the two lengths are the figures to read.
"""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from hil_bench.loop.runner import run_scenario
from hil_bench.scenario import SCENARIO_DIR, parse_scenario


def long_g2(seconds: float):
    text = (SCENARIO_DIR / "gong_g2_500rpm.toml").read_text()
    text = text.replace("duration_s = 1.5", f"duration_s = {seconds}")
    text = text.replace("window_s = [1.0, 1.5]", f"window_s = [{seconds - 0.5}, {seconds}]")
    return parse_scenario(text, Path(f"g2_{seconds:g}s.toml"))


CHILD = ("import resource, sys\n"
         "from hil_bench.cli import main\n"
         "rc = main(['check', sys.argv[1]])\n"
         "print('PEAK_RSS_KB', resource.getrusage(resource.RUSAGE_SELF).ru_maxrss, file=sys.stderr)\n"
         "sys.exit(rc)\n")


def check_in_child(path: Path) -> dict:
    """`bench check` in a fresh process: wall time, its own peak RSS (kB), exit code."""
    t0 = time.perf_counter()
    proc = subprocess.run([sys.executable, "-c", CHILD, str(path)], capture_output=True, text=True)
    wall = time.perf_counter() - t0
    if proc.returncode not in (0, 1):
        sys.exit(f"bench check {path} failed:\n{proc.stderr}")
    peak = int(proc.stderr.rsplit("PEAK_RSS_KB", 1)[1].split()[0])
    return {"wall_s": wall, "peak_rss_kb": peak, "rc": proc.returncode}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seconds", type=float, default=60.0)
    ap.add_argument("--short", type=float, default=15.0)
    args = ap.parse_args(argv)
    rows = {}
    with tempfile.TemporaryDirectory() as tmp:
        for seconds in (args.short, args.seconds):   # the short one first: peak RSS is a maximum
            out = Path(tmp) / f"g2_{seconds:g}s.mcap"
            t0 = time.perf_counter()
            res = run_scenario(long_g2(seconds), out_path=out, progress=False)
            if not res.ok:
                sys.exit(f"recording {seconds:g} s failed: {res.error}")
            rec_s = time.perf_counter() - t0
            row = check_in_child(out)
            row.update(seconds=seconds, cycles=res.cycles_done, file_mb=out.stat().st_size / 1e6,
                       record_wall_s=rec_s)
            rows[seconds] = row
            print(json.dumps(row))
    s, l = rows[args.short], rows[args.seconds]
    print(f"\n{'run':>8s} {'file MB':>8s} {'check s':>8s} {'peak RSS MB':>12s}")
    for r in (s, l):
        print(f"{r['seconds']:7g}s {r['file_mb']:8.1f} {r['wall_s']:8.2f} {r['peak_rss_kb'] / 1024:12.0f}")
    print(f"ratio {args.seconds:g}/{args.short:g} s: file {l['file_mb'] / s['file_mb']:.2f}, time "
          f"{l['wall_s'] / s['wall_s']:.2f}, peak RSS {l['peak_rss_kb'] / s['peak_rss_kb']:.2f}")
    print(json.dumps({"check_60s_wall_s": l["wall_s"], "check_60s_peak_rss_mb": l["peak_rss_kb"] / 1024,
                      "time_ratio": l["wall_s"] / s["wall_s"],
                      "file_ratio": l["file_mb"] / s["file_mb"]}))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
