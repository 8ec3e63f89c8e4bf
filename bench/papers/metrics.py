"""Metrics computed from recorded arrays (numpy only; every function documents its definition).

Conventions: angles in rad, speeds in rpm (mechanical) at this edge, times in s. A metric over a
steady-state window takes the samples whose time lies in [t0, t1].
"""
from __future__ import annotations

import dataclasses
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
    """Harmonic analysis of one signal over a whole number of electrical revolutions."""

    fundamental_hz: float             # mean electrical frequency over the revolutions (NaN: no fs)
    periods: int                      # whole revolutions of the angle the fit ran over
    fundamental_amplitude: float
    harmonics: dict[int, float]       # order -> amplitude (orders 2..max_order below Nyquist)
    thd_percent: float                # sqrt(sum of harmonic^2) / fundamental
    thd_n_percent: float              # everything but DC and the fundamental / fundamental
    phases_rad: dict[int, float] = dataclasses.field(default_factory=dict)  # order -> phase

    def harmonic_percent(self, order: int) -> float:
        return 100.0 * self.harmonics.get(order, math.nan) / self.fundamental_amplitude


def locked_spectrum(x: np.ndarray, theta_e_rad: np.ndarray, fs_hz: float | None = None,
                    max_order: int = 50) -> Spectrum:
    """Harmonics of x locked to the rotor: least squares on the electrical angle.

    ``theta_e_rad`` is the true electrical angle at the instants of the samples (wrapped or not;
    it is unwrapped here and must turn one way). The samples are cut to the longest whole number
    P of revolutions ending at the last sample (each sample standing for the angle step after
    it, so that N samples of one revolution at a constant speed are a whole one, as an FFT
    counts them), and x is fitted by

        x = c0 + sum_h (a_h cos h theta + b_h sin h theta),   h = 1 .. H

    H = max_order, lowered to the orders below Nyquist (h times the largest angle step per sample
    below pi). Amplitudes are peak values, A_h = hypot(a_h, b_h). THD counts the fitted orders
    2..H; THD+N is the RMS of everything the DC and the fundamental leave (harmonics beyond H,
    noise, anything not periodic in the angle) as a peak value, sqrt(2 mean(r^2)), over A_1.

    Unlike an FFT cut on the window's mean frequency, this does not leak when the speed drifts or
    a revolution is not a whole number of samples: a harmonic of the angle is a column of the
    fit whatever the speed did (tests/test_metrics.py). ``fs_hz`` (optional) only gives
    ``fundamental_hz``, the mean electrical frequency over the revolutions."""
    x = np.asarray(x, dtype=float)
    th = np.asarray(theta_e_rad, dtype=float)
    if x.shape != th.shape or x.ndim != 1:
        raise ValueError(f"signal and angle must be 1-D of one length, got {x.shape} and {th.shape}")
    if not (np.all(np.isfinite(x)) and np.all(np.isfinite(th))):
        raise ValueError("signal or angle has non-finite samples")
    if x.size < 3:
        raise ValueError(f"window holds {x.size} samples, less than one revolution")
    th = np.unwrap(th)
    if th[-1] < th[0]:                     # turning backwards: the same fit on -theta
        th = -th
    step = np.diff(th)
    if np.any(step < -1e-9):
        raise ValueError("the electrical angle does not turn one way in the window: no harmonic "
                         "of it to fit")
    # each sample stands for the step that follows it: N samples of a constant speed span
    # N steps (the FFT's convention), so a revolution of N samples is a whole one
    dstep = (th[-1] - th[0]) / (th.size - 1)
    span = th[-1] - th[0] + dstep
    periods = int(math.floor(span / TWO_PI + 1e-9))
    if periods < 1:
        raise ValueError(f"window holds {span / TWO_PI:.3g} electrical revolutions, less than one")
    first = int(np.searchsorted(th, th[-1] + dstep - TWO_PI * periods - 1e-6 * dstep))
    seg, ang = x[first:], th[first:]
    largest_step = float(np.max(np.diff(ang))) if ang.size > 1 else math.pi
    # orders whose largest step stays half a step below pi: at pi itself (a hair above an even
    # number of samples per revolution) the sine column is almost zero and the fit amplifies noise
    nyquist = (int(math.floor(math.pi / largest_step - 0.5)) if largest_step > 0 else max_order)
    top = max(1, min(max_order, nyquist))
    cols = [np.ones_like(ang)]
    for h in range(1, top + 1):
        cols += [np.cos(h * ang), np.sin(h * ang)]
    basis = np.stack(cols, axis=1)
    coef = np.linalg.lstsq(basis, seg, rcond=None)[0]
    amp = {h: float(math.hypot(coef[2 * h - 1], coef[2 * h])) for h in range(1, top + 1)}
    phase = {h: float(math.atan2(-coef[2 * h], coef[2 * h - 1])) for h in range(1, top + 1)}
    fund = amp[1]
    harmonics = {h: a for h, a in amp.items() if h >= 2}
    thd = 100.0 * math.sqrt(sum(a * a for a in harmonics.values())) / fund if fund > 0 else math.nan
    rest = seg - basis[:, :3] @ coef[:3]
    thd_n = 100.0 * math.sqrt(2.0 * float(np.mean(rest ** 2))) / fund if fund > 0 else math.nan
    f1 = periods * fs_hz / len(seg) if fs_hz else math.nan
    return Spectrum(f1, periods, fund, harmonics, thd, thd_n, phase)


