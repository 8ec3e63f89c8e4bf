"""A scope/DAQ export onto the control period (docs/replay.md "Resampling").

The drive samples its currents once per PWM period, synchronously at the carrier's centre, where
the switching ripple averages out: the control-rate samples are the period's mean current,
band-limited below the control Nyquist frequency 1/(2 Ts). A DAQ at another rate is brought onto
that grid in two steps:

1. **Anti-alias, zero phase.** Only when the DAQ is faster than the control rate: a 4th-order
   Butterworth low-pass at ``CUTOFF_PER_TS / Ts`` (0.4/Ts, 80 % of the control Nyquist) run
   forwards and backwards (``scipy.signal.sosfiltfilt``: 8th order, no phase shift, -6 dB at the
   cutoff). It removes the switching ripple and everything that would alias onto the grid; being
   zero phase it does not delay the currents (a causal filter would, and the estimators would read
   the delay as an angle error). Each stretch between gaps is filtered on its own.
2. **Cubic interpolation** (``scipy.interpolate.make_interp_spline``, k = 3) of the filtered
   samples at the grid instants t_k = t0 + k Ts. Its error for a sinusoid of frequency f sampled
   at fs is of order (2 pi f / fs)^4 / 384 of the amplitude: 4e-8 for the 33 Hz of 500 rpm at
   5 kHz.

Angles are unwrapped before and wrapped after. Duties are steps, not signals: row k takes the duty
in force at t_k + delay + Ts/2 (zero-order hold; ``delay`` = the computation delay, [control]
delay_s, default the profile's t_delay_s), the middle of the interval DUTY(k) acts on. Phase
voltages are averaged over each period [t_k, t_k + Ts) (the integral of the trapezoid rule,
which is the period-average filter the inverter's own averaging is), and become the duties
(v_x - min(v_a, v_b, v_c)) / v_dc that give the same line voltages; the estimators then take
them without a delay split (the average already is the voltage that acted over the period).
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from plant_rt.engine import REPLAY_CYCLE_DTYPE

from .capture import Anomalies, Capture, CaptureError, duty_raw_of, empty_telem

CUTOFF_PER_TS = 0.4       #: anti-alias cutoff [1/Ts]
BUTTER_ORDER = 4          #: per pass (sosfiltfilt doubles it)
GAP_FACTOR = 1.5          #: a sample interval above 1.5 x the median is a gap


def _segments(t: np.ndarray, gap_s: float) -> list[slice]:
    cuts = np.flatnonzero(np.diff(t) > gap_s) + 1
    bounds = [0, *cuts.tolist(), len(t)]
    return [slice(a, b) for a, b in zip(bounds[:-1], bounds[1:]) if b > a]


def _filtered(t: np.ndarray, x: np.ndarray, segs: list[slice], fs_hz: float, ts_s: float,
              notes: list[str]) -> np.ndarray:
    from scipy import signal

    cutoff = CUTOFF_PER_TS / ts_s
    if fs_hz <= 2.0 * cutoff * 1.05:
        return x    # the DAQ is not faster than the grid needs: nothing to remove
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
    from scipy.interpolate import make_interp_spline

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

    def on_grid(name: str) -> np.ndarray:
        return _interp(t, _filtered(t, arrays[name], segs, fs, ts, notes), segs, tk, seg_of_k)

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
        x = _interp(t, _filtered(t, th, segs, fs, ts, notes), segs, tk, seg_of_k)
        rows["theta_rad"] = np.mod(x, 2.0 * math.pi)
        rows["has_theta"] = 1
        theta_source = f"encoder (CSV column {sig['theta']['column']!r})"
    voltage_is_duty = "duty_a" in sig
    delay = float(ctl.get("delay_s", getattr(profile, "t_delay_s", 0.0) if profile else 0.0))
    if voltage_is_duty:
        t_hold = tk + delay + 0.5 * ts
        j = np.searchsorted(t, t_hold, side="right") - 1
        ok = j >= 0
        d = np.full((n, 3), np.nan)
        for c, name in enumerate(("duty_a", "duty_b", "duty_c")):
            d[ok, c] = arrays[name][j[ok]]
        good = ok & np.isfinite(d).all(axis=1)
        rows["duty_raw"][good] = duty_raw_of(d[good])
        rows["has_duty"][good] = 1
        method_v = f"duties: zero-order hold at t_k + {delay * 1e6:g} us + Ts/2"
    else:
        from scipy.integrate import cumulative_trapezoid

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
    filt = fs > 2.0 * CUTOFF_PER_TS / ts * 1.05
    cap.resampling = {
        "daq_rate_hz": fs, "control_rate_hz": 1.0 / ts, "samples": int(len(t)),
        "method": (f"{'zero-phase Butterworth ' + str(2 * BUTTER_ORDER) + 'th order at ' + format(CUTOFF_PER_TS / ts, '.0f') + ' Hz (sosfiltfilt), then ' if filt else 'no anti-alias filter (the DAQ is not faster than the grid needs), '}"
                   f"cubic spline at t_k = t0 + k Ts; {method_v}"),
    }
    cap.notes.extend(dict.fromkeys(notes))
    return cap
