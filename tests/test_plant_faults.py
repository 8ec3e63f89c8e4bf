"""Run-time plant faults (plant_rt/c/plant_fault.h) against an independent model and by direct
checks.

Electrical faults (open phase, stuck leg, phase-to-phase short) are compared with
hil_bench.plant_rt.verify.reference.simulate_faults: the circuit written out in phase variables (an open wire
makes the machine ONE loop through the two other phases, with the loop's flux linkage as the
state; the short is the terminal network solved with smooth diodes of the LEG currents), not
the C code's dq constrained dynamics and enumerated leg modes. As in test_plant_inverter_off,
the reference's diodes have a leakage scale i0 = DIODE_I0_A and the differences scale with it
(checked below: 10x smaller i0, 5-20x smaller difference). Measured (i0 = 1e-5 A):
open phase 0.29 i0 (IPMSM) / 0.88 i0 (braking), stuck leg 5.6 i0 at 100 A short-circuit
current, phase short 0.4 i0 (machine) / 2.4 i0 (leg and short currents); speed <= 5.4 i0.
Tolerances: 20 i0 [A] for every current, 10 i0 [rad/s] for the speed (those of the diode
tests).

Sensor, encoder, bus, lock and load faults have no independent model to speak of: they are
checked directly (what the sample reads, bit for bit where the definition is exact).
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from hil_bench.plant_rt.plant import FAULT_KINDS, Plant
from hil_bench.plant_rt.profile import load_profile
from hil_bench.plant_rt.verify import openloop, reference

DIODE_I0_A = 1e-5
CURRENT_TOL_A = 20 * DIODE_I0_A
SPEED_TOL_RAD_S = 10 * DIODE_I0_A
OFF = -1.0
TH0 = 0.3


@pytest.fixture
def gong():
    return load_profile("gong2020")


@pytest.fixture
def hou():
    return load_profile("hou2021")


def _apply(pl: Plant, faults: list[dict], k: int) -> None:
    for f in faults:
        on = f["k_on"] <= k and (f.get("k_off") is None or k < f["k_off"])
        active = f["kind"] in pl.faults_active()
        if on and not active:
            pl.set_fault(f["kind"], phase=f.get("phase", 0), phase2=f.get("phase2", 1),
                         level=f.get("level", 1), value=f.get("value", 0.0))
        elif not on and active:
            pl.clear_fault(f["kind"])


def run_c(prof, duties, faults, w0, **overrides):
    """C plant with the faults switched at period starts; machine and leg currents, short
    current, speed at t_0..t_n, and the plant."""
    pl = Plant(prof, **overrides)
    pl.set_initial(TH0, w0)
    n = len(duties)
    i_m, i_leg, i_f, w = np.empty((n + 1, 3)), np.empty((n + 1, 3)), np.empty(n + 1), np.empty(n + 1)

    def rec(k):
        s = pl.snapshot()
        st = pl.fault_status()
        i_m[k] = (s.i_a_a, s.i_b_a, s.i_c_a)
        i_leg[k] = (st["i_leg_a_a"], st["i_leg_b_a"], st["i_leg_c_a"])
        i_f[k], w[k] = st["i_short_a"], s.omega_m_rad_s

    _apply(pl, faults, 0)
    rec(0)
    for k in range(n):
        _apply(pl, faults, k)
        pl.step(*duties[k])
        rec(k + 1)
    return i_m, i_leg, i_f, w, pl


def compare(prof, duties, faults, w0, i0=DIODE_I0_A, **overrides):
    i_m, i_leg, i_f, w, pl = run_c(prof, duties, faults, w0, **overrides)
    ref = reference.simulate_faults(pl.params.as_dict(), duties, faults, theta_e0=TH0,
                                    omega_m0=w0, diode_i0_a=i0, rtol=1e-9)
    err = {"current_a": float(np.abs(i_m - ref.i_abc_a).max()),
           "leg_a": float(np.abs(i_leg - ref.i_leg_abc_a).max()),
           "short_a": float(np.abs(i_f - ref.i_short_a).max()),
           "speed_rad_s": float(np.abs(w - ref.omega_m_rad_s).max())}
    return err, i_m, i_leg, i_f, w, pl


def energy_residual(pl: Plant, w0: float) -> float:
    """electrical_in - (losses + work + absorbed + stored change), relative to the energy moved."""
    e = pl.energy()
    kin0 = 0.5 * pl.params.j_kgm2 * w0 * w0
    rhs = (e["copper_loss_j"] + e["viscous_loss_j"] + e["coulomb_loss_j"] + e["load_work_j"]
           + e["fault_absorbed_j"] + e["magnetic_j"] + e["kinetic_j"] - kin0)
    scale = max(abs(e["electrical_in_j"]), e["copper_loss_j"], abs(e["kinetic_j"] - kin0), 1e-9)
    return abs(e["electrical_in_j"] - rhs) / scale


def sync_duties(prof, n, w0, i_d, i_q, v_dc=None):
    vd, vq = openloop.operating_point_voltage(prof, prof.pole_pairs * w0, i_d, i_q)
    return openloop.synchronous(prof, n, theta_e0_rad=TH0, omega_e_rad_s=prof.pole_pairs * w0,
                                v_d_v=vd, v_q_v=vq, v_dc_v=v_dc)


# ------------------------------------------------------------------------------------------
# open phase

def test_open_phase_salient_machine_vs_reference(hou):
    w0 = 100.0
    d = sync_duties(hou, 250, w0, 0.0, 3.0)
    d[150:] = OFF                                  # then the controller's safe state
    faults = [dict(kind="open_phase", phase=1, k_on=60)]
    err, i_m, _, _, _, pl = compare(hou, d, faults, w0)
    assert np.abs(i_m[:60, 1]).max() > 2.0         # phase b carried current ...
    assert np.abs(i_m[61:, 1]).max() < 1e-12       # ... and none once its wire is open
    assert np.abs(i_m[61:150, 0]).max() > 1.0      # the two others still do (one loop)
    assert np.allclose(i_m[61:, 0], -i_m[61:, 2], atol=1e-12, rtol=0)
    assert err["current_a"] < CURRENT_TOL_A, err
    assert err["speed_rad_s"] < SPEED_TOL_RAD_S, err
    e = pl.energy()
    assert e["fault_absorbed_j"] > 1e-3            # the interrupted current's field energy
    assert energy_residual(pl, w0) < 1e-7


def test_open_phase_keeps_the_loop_flux_when_it_opens(hou):
    """The interruption rule itself: psi . n (n normal to the open phase's axis) is continuous,
    for Ld != Lq (not the orthogonal projection of the current)."""
    pl = Plant(hou)
    pl.set_initial(TH0, 100.0)
    for row in sync_duties(hou, 60, 100.0, -1.0, 3.0):
        pl.step(*row)
    s = pl.snapshot()
    n = np.array([-math.sqrt(3) / 2, -0.5])        # J u_b, u_b = (-1/2, sqrt(3)/2)
    before = float(n @ (s.psi_alpha_wb, s.psi_beta_wb))
    i_b_before = s.i_b_a
    pl.set_fault("open_phase", phase="b")
    s = pl.snapshot()
    after = float(n @ (s.psi_alpha_wb, s.psi_beta_wb))
    assert abs(i_b_before) > 1.0 and abs(s.i_b_a) < 1e-12
    assert after == pytest.approx(before, abs=1e-14)
    e = pl.energy()
    assert e["fault_absorbed_j"] > 0.0


@pytest.mark.parametrize("i_d", [8.0, -1.5])
def test_open_phase_keeps_the_loop_flux_with_saturation(hou, i_d):
    """The same rule with the d axis saturated (reference.simulate_faults refuses saturation, so
    this is the direct check): the loop flux psi . n, with psi_d from the independent Python
    curve (reference.psi_d_curve) of the currents before and after, is continuous through the
    interruption, although the current jumps; the orthogonal projection of the current (the
    rule of a linear machine) would not keep it. Open-loop voltages of the linear model drive the
    saturated machine to i_d = +6.9 A (L_inc 0.76 L_d) and -5.0 A (1.04 L_d: the other side of
    the knee) when phase b opens."""
    pl = Plant(hou, saturation=True)
    p = reference.RefParams.of(dict(hou.plant_params(), saturation=True))
    pl.set_initial(TH0, 100.0)
    for row in sync_duties(hou, 60, 100.0, i_d, 3.0):
        pl.step(*row)
    n = np.array([-math.sqrt(3) / 2, -0.5])        # J u_b, u_b = (-1/2, sqrt(3)/2)

    def loop_flux(s):
        th = s.theta_e_rad
        psi_d, psi_q = reference.psi_d_curve(p, s.i_d_a), hou.lq_h * s.i_q_a
        return float(n @ (psi_d * math.cos(th) - psi_q * math.sin(th),
                          psi_d * math.sin(th) + psi_q * math.cos(th)))

    s = pl.snapshot()
    before, i_b_before = loop_flux(s), s.i_b_a
    id_before, iq_before, th = s.i_d_a, s.i_q_a, s.theta_e_rad
    assert id_before * i_d > 0.0 and abs(i_b_before) > 1.0
    assert abs(reference.ld_inc_curve(p, id_before) / hou.ld_h - 1.0) > 0.03   # off the linear L
    pl.set_fault("open_phase", phase="b")
    s = pl.snapshot()
    assert abs(s.i_b_a) < 1e-12
    assert loop_flux(s) == pytest.approx(before, abs=1e-13)
    # the linear rule (projection of the current on n in dq) lands elsewhere on this curve
    nd = n[0] * math.cos(th) + n[1] * math.sin(th)
    nq = -n[0] * math.sin(th) + n[1] * math.cos(th)
    a = nd * id_before + nq * iq_before
    proj = float(n @ (reference.psi_d_curve(p, a * nd) * np.array([math.cos(th), math.sin(th)])
                      + hou.lq_h * a * nq * np.array([-math.sin(th), math.cos(th)])))
    assert abs(proj - before) > 1e-4
    assert pl.energy()["fault_absorbed_j"] > 0.0


def test_open_phase_all_legs_off_rectifies_through_one_loop(gong):
    """Wire c open, all legs off, line EMF a-b above the bus: the a-b loop conducts through the
    diodes (single-phase rectification); the C plant's located events against the reference."""
    w0, v_dc = 300.0, 120.0
    assert math.sqrt(3) * gong.psi_f_wb * gong.pole_pairs * w0 > v_dc
    d = sync_duties(gong, 250, w0, -20.0, 2.0, v_dc=v_dc)   # field weakening: inside the linear range
    d[120:] = OFF
    err, i_m, _, _, _, pl = compare(gong, d, [dict(kind="open_phase", phase=2, k_on=50)], w0,
                                    v_dc_v=v_dc)
    assert np.abs(i_m[130:, 0]).max() > 0.5        # braking current in the a-b loop
    assert np.abs(i_m[51:, 2]).max() < 1e-12
    assert pl.events >= 1
    assert err["current_a"] < CURRENT_TOL_A, err
    assert err["speed_rad_s"] < SPEED_TOL_RAD_S, err
    assert energy_residual(pl, w0) < 1e-7


def test_open_phase_clear_reconnects(gong):
    w0 = 100.0
    d = sync_duties(gong, 200, w0, 0.0, 3.0)
    err, i_m, *_ = compare(gong, d, [dict(kind="open_phase", phase=0, k_on=40, k_off=120)], w0)
    assert np.abs(i_m[41:120, 0]).max() < 1e-12
    assert np.abs(i_m[130:, 0]).max() > 1.0
    assert err["current_a"] < CURRENT_TOL_A, err


# ------------------------------------------------------------------------------------------
# stuck leg / shorted switch

@pytest.mark.parametrize("prof_name,phase,level", [("gong2020", 0, 1), ("hou2021", 2, 0)])
def test_stuck_leg_vs_reference(prof_name, phase, level):
    """One switch shorted while running, then the controller disables every leg: the stuck
    switch and the other legs' diodes keep a current path through the machine."""
    prof = load_profile(prof_name)
    w0 = 100.0
    d = sync_duties(prof, 250, w0, 0.0, 3.0)
    d[100:] = OFF
    faults = [dict(kind="leg_stuck", phase=phase, level=level, k_on=60)]
    err, i_m, _, _, w, pl = compare(prof, d, faults, w0)
    assert np.abs(i_m[110:]).max() > 10.0          # short-circuit current after the "trip"
    assert err["current_a"] < CURRENT_TOL_A, err
    assert err["speed_rad_s"] < SPEED_TOL_RAD_S, err
    assert energy_residual(pl, w0) < 1e-7
    snap = pl.snapshot()
    assert (snap.duty_a, snap.duty_b, snap.duty_c)[phase] == float(level)


def test_stuck_leg_clear_restores_the_command(gong):
    pl = Plant(gong)
    pl.step(0.3, 0.5, 0.7)
    pl.set_fault("leg_stuck", phase="a", level=1)
    pl.step(0.3, 0.5, 0.7)
    assert pl.snapshot().duty_a == 1.0
    pl.clear_fault("leg_stuck")
    pl.step(0.3, 0.5, 0.7)
    ref = Plant(gong)
    for _ in range(3):
        ref.step(0.3, 0.5, 0.7)
    assert pl.snapshot().duty_a == 0.3
    # the third period's voltage is the command's again (exactly), the stuck one left its mark
    assert pl.snapshot().v_a_v == ref.snapshot().v_a_v
    assert pl.snapshot().i_a_a != ref.snapshot().i_a_a
    assert pl.faults_active() == []


# ------------------------------------------------------------------------------------------
# phase-to-phase short

@pytest.mark.parametrize("prof_name,x,y,r_ohm,k_on", [("gong2020", 0, 1, 0.5, 60),
                                                     ("hou2021", 2, 0, 2.0, 40)])
def test_phase_short_vs_reference(prof_name, x, y, r_ohm, k_on):
    prof = load_profile(prof_name)
    w0 = 100.0
    d = sync_duties(prof, 250, w0, 0.0, 3.0)
    d[100:] = OFF
    faults = [dict(kind="phase_short", phase=x, phase2=y, value=r_ohm, k_on=k_on)]
    err, i_m, i_leg, i_f, _, pl = compare(prof, d, faults, w0)
    assert np.abs(i_f[k_on + 1:100]).max() > 10.0   # driven legs feed the short
    assert np.abs(i_f[110:]).max() > 1.0            # legs off: the machine brakes into it
    assert err["current_a"] < CURRENT_TOL_A, err
    assert err["leg_a"] < CURRENT_TOL_A, err
    assert err["short_a"] < CURRENT_TOL_A, err
    assert err["speed_rad_s"] < SPEED_TOL_RAD_S, err
    assert pl.fault_status()["short_fallbacks"] == 0
    assert energy_residual(pl, w0) < 1e-7


def test_phase_short_difference_scales_with_the_reference_diode(gong):
    """The C network (ideal diodes, located events) is the reference's i0 -> 0 limit."""
    w0 = 100.0
    d = sync_duties(gong, 160, w0, 0.0, 3.0)
    d[100:] = OFF
    faults = [dict(kind="phase_short", phase=0, phase2=1, value=0.5, k_on=60)]
    fine = compare(gong, d, faults, w0, i0=DIODE_I0_A)[0]
    coarse = compare(gong, d, faults, w0, i0=10 * DIODE_I0_A)[0]
    assert 5.0 < coarse["leg_a"] / fine["leg_a"] < 20.0, (coarse, fine)


def test_phase_short_while_driven_leaves_the_machine_alone_and_books_the_loss(gong):
    """Both shorted legs driven: the stiff averaged inverter holds the terminals, the machine
    runs exactly as without the short, and the inverter delivers R i_f^2 with
    i_f = (d_x - d_y) V_dc / R per interval (the delay split included)."""
    w0, r = 100.0, 1.5
    d = sync_duties(gong, 120, w0, 0.0, 3.0)
    healthy = run_c(gong, d, [], w0)
    faulted = run_c(gong, d, [dict(kind="phase_short", phase=0, phase2=1, value=r, k_on=0)], w0)
    assert np.abs(healthy[0] - faulted[0]).max() < 1e-10
    e = faulted[4].energy()
    ts, td, vdc = gong.ts_s, gong.t_delay_s, gong.v_dc_v
    prev = np.full(3, 0.5)
    want = 0.0
    for row in d:
        want += ((prev[0] - prev[1]) * vdc) ** 2 / r * td + ((row[0] - row[1]) * vdc) ** 2 / r * (ts - td)
        prev = row
    assert e["short_loss_j"] == pytest.approx(want, rel=1e-12)
    assert e["dc_bus_in_j"] == pytest.approx(e["electrical_in_j"] + e["short_loss_j"], rel=1e-14)


def test_phase_short_sampled_at_the_zero_vector(gong):
    """At t_k the PWM legs sit at the - rail: the sampled leg currents are the machine's while
    both shorted legs switch (PWM); with a leg stuck high the short shows in the sample."""
    pl = Plant(gong)
    pl.set_initial(TH0, 100.0)
    for row in sync_duties(gong, 40, 100.0, 0.0, 3.0):
        pl.step(*row)
    pl.set_fault("phase_short", phase="a", phase2="b", value=1.0)
    pl.step(0.6, 0.4, 0.5)
    s, m = pl.snapshot(), pl.sample()
    assert (m.i_a_a, m.i_b_a, m.i_c_a) == (s.i_a_a, s.i_b_a, s.i_c_a)
    assert abs(pl.fault_status()["i_short_a"] - 0.2 * gong.v_dc_v / 1.0) < 1e-9  # averaged
    pl.set_fault("leg_stuck", phase="a", level=1)
    m = pl.sample()
    assert m.i_a_a == pytest.approx(s.i_a_a + gong.v_dc_v / 1.0, abs=1e-9)
    assert m.i_b_a == pytest.approx(s.i_b_a - gong.v_dc_v / 1.0, abs=1e-9)


def test_phase_short_refusals(gong):
    pl = Plant(gong, inverter_nonlinear=True)
    with pytest.raises(ValueError, match="ideal inverter"):
        pl.set_fault("phase_short", phase="a", phase2="b", value=1.0)
    pl = Plant(gong)
    with pytest.raises(ValueError, match="phase2"):
        pl.set_fault("phase_short", phase="a", phase2="a", value=1.0)
    with pytest.raises(ValueError, match="resistance"):
        pl.set_fault("phase_short", phase="a", phase2="b", value=0.0)
    pl.set_fault("open_phase", phase="c")
    with pytest.raises(ValueError, match="open_phase"):
        pl.set_fault("phase_short", phase="a", phase2="b", value=1.0)
    with pytest.raises(ValueError, match="unknown fault kind"):
        pl.set_fault("meteor")


# ------------------------------------------------------------------------------------------
# sensors, encoder, bus (direct checks)

def _running(prof, n=50, **overrides):
    pl = Plant(prof, **overrides)
    pl.set_initial(TH0, 100.0)
    for row in sync_duties(prof, n, 100.0, 0.0, 3.0):
        pl.step(*row)
    return pl


@pytest.mark.parametrize("adc", [False, True])
def test_current_sensor_faults_read_as_defined(gong, adc):
    pl = _running(gong, adc_model=adc, adc_noise_a_rms=0.0)
    healthy = pl.sample_dict()
    s = pl.snapshot()
    true = [s.i_a_a, s.i_b_a, s.i_c_a]
    lsb = gong.adc_full_scale_a / 2 ** (gong.adc_bits - 1) if adc else 0.0
    tol = 0.5 * lsb + 1e-12
    cases = [("sensor_stuck", 1, 3.25, lambda i: 3.25), ("sensor_offset", 0, 0.8, lambda i: i + 0.8),
             ("sensor_gain", 2, 0.1, lambda i: 1.1 * i), ("sensor_dropout", 1, 0.0, lambda i: 0.0)]
    for kind, ph, value, want in cases:
        pl.set_fault(kind, phase=ph, value=value)
        m = pl.sample_dict()
        got = [m["i_a_a"], m["i_b_a"], m["i_c_a"]]
        assert abs(got[ph] - want(true[ph])) <= tol, (kind, got[ph], want(true[ph]))
        for other in {0, 1, 2} - {ph}:
            assert got[other] == healthy[("i_a_a", "i_b_a", "i_c_a")[other]]
        pl.clear_fault(kind)
        assert pl.sample_dict() == healthy        # cleared: exactly the healthy sample again


def test_sensor_fault_changes_neither_the_plant_nor_the_noise_stream(gong):
    d = sync_duties(gong, 80, 100.0, 0.0, 3.0)
    a = Plant(gong, adc_model=True, adc_seed=5)
    b = Plant(gong, adc_model=True, adc_seed=5)
    for p_ in (a, b):
        p_.set_initial(TH0, 100.0)
    for k, row in enumerate(d):
        if k == 20:
            a.set_fault("sensor_offset", phase="a", value=1.0)
        if k == 60:
            a.clear_fault("sensor_offset")
        a.step(*row)
        b.step(*row)
        ma, mb = a.sample_dict(), b.sample_dict()
        if 20 <= k < 59:
            assert ma["i_a_a"] != mb["i_a_a"]
            assert (ma["i_b_a"], ma["i_c_a"], ma["v_dc_v"]) == (mb["i_b_a"], mb["i_c_a"], mb["v_dc_v"])
        elif k >= 60:
            assert ma == mb
    assert a.snapshot_dict() == b.snapshot_dict()


def test_encoder_loss_and_stuck(gong):
    pl = _running(gong)
    m = pl.sample()
    assert m.enc_valid == 1 and m.theta_enc_rad == pl.snapshot().theta_e_rad
    pl.set_fault("encoder_stuck")
    held = pl.sample().theta_enc_rad
    for _ in range(10):
        pl.step(0.6, 0.4, 0.5)
    assert pl.sample().theta_enc_rad == held != pl.snapshot().theta_e_rad
    pl.set_fault("encoder_loss")
    assert pl.sample().enc_valid == 0 and pl.faults_active() == ["encoder_loss"]
    pl.clear_fault("encoder_loss")
    assert pl.sample().enc_valid == 1 and pl.sample().theta_enc_rad == pl.snapshot().theta_e_rad


@pytest.mark.parametrize("adc", [False, True])
def test_bus_sag_acts_on_the_inverter_and_the_reading(gong, adc):
    pl = _running(gong, adc_model=adc, adc_vdc_noise_v_rms=0.0)
    prev = sync_duties(gong, 50, 100.0, 0.0, 3.0)[-1]
    lsb = gong.adc_vdc_full_scale_v / 2 ** gong.adc_bits if adc else 0.0
    pl.set_fault("vdc", value=200.0)
    assert abs(pl.sample().v_dc_v - 200.0) <= 0.5 * lsb + 1e-12
    pl.step(0.8, 0.5, 0.5)
    s = pl.snapshot()
    assert s.v_dc_v == 200.0
    # line voltage a-b of that period: duty differences times the sagged bus, per interval
    td, ts = gong.t_delay_s, gong.ts_s
    want = ((prev[0] - prev[1]) * td + 0.3 * (ts - td)) / ts * 200.0
    assert s.v_a_v - s.v_b_v == pytest.approx(want, abs=1e-9)
    pl.clear_fault("vdc")
    assert abs(pl.sample().v_dc_v - gong.v_dc_v) <= 0.5 * lsb + 1e-12


def test_bus_fault_vs_reference(gong):
    w0 = 100.0
    d = sync_duties(gong, 150, w0, 0.0, 3.0)
    err, *_ = compare(gong, d, [dict(kind="vdc", value=250.0, k_on=50, k_off=100)], w0)
    assert err["current_a"] < 1e-5 * 9.8, err        # the ideal-plant tolerance (1e-5 x rated)
    assert err["speed_rad_s"] < 1e-5, err


# ------------------------------------------------------------------------------------------
# mechanics

def test_locked_rotor_holds_and_releases(gong):
    pl = _running(gong)
    w_before = pl.snapshot().omega_m_rad_s
    kin = 0.5 * gong.j_kgm2 * w_before ** 2
    work0 = pl.energy()["load_work_j"]
    pl.set_fault("locked_rotor")
    th = None
    for k in range(30):
        pl.step(0.6, 0.4, 0.5)
        s = pl.snapshot()
        assert s.omega_m_rad_s == 0.0
        th = s.theta_e_rad if th is None else th
        assert s.theta_e_rad == th
    e = pl.energy()
    assert e["load_work_j"] - work0 == pytest.approx(kin, rel=1e-12)   # the lock took it
    assert s.torque_load_nm == pytest.approx(s.torque_e_nm, abs=1e-12)  # and reacts T_e
    assert abs(s.torque_e_nm) > 0.1
    pl.clear_fault("locked_rotor")
    for _ in range(20):
        pl.step(0.6, 0.4, 0.5)
    assert pl.snapshot().omega_m_rad_s != 0.0


def test_load_torque_spike_vs_reference(gong):
    w0 = 100.0
    d = sync_duties(gong, 150, w0, 0.0, 3.0)
    faults = [dict(kind="load_torque", value=2.0, k_on=40, k_off=90)]
    err, _, _, _, w, pl = compare(gong, d, faults, w0)
    assert err["current_a"] < 1e-5 * 9.8, err
    assert err["speed_rad_s"] < 1e-6, err
    healthy = run_c(gong, d, [], w0)[3]
    assert healthy[90] - w[90] > 1.0 * 50 * gong.ts_s / gong.j_kgm2    # the spike decelerated it
    assert energy_residual(pl, w0) < 1e-7


# ------------------------------------------------------------------------------------------
# API

def test_reset_clears_everything_and_restores(gong):
    pl = Plant(gong)
    for kind in ("vdc", "locked_rotor", "load_torque", "encoder_loss"):
        pl.set_fault(kind, value=100.0)
    pl.set_fault("sensor_gain", phase="b", value=0.5)
    assert set(pl.faults_active()) == {"vdc", "locked_rotor", "load_torque", "encoder_loss", "sensor_gain"}
    pl.reset()
    assert pl.faults_active() == []
    fresh = Plant(gong)
    for row in sync_duties(gong, 30, 0.0, 0.0, 1.0):
        pl.step(*row)
        fresh.step(*row)
    assert pl.snapshot_dict() == fresh.snapshot_dict()
    assert pl.energy() == fresh.energy()


def test_kinds_names_and_phases(gong):
    assert FAULT_KINDS["open_phase"] == 1 and FAULT_KINDS["load_torque"] == 12
    pl = Plant(gong)
    with pytest.raises(ValueError, match="phase"):
        pl.set_fault("open_phase", phase="d")
    with pytest.raises(ValueError, match="level"):
        pl.set_fault("leg_stuck", phase="a", level=2)
    with pytest.raises(ValueError, match="gain"):
        pl.set_fault("sensor_gain", phase="a", value=-1.0)
    pl.set_fault("sensor_stuck", phase="a", value=1.0)
    pl.set_fault("sensor_dropout", phase="b")
    assert set(pl.faults_active()) == {"sensor_stuck", "sensor_dropout"}
    pl.clear_fault("sensor_stuck", phase="b")      # not that phase: nothing changes
    assert "sensor_stuck" in pl.faults_active()
    pl.clear_faults()
    assert pl.faults_active() == []
