#!/usr/bin/env python3
"""What the held-adapter note sees (bench/loop/links/serial_link.py, ``round_trip_note``): the set-up's
round trips (request to answer) and the spacings between consecutive answers, for the C stub behind
an emulated USB-serial adapter with a latency timer and for the stub on a bare pty, a few set-ups
each. Run it beside the load harness to see what a busy host does to both:

    python3 tools/load.py run -- .venv/bin/python tools/setup_spacings.py --setups 15

Each set-up is a short lockstep run (tests/short_scenario.py, 0.02 s) over
``serial:<pty>@1000000``; figures in ms. docs/real-drive.md, "The adapter's latency timer".
"""
from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from hil_bench.loop.links.serial_link import ROUND_TRIP_NOTE_MIN_S, ROUND_TRIPS_JUDGED  # noqa: E402
from hil_bench.loop.runner import Runner  # noqa: E402
from tests.drive_on_pty import EmulatedAdapter, StubOnPty  # noqa: E402
from tests.short_scenario import short_scenario  # noqa: E402


def one_setup(drive, out: Path) -> tuple[list[float], list[float], bool]:
    """(round trips [s], spacings [s], whether the note was given) of one run's set-up."""
    runner = Runner(short_scenario(0.02), link_spec=f"serial:{drive.path}@1000000", out_path=out,
                    progress=False, allow_slow_link=True)
    result = runner.run()
    if not result.ok:
        raise SystemExit(f"the run over {drive.path} failed: {result.error}")
    link = runner.session.link
    noted = any("HELLO/CONFIG" in n for n in link.notes)
    return (link.round_trips_s[:ROUND_TRIPS_JUDGED], list(link.answer_spacings_s), noted)


def _ms(values: list[float]) -> str:
    return " ".join(f"{v * 1e3:5.1f}" for v in values)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--setups", type=int, default=5, help="set-ups of each kind (default 5)")
    ap.add_argument("--latency-ms", type=float, default=16.0,
                    help="the emulated adapter's latency timer [ms] (default FTDI's 16)")
    args = ap.parse_args(argv)
    if args.setups < 1 or args.latency_ms <= 0:
        ap.error("--setups must be >= 1 and --latency-ms > 0")
    kinds = {f"held {args.latency_ms:g} ms": lambda: EmulatedAdapter(latency_ms=args.latency_ms),
             "prompt": StubOnPty}
    with tempfile.TemporaryDirectory() as tmp:
        for kind, make in kinds.items():
            firsts, laters, closest, noted = [], [], [], 0
            for i in range(args.setups):
                with make() as drive:
                    trips, spacings, said = one_setup(drive, Path(tmp) / f"{kind[:4]}{i}.mcap")
                print(f"{kind:12s} round trips {_ms(trips)} | spacings {_ms(spacings)}"
                      f"{' | note' if said else ''}", flush=True)
                firsts.append(trips[0])
                laters.extend(trips[1:])
                closest.append(min(spacings))
                noted += said
            print(f"{kind}: {args.setups} set-ups, first round trips {min(firsts) * 1e3:.1f}-"
                  f"{max(firsts) * 1e3:.1f} ms, later ones {min(laters) * 1e3:.1f}-"
                  f"{max(laters) * 1e3:.1f} ms, closest spacing {min(closest) * 1e3:.1f}-"
                  f"{max(closest) * 1e3:.1f} ms (the note's limit: "
                  f"{ROUND_TRIP_NOTE_MIN_S * 1e3:g} ms); note given {noted} of {args.setups}",
                  flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
