"""``run_replay``: one capture, one mode (offline, into a controller, into the plant)."""
from __future__ import annotations

import dataclasses
import time
from pathlib import Path

from hil_bench.record.atomic import refuse_output_is_input
from hil_bench.record.recorder import reserve_recording

from .capture import Capture
from .controller import run_controller
from .modes import (
    MODES,
    ReplayError,
    ReplayOptions,
    ReplayResult,
    _pace,
    _window,
    default_out,
    resolve_profile,
)
from .offline import run_offline
from .plant import run_plant


def run_replay(cap: Capture, opts: ReplayOptions) -> ReplayResult:
    if opts.mode not in MODES:
        raise ReplayError(f"--mode {opts.mode!r}: one of {', '.join(MODES)}")
    given = opts.out is not None
    out = Path(opts.out) if given else default_out(cap, opts.mode)
    # never over its own input, with or without --force (bench replay CAP --out CAP)
    refuse_output_is_input([out], [("capture", cap.path)])
    profile = resolve_profile(cap, opts.profile)
    window = _window(cap, opts)
    pace_s = _pace(cap, opts.rate)
    # the name taken (a default one that is taken becomes the next free one); with --force the
    # previous file moved aside until the new one is in place
    taken = reserve_recording(out, force=opts.force, pick_free=not given, side_suffixes=())
    out = taken.path
    res = ReplayResult(cap, opts.mode, out, window_s=window)
    fn = {"offline": run_offline, "controller": run_controller, "plant": run_plant}[opts.mode]
    t0 = time.monotonic()
    try:
        fn(cap, dataclasses.replace(opts, reservation=taken), profile, out, window, pace_s, res)
    finally:
        taken.release()   # nothing written (set-up failed): the name is free again
    res.wall_s = time.monotonic() - t0
    return res
