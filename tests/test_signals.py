"""hil_bench.signals against float64 reference cases whose figures are known analytically: a
first-order step (settling time tau ln(A/band), 10-90 % rise time tau ln 9, no overshoot), an
underdamped second-order step (overshoot exp(-zeta pi / sqrt(1 - zeta^2)); its settling time found
by scipy's root finder on the closed-form response), a ramp with a bounded ripple, and sines of
known frequency. Each failing check is asserted on where (time) and by how much its message says.
"""
from __future__ import annotations

import math
import re
import subprocess
import sys

import numpy as np
import pandas as pd
import pytest
from scipy.optimize import brentq

from hil_bench import signals
from hil_bench.signals import SignalCheckFailed

DT = 1e-5          # sampling of the reference responses [s]


def crossing_tol(tau_s: float) -> float:
    """Linear interpolation of an exponential over one sample misses its crossing by at most
    DT^2 |y''| / (8 |y'|) = DT^2 / (8 tau)."""
    return DT ** 2 / (8.0 * tau_s)


def peak_tol_pct(zeta: float, wn_rad_s: float) -> float:
    """The largest sample misses a peak by at most |y''| (DT/2)^2 / 2, |y''| at the peak of a
    unit second-order step being wn^2 times its overshoot (in % of the unit step)."""
    mp = math.exp(-zeta * math.pi / math.sqrt(1 - zeta ** 2))
    return 100.0 * 0.5 * wn_rad_s ** 2 * mp * (DT / 2) ** 2


def first_order(tau_s: float, amp: float, t_end_s: float, t_step_s: float = 0.0,
                y0: float = 0.0) -> pd.Series:
    t = np.arange(0.0, t_end_s, DT)
    y = y0 + amp * (1.0 - np.exp(-np.clip(t - t_step_s, 0.0, None) / tau_s))
    return pd.Series(y, index=pd.Index(t, name="t_s"), name="speed_rpm")


def second_order(zeta: float, wn_rad_s: float, t_end_s: float) -> tuple[pd.Series, callable]:
    wd = wn_rad_s * math.sqrt(1.0 - zeta ** 2)
    phi = math.acos(zeta)

    def y(t):
        return 1.0 - (np.exp(-zeta * wn_rad_s * t) / math.sqrt(1.0 - zeta ** 2)
                      * np.sin(wd * t + phi))

    t = np.arange(0.0, t_end_s, DT)
    return pd.Series(y(t), index=pd.Index(t, name="t_s"), name="x"), y


# -- settling --------------------------------------------------------------------------------------

def test_settling_time_of_a_first_order_step_is_tau_ln_amp_over_band():
    tau, amp, band = 0.02, 300.0, 6.0            # a 2 % band
    y = first_order(tau, amp, 0.2)
    measured = signals.settles(y, amp, band=band, within_s=0.1)
    assert measured == pytest.approx(tau * math.log(amp / band), abs=crossing_tol(tau))
    # the band in percent of the step is the same band
    assert signals.settles(y, amp, band_pct=2.0, within_s=0.1) == pytest.approx(measured, abs=1e-12)


def test_settling_time_counts_from_start_s():
    tau, amp = 0.01, 100.0
    y = first_order(tau, amp, 0.2, t_step_s=0.05, y0=20.0)
    got = signals.settles(y, 120.0, band=1.0, within_s=0.06, start_s=0.05)
    assert got == pytest.approx(tau * math.log(100.0), abs=crossing_tol(tau))


def test_settling_time_of_a_second_order_step_against_the_root_of_its_closed_form():
    zeta, wn = 0.4, 200.0
    x, y = second_order(zeta, wn, 0.3)
    band = 0.02
    # the reference: the last time |y - 1| = band, found on the closed form by brentq inside the
    # last stretch where the envelope can still reach the band
    t = np.arange(0.0, 0.3, 1e-6)
    out = np.flatnonzero(np.abs(y(t) - 1.0) > band)
    ref = brentq(lambda s: abs(y(s) - 1.0) - band, t[out[-1]], t[out[-1] + 1], xtol=1e-15)
    got = signals.settles(x, 1.0, band=band, within_s=0.1)
    assert got == pytest.approx(ref, abs=1e-8)   # linear interpolation over a 10 us sample


