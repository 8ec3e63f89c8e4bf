"""``run_replay``: one capture, one mode (offline, into a controller, into the plant)."""
from __future__ import annotations

import time
from pathlib import Path

from hil_bench.record.recorder import check_target

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
    out = Path(opts.out) if opts.out else default_out(cap, opts.mode)
    check_target(out, opts.force)
    profile = resolve_profile(cap, opts.profile)
    window = _window(cap, opts)
    pace_s = _pace(cap, opts.rate)
    res = ReplayResult(cap, opts.mode, out, window_s=window)
    fn = {"offline": run_offline, "controller": run_controller, "plant": run_plant}[opts.mode]
    t0 = time.monotonic()
    fn(cap, opts, profile, out, window, pace_s, res)
    res.wall_s = time.monotonic() - t0
    return res
