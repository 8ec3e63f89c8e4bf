"""The live view's dropped-frame figures for a reading and a stalled viewer (docs/foxglove.md,
"Dropped frames"): G2 on the stub, each with one client of tests/test_live_view.py.

    .venv/bin/python tools/live_view_drops.py

* reading: ``--live`` (50 Hz) ``--pace 1``, a client subscribed to everything that reads it all;
* stalled: ``--live-rate`` 1e6, a foxglove-sdk queue of 16, a 4 MiB ring, as fast as the link
  goes, a client subscribed to everything that stops reading after its first message (the set-up
  of test_a_viewer_that_stops_reading_does_not_hold_the_run).

Prints, for each, what the client read, the run's live_view figures and the bench's line.
"""
from __future__ import annotations

import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from test_live_view import Viewer, _run  # noqa: E402 - the tests' own Foxglove client

from hil_bench.record.live_view import LiveOptions, stats_line  # noqa: E402


def main() -> int:
    for name, live, pace, stall in (
            ("reading", LiveOptions(port=0), 1.0, False),
            ("stalled", LiveOptions(port=0, rate_hz=1e6, backlog=16), None, True)):
        with tempfile.TemporaryDirectory() as d:
            result, (viewer,) = _run(Path(d), live=live, pace=pace,
                                     make_viewer=lambda port, s=stall: Viewer(port, None, stall=s),
                                     ring_bytes=4 * 1024 * 1024)
            viewer.release.set()
            viewer.done.wait(10)
            print(f"{name}: run ok {result.ok}, {result.cycles_done} cycles; the client read "
                  f"{len(viewer.messages)} messages; live_view {result.live_stats}")
            print(f"  {stats_line(result.live_stats)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
