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
