#!/usr/bin/env python3
"""Run the bench on a busy host, and prove that lockstep runs come out the same (issue 26).

    python tools/load.py run [--hogs N] [--pause PATTERN] -- COMMAND ...
        run COMMAND beside N CPU-bound processes (default 2 per CPU) while its controller
        processes (the host stub, QEMU; PATTERN: a regex over their command lines, "" for none)
        are stopped for 50-500 ms every 0.3-1.5 s; exits with COMMAND's code and prints the pauses

    python tools/load.py check [--quick] [--only stub,sil,slcan,qemu,ci,late,lossy]
        the battery of docs/performance.md "A busy host": G2 --strict over the stub (10 runs), SIL,
        SLCAN and pil-qemu (3 each) under that load, each run's /plant/state and
        /controller/telemetry compared with an unloaded run's, value for value; the example
        project's pytest (10 runs) under load; a drive that answers every 500th cycle 300 ms late
        (no load: it passes --strict); a link that loses 1 % of the DUTY frames (it completes, its
        lost frames reported as a link problem). Prints one line per run and a table; exit 1 if
        any check failed. --quick: 2 runs where the battery says 10, 1 where it says 3.

Lockstep runs only: real time is paced by the wall clock, where a busy host is what is measured
(docs/realtime.md).
"""
from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from tests.host_load import BENCH_PATTERN, CONTROLLER_PATTERN, HostLoad  # noqa: E402

PY = sys.executable
TOPICS = ("/plant/state", "/controller/telemetry")


def bench(*args: str, env: dict | None = None) -> subprocess.CompletedProcess:
    return subprocess.run([PY, "-m", "hil_bench", *args], cwd=REPO, capture_output=True, text=True,
                          env=env)


def same_rows(a: Path, b: Path) -> str:
    """'' when the two recordings' plant and controller rows are equal value for value, else what
    differs."""
    import numpy as np

    from hil_bench.record.recording import load_recording

    ra, rb = load_recording(a), load_recording(b)
    for topic in TOPICS:
        ta, tb = ra.topic(topic), rb.topic(topic)
        for col, va in ta.items():
            vb = tb.get(col)
            if vb is None or len(va) != len(vb):
                return f"{topic}.{col}: {len(va)} rows vs {0 if vb is None else len(vb)}"
            if not np.array_equal(np.asarray(va), np.asarray(vb), equal_nan=va.dtype.kind == "f"):
                k = int(np.flatnonzero(np.asarray(va) != np.asarray(vb))[0])
                return f"{topic}.{col}: row {k} {va[k]!r} vs {vb[k]!r}"
    return ""


def late_figures(path: Path) -> str:
    from hil_bench.papers.check import check_recording

    t = check_recording(path).integrity.timing
    return f"late {t.get('late_answers', 0)}, re-sends {t.get('retries', 0)}"


