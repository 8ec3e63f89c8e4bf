#!/usr/bin/env python3
"""Run a bench command against the C stub behind an emulated USB-serial adapter: the wire paced at
a baud rate (8N1) and the adapter holding the drive's answers until its latency timer expires, as
FTDI's chips do (tests/drive_on_pty.py, EmulatedAdapter). What a lockstep cycle costs through such
an adapter, before one is on the bench (docs/real-drive.md, "The adapter's latency timer").

    python tools/serial_adapter.py --baud 937500 --latency-ms 16 -- \\
        .venv/bin/bench run gong_g2_serial_1mbaud --link 'serial:{port}@937500' --out x.mcap

``{port}`` in the command is replaced by the emulated adapter's port. Exits with the command's
code. Lockstep only: the pacing is done with sleeps in Python threads (right to about 0.1-0.3 ms),
too coarse for a real-time run.
"""
from __future__ import annotations

import argparse
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from tests.drive_on_pty import EmulatedAdapter  # noqa: E402


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--baud", type=int, default=None,
                    help="the wire's rate, 8N1 (default: not paced)")
    ap.add_argument("--latency-ms", type=float, default=0.0,
                    help="the adapter's latency timer [ms] (FTDI's default: 16; 0: none)")
    ap.add_argument("command", nargs=argparse.REMAINDER,
                    help="-- then the command; {port} is the adapter's port")
    args = ap.parse_args(argv)
    command = args.command[1:] if args.command[:1] == ["--"] else args.command
    if not command:
        ap.error("give the command to run after --")
    if args.baud is not None and args.baud <= 0:
        ap.error(f"--baud {args.baud}: must be > 0")
    if args.latency_ms < 0:
        ap.error(f"--latency-ms {args.latency_ms:g}: must be >= 0")
    with EmulatedAdapter(baud=args.baud, latency_ms=args.latency_ms) as adapter:
        print(f"emulated adapter on {adapter.path}: wire "
              f"{f'{args.baud} baud' if args.baud else 'not paced'}, latency timer "
              f"{args.latency_ms:g} ms", flush=True)
        return subprocess.call([part.replace("{port}", adapter.path) for part in command])


if __name__ == "__main__":
    sys.exit(main())
