"""Metrics against signals whose answer is known, and against scipy's independent estimate."""
import math

import numpy as np
import pytest
from scipy import signal

from hil_bench.papers import metrics

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


# -- estimation error, transients, observers, initial position, delay: closed-form answers ------

def test_speed_error_band_is_max_abs_difference():
    t = np.arange(0, 1, 1e-3)
    truth = 10 + np.sin(2 * np.pi * 3 * t)
    est = truth + 1.5 * np.cos(2 * np.pi * 7 * t)          # error amplitude exactly 1.5 at t = 0
    est[5] = np.nan                                        # a missing sample is ignored
    assert metrics.speed_error_band_rpm(est, truth) == pytest.approx(1.5, abs=1e-12)


def test_settling_time_of_a_first_order_response():
    """x = 1 - exp(-t/tau) enters +-2 % of 1 at t = tau ln 50 and stays."""
    tau, dt = 0.01, 1e-5
    t = np.arange(0, 0.2, dt)
    x = 1 - np.exp(-t / tau)
    assert metrics.settling_time_s(t, x, 1.0, 0.02, 0.0) == pytest.approx(tau * math.log(50),
                                                                         abs=dt)
    # never settles: NaN; inside from the start: 0
    assert math.isnan(metrics.settling_time_s(t, x, 2.0, 0.02, 0.0))
    assert metrics.settling_time_s(t, x, 0.5, 1.0, 0.0) == 0.0


def test_response_time_uses_the_pre_event_band():
    """A steady error ripple of +-0.2 before the event (its band), then a disturbance
    3 exp(-(t - 0.5)/tau): back inside +-0.2 for good at tau ln 15."""
    dt, tau = 1e-6, 2e-3
    t = np.arange(0.4, 0.6, dt)
    err = np.where(t >= 0.5, 3 * np.exp(-(t - 0.5) / tau), 0.2 * np.cos(2 * np.pi * 1000 * t))
    assert metrics.response_time_s(t, err, 0.5, pre_window_s=0.05) == pytest.approx(
        tau * math.log(15), abs=2 * dt)
    # a floor above the pre-event band widens it: 3 exp(-x/tau) = 0.5 at tau ln 6
    assert metrics.response_time_s(t, err, 0.5, floor=0.5) == pytest.approx(tau * math.log(6),
                                                                            abs=2 * dt)


def test_speed_dip_and_recovery_of_a_known_transient():
    """n = 10 - 4 (t - t0)/T exp(1 - (t - t0)/T): minimum 6 at t0 + T; back within 0.5 when
    4 x e^(1-x) = 0.5 (x > 1)."""
    t0, big_t, dt = 0.2, 0.005, 1e-6
    t = np.arange(0.0, 0.3, dt)
    x = np.clip((t - t0) / big_t, 0, None)
    n = 10 - 4 * x * np.exp(1 - x)
    d = metrics.speed_dip(t, n, t0, 10.0, 0.5)
    assert d.depth == pytest.approx(4.0, abs=1e-9)
    assert d.t_extreme_s == pytest.approx(t0 + big_t, abs=dt)
    from scipy.optimize import brentq
    x_r = brentq(lambda x: 4 * x * math.exp(1 - x) - 0.5, 1.0, 20.0)
    assert d.recovery_s == pytest.approx(x_r * big_t, abs=2 * dt)
    # an unload: the speed rises; sign = -1 measures the rise
    up = metrics.speed_dip(t, 20 - n, t0, 10.0, 0.5, sign=-1.0)
    assert up.depth == pytest.approx(4.0, abs=1e-9)


def test_step_response_of_a_second_order_system():
    """Under-damped step 1000 -> 1200: overshoot 200 exp(-zeta pi / sqrt(1 - zeta^2))."""
    zeta, wn, dt = 0.3, 60.0, 1e-5
    t = np.arange(0, 0.5, dt)
    wd = wn * math.sqrt(1 - zeta ** 2)
    ts = t - 0.1
    y = np.where(ts >= 0, 1 - np.exp(-zeta * wn * ts) * (np.cos(wd * ts) + zeta * wn / wd
                                                          * np.sin(wd * ts)), 0.0)
    x = 1000 + 200 * y
    r = metrics.step_response(t, x, 0.1, 1200.0, band=10.0)
    assert r.overshoot == pytest.approx(200 * math.exp(-zeta * math.pi / math.sqrt(1 - zeta ** 2)),
                                        rel=1e-6)
    assert 0.0 < r.settling_s < 4.0 / (zeta * wn)     # the envelope's 5 % time bounds it
    down = metrics.step_response(t, 2200 - x, 0.1, 1000.0, band=10.0)
    assert down.overshoot == pytest.approx(r.overshoot, rel=1e-9)   # direction from the step


