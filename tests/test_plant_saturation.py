"""d-axis saturation: the small-signal inductances stay the profile values, the flux curve is
what the docs say, and the HF current differs between N and S by the stated amounts (what Hou
et al.'s polarity identification relies on; numbers in plant_rt/profiles/hou2021.toml and
plant_rt/README.md, from python -m hil_bench.plant_rt.verify.saturation_study)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from hil_bench.plant_rt.plant import Plant, ffi, lib
from hil_bench.plant_rt.profile import load_profile
from hil_bench.plant_rt.verify import reference
from hil_bench.plant_rt.verify import saturation_study as ss
from hil_bench.plant_rt.verify.openloop import duties_from_alphabeta

HOU = load_profile("hou2021")
# stated in the profile / README (6 V, 1250 Hz, standstill)
STATED_N_A, STATED_S_A, STATED_RATIO = 0.3064, 0.3043, 1.0069
STATED_BIAS_RATIO = 1.208   # +-2.38 A bias


def _machine(sat: bool = True):
    m = ffi.new("pmsm_machine_t *")
    cfg = ffi.new("pmsm_machine_config_t *", dict(rs_ohm=HOU.rs_ohm, ld_h=HOU.ld_h, lq_h=HOU.lq_h,
                                                   psi_f_wb=HOU.psi_f_wb, pole_pairs=HOU.pole_pairs))
    assert lib.pmsm_machine_init(m, cfg) == 0
    if sat:
        sc = ffi.new("pmsm_saturation_config_t *", dict(l_inf_ratio=HOU.sat_l_inf_ratio,
                                                         i_scale_a=HOU.sat_i_scale_a, i_knee_a=HOU.sat_i_knee_a))
        assert lib.pmsm_machine_set_saturation(m, sc) == 0
    return m


def test_flux_curve_as_documented():
    m = _machine()
    p = reference.RefParams.of(dict(HOU.plant_params(), saturation=True))
    for i in np.linspace(-15, 15, 31):
        assert lib.pmsm_machine_psi_d(m, i) == pytest.approx(reference.psi_d_curve(p, i), abs=1e-15)
        assert lib.pmsm_machine_ld_inc(m, i) == pytest.approx(reference.ld_inc_curve(p, i), rel=1e-13)
    assert lib.pmsm_machine_psi_d(m, 0.0) == HOU.psi_f_wb
    assert lib.pmsm_machine_ld_inc(m, 0.0) == pytest.approx(HOU.ld_h, rel=1e-15)
    # the targets the profile's parameters were fitted to
    ir = HOU.rated["current_a"]
    assert lib.pmsm_machine_ld_inc(m, ir) / HOU.ld_h == pytest.approx(0.80, abs=0.005)
    assert lib.pmsm_machine_ld_inc(m, -ir) / HOU.ld_h == pytest.approx(1.05, abs=0.005)
    assert max(lib.pmsm_machine_ld_inc(m, i) for i in np.linspace(-6, 0, 601)) / HOU.ld_h == pytest.approx(1.08, abs=0.005)


def test_small_signal_inductances_are_the_profile_values():
    """A tiny HF injection at zero current sees L_d and L_q: the same response as the linear
    machine (to 1e-4), on both axes."""
    u = 0.02  # V: ~1 mA of HF current
    for axis in ("d", "q"):
        amps = []
        for sat in (False, True):
            plant = Plant(HOU, saturation=sat, dyno=True, dyno_speed_rad_s=0.0, t_delay_s=0.0)
            n = 4000
            t = (np.arange(n) + 0.5) * HOU.ts_s
            w = 2 * math.pi * 1250.0
            v = u * np.sin(w * t)
            va, vb = (v, 0 * v) if axis == "d" else (0 * v, v)
            out = plant.run(duties_from_alphabeta(va, vb, HOU.v_dc_v))
            x = out["i_d_a" if axis == "d" else "i_q_a"][2000:]
            amps.append(0.5 * (x.max() - x.min()))
        assert amps[1] == pytest.approx(amps[0], rel=1e-4), axis
        # and it is U / (w L) of the profile's inductance (8 samples per cycle, averaged PWM)
        l = HOU.ld_h if axis == "d" else HOU.lq_h
        assert amps[0] == pytest.approx(u / (w * l), rel=0.05)


def test_hf_current_n_vs_s_without_bias():
    """Rotating 6 V / 1250 Hz injection at standstill: the d-current peak towards N exceeds the
    one towards S by the stated amount; the linear machine shows no difference."""
    r = ss.hf_response(HOU)
    assert r.i_n_a == pytest.approx(STATED_N_A, abs=2e-4)
    assert r.i_s_a == pytest.approx(STATED_S_A, abs=2e-4)
    assert r.ratio_ns == pytest.approx(STATED_RATIO, abs=3e-4)
    assert r.ratio_ns > 1.005
    # an independent estimate from the flux curve alone (zero mean current in steady state)
    qn, qs = ss.quasi_static(HOU)
    assert qn / qs == pytest.approx(r.ratio_ns, abs=3e-4)
    # linear machine: symmetric
    lin = Plant(HOU, ts_s=HOU.ts_s / 16, t_delay_s=0.0, dyno=True, dyno_speed_rad_s=0.0)
    assert lin.params.saturation is False
    # (hf_response switches saturation on; build the symmetric case by hand)
    n = 16 * 2000
    ts = HOU.ts_s / 16
    t = (np.arange(n) + 0.5) * ts
    w = 2 * math.pi * 1250.0
    g = math.sin(0.5 * w * ts) / (0.5 * w * ts)
    out = lin.run(duties_from_alphabeta(6 * g * np.sin(w * t), 6 * g * np.cos(w * t), HOU.v_dc_v))
    i_d = out["i_d_a"][n // 2:]
    assert i_d.max() / -i_d.min() == pytest.approx(1.0, abs=2e-4)


def test_n_pole_found_in_the_stator_frame():
    """Hou's procedure works on stator quantities: with N on +alpha (theta = 0) the HF current
    reaches further along +alpha than along -alpha; with the rotor turned by 180 deg (S on
    +alpha) it is the other way round."""
    ext = {}
    for theta in (0.0, math.pi):
        plant = Plant(HOU, saturation=True, ts_s=HOU.ts_s / 16, t_delay_s=0.0, dyno=True, dyno_speed_rad_s=0.0)
        plant.set_initial(theta, 0.0)
        n = 16 * 1600
        ts = HOU.ts_s / 16
        t = (np.arange(n) + 0.5) * ts
        w = 2 * math.pi * 1250.0
        g = math.sin(0.5 * w * ts) / (0.5 * w * ts)
        # rotating injection in the stator frame (does not need the rotor angle)
        out = plant.run(duties_from_alphabeta(6 * g * np.cos(w * t), 6 * g * np.sin(w * t), HOU.v_dc_v))
        ia = out["i_alpha_a"][n // 2:]
        ext[theta] = (ia.max(), -ia.min())
    assert ext[0.0][0] > ext[0.0][1] * 1.003          # +alpha is N
    assert ext[math.pi][0] < ext[math.pi][1] / 1.003  # +alpha is S


def test_hf_amplitude_with_a_d_current_bias():
    """A d-current bias towards N / S changes the HF amplitude to first order:
    ratio = L_inc(-b) / L_inc(+b) (1.208 at half rated current)."""
    b = 0.5 * HOU.rated["current_a"]
    pos = ss.hf_response(HOU, bias_a=b)
    neg = ss.hf_response(HOU, bias_a=-b)
    assert pos.i_mean_a == pytest.approx(b, abs=0.01)
    assert neg.i_mean_a == pytest.approx(-b, abs=0.01)
    ratio = pos.amplitude_a / neg.amplitude_a
    assert ratio == pytest.approx(STATED_BIAS_RATIO, abs=0.003)
    p = reference.RefParams.of(dict(HOU.plant_params(), saturation=True))
    assert ratio == pytest.approx(reference.ld_inc_curve(p, -b) / reference.ld_inc_curve(p, b), rel=0.005)


def test_saturation_changes_torque_and_emf_consistently():
    """T_e = 1.5 p (psi_d i_q - L_q i_d i_q) and the snapshot's stator flux."""
    plant = Plant(HOU, saturation=True)
    plant.set_initial(0.7, 30.0)
    for k in range(300):
        ang = 0.7 + 0.02 * k
        plant.step(0.5 + 0.03 * math.cos(ang), 0.5 + 0.03 * math.cos(ang - 2.094), 0.5 + 0.03 * math.cos(ang + 2.094))
    s = plant.snapshot()
    m = _machine()
    psi_d = lib.pmsm_machine_psi_d(m, s.i_d_a)
    assert s.torque_e_nm == pytest.approx(1.5 * 3 * (psi_d * s.i_q_a - HOU.lq_h * s.i_d_a * s.i_q_a), rel=1e-12)
    c, sn = math.cos(s.theta_e_rad), math.sin(s.theta_e_rad)
    assert s.psi_alpha_wb == pytest.approx(psi_d * c - HOU.lq_h * s.i_q_a * sn, abs=1e-14)
    assert s.psi_beta_wb == pytest.approx(psi_d * sn + HOU.lq_h * s.i_q_a * c, abs=1e-14)
    assert abs(s.i_d_a) > 0.5
