"""harm_comp (Yuan eq. 28-37): angle-synchronous 5th/7th extraction by GSDFT and SDFT and the
compensation voltages, C float32 vs the float64 model (tests/models/harm_comp.py) and vs the
known harmonics of a synthetic current.

Machine: the yuan2020 profile values (R 0.6383 ohm, Ls 2 mH, p = 4), Ts = 100 us, speeds 10 and
50 rpm. Tolerances: I5, I7 within 2e-4 A and theta5, theta7 within 1e-3 rad of the truth (linear
interpolation between 100 us samples, float32 angle); C vs model 5e-5 A on the harmonic-frame
currents; compensation voltage vs eq. 36-37 within 1e-4 V.

Y4 (THD with/without compensation on the closed loop) needs the plant's dead time and is not
tested here: see docs/estimators_dft_hfi.md, "How Y4 should be tested".
"""
import math

import numpy as np
import pytest

from hil_bench.firmware_stub.est_dft import HarmComp
from tests.models import harm_comp as model

R_OHM, LS_H, TS_S, POLES = 0.6383, 2e-3, 1e-4, 4
HARMONICS = {1: (5.0, 0.3 + math.pi / 2), -5: (0.20, -1.0), 7: (0.21, 2.0), -11: (0.04, 0.5),
             13: (0.03, -2.5)}
DC_A = 0.1 - 0.05j


def omega_e(rpm):
    return rpm * 2 * math.pi / 60 * POLES


def run(rpm, periods=2.2, extractor="gsdft", theta0=0.37, harmonics=HARMONICS, dc=DC_A, **cfg):
    """Drive the C with a synthetic current at constant speed; returns (outputs, inputs)."""
    w = omega_e(rpm)
    n = int(periods * 2 * math.pi / w / TS_S)
    th_unwrapped = theta0 + w * TS_S * np.arange(n)
    th32 = np.mod(th_unwrapped, 2 * math.pi).astype(np.float32)
    i_ab = model.synthetic_current(th_unwrapped, harmonics, dc)
    hc = HarmComp(R_OHM, LS_H, TS_S, extractor=extractor, **cfg)
    outs = [hc.step(i_ab[k].real, i_ab[k].imag, float(th32[k]), w) for k in range(n)]
    return hc, outs, dict(theta32=th32, i_ab=i_ab, w=w)


def wrap(x):
    return (x + math.pi) % (2 * math.pi) - math.pi


@pytest.mark.parametrize("rpm", [10.0, 50.0])
@pytest.mark.parametrize("extractor", ["gsdft", "sdft"])
def test_extracts_known_5th_and_7th(rpm, extractor):
    hc, outs, _ = run(rpm, extractor=extractor)
    o = outs[-1]
    assert o.valid
    assert abs(o.i5_a - 0.20) < 2e-4 and abs(wrap(o.theta5_rad + 1.0)) < 1e-3, o
    assert abs(o.i7_a - 0.21) < 2e-4 and abs(wrap(o.theta7_rad - 2.0)) < 1e-3, o
    assert o.n_samples >= 2 * hc.config.m


@pytest.mark.parametrize("rpm", [10.0, 50.0])
def test_y7_gsdft_and_sdft_agree_in_steady_state(rpm):
    _, g, _ = run(rpm, extractor="gsdft")
    _, s, _ = run(rpm, extractor="sdft")
    for a, b in zip(g[-2000:], s[-2000:]):
        assert abs(a.i_dq5_a - b.i_dq5_a) < 1e-4 and abs(a.i_dq7_a - b.i_dq7_a) < 1e-4


@pytest.mark.parametrize("extractor", ["gsdft", "sdft"])
def test_c_matches_float64_model_sample_by_sample(extractor):
    hc, outs, inp = run(50.0, extractor=extractor, periods=1.5)
    m = hc.config.m
    th = np.unwrap(inp["theta32"].astype(float))
    x, j, k = model.angle_synchronous(th, inp["i_ab"], m)
    p5, p7 = model.extract(x, m, extractor, dc_block=True)
    i5, i7 = model.harmonic_frames(p5, p7, j, m)
    # the C output after control step k holds the last grid sample taken in that step
    last_of_step = np.nonzero(np.diff(np.append(k, k[-1] + 1)) > 0)[0]
    window = m // 3 + 1 if extractor == "gsdft" else m
    worst = 0.0
    for s in last_of_step[window:]:
        o = outs[k[s]]
        worst = max(worst, abs(o.i_dq5_a - i5[s]), abs(o.i_dq7_a - i7[s]))
    assert worst < 5e-5, worst


