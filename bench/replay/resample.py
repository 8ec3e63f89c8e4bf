"""A scope/DAQ export onto the control period (docs/replay.md "Resampling").

What the controller is given in cycle k is the current at the sampling instant t_k (the bench's
sensor model, and a DSP sampling synchronously with its PWM). A DAQ at another rate, with its own
time origin, is brought onto the grid t_k = t0 + k Ts by

1. **cubic interpolation** (``scipy.interpolate.make_interp_spline``, k = 3) of the samples at
   the instants t_k, stretch by stretch between gaps. No filter by default: a low-pass changes the
   very values the controller saw. Measured on the example (tools/make_example_captures.py: a
   5 kHz DAQ whose samples lie 100 us off the 1.667 kHz grid), the currents on the grid are
   within 31-41 mA RMS (0.26 A at most, during the start-up's current steps) of the recorded
   ones, and the duties equal; an 8th-order zero-phase low-pass at 0.4/Ts made the error 0.17 A
   RMS on a 2.5 kHz export (within each period the current has content far above the control
   Nyquist frequency, and the drive samples it, it does not average it). The DAQ must be fast
   enough to follow the current within a period; a slower one is interpolated all the same and
   its error is what a comparison with a recording shows (2.5 kHz unfiltered: 77 mA RMS).
2. **optional anti-alias filter** ``[control] antialias_hz``: a 4th-order Butterworth run forwards
   and backwards (``scipy.signal.sosfiltfilt``: 8th order, zero phase, -6 dB at the cutoff)
   before the interpolation, for a DAQ whose signals carry switching ripple or noise that the
   drive's synchronous sampling would not see. Zero phase because a causal filter delays the
   currents and the estimators would read the delay as an angle error.

Angles are unwrapped before and wrapped after. Duties are steps, not signals: row k takes the
first sample in [t_k + delay, t_k+1 + delay), the interval DUTY(k) acts on (``delay`` = the
computation delay, [control] delay_s, default the profile's t_delay_s); a period without a sample
there holds the last duties (counted). Phase voltages are averaged over each period
[t_k, t_k + Ts) (the trapezoid integral: the period average the inverter's own averaging is), and
become the duties (v_x - min(v_a, v_b, v_c)) / v_dc that give the same line voltages; the
estimators then take them without a delay split (the average already is the voltage that acted
over the period).
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from hil_bench.installation import require_extra
from hil_bench.plant_rt.engine import REPLAY_CYCLE_DTYPE

from .capture import Anomalies, Capture, CaptureError, duty_raw_of, empty_telem

#: what needs SciPy here (its ExtraMissing message)
DAQ_FEATURE = "bench replay of a scope/DAQ CSV export (anti-alias filter, spline resampling)"
BUTTER_ORDER = 4          #: per pass (sosfiltfilt doubles it)
GAP_FACTOR = 1.5          #: a sample interval above 1.5 x the median is a gap


def _segments(t: np.ndarray, gap_s: float) -> list[slice]:
    cuts = np.flatnonzero(np.diff(t) > gap_s) + 1
    bounds = [0, *cuts.tolist(), len(t)]
    return [slice(a, b) for a, b in zip(bounds[:-1], bounds[1:]) if b > a]


def _filtered(t: np.ndarray, x: np.ndarray, segs: list[slice], fs_hz: float,
              cutoff_hz: float | None, notes: list[str]) -> np.ndarray:
    if cutoff_hz is None:
        return x
    cutoff = cutoff_hz
    if fs_hz <= 2.0 * cutoff * 1.05:
        notes.append(f"anti-alias cutoff {cutoff:g} Hz is at or above the DAQ's Nyquist "
                     f"frequency ({fs_hz / 2:g} Hz): not applied")
        return x
    signal = require_extra(DAQ_FEATURE, "scipy.signal")
    sos = signal.butter(BUTTER_ORDER, cutoff, btype="low", fs=fs_hz, output="sos")
    y = x.astype(float).copy()
    for s in segs:
        n = s.stop - s.start
        if n > 3 * (2 * len(sos) + 1):
            y[s] = signal.sosfiltfilt(sos, x[s])
        else:
            notes.append(f"a stretch of {n} samples is too short for the anti-alias filter; "
                         f"interpolated unfiltered")
    return y


def _interp(t: np.ndarray, x: np.ndarray, segs: list[slice], tk: np.ndarray,
            seg_of_k: np.ndarray) -> np.ndarray:
    make_interp_spline = require_extra(DAQ_FEATURE, "scipy.interpolate").make_interp_spline
    out = np.full(len(tk), np.nan)
    for j, s in enumerate(segs):
        sel = seg_of_k == j
        if not sel.any():
            continue
        ts, xs = t[s], x[s]
        if len(ts) >= 4:
            out[sel] = make_interp_spline(ts, xs, k=3)(tk[sel])
        else:
            out[sel] = np.interp(tk[sel], ts, xs)
    return out


def resample_capture(path: Path, m: dict, arrays: dict[str, np.ndarray], line_no: np.ndarray,
                     an: Anomalies, problems: list[str], profile, ts_s: float | None) -> Capture:
    ctl = m["control"]
    t = arrays["time"]
    # never reorder: samples whose time does not increase are counted and left out
    keep = np.ones(len(t), dtype=bool)
    last = -math.inf
    for i in range(len(t)):
        if t[i] > last:
            last = t[i]
            continue
        keep[i] = False
        kind = "duplicates" if t[i] == last else "out_of_order"
        an.add(kind, f"line {line_no[i]}: time {t[i]:.9g} s "
                     f"{'repeats' if kind == 'duplicates' else 'goes backwards'}; sample left out")
    t = t[keep]
    arrays = {k: v[keep] for k, v in arrays.items()}
    line_no = line_no[keep]
    dt = np.diff(t)
    dt_med = float(np.median(dt))
    fs = 1.0 / dt_med
    gap_s = GAP_FACTOR * dt_med
    for i in np.flatnonzero(dt > gap_s):
        an.add("gaps", f"lines {line_no[i]}-{line_no[i + 1]}: no samples for {dt[i] * 1e3:.3f} ms "
                       f"({dt[i] / dt_med:.1f} sample intervals)", float(t[i]))
    if "ts_s" in ctl:
        ts, ts_source = float(ctl["ts_s"]), "mapping [control] ts_s"
    elif ts_s is not None:
        ts, ts_source = float(ts_s), "--ts-us"
    else:
        raise CaptureError(f"{path}: the control period is unknown: give [control] ts_s in the "
                           f"mapping file or --ts-us")
    t0 = float(ctl.get("t0_s", t[0]))
    k_first = int(math.ceil((t[0] - t0) / ts - 1e-9))
    k_last = int(math.floor((t[-1] - t0) / ts + 1e-9))
    if k_last < k_first:
        raise CaptureError(f"{path}: the capture is shorter than one control period")
    k = np.arange(k_first, k_last + 1)
    tk = t0 + k * ts
    segs = _segments(t, gap_s)
    seg_of_k = np.full(len(k), -1)
    for j, s in enumerate(segs):
        seg_of_k[(tk >= t[s.start] - 1e-12) & (tk <= t[s.stop - 1] + 1e-12)] = j
    inside = seg_of_k >= 0
    if (~inside).any():
        an.counts["cycles_missing"] += int((~inside).sum())
    k, tk, seg_of_k = k[inside], tk[inside], seg_of_k[inside]
    notes: list[str] = []
    sig = m["signals"]
    cutoff_hz = ctl.get("antialias_hz")
    if cutoff_hz is not None:
        cutoff_hz = float(cutoff_hz)

    def on_grid(name: str) -> np.ndarray:
        return _interp(t, _filtered(t, arrays[name], segs, fs, cutoff_hz, notes), segs, tk, seg_of_k)

    cur = {n: on_grid(n) for n in ("i_a", "i_b", "i_c") if n in sig}
    if "i_c" not in cur:
        cur["i_c"] = -cur["i_a"] - cur["i_b"]
    elif "i_b" not in cur:
        cur["i_b"] = -cur["i_a"] - cur["i_c"]
    elif "i_a" not in cur:
        cur["i_a"] = -cur["i_b"] - cur["i_c"]
    v_dc = on_grid("v_dc")
    n = len(k)
    rows = np.zeros(n, dtype=REPLAY_CYCLE_DTYPE)
    rows["t_s"] = (k - k_first) * ts if ctl.get("t0_s") is None else k * ts
    rows["seq"] = k & 0xFFFF
    rows["i_abc_a"] = np.stack([cur["i_a"], cur["i_b"], cur["i_c"]], 1)
    rows["v_dc_v"] = v_dc
    telem = empty_telem(n)
    theta_source = None
    if "theta" in sig:
        th = np.unwrap(arrays["theta"])
        if sig["theta"].get("frame", "electrical") == "mechanical":
            if profile is None:
                raise CaptureError(f"{sig['theta']['where']}.frame: a mechanical angle needs the "
                                   f"pole pairs: give --profile")
            th = th * int(profile.pole_pairs)
        x = _interp(t, _filtered(t, th, segs, fs, cutoff_hz, notes), segs, tk, seg_of_k)
        rows["theta_rad"] = np.mod(x, 2.0 * math.pi)
        rows["has_theta"] = 1
        theta_source = f"encoder (CSV column {sig['theta']['column']!r})"
    voltage_is_duty = "duty_a" in sig
    delay = float(ctl.get("delay_s", getattr(profile, "t_delay_s", 0.0) if profile else 0.0))
    if voltage_is_duty:
        j = np.searchsorted(t, tk + delay, side="left")
        ok = j < len(t)
        ok[ok] &= t[j[ok]] < tk[ok] + delay + ts
        d = np.full((n, 3), np.nan)
        for c, name in enumerate(("duty_a", "duty_b", "duty_c")):
            d[ok, c] = arrays[name][j[ok]]
        good = ok & np.isfinite(d).all(axis=1)
        rows["duty_raw"][good] = duty_raw_of(d[good])
        rows["has_duty"][good] = 1
        method_v = (f"duties: the first sample in [t_k + {delay * 1e6:g} us, t_k+1 + "
                    f"{delay * 1e6:g} us), the interval DUTY(k) acts on")
        if (~ok).any():
            an.add("drops", f"{int((~ok).sum())} period(s) without a DAQ sample inside the interval "
                            f"their duty acts on (the DAQ is slower than the PWM); the last duties "
                            f"held", n=int((~ok).sum()))
    else:
        cumulative_trapezoid = require_extra(DAQ_FEATURE, "scipy.integrate").cumulative_trapezoid

        avg = []
        for name in ("v_a", "v_b", "v_c"):
            integ = cumulative_trapezoid(arrays[name], t, initial=0.0)
            i0 = np.interp(tk, t, integ)
            i1 = np.interp(tk + ts, t, integ)
            a = (i1 - i0) / ts
            a[tk + ts > t[-1]] = np.nan
            avg.append(a)
        v = np.stack(avg, 1)
        d = (v - np.nanmin(v, axis=1, keepdims=True)) / v_dc[:, None]
        good = np.isfinite(d).all(axis=1) & (d <= 1.0 + 1e-9).all(axis=1)
        over = np.isfinite(d).all(axis=1) & ~good
        if over.any():
            an.add("damaged", f"{int(over.sum())} period(s) with line voltages above v_dc "
                              f"(check the voltage scaling); left without duties",
                   n=int(over.sum()))
        rows["duty_raw"][good] = duty_raw_of(d[good])
        rows["has_duty"][good] = 1
        method_v = "phase voltages: mean over each period (trapezoid integral) -> duties"
    cap = Capture(path=path, kind="csv", ts_s=ts, ts_source=ts_source, rows=rows, telem=telem,
                  anomalies=an, problems=problems, theta_source=theta_source,
                  voltage_is_duty=voltage_is_duty)
    filt = cutoff_hz is not None and fs > 2.0 * cutoff_hz * 1.05
    cap.resampling = {
        "daq_rate_hz": fs, "control_rate_hz": 1.0 / ts, "samples": int(len(t)),
        "method": ((f"zero-phase Butterworth, {2 * BUTTER_ORDER}th order at {cutoff_hz:g} Hz "
                    f"(sosfiltfilt), then " if filt else "no filter, ")
                   + f"cubic spline at t_k = t0 + k Ts; {method_v}"),
    }
    cap.notes.extend(dict.fromkeys(notes))
    return cap
