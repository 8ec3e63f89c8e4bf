"""Disabled inverter legs (duty < 0): freewheeling diodes, the inverter's safe state.

All legs off, back EMF (line-to-line peak) below V_dc: the currents decay through the diodes
to exactly zero and stay there; the rotor coasts down exponentially. Above V_dc: the diode
bridge rectifies, a braking current flows and energy goes into the DC bus.

The C plant uses ideal diodes with located switching events; the reference
(plant_rt/verify/reference.py) uses a smooth, stiff diode characteristic whose leakage scale is
i0 = DIODE_I0_A. The C-vs-reference differences are proportional to i0 (measured from
i0 = 1e-4 down to 1e-6 A: the C model is the reference's i0 -> 0 limit). Largest measured
differences per unit i0 over the cases below: current 5.4 A/A (braking, gong2020, 100 V bus),
speed 4.2 (rad/s)/A and electrical angle 0.11 rad/A (random pattern, hou2021). The tolerances
are ~3x those: 20 i0 [A], 10 i0 [rad/s], 0.3 i0 [rad].
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from hil_bench.plant_rt.plant import Plant
from hil_bench.plant_rt.profile import load_profile
from hil_bench.plant_rt.verify import openloop, reference
from hil_bench.plant_rt.verify.error_study import compare

DIODE_I0_A = 1e-5                   # reference diode leakage scale [A]
CURRENT_TOL_A = 20 * DIODE_I0_A     # measured <= 5.4 i0
SPEED_TOL_RAD_S = 10 * DIODE_I0_A   # measured <= 4.2 i0
ANGLE_TOL_RAD = 0.3 * DIODE_I0_A    # measured <= 0.11 i0
OFF = (-1.0, -1.0, -1.0)


def _line_emf_peak(prof, omega_m):
    return math.sqrt(3.0) * prof.psi_f_wb * prof.pole_pairs * omega_m


def test_all_off_below_vdc_currents_decay_to_zero_and_stay():
    prof = load_profile("gong2020")
    w0 = 100.0
    assert _line_emf_peak(prof, w0) < 0.25 * prof.v_dc_v
    v_d, v_q = openloop.operating_point_voltage(prof, prof.pole_pairs * w0, 0.0, 5.0)
    pwm = openloop.synchronous(prof, 100, theta_e0_rad=0.0, omega_e_rad_s=prof.pole_pairs * w0,
                               v_d_v=v_d, v_q_v=v_q)
    duties = np.vstack([pwm, np.tile(OFF, (400, 1))])
    plant = Plant(prof)
    plant.set_initial(0.0, w0)
    out = plant.run(duties)
    on, off = out[:100], out[100:]
    assert np.abs(on["i_q_a"][-1]) > 2.0                      # a real current was flowing
    i_off = np.abs(np.stack([off["i_a_a"], off["i_b_a"], off["i_c_a"]]))
    zero = i_off.max(axis=0) == 0.0
    assert zero.any()
    first_zero = int(np.argmax(zero))
    # the off command acts at t_delay; ~2 mH * 5 A / 250 V = 40 us later the diodes are off
    assert first_zero <= 1                                     # gone within a period ...
    assert (i_off[:, first_zero:] == 0.0).all()                # ... and exactly zero after
    assert (off["torque_e_nm"][first_zero:] == 0.0).all()
    assert plant.events >= 2                                   # diode turn-offs were located
    # terminals float: the averaged phase voltages are the back EMF
    e_a = off["e_alpha_v"]
    assert np.abs(off["v_a_v"][-1] - 0.5 * (e_a[-1] + e_a[-2])) < 0.05 * np.abs(e_a).max()
    # rotor coasts down exponentially (no load, no current): omega(t) = omega(t1) e^{-B t/J}
    k1 = first_zero
    t = off["t_s"][k1:] - off["t_s"][k1]
    want = off["omega_m_rad_s"][k1] * np.exp(-t * prof.b_nms / prof.j_kgm2)
    assert np.abs(off["omega_m_rad_s"][k1:] - want).max() < 1e-9 * w0

    # the independent reference agrees through the decay (leakage ~ i0 afterwards)
    ref = reference.simulate(prof, duties[:150], omega_m0=w0, diode_i0_a=DIODE_I0_A, rtol=1e-9)
    err = compare(out[:150], ref, prof.rated["current_a"])
    assert err["current_a"] < CURRENT_TOL_A, err
    assert err["speed_rad_s"] < SPEED_TOL_RAD_S, err


@pytest.mark.parametrize("ratio,flows", [(0.97, False), (1.05, True)])
def test_all_off_threshold_is_line_emf_equal_vdc(ratio, flows):
    """From zero current, a disabled inverter conducts iff the line EMF peak exceeds V_dc."""
    prof = load_profile("gong2020")
    w = ratio * prof.v_dc_v / (math.sqrt(3.0) * prof.psi_f_wb * prof.pole_pairs)
    plant = Plant(prof, t_delay_s=0.0, j_kgm2=10.0)  # no initial short; speed ~ constant
    plant.set_initial(0.2, w)
    out = plant.run(np.tile(OFF, (300, 1)))
    peak = np.abs(np.stack([out["i_a_a"], out["i_b_a"], out["i_c_a"]])).max()
    if flows:
        assert peak > 0.5
        assert plant.energy()["electrical_in_j"] < 0.0
    else:
        assert peak == 0.0
        assert plant.energy()["electrical_in_j"] == 0.0


def test_all_off_above_vdc_brakes_like_a_diode_bridge():
    prof = load_profile("gong2020")
    v_dc, w0 = 100.0, 200.0
    assert _line_emf_peak(prof, w0) > 1.1 * v_dc
    n = 100
    duties = np.tile(OFF, (n, 1))
    plant = Plant(prof, v_dc_v=v_dc)
    plant.set_initial(0.0, w0)
    out = plant.run(duties)
    i_abc = np.stack([out["i_a_a"], out["i_b_a"], out["i_c_a"]])
    assert np.abs(i_abc).max() > 1.0                          # braking current flows
    assert out["torque_e_nm"].mean() < -0.05                  # and brakes
    e = plant.energy()
    assert e["electrical_in_j"] < -0.1                        # energy goes into the bus
    stored = e["magnetic_j"] + e["kinetic_j"] - 0.5 * prof.j_kgm2 * w0**2
    assert e["electrical_in_j"] == pytest.approx(stored + e["copper_loss_j"] + e["viscous_loss_j"]
                                                 + e["load_work_j"], abs=1e-7)
    # rectifier: a phase conducts only through its diodes, so at any instant at least one of the
    # three phases is open or the pattern is a commutation; the phase voltage never exceeds the
    # bus: |v_x| <= 2/3 V_dc for every averaged phase voltage
    for key in ("v_a_v", "v_b_v", "v_c_v"):
        assert np.abs(out[key]).max() <= 2.0 / 3.0 * v_dc + 1e-9

    ref_fine = reference.simulate(dict(prof.plant_params(), v_dc_v=v_dc), duties, omega_m0=w0,
                                  diode_i0_a=DIODE_I0_A, rtol=1e-9)
    err = compare(out, ref_fine, prof.rated["current_a"])
    assert err["current_a"] < CURRENT_TOL_A, err
    assert err["speed_rad_s"] < SPEED_TOL_RAD_S, err
    assert err["theta_e_rad"] < ANGLE_TOL_RAD, err
    # the difference is the reference's regularisation: 10x the leakage -> ~10x the difference
    ref_coarse = reference.simulate(dict(prof.plant_params(), v_dc_v=v_dc), duties, omega_m0=w0,
                                    diode_i0_a=10 * DIODE_I0_A, rtol=1e-9)
    err_coarse = compare(out, ref_coarse, prof.rated["current_a"])
    assert 5.0 < err_coarse["current_a"] / err["current_a"] < 20.0


def test_one_leg_off_on_a_salient_machine():
    """IPMSM, leg a disabled, b and c switching: phase a stays open (exactly zero current)
    while its terminal voltage stays between the rails; the rest matches the reference."""
    prof = load_profile("hou2021")
    n = 300
    k = np.arange(n)
    m = 0.03 * np.sin(2 * np.pi * k / 100)
    duties = np.stack([np.full(n, -1.0), 0.5 + m, 0.5 - m], axis=-1)
    plant = Plant(prof)
    plant.set_initial(0.5, 30.0)
    out = plant.run(duties)
    assert np.abs(out["i_a_a"]).max() < 1e-12  # zero up to the dq -> abc rounding
    assert np.abs(out["i_b_a"]).max() > 1.0
    assert np.allclose(out["i_b_a"], -out["i_c_a"], atol=1e-12, rtol=0)
    ref = reference.simulate(prof, duties, theta_e0=0.5, omega_m0=30.0, diode_i0_a=DIODE_I0_A,
                             rtol=1e-9)
    err = compare(out, ref, prof.rated["current_a"])
    assert err["current_a"] < CURRENT_TOL_A, err
    assert err["speed_rad_s"] < SPEED_TOL_RAD_S, err


def _random_leg_pattern(rng: np.random.Generator, n: int, hold: int = 10) -> np.ndarray:
    """Duties in [0.3, 0.7] held for `hold` periods, each leg disabled with probability 0.4."""
    d = rng.uniform(0.3, 0.7, (n // hold, 3))
    d[rng.uniform(0.0, 1.0, d.shape) < 0.4] = -1.0
    return np.repeat(d, hold, axis=0)


@pytest.mark.parametrize("seed,name", [(3, "gong2020"), (4, "hou2021")])
def test_random_enable_disable_patterns_match_reference(seed, name):
    """Mixed PWM / disabled legs switching every 10 periods, rotor spinning (either direction):
    every diode mode combination the plant can meet, against the independent reference."""
    rng = np.random.default_rng(seed)
    prof = load_profile(name)
    duties = _random_leg_pattern(rng, 200)
    w0, th0 = float(rng.uniform(-300, 300)), float(rng.uniform(0, 2 * math.pi))
    plant = Plant(prof)
    plant.set_initial(th0, w0)
    out = plant.run(duties)
    assert plant.events >= 5
    ref = reference.simulate(prof, duties, theta_e0=th0, omega_m0=w0, diode_i0_a=DIODE_I0_A, rtol=1e-9)
    err = compare(out, ref, prof.rated["current_a"])
    assert err["current_a"] < CURRENT_TOL_A, err
    assert err["speed_rad_s"] < SPEED_TOL_RAD_S, err
    assert err["theta_e_rad"] < ANGLE_TOL_RAD, err


def test_random_patterns_invariants():
    """C only, many cases: finite state, |v_phase| <= 2/3 V_dc, energy balance."""
    rng = np.random.default_rng(7)
    for trial in range(90):
        name = ("gong2020", "hou2021", "yuan2020")[trial % 3]
        v_dc = float(rng.choice([60.0, 100.0, 310.0, 540.0]))
        plant = Plant.from_profile(name, v_dc_v=v_dc, t_delay_s=float(rng.uniform(0.0, 1e-4)))
        w0 = float(rng.uniform(-400.0, 400.0))
        plant.set_initial(float(rng.uniform(0, 2 * math.pi)), w0)
        plant.set_load_torque(float(rng.uniform(-2.0, 2.0)))
        duties = _random_leg_pattern(rng, 200)
        out = plant.run(duties)
        assert np.isfinite(out.view(np.float64)).all(), trial
        for key in ("v_a_v", "v_b_v", "v_c_v"):
            assert np.abs(out[key]).max() <= 2.0 / 3.0 * v_dc * (1 + 1e-12), (trial, key)
        e = plant.energy()
        kin0 = 0.5 * plant.params.j_kgm2 * w0**2
        res = e["electrical_in_j"] - (e["magnetic_j"] + e["kinetic_j"] - kin0 + e["copper_loss_j"]
                                      + e["viscous_loss_j"] + e["load_work_j"])
        scale = abs(e["electrical_in_j"]) + e["copper_loss_j"] + kin0 + abs(e["load_work_j"])
        assert abs(res) < 1e-7 * scale, (trial, res, scale)
