"""Metrics computed from recorded arrays (numpy only; every function documents its definition).

Conventions: angles in rad, speeds in rpm (mechanical) at this edge, times in s. A metric over a
steady-state window takes the samples whose time lies in [t0, t1].
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

TWO_PI = 2.0 * math.pi


def wrap_pi(x: np.ndarray) -> np.ndarray:
    """Wrap angles to [-pi, pi)."""
    return (np.asarray(x) + math.pi) % TWO_PI - math.pi


def window_mask(t_s: np.ndarray, window_s: tuple[float, float]) -> np.ndarray:
    return (t_s >= window_s[0]) & (t_s <= window_s[1])


def speed_band_rpm(speed_rpm: np.ndarray, ref_rpm: float) -> float:
    """Speed fluctuation as the papers quote it (+-x rpm): max |n - n_ref| over the window."""
    s = np.asarray(speed_rpm, dtype=float)
    s = s[np.isfinite(s)]
    return float(np.max(np.abs(s - ref_rpm))) if s.size else math.nan


def half_peak_to_peak(x: np.ndarray) -> float:
    """(max - min) / 2 of the finite samples."""
    x = np.asarray(x, dtype=float)
    x = x[np.isfinite(x)]
    return float((x.max() - x.min()) / 2.0) if x.size else math.nan


@dataclass(frozen=True)
class AngleError:
    max_abs_rad: float
    mean_rad: float
    rms_rad: float


def angle_error(theta_hat_rad: np.ndarray, theta_true_rad: np.ndarray) -> AngleError:
    """Position-estimation error PEE = wrap(theta_hat - theta_true): max |PEE|, mean, RMS."""
    e = wrap_pi(np.asarray(theta_hat_rad, float) - np.asarray(theta_true_rad, float))
    e = e[np.isfinite(e)]
    if not e.size:
        return AngleError(math.nan, math.nan, math.nan)
    return AngleError(float(np.max(np.abs(e))), float(np.mean(e)), float(np.sqrt(np.mean(e * e))))


def mean_angle_rad(x: np.ndarray) -> float:
    """Circular mean of angles: atan2(mean sin, mean cos) in (-pi, pi] (a wrapped angle's mean
    that does not break at +-pi). NaN samples are ignored; NaN if none is left."""
    x = np.asarray(x, float)
    x = x[np.isfinite(x)]
    if not x.size:
        return math.nan
    return float(math.atan2(np.mean(np.sin(x)), np.mean(np.cos(x))))


def holds_speed(mean_rpm: float, ref_rpm: float) -> bool:
    """The bench's operating-point check (a bench definition, not a paper's rule): a window
    held ``ref_rpm`` when its true mean speed is within 10 % + 0.5 rpm of it."""
    return math.isfinite(mean_rpm) and abs(mean_rpm - ref_rpm) <= 0.1 * abs(ref_rpm) + 0.5


@dataclass(frozen=True)
class Spectrum:
    """Harmonic analysis of one signal over an integer number of fundamental periods."""

    fundamental_hz: float
    periods: int
    fundamental_amplitude: float
    harmonics: dict[int, float]       # order -> amplitude (orders 2..max_order)
    thd_percent: float                # sqrt(sum of harmonic^2) / fundamental
    thd_n_percent: float              # everything but DC and the fundamental bin / fundamental

    def harmonic_percent(self, order: int) -> float:
        return 100.0 * self.harmonics.get(order, math.nan) / self.fundamental_amplitude


def harmonic_spectrum(x: np.ndarray, fs_hz: float, fundamental_hz: float,
                      max_order: int = 50) -> Spectrum:
    """THD by FFT over the longest whole number of fundamental periods at the end of x.

    The samples are cut to P whole periods (P = floor(len * f1 / fs)) so that harmonic h falls
    on FFT bin h*P (rectangular window, no leakage for a stationary periodic signal). THD counts
    harmonics 2..max_order below Nyquist; THD+N counts every bin except DC and the fundamental.
    Amplitudes are peak values.
    """
    x = np.asarray(x, dtype=float)
    if not np.all(np.isfinite(x)):
        raise ValueError("signal has non-finite samples")
    if fundamental_hz <= 0:
        raise ValueError(f"fundamental must be > 0 Hz, got {fundamental_hz!r}")
    samples_per_period = fs_hz / fundamental_hz
    periods = int(math.floor(len(x) / samples_per_period))
    if periods < 1:
        raise ValueError(f"window holds {len(x)} samples, less than one period "
                         f"({samples_per_period:.1f} samples) of {fundamental_hz:.3g} Hz")
    n = int(round(periods * samples_per_period))
    seg = x[-n:]
    spec = np.fft.rfft(seg) / n
    amp = 2.0 * np.abs(spec)
    amp[0] /= 2.0
    fund = float(amp[periods])
    harmonics = {}
    for h in range(2, max_order + 1):
        b = h * periods
        if b >= len(amp) - 1:
            break
        harmonics[h] = float(amp[b])
    thd = 100.0 * math.sqrt(sum(a * a for a in harmonics.values())) / fund if fund > 0 else math.nan
    rest = np.delete(amp[1:], periods - 1)
    thd_n = 100.0 * float(np.sqrt(np.sum(rest ** 2))) / fund if fund > 0 else math.nan
    return Spectrum(fundamental_hz, periods, fund, harmonics, thd, thd_n)


def fundamental_amplitude(x: np.ndarray, fs_hz: float, fundamental_hz: float) -> float:
    return harmonic_spectrum(x, fs_hz, fundamental_hz, max_order=1).fundamental_amplitude


# -- estimation error ----------------------------------------------------------------------------

def speed_error_band_rpm(estimate_rpm: np.ndarray, truth_rpm: np.ndarray) -> float:
    """Speed-estimation error as the papers quote it (+-x rpm): max |n_hat - n| over the samples
    (estimate and true speed at the same instants). NaN samples are ignored."""
    e = np.asarray(estimate_rpm, float) - np.asarray(truth_rpm, float)
    e = e[np.isfinite(e)]
    return float(np.max(np.abs(e))) if e.size else math.nan


def mean_abs(x: np.ndarray) -> float:
    x = np.asarray(x, float)
    x = x[np.isfinite(x)]
    return float(np.mean(np.abs(x))) if x.size else math.nan


# -- transients ------------------------------------------------------------------------------------

def settling_time_s(t_s: np.ndarray, x: np.ndarray, target: float, band: float,
                    t_event_s: float) -> float:
    """Time from t_event_s until x enters [target - band, target + band] and stays there to the
    end of the samples. 0 if x is inside from the event on; NaN if it never settles (still
    outside at the last sample) or there are no samples after the event."""
    t = np.asarray(t_s, float)
    x = np.asarray(x, float)
    after = t >= t_event_s
    if not np.any(after):
        return math.nan
    t, x = t[after], x[after]
    outside = ~(np.abs(x - target) <= band)       # NaN counts as outside
    if not np.any(outside):
        return 0.0
    last = int(np.nonzero(outside)[0][-1])
    if last == len(x) - 1:
        return math.nan
    return float(t[last + 1] - t_event_s)


def response_time_s(t_s: np.ndarray, err: np.ndarray, t_event_s: float,
                    pre_window_s: float = 0.05, floor: float = 0.0) -> float:
    """Estimator response time to a disturbance at t_event_s: the time until the estimation error
    err (e.g. n_hat - n) is back, for good, inside the band it kept before the event
    (max |err| over [t_event_s - pre_window_s, t_event_s), at least ``floor``)."""
    t = np.asarray(t_s, float)
    e = np.asarray(err, float)
    pre = (t >= t_event_s - pre_window_s) & (t < t_event_s) & np.isfinite(e)
    if not np.any(pre):
        return math.nan
    band = max(float(np.max(np.abs(e[pre]))), floor)
    return settling_time_s(t, e, 0.0, band, t_event_s)


@dataclass(frozen=True)
class Dip:
    """Speed dip after a load step (or rise after an unload: ``sign`` = -1)."""

    depth: float          # max excursion from the reference against the disturbance (>= 0)
    t_extreme_s: float    # when it happened (after the event)
    recovery_s: float     # from the event until back within ``band`` of the reference for good


def speed_dip(t_s: np.ndarray, speed: np.ndarray, t_event_s: float, ref: float, band: float,
              sign: float = 1.0, t_end_s: float | None = None) -> Dip:
    """Dip of ``speed`` below ``ref`` after t_event_s (sign = +1: a load step slows the rotor;
    sign = -1: an unload speeds it up), up to t_end_s. depth = max(sign (ref - speed))."""
    t = np.asarray(t_s, float)
    n = np.asarray(speed, float)
    m = t >= t_event_s
    if t_end_s is not None:
        m &= t <= t_end_s
    if not np.any(m):
        return Dip(math.nan, math.nan, math.nan)
    dev = sign * (ref - n[m])
    i = int(np.nanargmax(dev))
    return Dip(max(float(dev[i]), 0.0), float(t[m][i]),
               settling_time_s(t[m], n[m], ref, band, t_event_s))


@dataclass(frozen=True)
class StepResponse:
    overshoot: float      # beyond the final value, in the step's direction (>= 0)
    settling_s: float     # from the step until within ``band`` of the final value for good


def step_response(t_s: np.ndarray, x: np.ndarray, t_step_s: float, final: float, band: float,
                  t_end_s: float | None = None) -> StepResponse:
    """Overshoot and settling time of a step to ``final`` at t_step_s (the direction is taken
    from the value just before the step)."""
    t = np.asarray(t_s, float)
    x = np.asarray(x, float)
    before = x[t < t_step_s]
    m = t >= t_step_s
    if t_end_s is not None:
        m &= t <= t_end_s
    if not before.size or not np.any(m):
        return StepResponse(math.nan, math.nan)
    direction = 1.0 if final >= before[-1] else -1.0
    over = max(float(np.nanmax(direction * (x[m] - final))), 0.0)
    return StepResponse(over, settling_time_s(t[m], x[m], final, band, t_step_s))


# -- observers ------------------------------------------------------------------------------------

def chattering_index_a(i_hat_alpha: np.ndarray, i_hat_beta: np.ndarray, i_alpha: np.ndarray,
                       i_beta: np.ndarray, t_s: np.ndarray | None = None,
                       omega_e_rad_s: float | None = None) -> float:
    """Chattering of a sliding-mode observer about its sliding surface i_hat - i = 0 (Yuan
    Fig. 17: the estimated current against the measured one): the RMS of the current
    observation error d = i_hat - i in alpha-beta [A], after removing from each axis its DC and
    its component at the electrical frequency omega_e_rad_s (least squares over the window) when
    t_s and omega_e_rad_s are given. That smooth part is not chattering: an observer working as
    a linear one (a smooth switching function inside its boundary layer) keeps d proportional to
    the back EMF, e = L_obs d, a clean sinusoid. What is left is the scatter about the smooth
    trajectory: the width of the band in Fig. 17."""
    d = [np.asarray(i_hat_alpha, float) - np.asarray(i_alpha, float),
         np.asarray(i_hat_beta, float) - np.asarray(i_beta, float)]
    ok = np.isfinite(d[0]) & np.isfinite(d[1])
    if not np.any(ok):
        return math.nan
    d = [x[ok] for x in d]
    if t_s is not None and omega_e_rad_s is not None:
        t = np.asarray(t_s, float)[ok]
        w = float(omega_e_rad_s)
        basis = np.stack([np.ones_like(t), np.cos(w * t), np.sin(w * t)], axis=1)
        d = [x - basis @ np.linalg.lstsq(basis, x, rcond=None)[0] for x in d]
    return float(np.sqrt(np.mean(d[0] ** 2 + d[1] ** 2)))


# -- initial position --------------------------------------------------------------------------------

@dataclass(frozen=True)
class InitialPosition:
    error_rad: np.ndarray     # wrap(theta_hat - theta) per trial
    max_abs_rad: float        # over the trials whose polarity is right
    polarity_rate: float      # fraction of trials with |error| < pi/2 (N/S right)


def initial_position(theta_hat_rad, theta_true_rad) -> InitialPosition:
    """Initial-position results of several trials: the error of each, the largest error among the
    trials with the right N/S polarity, and the polarity success rate (a wrong polarity reads
    about pi)."""
    e = wrap_pi(np.asarray(theta_hat_rad, float) - np.asarray(theta_true_rad, float))
    ok = np.abs(e) < math.pi / 2
    return InitialPosition(e, float(np.max(np.abs(e[ok]))) if np.any(ok) else math.nan,
                           float(np.mean(ok)) if e.size else math.nan)


# -- computation delay (Gong eq. 20) -------------------------------------------------------------

def delay_estimates_s(i1: np.ndarray, i2: np.ndarray, ts_s: float, min_step: float = 1e-3,
                      t_max_s: float | None = None) -> np.ndarray:
    """Gong eq. 20 per period and phase: t_d = |i2(k) - i1(k)| / |i2(k) - i2(k-1)| * Ts.

    i1[k]: the sample at t_k; i2[k]: the sample at the actuation instant t_k + t_d of the same
    period (arrays (n,) or (n, phases)). Periods whose denominator is below ``min_step`` (no
    usable current change) or whose estimate exceeds ``t_max_s`` (default 0.9 Ts) are dropped
    (the guards of firmware_stub/src/est_delay_comp.c). Returns the per-period mean over the
    valid phases (NaN where none is valid)."""
    i1 = np.atleast_2d(np.asarray(i1, float).T).T
    i2 = np.atleast_2d(np.asarray(i2, float).T).T
    t_max = 0.9 * ts_s if t_max_s is None else t_max_s
    num = np.abs(i2[1:] - i1[1:])
    den = np.abs(i2[1:] - i2[:-1])
    with np.errstate(divide="ignore", invalid="ignore"):
        td = num / den * ts_s
    td[~(den >= min_step) | ~(td <= t_max)] = np.nan
    valid = np.isfinite(td)
    out = np.full(td.shape[0], np.nan)
    has = valid.any(axis=1)
    out[has] = np.nansum(np.where(valid, td, 0.0), axis=1)[has] / valid.sum(axis=1)[has]
    return out


def percent_change(before: float, after: float) -> float:
    """100 (after - before) / |before| (e.g. the iq change of Gong's G6: negative = falls)."""
    return 100.0 * (after - before) / abs(before) if before else math.nan


def window_start_s(rec) -> float:
    """Start of the metrics window of the scenario attached to a recording ([metrics] window_s)."""
    from hil_bench.scenario import scenario_of
    return float(scenario_of(rec).metrics_window_s[0])
