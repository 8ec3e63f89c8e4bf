"""Signal checks for scripted tests: the assertions HIL engineers write on a recorded response
(docs/api.md, "Signal checks").

Every check takes a signal with its time base -- a pandas Series indexed by time [s] (a column
of ``Session.capture()``, of ``load_recording(...)[topic].set_index("t_s")``), or an array with
``t=`` its times [s] -- returns the figure it measured, and raises :class:`SignalCheckFailed` (an
AssertionError) whose message says where (the time) and by how much the signal missed::

    from hil_bench import signals

    w = s.capture(0.5)                                   # Session: rows from the step on
    signals.settles(w.speed_rpm, 800, band=16, within_s=0.3)      -> settling time [s]
    signals.overshoot(w.speed_rpm, 800, below_pct=10)              -> overshoot [% of the step]
    signals.rise_time(w.speed_rpm, 500, 800, within_s=0.15)       -> 10-90 % rise time [s]
    signals.stays_within(w.i_q_a, -1, 12, start_s=0.2)           -> (min, max)
    signals.stays_near(w.speed_rpm, 800, 8, start_s=0.3)         -> largest deviation
    signals.follows_ramp(w.speed_rpm, slope_per_s=2000, tolerance=20)   -> largest error
    signals.frequency(w.e_alpha_v, expected_hz=33.3, rel_tol=0.01)     -> frequency [Hz]

Times (``start_s``, ``end_s``) are on the signal's own time base; durations (``within_s``) count
from ``start_s`` (default: the first sample). Samples that are NaN (a cycle without telemetry)
are left out. Crossing times are interpolated linearly between samples; peaks and extremes are
the samples'; the frequency is the peak of a Hann-windowed spectrum (numpy's FFT) refined by a
least-squares fit of the tone and its harmonics (numpy, scipy.optimize).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Callable

import numpy as np

from hil_bench.errors import ArgumentError, BenchError

__all__ = ["SignalCheckFailed", "settles", "overshoot", "rise_time", "stays_within",
           "stays_near", "follows", "follows_ramp", "frequency"]


class SignalCheckFailed(BenchError, AssertionError):
    """A signal check failed. ``measured``: the figure measured (NaN if none); ``t_s``: where
    [s]; ``by``: how far beyond the limit (in the check's unit)."""

    def __init__(self, message: str, measured: float = math.nan, t_s: float = math.nan,
                 by: float = math.nan):
        super().__init__(message)
        self.measured = measured
        self.t_s = t_s
        self.by = by


@dataclass(frozen=True)
class _Signal:
    name: str
    t: np.ndarray
    y: np.ndarray


def _signal(y: Any, t: Any, start_s: float | None, end_s: float | None,
            what: str) -> _Signal:
    """The samples of ``y`` with their times, NaNs left out, within [start_s, end_s]."""
    name = "signal"
    if t is None:
        index = getattr(y, "index", None)
        if index is None or hasattr(y, "columns"):
            raise ArgumentError(f"signals.{what}: give a pandas Series indexed by time [s], or an "
                            f"array with t= its times [s]"
                            + (" (a DataFrame: pick a column, e.g. w.speed_rpm)"
                               if hasattr(y, "columns") else ""))
        name = str(getattr(y, "name", None) or name)
        tt = np.asarray(index, dtype=float)
    else:
        name = str(getattr(y, "name", None) or name)
        tt = np.asarray(t, dtype=float)
    yy = np.asarray(y, dtype=float)
    if yy.ndim != 1 or tt.shape != yy.shape:
        raise ArgumentError(f"signals.{what}: {name} has {yy.shape} values and {tt.shape} times "
                         f"(one time per sample)")
    if len(tt) > 1 and not np.all(np.diff(tt) > 0):
        raise ArgumentError(f"signals.{what}: the times of {name} do not increase")
    keep = np.isfinite(yy)
    if start_s is not None:
        keep &= tt >= start_s - 1e-12
    if end_s is not None:
        keep &= tt <= end_s + 1e-12
    if keep.sum() < 2:
        span = f" in [{start_s}, {end_s}] s" if (start_s, end_s) != (None, None) else ""
        raise ArgumentError(f"signals.{what}: {name} has {int(keep.sum())} finite samples{span}; "
                         f"a check needs at least 2")
    return _Signal(name, tt[keep], yy[keep])


def _fmt(v: float) -> str:
    return f"{v:.6g}"


def _crossing(t: np.ndarray, y: np.ndarray, i: int, level: float) -> float:
    """The time the line from sample i-1 to sample i crosses ``level`` (i's time if i == 0)."""
    if i <= 0:
        return float(t[0])
    y0, y1 = y[i - 1], y[i]
    if y1 == y0:
        return float(t[i])
    return float(t[i - 1] + (level - y0) / (y1 - y0) * (t[i] - t[i - 1]))


def settles(y: Any, target: float, *, within_s: float, band: float | None = None,
            band_pct: float | None = None, start_s: float | None = None,
            t: Any = None) -> float:
    """The signal enters ``target ± band`` and stays in it to its end, within ``within_s`` of
    ``start_s``. ``band_pct``: the band in percent of the step (|target - the first sample|).
    Returns the settling time [s] after ``start_s`` (interpolated to the band's edge)."""
    __tracebackhide__ = True
    s = _signal(y, t, start_s, None, "settles")
    t0 = float(s.t[0]) if start_s is None else float(start_s)
    if (band is None) == (band_pct is None):
        raise ArgumentError("signals.settles: give band (absolute) or band_pct (of the step)")
    if band is None:
        band = abs(target - s.y[0]) * band_pct / 100.0
    if not band > 0:
        raise ArgumentError(f"signals.settles: the band is > 0, got {band!r}")
    err = np.abs(s.y - target)
    out = np.flatnonzero(err > band)
    if out.size == 0:
        settle = 0.0
    elif out[-1] == len(s.y) - 1:
        worst = int(np.argmax(err))
        raise SignalCheckFailed(
            f"{s.name} does not settle to {_fmt(target)} ± {_fmt(band)}: at its last sample "
            f"(t = {_fmt(s.t[-1])} s) it is {_fmt(s.y[-1])}, {_fmt(err[-1] - band)} beyond the "
            f"band (furthest {_fmt(s.y[worst])} at t = {_fmt(s.t[worst])} s)",
            math.inf, float(s.t[-1]), float(err[-1] - band))
    else:
        i = int(out[-1]) + 1                      # the first sample of the last stay in the band
        edge = target + band if s.y[i - 1] > target else target - band
        settle = _crossing(s.t, s.y, i, edge) - t0
    if settle > within_s:
        late = t0 + within_s
        after = np.flatnonzero(s.t > late)
        j = int(after[np.argmax(err[after])])      # the furthest excursion after the deadline
        raise SignalCheckFailed(
            f"{s.name} settles to {_fmt(target)} ± {_fmt(band)} {_fmt(settle)} s after "
            f"t = {_fmt(t0)} s (at t = {_fmt(t0 + settle)} s), {_fmt(settle - within_s)} s later "
            f"than {_fmt(within_s)} s; after t = {_fmt(late)} s it is out of the band up to "
            f"{_fmt(s.y[j])} at t = {_fmt(s.t[j])} s, {_fmt(err[j] - band)} beyond it",
            settle, t0 + settle, settle - within_s)
    return settle


def overshoot(y: Any, target: float, *, below_pct: float | None = None,
              initial: float | None = None, start_s: float | None = None,
              t: Any = None) -> float:
    """How far the signal goes beyond ``target`` in the step's direction, in percent of the step
    (``target - initial``; ``initial`` default: the first sample); fails unless below
    ``below_pct``. Returns the overshoot [%] (0 when it never passes the target)."""
    __tracebackhide__ = True
    s = _signal(y, t, start_s, None, "overshoot")
    y0 = float(s.y[0]) if initial is None else float(initial)
    step = target - y0
    if step == 0:
        raise ArgumentError(f"signals.overshoot: no step (target {_fmt(target)} = initial)")
    beyond = (s.y - target) * math.copysign(1.0, step)
    i = int(np.argmax(beyond))
    pct = max(float(beyond[i]), 0.0) / abs(step) * 100.0
    if below_pct is not None and not pct < below_pct:
        raise SignalCheckFailed(
            f"{s.name} overshoots {_fmt(target)} by {_fmt(pct)} % of the step from {_fmt(y0)} "
            f"({_fmt(s.y[i])} at t = {_fmt(s.t[i])} s, {_fmt(beyond[i])} beyond the target), "
            f"not below {_fmt(below_pct)} %: {_fmt(pct - below_pct)} points over",
            pct, float(s.t[i]), pct - below_pct)
    return pct


def rise_time(y: Any, initial: float, final: float, *, within_s: float | None = None,
              levels: tuple[float, float] = (0.1, 0.9), start_s: float | None = None,
              t: Any = None) -> float:
    """The time the signal takes through the step from ``initial`` to ``final`` between the
    ``levels`` of it (10-90 % by default; a falling step when final < initial), from its first
    crossing of the lower level to its first crossing of the upper; fails unless within
    ``within_s``. Returns the rise (or fall) time [s]."""
    __tracebackhide__ = True
    s = _signal(y, t, start_s, None, "rise_time")
    lo_f, hi_f = levels
    if not 0.0 <= lo_f < hi_f <= 1.0:
        raise ArgumentError(f"signals.rise_time: levels are 0 <= low < high <= 1, got {levels!r}")
    step = final - initial
    if step == 0:
        raise ArgumentError("signals.rise_time: no step (final = initial)")
    word = "rises" if step > 0 else "falls"
    sign = math.copysign(1.0, step)
    progress = (s.y - initial) * sign                   # > 0 towards final
    lo, hi = initial + lo_f * step, initial + hi_f * step
    a = np.flatnonzero(progress >= lo_f * abs(step))
    b = np.flatnonzero(progress >= hi_f * abs(step))
    if a.size == 0 or b.size == 0:
        level, frac = (lo, lo_f) if a.size == 0 else (hi, hi_f)
        i = int(np.argmax(progress))
        raise SignalCheckFailed(
            f"{s.name} never {word} to {_fmt(level)} ({_fmt(frac * 100)} % of the step from "
            f"{_fmt(initial)} to {_fmt(final)}): it gets to {_fmt(s.y[i])} at most "
            f"(t = {_fmt(s.t[i])} s), {_fmt(abs(level - s.y[i]))} short",
            math.inf, float(s.t[i]), abs(level - float(s.y[i])))
    t_lo = _crossing(s.t, s.y, int(a[0]), lo)
    t_hi = _crossing(s.t, s.y, int(b[0]), hi)
    rise = t_hi - t_lo
    if within_s is not None and rise > within_s:
        raise SignalCheckFailed(
            f"{s.name} {word} from {_fmt(lo)} to {_fmt(hi)} ({_fmt(lo_f * 100)}-"
            f"{_fmt(hi_f * 100)} % of {_fmt(initial)} -> {_fmt(final)}) in {_fmt(rise)} s "
            f"(t = {_fmt(t_lo)} to {_fmt(t_hi)} s), {_fmt(rise - within_s)} s longer than "
            f"{_fmt(within_s)} s", rise, t_hi, rise - within_s)
    return rise


def _excursions(s: _Signal, over: np.ndarray) -> str:
    """Where the samples flagged ``over`` are: the first stretch and how many there are."""
    idx = np.flatnonzero(over)
    breaks = np.flatnonzero(np.diff(idx) > 1)
    first_end = idx[breaks[0]] if breaks.size else idx[-1]
    stretches = breaks.size + 1
    return (f"from t = {_fmt(s.t[idx[0]])} s to {_fmt(s.t[first_end])} s"
            + (f" (and {stretches - 1} more stretch{'es' if stretches > 2 else ''}, "
               f"{idx.size} samples in all)" if stretches > 1 else f" ({idx.size} samples)"))


def stays_within(y: Any, low: float | None = None, high: float | None = None, *,
                 start_s: float | None = None, end_s: float | None = None,
                 t: Any = None) -> tuple[float, float]:
    """Every sample in [start_s, end_s] lies in [low, high] (either may be None: unbounded).
    Returns the (min, max) of the samples."""
    __tracebackhide__ = True
    s = _signal(y, t, start_s, end_s, "stays_within")
    if low is None and high is None:
        raise ArgumentError("signals.stays_within: give low, high or both")
    lo = -math.inf if low is None else float(low)
    hi = math.inf if high is None else float(high)
    if not lo <= hi:
        raise ArgumentError(f"signals.stays_within: low {lo:g} > high {hi:g}")
    beyond = np.maximum(s.y - hi, lo - s.y)
    if (beyond > 0).any():
        i = int(np.argmax(beyond))
        side = "above" if s.y[i] > hi else "below"
        raise SignalCheckFailed(
            f"{s.name} leaves [{_fmt(lo)}, {_fmt(hi)}] {_excursions(s, beyond > 0)}; furthest "
            f"at t = {_fmt(s.t[i])} s: {_fmt(s.y[i])}, {_fmt(beyond[i])} {side} the band",
            float(s.y[i]), float(s.t[i]), float(beyond[i]))
    return float(s.y.min()), float(s.y.max())


def stays_near(y: Any, value: float, tolerance: float, *, start_s: float | None = None,
               end_s: float | None = None, t: Any = None) -> float:
    """Every sample in [start_s, end_s] lies within ``value ± tolerance``. Returns the largest
    deviation |y - value|."""
    __tracebackhide__ = True
    return _follows(y, lambda tt: np.full_like(tt, float(value)), tolerance, start_s, end_s, t,
                    "stays_near", f"{_fmt(value)}")


def follows(y: Any, reference: Any, tolerance: float, *, start_s: float | None = None,
            end_s: float | None = None, t: Any = None) -> float:
    """Every sample in [start_s, end_s] lies within ``tolerance`` of ``reference``: a function of
    time [s] (vectorised over numpy arrays), or a Series indexed by time (interpolated linearly
    at the signal's times). Returns the largest deviation."""
    __tracebackhide__ = True
    if callable(reference):
        ref = reference
    else:
        rt = np.asarray(getattr(reference, "index", None), dtype=float)
        ry = np.asarray(reference, dtype=float)
        if rt.shape != ry.shape:
            raise ArgumentError("signals.follows: the reference is a function of time or a Series "
                            "indexed by time [s]")
        ref = lambda tt: np.interp(tt, rt, ry)   # noqa: E731
    return _follows(y, ref, tolerance, start_s, end_s, t, "follows", "the reference")


def follows_ramp(y: Any, *, slope_per_s: float, tolerance: float,
                 start_value: float | None = None, start_s: float | None = None,
                 end_s: float | None = None, t: Any = None) -> float:
    """The signal follows the ramp ``start_value + slope_per_s (t - start_s)`` within
    ``tolerance`` over [start_s, end_s] (``start_value`` default: the first sample). Returns the
    largest deviation."""
    __tracebackhide__ = True
    s = _signal(y, t, start_s, end_s, "follows_ramp")
    t0 = float(s.t[0])
    v0 = float(s.y[0]) if start_value is None else float(start_value)
    slope = float(slope_per_s)
    return _follows(s.y, lambda tt: v0 + slope * (tt - t0), tolerance, None, None, s.t,
                    "follows_ramp", f"the ramp {_fmt(v0)} + {_fmt(slope)}/s (t - {_fmt(t0)} s)",
                    name=s.name)


def _follows(y, ref: Callable, tolerance: float, start_s, end_s, t, what: str, against: str,
             name: str | None = None) -> float:
    __tracebackhide__ = True
    s = _signal(y, t, start_s, end_s, what)
    if name is not None:
        s = _Signal(name, s.t, s.y)
    if not tolerance > 0:
        raise ArgumentError(f"signals.{what}: the tolerance is > 0, got {tolerance!r}")
    r = np.asarray(ref(s.t), dtype=float)
    dev = s.y - r
    err = np.abs(dev)
    i = int(np.argmax(err))
    if err[i] > tolerance:
        raise SignalCheckFailed(
            f"{s.name} leaves {against} ± {_fmt(tolerance)} {_excursions(s, err > tolerance)}; "
            f"furthest at t = {_fmt(s.t[i])} s: {_fmt(s.y[i])} against {_fmt(r[i])}, "
            f"{_fmt(err[i] - tolerance)} beyond the tolerance",
            float(err[i]), float(s.t[i]), float(err[i] - tolerance))
    return float(err[i])


#: harmonics of the fundamental fitted with it (below Nyquist), so that a distorted oscillation's
#: harmonics do not pull the estimate
FIT_HARMONICS = 5


def _dominant_frequency(s: _Signal) -> float:
    """Hann-windowed, zero-padded spectrum (numpy's FFT): the peak; then the frequency whose
    least-squares fit of a sine at it, its harmonics and a constant (numpy.linalg.lstsq) leaves
    the least residual, within half a bin of the peak (scipy.optimize.minimize_scalar): the
    maximum-likelihood estimate for a tone in white noise, free of the bias the window's
    leakage and the negative-frequency image give the peak alone over a few periods."""
    from hil_bench.installation import require_extra

    minimize_scalar = require_extra("signals.frequency", "scipy.optimize").minimize_scalar

    n = len(s.t)
    dt = np.diff(s.t)
    step = float(np.median(dt))
    if n < 8 or np.max(np.abs(dt - step)) > 1e-6 * step + 1e-12:
        raise ArgumentError(f"signals.frequency: {s.name} needs at least 8 uniformly spaced samples "
                         f"(a gap or a decimated stretch: pick a window without one)")
    v = s.y - s.y.mean()
    if not np.any(v):
        raise SignalCheckFailed(f"{s.name} does not oscillate from t = {_fmt(s.t[0])} s to "
                                f"{_fmt(s.t[-1])} s (it is constant at {_fmt(s.y[0])})")
    pad = 1 << int(math.ceil(math.log2(8 * n)))
    spec = np.abs(np.fft.rfft(v * np.hanning(n), pad))
    k = int(np.argmax(spec[1:])) + 1
    f0 = k / (pad * step)
    tt = s.t - s.t[0]
    harmonics = max(1, min(FIT_HARMONICS, int(0.45 / (f0 * step))))

    def residual(f: float) -> float:
        cols = [np.ones(n)]
        for h in range(1, harmonics + 1):
            cols += [np.sin(2 * np.pi * h * f * tt), np.cos(2 * np.pi * h * f * tt)]
        a = np.stack(cols, axis=1)
        c = np.linalg.lstsq(a, s.y, rcond=None)[0]
        return float(np.sum((a @ c - s.y) ** 2))

    half_bin = 0.5 / (n * step)
    lo, hi = max(f0 - half_bin, 0.25 / (n * step)), min(f0 + half_bin, 0.5 / step)
    best = minimize_scalar(residual, bounds=(lo, hi), method="bounded",
                           options={"xatol": 1e-12 * f0})
    return float(best.x) if best.success else float(f0)


def frequency(y: Any, *, expected_hz: float | None = None, tolerance_hz: float | None = None,
              rel_tol: float | None = None, start_s: float | None = None,
              end_s: float | None = None, t: Any = None) -> float:
    """The frequency of the signal's dominant oscillation [Hz] over [start_s, end_s] (uniformly
    sampled): the peak of a Hann-windowed spectrum, refined by a least-squares fit of a sine, its
    harmonics and a constant (``_dominant_frequency``). With ``expected_hz`` it fails unless
    within ``tolerance_hz`` or ``rel_tol`` (relative) of it."""
    __tracebackhide__ = True
    s = _signal(y, t, start_s, end_s, "frequency")
    f_hz = _dominant_frequency(s)
    if expected_hz is not None:
        if tolerance_hz is None and rel_tol is None:
            raise ArgumentError("signals.frequency: with expected_hz give tolerance_hz or rel_tol")
        tol = min(x for x in (tolerance_hz, None if rel_tol is None else rel_tol * expected_hz)
                  if x is not None)
        off = f_hz - expected_hz
        if abs(off) > tol:
            raise SignalCheckFailed(
                f"{s.name} oscillates at {_fmt(f_hz)} Hz from t = {_fmt(s.t[0])} s to "
                f"{_fmt(s.t[-1])} s, {_fmt(off)} Hz from {_fmt(expected_hz)} Hz (tolerance "
                f"{_fmt(tol)} Hz): {_fmt(abs(off) - tol)} Hz beyond",
                f_hz, float(s.t[0]), abs(off) - tol)
    return f_hz
