"""A --live run with an idle connection held by its parent, N times (docs/foxglove.md, "A viewer
never holds the recording"; issue 28.1).

    .venv/bin/python tools/live_view_idle.py [--runs 10] [--scenario gong_g2_500rpm]

Each run: ``bench run SCENARIO --live 0 --no-progress`` as a child process; this process reads the
port the bench prints, opens a TCP connection to it that never speaks (no WebSocket handshake:
what a port scanner, a health check or a half-started viewer leaves) and holds it until the bench
has exited. A recording counts as complete when it is at --out (no ``.partial`` left), the
bench said nothing of its recorder, and it holds a /plant/state row for every cycle the run did
(its own run_result; a run that ended early for another reason, e.g. the lockstep wait on a
loaded machine, is said so beside). Prints one line per run and the count; exit status 0 only if
every recording was complete.
"""
from __future__ import annotations

import argparse
import re
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path


def one_run(scenario: str, folder: Path, i: int) -> tuple[bool, str]:
    out = folder / f"idle{i}.mcap"
    t0 = time.monotonic()
    proc = subprocess.Popen([sys.executable, "-m", "hil_bench", "run", scenario, "--live", "0",
                             "--no-progress", "--out", str(out)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    held = None
    lines: list[str] = []
    try:
        for line in proc.stderr:
            lines.append(line)
            m = re.search(r"ws://127\.0\.0\.1:(\d+)", line)
            if m:
                held = socket.create_connection(("127.0.0.1", int(m.group(1))))
                break
        err = "".join(lines) + proc.stderr.read()
        proc.stdout.read()
        proc.wait()
    finally:
        if held is not None:
            held.close()
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    wall_s = time.monotonic() - t0
    said = " ".join(err.split())
    if held is None:
        return False, f"never saw the live view's port: {said[-300:]}"
    partial = out.with_name(f".{out.name}.partial")
    if not out.exists() or partial.exists() or "recorder" in said:
        return False, (f"exit {proc.returncode}, recording "
                       f"{'missing' if not out.exists() else 'left as ' + str(partial)}: "
                       f"{said[-300:]}")
    from hil_bench.record.recording import load_recording
    from hil_bench.scenario import load_scenario

    rec = load_recording(out, topics=["/plant/state"])
    rows = len(rec.topic("/plant/state")["t_s"])
    done = int(rec.metadata["run_result"]["cycles_done"])
    every = load_scenario(scenario).recording.decimate
    if rows < done // every:
        return False, f"exit {proc.returncode}: {rows} /plant/state rows for {done} cycles"
    text = f"exit {proc.returncode}, {done} cycles, {rows} /plant/state rows, {wall_s:.1f} s wall"
    if proc.returncode != 0:   # the run itself ended early (e.g. the lockstep wait on a loaded
        why = rec.metadata["run_result"].get("error", "")   # machine): not the live view's doing
        text += f"; the run ended early: {why}"
    return True, text


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--runs", type=int, default=10)
    ap.add_argument("--scenario", default="gong_g2_500rpm")
    args = ap.parse_args(argv)
    if args.runs < 1:
        ap.error("--runs: at least 1")
    complete = 0
    with tempfile.TemporaryDirectory() as d:
        for i in range(args.runs):
            ok, text = one_run(args.scenario, Path(d), i)
            complete += ok
            print(f"run {i + 1}: {'complete' if ok else 'NOT complete'}: {text}", flush=True)
    print(f"{complete} of {args.runs} recordings complete with an idle connection held by the "
          f"parent")
    return 0 if complete == args.runs else 1


if __name__ == "__main__":
    raise SystemExit(main())