class Battery:
    def __init__(self, out: Path, quick: bool):
        self.out, self.quick = out, quick
        self.rows: list[tuple[str, int, int, str]] = []   # what, passed, of, note

    def n(self, full: int) -> int:
        return (2 if full >= 10 else 1) if self.quick else full

    def record(self, what: str, ok: list[bool], note: str) -> None:
        self.rows.append((what, sum(ok), len(ok), note))
        print(f"== {what}: {sum(ok)}/{len(ok)} ({note})", flush=True)

    def runs_like_unloaded(self, label: str, scenario: str, link: str, runs: int, pattern: str) -> None:
        base = self.out / f"{label}-unloaded.mcap"
        r = bench("run", scenario, "--link", link, "--out", str(base), "--no-progress", "--strict")
        if r.returncode != 0:
            self.record(f"{label}: G2 --strict", [False], f"the unloaded run failed: {r.stdout[-400:]}")
            return
        ok, notes = [], []
        with HostLoad(pause_pattern=pattern) as load:
            for i in range(runs):
                out = self.out / f"{label}-loaded-{i}.mcap"
                t0 = time.monotonic()
                r = bench("run", scenario, "--link", link, "--out", str(out), "--no-progress",
                          "--strict")
                wall = time.monotonic() - t0
                diff = same_rows(base, out) if out.exists() else "no recording"
                good = r.returncode == 0 and not diff
                ok.append(good)
                line = (f"  {label} run {i + 1}: exit {r.returncode}, {wall:.1f} s wall, rows "
                        f"{'identical' if not diff else 'DIFFERENT: ' + diff}"
                        + (f", {late_figures(out)}" if out.exists() else ""))
                print(line, flush=True)
                if not good:
                    notes.append(line.strip() + " | " + r.stdout[-300:].replace("\n", " "))
        self.record(f"{label}: {scenario} --strict under load, rows == unloaded", ok,
                    load.summary() + ("; " + "; ".join(notes) if notes else ""))

    def example_project(self, runs: int) -> None:
        ok = []
        env = dict(os.environ, PYTHONPATH=str(REPO))
        with HostLoad(pause_pattern=CONTROLLER_PATTERN) as load:
            for i in range(runs):
                r = subprocess.run([PY, "-m", "pytest", "-q", "-p", "no:cacheprovider",
                                    "--hil-link", "stub", "-W", "error::DeprecationWarning"],
                                   cwd=REPO / "examples" / "firmware_ci", capture_output=True,
                                   text=True, env=env)
                ok.append(r.returncode == 0)
                tail = r.stdout.strip().splitlines()[-1:] or ["?"]
                print(f"  examples/firmware_ci run {i + 1}: exit {r.returncode}: {tail[0]}", flush=True)
        self.record("examples/firmware_ci pytest under load", ok, load.summary())

    def late_drive(self) -> None:
        """No load: the stub answers every 500th cycle 300 ms late, intact."""
        from hil_bench.loop.runner import Runner
        from hil_bench.papers.check import check_recording
        from hil_bench.scenario import load_scenario

        out = self.out / "late.mcap"
        res = Runner(load_scenario("gong_g2_500rpm"), out_path=out, progress=False,
                     stub_args=("--inject", "late@1000")).run()
        rep = check_recording(out)
        verdicts = {r.verdict for r in rep.results if not r.quantity.diagnostic}
        good = res.ok and rep.integrity.ok and "FAIL" not in verdicts and "INVALID" not in verdicts
        self.record("a drive 300 ms late every 500th cycle: G2 --strict", [good],
                    f"{late_figures(out)}, verdicts {sorted(verdicts)}, integrity "
                    f"{'ok' if rep.integrity.ok else 'NOT OK'}")

    def lossy_link(self) -> None:
        """No load: 1 % of the DUTY frames dropped on the way (a [[faults]] drop)."""
        from hil_bench.loop.runner import Runner
        from hil_bench.papers.check import check_recording
        from hil_bench.scenario import derive_scenario

        scn = derive_scenario("gong_g2_500rpm", "gong_g2_lossy", [("faults", [
            {"kind": "drop", "direction": "from_controller", "message": "DUTY", "probability": 0.01,
             "count": 0, "t_s": 0.2, "seed": 3}])])
        out = self.out / "lossy.mcap"
        res = Runner(scn, out_path=out, progress=False).run()
        rep = check_recording(out)
        lost = [p for p in rep.integrity.problems if p.name == "lost_frames"]
        good = res.ok and bool(lost) and not rep.integrity.ok
        self.record("1 % of DUTY frames lost: completes, lost frames a link problem", [good],
                    f"{res.cycles_done} cycles; {lost[0].text if lost else 'no lost_frames problem'}")

    def table(self) -> str:
        lines = ["| check | passed | note |", "|---|---|---|"]
        lines += [f"| {w} | {p} of {n} | {note} |" for w, p, n, note in self.rows]
        return "\n".join(lines)


def check(args) -> int:
    only = set(args.only.split(",")) if args.only else {"stub", "sil", "slcan", "qemu", "ci", "late",
                                                          "lossy"}
    with tempfile.TemporaryDirectory(prefix="hil-load-") as tmp:
        b = Battery(Path(tmp), args.quick)
        t0 = time.monotonic()
        if "stub" in only:
            b.runs_like_unloaded("stub", "gong_g2_500rpm", "stub", b.n(10), CONTROLLER_PATTERN)
        if "sil" in only:
            b.runs_like_unloaded("sil", "gong_g2_500rpm", "sil", b.n(3), BENCH_PATTERN)
        if "slcan" in only:
            b.runs_like_unloaded("slcan", "gong_g2_500rpm_can", "stub-slcan", b.n(3), CONTROLLER_PATTERN)
        if "qemu" in only:
            b.runs_like_unloaded("qemu", "gong_g2_500rpm", "pil-qemu", b.n(3), CONTROLLER_PATTERN)
        if "ci" in only:
            b.example_project(b.n(10))
        if "late" in only:
            b.late_drive()
        if "lossy" in only:
            b.lossy_link()
        print(f"\n{b.table()}\n\n{time.monotonic() - t0:.0f} s wall, {os.cpu_count()} CPUs, "
              f"load average {os.getloadavg()[0]:.1f}")
        return 0 if all(p == n for _, p, n, _ in b.rows) else 1


def run(args) -> int:
    cmd = args.command[1:] if args.command[:1] == ["--"] else args.command
    if not cmd:
        print("load.py run: no command (python tools/load.py run -- COMMAND ...)", file=sys.stderr)
        return 2
    with HostLoad(hogs=args.hogs, pause_pattern=args.pause or None) as load:
        rc = subprocess.call(cmd)
    print(f"load.py: {load.summary()}", file=sys.stderr)
    return rc


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="what", required=True)
    r = sub.add_parser("run", help="run a command on a busy host")
    r.add_argument("--hogs", type=int, default=None, help="CPU-bound processes (default 2 per CPU)")
    r.add_argument("--pause", default=CONTROLLER_PATTERN,
                   help="regex over the command lines of the processes to stop now and then")
    r.add_argument("command", nargs=argparse.REMAINDER)
    c = sub.add_parser("check", help="the battery: lockstep runs under load equal unloaded ones")
    c.add_argument("--quick", action="store_true")
    c.add_argument("--only", default="", help="comma list of stub, sil, slcan, qemu, ci, late, lossy")
    args = ap.parse_args(argv)
    return run(args) if args.what == "run" else check(args)


if __name__ == "__main__":
    sys.exit(main())