def test_a_late_settling_fails_saying_when_and_by_how_much():
    tau, amp, band = 0.02, 300.0, 6.0
    y = first_order(tau, amp, 0.2)
    with pytest.raises(SignalCheckFailed) as err:
        signals.settles(y, amp, band=band, within_s=0.05)
    exact = tau * math.log(amp / band)          # 0.07824 s
    e = err.value
    assert isinstance(e, AssertionError)
    assert e.measured == pytest.approx(exact, abs=crossing_tol(tau))
    assert e.by == pytest.approx(exact - 0.05, abs=crossing_tol(tau))
    msg = str(e)
    assert "speed_rpm settles to 300 ± 6 0.0782" in msg, msg
    assert "0.0282" in msg and "later than 0.05 s" in msg, msg
    # the furthest it was out of the band after the deadline: its first sample after 0.05 s
    value, t, by = map(float, re.search(r"after t = 0.05 s it is out of the band up to "
                                        r"([\d.]+) at t = ([\d.]+) s, ([\d.]+) beyond it",
                                        msg).groups())
    assert t == pytest.approx(0.05 + DT, abs=1e-9)
    assert value == pytest.approx(amp * (1 - math.exp(-t / tau)), rel=1e-5)
    assert by == pytest.approx(amp - value - band, abs=1e-3)   # both printed to 6 digits


def test_a_signal_that_never_settles_fails_at_its_last_sample():
    t = np.arange(0.0, 0.1, DT)
    y = 100.0 + 10.0 * np.cos(2 * np.pi * 50 * t)        # 110 at the last sample
    with pytest.raises(SignalCheckFailed, match=r"does not settle to 100 ± 1: at its last sample"):
        signals.settles(y, 100.0, band=1.0, within_s=1.0, t=t)


# -- overshoot -------------------------------------------------------------------------------------

@pytest.mark.parametrize("zeta", [0.2, 0.5, 0.7])
def test_overshoot_of_a_second_order_step_is_exp_minus_zeta_pi_over_root(zeta):
    x, _ = second_order(zeta, 300.0, 0.2)
    exact = 100.0 * math.exp(-zeta * math.pi / math.sqrt(1 - zeta ** 2))
    got = signals.overshoot(x, 1.0, below_pct=exact + 1.0)
    assert got == pytest.approx(exact, abs=peak_tol_pct(zeta, 300.0))   # the largest sample


def test_a_first_order_step_has_no_overshoot():
    assert signals.overshoot(first_order(0.01, -50.0, 0.1), -50.0, below_pct=0.1) == 0.0


def test_too_much_overshoot_fails_saying_the_peak_and_its_time():
    zeta, wn = 0.3, 300.0
    x, _ = second_order(zeta, wn, 0.2)
    exact = 100.0 * math.exp(-zeta * math.pi / math.sqrt(1 - zeta ** 2))    # 37.2 %
    t_peak = math.pi / (wn * math.sqrt(1 - zeta ** 2))
    with pytest.raises(SignalCheckFailed) as err:
        signals.overshoot(x, 1.0, below_pct=10.0)
    e = err.value
    assert e.measured == pytest.approx(exact, abs=peak_tol_pct(zeta, wn))
    assert e.t_s == pytest.approx(t_peak, abs=DT)
    assert e.by == pytest.approx(exact - 10.0, abs=peak_tol_pct(zeta, wn))
    assert f"overshoots 1 by {exact:.6g} %" in str(e) and "not below 10 %" in str(e)


def test_a_falling_step_overshoots_downwards():
    x, _ = second_order(0.5, 300.0, 0.2)
    falling = 10.0 - 4.0 * x                        # 10 -> 6, undershoots 6
    exact = 100.0 * math.exp(-0.5 * math.pi / math.sqrt(0.75))
    assert signals.overshoot(falling, 6.0) == pytest.approx(exact, abs=peak_tol_pct(0.5, 300.0))


# -- rise time -------------------------------------------------------------------------------------

def test_rise_time_10_90_of_a_first_order_step_is_tau_ln_9():
    tau = 0.015
    y = first_order(tau, 500.0, 0.2, y0=100.0)
    got = signals.rise_time(y, 100.0, 600.0, within_s=0.05)
    assert got == pytest.approx(tau * math.log(9.0), abs=2 * crossing_tol(tau))


def test_fall_time_of_a_falling_first_order_step():
    tau = 0.004
    y = first_order(tau, -300.0, 0.1, y0=800.0)
    assert signals.rise_time(y, 800.0, 500.0) == pytest.approx(tau * math.log(9.0),
                                                               abs=2 * crossing_tol(tau))


