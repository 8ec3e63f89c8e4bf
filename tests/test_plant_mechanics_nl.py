"""Mechanics: C-side load-torque profiles (step, ramp, table), Coulomb friction, the
dynamometer mode (speed imposed, torque reported), and their interplay with set_load_torque."""
from __future__ import annotations

import math

import numpy as np
import pytest

from hil_bench.plant_rt.plant import Plant, ffi, lib
from hil_bench.plant_rt.profile import load_profile
from hil_bench.plant_rt.verify import reference

GONG = load_profile("gong2020")
J = GONG.j_kgm2


def _idle(**ov):
    """All legs off at standstill: no electrical torque (the EMF never reaches the bus), so the
    rotor is driven by the load alone; no viscous friction: omega = -int T_load dt / J.
    t_delay = 0: no short-circuited first interval (the initial 0.5 duties)."""
    return Plant(GONG, b_nms=0.0, t_delay_s=0.0, **ov)


PROFILES = {
    "step": dict(load_profile="step", load_t0_s=0.01234, load_torque0_nm=0.5, load_torque1_nm=-1.0),
    "ramp": dict(load_profile="ramp", load_t0_s=0.00515, load_t1_s=0.03, load_torque0_nm=0.2,
                 load_torque1_nm=-0.8),
    "table": dict(load_profile="table", load_table_t_s=[0.0021, 0.01, 0.01005, 0.03],
                  load_table_nm=[0.0, 1.0, -2.0, 0.5]),
}


@pytest.mark.parametrize("name", sorted(PROFILES))
def test_profile_impulse_is_exact_at_every_sampling_instant(name):
    p = _idle(**PROFILES[name])
    prm = reference.RefParams.of(p.params)
    n = 400
    w = np.empty(n)
    for k in range(n):
        p.step(-1.0, -1.0, -1.0)
        w[k] = p.snapshot().omega_m_rad_s
    # -1/J int_0^t T dt of the continuous profile (exact: trapezoids between its breakpoints)
    ts = GONG.ts_s
    impulse = np.cumsum([reference.load_profile_period_mean(prm, k * ts, (k + 1) * ts) * ts for k in range(n)])
    want = -impulse / J
    assert np.abs(w - want).max() < 1e-11 * np.abs(want).max()
    assert np.abs(want).max() > 0.5
    # the profile as the plant reports it
    for tq in (0.0, 0.005, 0.01, 0.012345, 0.02, 1.0):
        assert p.load_torque_at(tq) == pytest.approx(reference.load_profile_value(prm, tq), abs=1e-12)


def test_period_mean_is_exact_in_c():
    lp = ffi.new("mechanics_load_profile_t *", dict(kind=3, table_n=4, table_t_s=[0.0, 1.0, 1.5, 3.0],
                                                     table_nm=[0.0, 2.0, -1.0, 1.0]))
    prm = reference.RefParams.of(dict(GONG.plant_params(), load_profile="table",
                                      load_table_t_s=(0.0, 1.0, 1.5, 3.0), load_table_nm=(0.0, 2.0, -1.0, 1.0)))
    for a, b in ((-1.0, 0.5), (0.3, 1.2), (0.9, 1.6), (1.2, 1.4), (2.0, 4.0), (0.0, 3.0)):
        assert lib.mechanics_load_profile_mean(lp, a, b) == pytest.approx(
            reference.load_profile_period_mean(prm, a, b), abs=1e-12)


def test_set_load_torque_adds_to_the_profile():
    p = _idle(load_profile="step", load_t0_s=0.0, load_torque1_nm=0.3)
    p.set_load_torque(0.2)
    for _ in range(100):
        p.step(-1.0, -1.0, -1.0)
    s = p.snapshot()
    assert s.torque_load_nm == pytest.approx(0.5)
    assert s.omega_m_rad_s == pytest.approx(-0.5 * 100 * GONG.ts_s / J, rel=1e-12)


def test_coulomb_coast_down_and_creep():
    # coast-down far from zero speed: deceleration T_c / J (tanh ~ 1), then the speed settles at 0
    tc, band = 0.2, 0.05
    p = Plant(GONG, b_nms=0.0, coulomb_nm=tc, coulomb_band_rad_s=band, t_delay_s=0.0)
    p.set_initial(0.0, 2.0)
    for _ in range(500):
        p.step(-1.0, -1.0, -1.0)
    w1 = p.snapshot().omega_m_rad_s
    assert w1 == pytest.approx(2.0 - tc / J * 0.05, rel=1e-6)
    assert p.snapshot().torque_friction_nm == pytest.approx(tc * math.tanh(w1 / band), rel=1e-12)
    for _ in range(20000):
        p.step(-1.0, -1.0, -1.0)
    assert abs(p.snapshot().omega_m_rad_s) < 1e-3
    # a load smaller than T_c makes the rotor creep at -band * atanh(T / T_c) (no stiction)
    p = Plant(GONG, b_nms=0.0, coulomb_nm=tc, coulomb_band_rad_s=band)
    p.set_load_torque(0.1)
    for _ in range(20000):
        p.step(-1.0, -1.0, -1.0)
    assert p.snapshot().omega_m_rad_s == pytest.approx(-band * math.atanh(0.1 / tc), rel=1e-4)


def test_dyno_imposes_the_speed_and_reports_the_torque():
    p = Plant(GONG, dyno=True, dyno_speed_rad_s=100.0)
    s = p.snapshot()
    assert s.omega_m_rad_s == 100.0
    # short-circuit the machine (zero voltage): braking torque, the dyno has to drive it
    for _ in range(2000):
        p.step(0.5, 0.5, 0.5)
    s = p.snapshot()
    assert s.omega_m_rad_s == 100.0
    assert s.torque_e_nm < -0.5
    assert s.torque_load_nm == pytest.approx(s.torque_e_nm - GONG.b_nms * 100.0, rel=1e-12)
    # steady-state short-circuit torque of the SPMSM at this speed (analytic)
    we = 400.0
    r, l, psi = GONG.rs_ohm, GONG.ld_h, GONG.psi_f_wb
    iq = -r * we * psi / (r * r + (we * l) ** 2)
    assert s.torque_e_nm == pytest.approx(1.5 * 4 * psi * iq, rel=1e-6)
    # the load torque and profile do not act on an imposed speed
    p.set_load_torque(3.0)
    for _ in range(10):
        p.step(0.5, 0.5, 0.5)
    assert p.snapshot().omega_m_rad_s == 100.0


def test_dyno_slew_and_step():
    p = Plant(GONG, dyno=True, dyno_speed_rad_s=10.0, dyno_accel_rad_s2=50.0)
    p.set_dyno_speed(12.0)
    w = []
    for _ in range(600):
        p.step(0.5, 0.5, 0.5)
        w.append(p.snapshot().omega_m_rad_s)
    w = np.array(w)
    assert w[0] == pytest.approx(10.0 + 50.0 * GONG.ts_s)
    assert np.all(np.diff(w[:399]) == pytest.approx(50.0 * GONG.ts_s))
    assert w[399] == pytest.approx(12.0) and np.all(w[399:] == pytest.approx(12.0))
    q = Plant(GONG, dyno=True, dyno_speed_rad_s=10.0)
    q.set_dyno_speed(-5.0)
    q.step(0.5, 0.5, 0.5)
    assert q.snapshot().omega_m_rad_s == -5.0


def test_profiles_and_friction_are_off_by_default():
    for name in ("gong2020", "hou2021", "yuan2020"):
        prof = load_profile(name)
        assert prof.load_profile == "none" and prof.coulomb_nm == 0.0 and prof.dyno is False