@pytest.mark.parametrize("rpm", [10.0, 50.0])
def test_compensation_voltage_is_eq_36_37(rpm):
    hc, outs, inp = run(rpm)
    o, w = outs[-1], inp["w"]
    u5, u7 = model.compensation(o.i5_a, o.theta5_rad, o.i7_a, o.theta7_rad, R_OHM, LS_H, w)
    assert abs(o.u5_dq5_v - u5) < 1e-5 and abs(o.u7_dq7_v - u7) < 1e-5
    # and from the true harmonics (extraction + eq. 36-37 end to end)
    t5, t7 = model.compensation(0.20, -1.0, 0.21, 2.0, R_OHM, LS_H, w)
    assert abs(o.u5_dq5_v - t5) < 1e-4 and abs(o.u7_dq7_v - t7) < 1e-4
    for theta in (0.0, 0.4, 2.0, 5.5):
        assert abs(hc.voltage_dq(theta) - model.voltage_dq(u5, u7, theta)) < 1e-5


def test_sign_convention_adding_the_voltage_cancels_the_harmonic():
    """eq. 31: du = u* - u. Applied to an R-L dq machine (L_s, cross-coupling), the voltage
    u5_dq5 e^{-j6 theta} alone must drive exactly -i5 (and the 7th's -i7): adding it to the
    command cancels the harmonic that the inverter's voltage error had caused."""
    rpm = 50.0
    hc, outs, inp = run(rpm)
    o, w = outs[-1], inp["w"]
    dt, n = 2e-6, 200000                   # 0.4 s, 4 periods of 6 w_e at 50 rpm
    t = np.arange(n) * dt
    th = w * t
    u = o.u5_dq5_v * np.exp(-6j * th) + o.u7_dq7_v * np.exp(6j * th)
    i = 0j
    i_hist = np.empty(n, dtype=complex)
    for k in range(n):                     # L di/dt = u - R i - j w L i  (dq, SPMSM)
        i += dt * (u[k] - R_OHM * i - 1j * w * LS_H * i) / LS_H
        i_hist[k] = i
    late = t > 0.2
    i5 = np.mean(i_hist[late] * np.exp(6j * th[late]))     # into the 5th's frame (eq. 32)
    i7 = np.mean(i_hist[late] * np.exp(-6j * th[late]))
    assert abs(i5 + o.i_dq5_a) < 2e-3 * abs(o.i_dq5_a)
    assert abs(i7 + o.i_dq7_a) < 2e-3 * abs(o.i_dq7_a)


def test_window_fill_time_gsdft_is_a_third_of_sdft():
    """Time to the first valid output: M/3 + 1 grid samples (GSDFT with DC block) vs M (SDFT)."""
    hc_g, g, _ = run(50.0, periods=1.2, extractor="gsdft")
    hc_s, s, _ = run(50.0, periods=1.2, extractor="sdft")
    first_g = next(k for k, o in enumerate(g) if o.valid)
    first_s = next(k for k, o in enumerate(s) if o.valid)
    period_steps = 2 * math.pi / omega_e(50.0) / TS_S
    assert abs(first_g / period_steps - (hc_g.config.m // 3 + 1) / hc_g.config.m) < 0.02
    assert abs(first_s / period_steps - 1.0) < 0.02


def test_speed_range_and_restart():
    hc = HarmComp(R_OHM, LS_H, TS_S)
    w = omega_e(50.0)
    cfg = hc.config
    assert cfg.omega_min_rad_s < w < cfg.omega_max_rad_s
    th = 0.0
    for _ in range(12000):                 # > 2 periods: valid
        th += w * TS_S
        o = hc.step(1.0, 0.0, th % (2 * math.pi), w)
    assert o.valid
    o = hc.step(1.0, 0.0, th % (2 * math.pi), 0.5 * cfg.omega_min_rad_s)   # too slow
    assert not o.valid and o.u5_dq5_v == 0 and hc.voltage_dq(0.3) == 0
    o = hc.step(1.0, 0.0, th % (2 * math.pi), 2.0 * cfg.omega_max_rad_s)   # too fast
    assert not o.valid
    n_before = o.n_samples
    for _ in range(1000):                  # back in range: the window refills from empty
        th += w * TS_S
        o = hc.step(1.0, 0.0, th % (2 * math.pi), w)
    assert o.n_samples > n_before and not o.valid
    # a backward jump of more than a grid step restarts too
    o = hc.step(1.0, 0.0, (th - 0.5) % (2 * math.pi), w)
    assert not o.valid


@pytest.mark.parametrize("cfg", [dict(m=100), dict(m=0), dict(k_comp=float("nan")),
                                 dict(omega_min_rad_s=0.0), dict(omega_max_rad_s=0.1), dict(m=102)])
def test_bad_configuration_is_refused(cfg):
    with pytest.raises(ValueError, match="HarmComp"):
        HarmComp(R_OHM, LS_H, TS_S, **cfg)
    with pytest.raises(ValueError, match="HarmComp"):
        HarmComp(R_OHM, 0.0, TS_S)
    with pytest.raises(ValueError, match="extractor"):
        HarmComp(R_OHM, LS_H, TS_S, extractor="fft")
