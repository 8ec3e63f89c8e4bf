"""Press Ctrl-C at `bench run` many times over, at random gaps, and say how each run ended.

    .venv/bin/python tools/ctrl_c_stress.py [RUNS] [--seed N] [--keep DIR]

Each run: a lockstep scenario that cannot end by itself (tests/test_loop.py's SHORT, 600 s), a
first SIGINT once the recording passes 300 kB, then 0-4 more at gaps drawn from 0-500 ms (the
same as a user hammering Ctrl-C). A run is OK when the command ends with 130 (or by SIGINT itself,
which a shell also reports as 130: CPython's exit after a KeyboardInterrupt went through it), no
traceback is printed, and the recording is finalised (readable, its summary written). A failing
run's stdout and stderr are kept in DIR. The last line is a count. Not a unit test (it takes
5-15 s a run); tests/test_tracebacks.py holds three fixed patterns of presses.
"""
from __future__ import annotations

import argparse
import random
import re
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def _scenario_text() -> str:
    src = (REPO / "tests" / "test_loop.py").read_text()
    m = re.search(r'SHORT = (""".*?""")', src, re.S)
    if m is None:
        raise SystemExit("tests/test_loop.py: SHORT not found")
    return eval(m.group(1)).format(duration=600.0)


def one_run(i: int, gaps_s: list[float], work: Path) -> tuple[bool, str]:
    from hil_bench.record.recorder import partial_path
    from hil_bench.record.recording import RecordingError, load_recording

    d = work / f"r{i}"
    d.mkdir(parents=True, exist_ok=True)
    out = d / "interrupted.mcap"
    scn = d / "long.toml"
    scn.write_text(_scenario_text())
    proc = subprocess.Popen([sys.executable, "-m", "hil_bench", "run", str(scn), "--out", str(out),
                             "--no-progress"], cwd=REPO, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    part = partial_path(out)
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and (not part.exists() or part.stat().st_size < 300_000):
        time.sleep(0.05)
    if proc.poll() is not None:
        so, se = proc.communicate()
        return False, f"the run ended before the first Ctrl-C (rc {proc.returncode})\n{so}\n{se}"
    proc.send_signal(signal.SIGINT)
    for gap in gaps_s:
        time.sleep(gap)
        if proc.poll() is None:
            proc.send_signal(signal.SIGINT)
    so, se = proc.communicate(timeout=120)
    why = []
    if proc.returncode not in (130, -signal.SIGINT):
        why.append(f"exit {proc.returncode}")
    if "Traceback" in so + se:
        why.append("a traceback")
    try:
        if load_recording(out).truncated is not None:
            why.append("recording not finalised")
    except (RecordingError, OSError) as exc:
        why.append(f"recording unreadable: {exc}")
    return not why, "; ".join(why) + f"\n--- stdout\n{so}\n--- stderr\n{se}"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("runs", type=int, nargs="?", default=20)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--keep", type=Path, default=None, help="folder for the failing runs' output")
    args = ap.parse_args()
    rng = random.Random(args.seed)
    work = Path(tempfile.mkdtemp(prefix="ctrl_c_stress_"))
    keep = args.keep or work
    bad = 0
    for i in range(args.runs):
        gaps = [rng.choice([0.0, 0.01, 0.05, 0.1, 0.2, 0.3, 0.5]) for _ in range(rng.randint(0, 4))]
        ok, text = one_run(i, gaps, work)
        print(f"{i:3d} presses after the first at {gaps} s: {'OK' if ok else 'FAIL ' + text.splitlines()[0]}",
              flush=True)
        if not ok:
            bad += 1
            keep.mkdir(parents=True, exist_ok=True)
            (keep / f"fail{i}.txt").write_text(text)
    print(f"{args.runs - bad} of {args.runs} runs ended cleanly (seed {args.seed}); failures in {keep}")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