def harmonic_spectrum(x: np.ndarray, fs_hz: float, fundamental_hz: float,
                      max_order: int = 50) -> Spectrum:
    """The spectrum of x locked to a constant-frequency angle 2 pi f1 t (``locked_spectrum``):
    for a signal whose frequency is known to be constant (a synthetic trajectory, a study at a
    fixed speed). Over a whole number of periods of a whole number of samples it equals the FFT's
    bins; it does not leak when a period is not a whole number of samples. Claims on recordings
    use ``locked_spectrum`` on the plant's true angle (the speed drifts)."""
    if fundamental_hz <= 0:
        raise ValueError(f"fundamental must be > 0 Hz, got {fundamental_hz!r}")
    x = np.asarray(x, dtype=float)
    if x.size * fundamental_hz / fs_hz < 1.0 - 1e-9:
        raise ValueError(f"window holds {len(x)} samples, less than one period "
                         f"({fs_hz / fundamental_hz:.1f} samples) of {fundamental_hz:.3g} Hz")
    theta = TWO_PI * fundamental_hz * np.arange(x.size) / fs_hz
    return locked_spectrum(x, theta, fs_hz, max_order)


def fundamental_amplitude(x: np.ndarray, fs_hz: float, fundamental_hz: float) -> float:
    return harmonic_spectrum(x, fs_hz, fundamental_hz, max_order=1).fundamental_amplitude


# -- steadiness of a window ----------------------------------------------------------------------

#: the steadiness rule's floor: half the finest print precision of the papers' speed figures
#: (Yuan's +-1.5 rpm, Gong's +-7.5 rpm are printed to 0.1 rpm), plus a hundredth of the smallest
#: speed fluctuation the papers quote relative to their speed (Gong's +-24 rpm at 2000 rpm: 1.2 %)
#: times the speed: a settling tail below it changes no comparison with a printed number
STEADY_FLOOR_RPM = 0.05
STEADY_FLOOR_REL = 1.0e-4
#: how much wider than its second half's band the whole window may be (the extremes of a
#: stationary signal differ from half to half; a decaying transient's do by more)
STEADY_FACTOR = 2.0


@dataclass(frozen=True)
class Steadiness:
    steady: bool
    band_rpm: float          # max |n - mean of the second half| over the second half
    whole_rpm: float         # the same over the whole window
    limit_rpm: float         # STEADY_FACTOR x band + STEADY_FLOOR_RPM + STEADY_FLOOR_REL |mean|

    def text(self) -> str:
        return (f"the true speed keeps {self.band_rpm:.3g} rpm about its mean in the window's "
                f"second half but {self.whole_rpm:.3g} rpm over the whole window (limit "
                f"{self.limit_rpm:.3g} rpm)")


STEADY_DEF = (f"bench definition: a window is steady when the true speed over the whole window "
              f"stays within {STEADY_FACTOR:g} x the band it keeps in the window's second half "
              f"(about that half's mean) + {STEADY_FLOOR_RPM:g} rpm + {100 * STEADY_FLOOR_REL:g} % "
              f"of the speed: the settling-time idea (a transient has settled once the signal "
              f"stays in the band of its final value, Ogata, Modern Control Engineering, 5-3) "
              f"with the final band measured, not assumed; {STEADY_FLOOR_RPM:g} rpm is half the "
              f"papers' finest printed speed step (0.1 rpm), {100 * STEADY_FLOOR_REL:g} % a "
              f"hundredth of the smallest relative speed fluctuation they quote (Gong's +-24 rpm "
              f"at 2000 rpm, 1.2 %)")


def steadiness(speed_rpm: np.ndarray) -> Steadiness:
    """Whether a window is steady state (``STEADY_DEF``): a decaying transient (a settling after
    a start-up or a step) is wider in the first half than in the second; a stationary ripple is
    not."""
    n = np.asarray(speed_rpm, float)
    n = n[np.isfinite(n)]
    if n.size < 4:
        return Steadiness(False, math.nan, math.nan, math.nan)
    second = n[n.size // 2:]
    mid = float(np.mean(second))
    band = float(np.max(np.abs(second - mid)))
    whole = float(np.max(np.abs(n - mid)))
    limit = STEADY_FACTOR * band + STEADY_FLOOR_RPM + STEADY_FLOOR_REL * abs(mid)
    return Steadiness(whole <= limit, band, whole, limit)


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