def test_chattering_index_is_rms_distance_from_the_diagonal():
    t = np.linspace(0, 1, 10001)
    i_a, i_b = np.cos(2 * np.pi * t), np.sin(2 * np.pi * t)
    # alpha chatters as a +-0.1 square wave, beta exact: rms 0.1
    sq = 0.1 * np.sign(np.sin(2 * np.pi * 500 * t + 0.1))
    assert metrics.chattering_index_a(i_a + sq, i_b, i_a, i_b) == pytest.approx(0.1, rel=1e-3)
    assert metrics.chattering_index_a(i_a, i_b, i_a, i_b) == 0.0
    # a smooth error at the electrical frequency (a linear observer's d = e / L) plus an offset
    # is not chattering: removed when t and omega are given, leaving the square wave
    smooth_a = 0.9 * np.sin(2 * np.pi * t + 0.3) + 0.05
    smooth_b = -0.9 * np.cos(2 * np.pi * t + 0.3)
    got = metrics.chattering_index_a(i_a + smooth_a + sq, i_b + smooth_b, i_a, i_b, t, 2 * np.pi)
    assert got == pytest.approx(0.1, rel=2e-3)
    assert metrics.chattering_index_a(i_a + smooth_a, i_b + smooth_b, i_a, i_b) == \
        pytest.approx(math.sqrt(0.9 ** 2 + 0.05 ** 2), rel=1e-3)


def test_initial_position_error_and_polarity_rate():
    truth = np.radians([0, 45, 90, 135, 180])
    hat = truth + np.radians([0.5, -0.8, 0.2, 180.3, 0.0])   # one trial with the wrong polarity
    r = metrics.initial_position(hat, truth)
    assert r.polarity_rate == pytest.approx(0.8)
    assert r.max_abs_rad == pytest.approx(math.radians(0.8))
    assert abs(r.error_rad[3]) == pytest.approx(math.radians(179.7))


def test_delay_estimate_on_piecewise_linear_currents():
    """Gong's assumption 1 exactly: the current is linear while a vector acts, the vector of
    period k acting from t_k + t_d. i1(k) = i(t_k), i2(k) = i(t_k + t_d): eq. 20 returns t_d."""
    ts, td, n = 1e-4, 34.1e-6, 200
    rng = np.random.default_rng(3)
    slopes = rng.uniform(-2e3, 2e3, size=n + 1)       # A/s of the vector acting from t_k + t_d
    # current at the actuation instants a_k = t_k + td
    i_act = np.concatenate([[0.0], np.cumsum(slopes[:-1] * ts)])
    i1 = i_act[:-1] + slopes[:-1] * (ts - td)          # i(t_{k+1}) from a_k
    i1 = np.concatenate([[i_act[0] - slopes[0] * td], i1])[:n]
    i2 = i_act[:n]
    # i1[k] = i(t_k) lies before i2[k] = i(t_k + t_d) on the segment of period k-1
    est = metrics.delay_estimates_s(i1, i2, ts, min_step=1e-6)
    valid = est[np.isfinite(est)]
    assert valid.size > n // 2
    assert np.allclose(valid, td, rtol=1e-9)


def test_percent_change():
    assert metrics.percent_change(1.15, 1.08) == pytest.approx(-6.087, abs=1e-3)


def test_mean_angle_does_not_break_at_pi():
    """Circular mean: angles scattered about +-pi average to pi, not to 0 (their plain mean)."""
    x = np.array([math.pi - 0.1, -math.pi + 0.1, math.pi - 0.05, -math.pi + 0.05])
    assert abs(abs(metrics.mean_angle_rad(x)) - math.pi) < 1e-12
    assert np.mean(x) == pytest.approx(0.0, abs=1e-12)           # what it must not be
    assert metrics.mean_angle_rad(np.array([0.2, 0.4, np.nan])) == pytest.approx(0.3, abs=1e-12)
    assert math.isnan(metrics.mean_angle_rad(np.array([np.nan])))


def test_holds_speed_is_ten_percent_plus_half_rpm():
    assert metrics.holds_speed(10.0 + 1.5, 10.0)            # 10 % + 0.5 rpm = 1.5 rpm
    assert not metrics.holds_speed(10.0 + 1.51, 10.0)
    assert metrics.holds_speed(-550.0, -500.0)              # signed reference
    assert not metrics.holds_speed(0.6, 0.0) and metrics.holds_speed(0.5, 0.0)
    assert not metrics.holds_speed(math.nan, 10.0)
