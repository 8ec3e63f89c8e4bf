"""Metrics against signals whose answer is known, and against scipy's independent estimate."""
import math

import numpy as np
import pytest
from scipy import signal

from bench import metrics

FS = 10_000.0


def test_thd_of_known_harmonics():
    f1 = 33.3
    t = np.arange(int(FS * 0.6)) / FS
    x = 2.0 * np.sin(2 * np.pi * f1 * t) + 0.08 * np.sin(2 * np.pi * 5 * f1 * t + 0.3) \
        + 0.06 * np.sin(2 * np.pi * 7 * f1 * t - 1.0)
    s = metrics.harmonic_spectrum(x, FS, f1)
    # exact up to the rounding of the whole-period window to whole samples (< 0.5 sample)
    assert s.fundamental_amplitude == pytest.approx(2.0, rel=2e-3)
    assert s.harmonic_percent(5) == pytest.approx(4.0, abs=0.05)
    assert s.harmonic_percent(7) == pytest.approx(3.0, abs=0.05)
    assert s.thd_percent == pytest.approx(5.0, abs=0.07)


def test_thd_matches_scipy_periodogram():
    """Independent check: harmonic power from scipy.signal.periodogram on the same window."""
    f1 = 50.0
    t = np.arange(int(FS * 0.4)) / FS   # exactly 20 periods
    x = np.sin(2 * np.pi * f1 * t) + 0.1 * np.sin(2 * np.pi * 3 * f1 * t) \
        + 0.02 * np.sin(2 * np.pi * 11 * f1 * t)
    ours = metrics.harmonic_spectrum(x, FS, f1).thd_percent
    f, pxx = signal.periodogram(x, FS, window="boxcar", scaling="spectrum")
    power = {h: pxx[np.argmin(np.abs(f - h * f1))] for h in range(1, 51)}
    ref = 100 * math.sqrt(sum(power[h] for h in range(2, 51)) / power[1])
    assert ours == pytest.approx(ref, rel=1e-9)


def test_thd_n_counts_noise_thd_does_not():
    rng = np.random.default_rng(1)
    f1 = 50.0
    t = np.arange(int(FS * 0.4)) / FS
    x = np.sin(2 * np.pi * f1 * t) + 0.05 * rng.standard_normal(t.size)
    s = metrics.harmonic_spectrum(x, FS, f1)
    assert s.thd_n_percent > 3 * s.thd_percent


def test_angle_error_wraps():
    theta = np.array([0.05, 6.25, 3.0])
    hat = np.array([6.28, 0.02, 3.1])
    e = metrics.angle_error(hat, theta)
    assert e.max_abs_rad == pytest.approx(0.1, abs=1e-3)


def test_speed_band():
    assert metrics.speed_band_rpm(np.array([495.0, 503.0, 500.0]), 500.0) == 5.0
    assert metrics.half_peak_to_peak(np.array([495.0, 503.0])) == 4.0


def test_spectrum_rejects_short_window():
    with pytest.raises(ValueError, match="less than one period"):
        metrics.harmonic_spectrum(np.ones(10), FS, 50.0)