def test_rise_time_of_a_second_order_step_against_its_closed_form():
    zeta, wn = 0.6, 250.0
    x, y = second_order(zeta, wn, 0.2)
    t10 = brentq(lambda s: y(s) - 0.1, 1e-9, 0.02, xtol=1e-15)
    t90 = brentq(lambda s: y(s) - 0.9, t10, math.pi / (wn * math.sqrt(1 - zeta ** 2)), xtol=1e-15)
    assert signals.rise_time(x, 0.0, 1.0) == pytest.approx(t90 - t10, abs=1e-8)


def test_a_slow_rise_fails_with_its_times_and_excess():
    tau = 0.02
    y = first_order(tau, 1.0, 0.3)
    exact = tau * math.log(9.0)                      # 0.0439 s
    with pytest.raises(SignalCheckFailed) as err:
        signals.rise_time(y, 0.0, 1.0, within_s=0.03)
    e = err.value
    assert e.measured == pytest.approx(exact, abs=2 * crossing_tol(tau))
    assert e.by == pytest.approx(exact - 0.03, abs=2 * crossing_tol(tau))
    assert e.t_s == pytest.approx(tau * math.log(10.0), abs=crossing_tol(tau))   # 90 % crossing
    assert "rises from 0.1 to 0.9" in str(e) and "longer than 0.03 s" in str(e)


def test_a_step_that_never_gets_there_says_how_far_short():
    y = first_order(0.01, 0.5, 0.1)                  # heads for 0.5 of a step to 1
    with pytest.raises(SignalCheckFailed, match=r"never rises to 0.9 \(90 % .*short"):
        signals.rise_time(y, 0.0, 1.0)


# -- bands -----------------------------------------------------------------------------------------

def test_stays_within_gives_the_extremes_and_fails_at_the_furthest_excursion():
    t = np.arange(0.0, 0.1, DT)
    y = pd.Series(5.0 + np.sin(2 * np.pi * 20 * t), index=t, name="i_q_a")
    lo, hi = signals.stays_within(y, 3.9, 6.1)
    assert (lo, hi) == pytest.approx((4.0, 6.0), abs=1e-6)
    with pytest.raises(SignalCheckFailed) as err:
        signals.stays_within(y, 4.5, 5.8, start_s=0.02, end_s=0.07)
    e = err.value
    # furthest: the minimum 4 at t = 0.0375 s (a quarter-wave after 0.025), 0.5 below 4.5
    assert e.t_s == pytest.approx(0.0375, abs=DT) and e.by == pytest.approx(0.5, abs=1e-6)
    assert "i_q_a leaves [4.5, 5.8] from t = 0.02" in str(e) and "below the band" in str(e)


def test_stays_near_returns_the_largest_deviation():
    t = np.arange(0.0, 0.05, DT)
    y = 800.0 + 3.0 * np.cos(2 * np.pi * 100 * t)
    assert signals.stays_near(y, 800.0, 3.5, t=t) == pytest.approx(3.0, abs=1e-9)
    with pytest.raises(SignalCheckFailed, match=r"leaves 800 ± 2 from t = 0 s"):
        signals.stays_near(y, 800.0, 2.0, t=t)


# -- ramps -----------------------------------------------------------------------------------------

def test_follows_ramp_measures_the_ripple_on_a_ramp():
    t = np.arange(0.1, 0.4, DT)
    ripple = 0.7 * np.sin(2 * np.pi * 37 * t)
    y = pd.Series(50.0 + 2000.0 * (t - 0.1) + ripple, index=t, name="speed_rpm")
    got = signals.follows_ramp(y, slope_per_s=2000.0, tolerance=1.0, start_value=50.0)
    assert got == pytest.approx(np.max(np.abs(ripple)), abs=1e-9)
    with pytest.raises(SignalCheckFailed) as err:
        signals.follows_ramp(y, slope_per_s=2010.0, tolerance=1.0, start_value=50.0)
    # a slope 10 rpm/s off grows the error by 10 rpm/s: beyond 1 + ripple within 0.17 s
    assert err.value.measured == pytest.approx(np.max(np.abs(ripple - 10.0 * (t - 0.1))), abs=1e-9)
    assert "the ramp 50 + 2010/s (t - 0.1 s) ± 1" in str(err.value)


def test_follows_a_reference_series():
    t = np.arange(0.0, 0.1, 1e-4)
    ref = pd.Series(np.sin(2 * np.pi * 10 * t), index=t)
    y = pd.Series(np.sin(2 * np.pi * 10 * t) + 0.01, index=t)
    assert signals.follows(y, ref, 0.02) == pytest.approx(0.01, abs=1e-12)


# -- frequency -------------------------------------------------------------------------------------

@pytest.mark.parametrize("f_hz", [33.3, 47.31, 250.0, 1234.5])
def test_frequency_of_a_sine_of_known_frequency(f_hz):
    t = np.arange(0.0, 0.2, 1e-4)                    # 10 kHz, as a recording
    y = 3.0 + 2.0 * np.sin(2 * np.pi * f_hz * t + 0.3) + 0.2 * np.sin(2 * np.pi * 3 * f_hz * t)
    got = signals.frequency(y, t=t, expected_hz=f_hz, rel_tol=1e-3)
    assert got == pytest.approx(f_hz, rel=1e-6)


def test_frequency_under_noise():
    rng = np.random.default_rng(7)
    t = np.arange(0.0, 0.5, 1e-4)
    f_hz = 61.7
    y = np.sin(2 * np.pi * f_hz * t) + 0.3 * rng.standard_normal(len(t))
    assert signals.frequency(y, t=t) == pytest.approx(f_hz, rel=1e-3)


def test_a_wrong_frequency_fails_saying_by_how_much():
    t = np.arange(0.0, 0.2, 1e-4)
    y = pd.Series(np.sin(2 * np.pi * 50.0 * t), index=t, name="e_alpha_v")
    with pytest.raises(SignalCheckFailed) as err:
        signals.frequency(y, expected_hz=52.0, tolerance_hz=0.5)
    e = err.value
    assert e.measured == pytest.approx(50.0, rel=1e-6)
    assert e.by == pytest.approx(1.5, abs=1e-4)
    assert "e_alpha_v oscillates at 50 Hz" in str(e) and "-2 Hz from 52 Hz" in str(e)


# -- inputs and tracebacks -------------------------------------------------------------------------

def test_bad_inputs_are_clear_errors():
    t = np.arange(0.0, 1.0, 0.1)
    with pytest.raises(TypeError, match="an array with t= its times"):
        signals.stays_within(np.ones(10), 0, 2)
    with pytest.raises(TypeError, match="pick a column"):
        signals.stays_within(pd.DataFrame({"a": np.ones(10)}), 0, 2)
    with pytest.raises(ValueError, match="do not increase"):
        signals.stays_within(np.ones(10), 0, 2, t=t[::-1])
    with pytest.raises(ValueError, match="at least 2"):
        signals.stays_within(np.ones(10), 0, 2, t=t, start_s=5.0)
    with pytest.raises(ValueError, match="band .absolute. or band_pct"):
        signals.settles(np.ones(10), 1.0, within_s=1.0, t=t)
    with pytest.raises(ValueError, match="uniformly spaced"):
        signals.frequency(np.sin(t ** 2), t=t ** 2)


def test_nan_samples_are_left_out():
    t = np.arange(0.0, 1.0, 0.1)
    y = np.array([1.0, np.nan, 1.1, 0.9, np.nan, 1.0, 1.0, 1.05, 0.95, 1.0])
    assert signals.stays_within(y, 0.8, 1.2, t=t) == (0.9, 1.1)


def test_a_failed_check_points_at_the_test_not_the_library(tmp_path):
    """``__tracebackhide__``: pytest's report of a failed check shows the test's line, not the
    body of hil_bench.signals (a pytest run of its own, as a downstream project's)."""
    (tmp_path / "test_band.py").write_text(
        "import numpy as np\n"
        "from hil_bench import signals\n\n"
        "def test_band():\n"
        "    t = np.arange(0.0, 1.0, 0.1)\n"
        "    signals.stays_within(np.arange(10.0), 0, 5, t=t)\n")
    proc = subprocess.run([sys.executable, "-m", "pytest", "-p", "no:cacheprovider",
                           "test_band.py"], cwd=tmp_path, capture_output=True, text=True,
                          timeout=300)
    out = proc.stdout
    assert proc.returncode == 1, out
    assert "signals.stays_within(np.arange(10.0), 0, 5, t=t)" in out, out
    assert "SignalCheckFailed: signal leaves [0, 5] from t = 0.6 s to 0.9 s (4 samples)" in out, out
    assert "beyond = np.maximum" not in out and "raise SignalCheckFailed(" not in out, out
