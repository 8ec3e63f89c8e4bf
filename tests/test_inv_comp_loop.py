"""The inverter-error feed-forward in the control ISR, in one process with the C plant: the
firmware (controller.c through hil_bench.firmware_stub._fw_c) and the plant (plant_rt) close the
encoder loop on the yuan2020 motor with the calibrated dead time and drops, at 50 rpm and 5 N m.

* without compensation the plant's phase current carries the 5th and 7th (the dead time's
  6k +- 1 family) and the voltage the observers are handed is ~(4/pi) x 8 V away from what the
  plant applied; with INV_COMP_ENABLE and the plant's own parameters (residual 0) the 5th and 7th
  fall below 0.1 % and the observers' voltage is the plant's to within the current-estimation
  residual the feed-forward leaves near the zero crossings (bounds below, measured: see the
  asserts' messages);
* the drive's estimate at (1 - r) x the plant's values leaves r of the error (the 5th + 7th
  scale with it);
* every current source of INV_COMP_ENABLE (1..4) compensates; a bad configuration is refused at
  start (CONFIG_INVALID).
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from hil_bench.papers.metrics import harmonic_spectrum
from hil_bench.plant_rt.plant import Plant
from hil_bench.plant_rt.profile import load_profile
from hil_bench.protocol.messages import Param

fw = pytest.importorskip("hil_bench.firmware_stub._fw_c")
ffi, lib = fw.ffi, fw.lib

RPM = 50.0
W_M = RPM * 2 * math.pi / 60
STATE_FAULT = 4


def _loop(comp: dict[Param, float] | None, t_end_s: float = 0.7, adc: bool = True):
    """Encoder loop; returns (t, i_a, observer-voltage error |v_obs - v_plant|)."""
    prof = load_profile("yuan2020")
    plant = Plant(prof, inverter_nonlinear=True, adc_model=adc, coulomb_nm=5.0,
                  coulomb_band_rad_s=0.05)
    plant.set_initial(0.0, W_M)
    c = ffi.new("controller_t *")
    lib.ctrl_init(c)
    cfg = c.cfg
    for name in ("rs_ohm", "ld_h", "lq_h", "psi_f_wb", "j_kgm2", "b_nms", "ts_s"):
        setattr(cfg, name, getattr(prof, name))
    cfg.pole_pairs, cfg.v_dc_nom_v, cfg.t_act_delay_s = prof.pole_pairs, prof.v_dc_v, prof.t_delay_s
    cfg.estimator, cfg.iq_max_a, cfg.i_trip_a = 5.0, 15.0, 19.6
    for p, v in (comp or {}).items():
        assert lib.ctrl_param_set(ffi.addressof(cfg), int(p), float(v)) == 0, p
    assert lib.ctrl_start(c) == 0
    lib.ctrl_set_speed_ref(c, W_M)
    smp = ffi.new("ctrl_sample_t *")
    n = int(round(t_end_s / prof.ts_s))
    t, ia, err = np.empty(n), np.empty(n), np.empty(n)
    for k in range(n):
        m = plant.sample()
        smp.i_a_a, smp.i_b_a, smp.i_c_a = m.i_a_a, m.i_b_a, m.i_c_a
        smp.v_dc_v, smp.v_dc_valid = m.v_dc_v, 1
        smp.theta_enc_rad, smp.theta_enc_valid = m.theta_enc_rad, m.enc_valid
        out = lib.ctrl_step(c, smp)
        assert out.state != STATE_FAULT, (k, out.fault)
        s = plant.snapshot()
        t[k], ia[k] = k * prof.ts_s, s.i_a_a
        err[k] = math.hypot(c.v_ab_acted_v.x - s.v_alpha_v, c.v_ab_acted_v.y - s.v_beta_v)
        plant.step(*out.duty_abc)
    return t, ia, err, prof


def _comp(residual: float, mode: int = 4) -> dict[Param, float]:
    prof = load_profile("yuan2020")
    inv = prof.plant_params()
    f = 1.0 - residual
    return {Param.INV_COMP_ENABLE: mode, Param.INV_COMP_DEAD_TIME_S: f * inv["dead_time_s"],
            Param.INV_COMP_V_SWITCH_V: f * inv["v_switch_drop_v"],
            Param.INV_COMP_R_SWITCH_OHM: f * inv["r_switch_ohm"],
            Param.INV_COMP_V_DIODE_V: f * inv["v_diode_drop_v"],
            Param.INV_COMP_R_DIODE_OHM: f * inv["r_diode_ohm"],
            Param.INV_COMP_BAND_A: inv["i_cap_band_a"], Param.INV_COMP_SHAPE: 1}


def _h57(t, ia, prof, t0=0.4):
    m = t >= t0
    sp = harmonic_spectrum(ia[m], 1.0 / prof.ts_s, RPM / 60 * prof.pole_pairs)
    return sp


@pytest.fixture(scope="module")
def runs():
    return {"off": _loop(None), "r0": _loop(_comp(0.0)), "r10": _loop(_comp(0.1))}


def test_compensation_removes_the_dead_time_harmonics(runs):
    off = _h57(*runs["off"][:2], runs["off"][3])
    on = _h57(*runs["r0"][:2], runs["r0"][3])
    h_off = math.hypot(off.harmonic_percent(5), off.harmonic_percent(7))
    h_on = math.hypot(on.harmonic_percent(5), on.harmonic_percent(7))
    # measured: 5th 0.86 %, 7th 0.50 % without; 0.0001 %, 0.005 % with (the stub's 500 Hz
    # current loop rejects most of the dead time's voltage error; its residual is what remains)
    assert h_off > 0.5, h_off
    assert h_on < 0.02 * h_off, (h_off, h_on)


def test_residual_scales_the_harmonics(runs):
    off = _h57(*runs["off"][:2], runs["off"][3])
    r10 = _h57(*runs["r10"][:2], runs["r10"][3])
    ratio = math.hypot(r10.harmonic_percent(5), r10.harmonic_percent(7)) / \
        math.hypot(off.harmonic_percent(5), off.harmonic_percent(7))
    assert 0.08 < ratio < 0.12, ratio              # 10 % of the error left: measured 0.097


def test_observers_see_the_applied_voltage(runs):
    e_off = runs["off"][2][4000:]
    e_on = runs["r0"][2][4000:]
    assert np.sqrt(np.mean(e_off ** 2)) > 5.0, np.sqrt(np.mean(e_off ** 2))
    # ADC noise on the bus (0.5 V rms) through the modulation and the current-vector residual
    # near the zero crossings: measured 0.013 V rms, 0.064 V peak (8.7 V rms without)
    assert np.sqrt(np.mean(e_on ** 2)) < 0.03, np.sqrt(np.mean(e_on ** 2))
    assert np.max(e_on) < 0.15, np.max(e_on)
    e_r10 = runs["r10"][2][4000:]                  # 10 % of the error left: measured 0.87 V
    assert 0.08 < np.sqrt(np.mean(e_r10 ** 2)) / np.sqrt(np.mean(e_off ** 2)) < 0.12


@pytest.mark.parametrize("mode", [1, 2, 3, 4])
def test_every_current_source_compensates(mode):
    t, ia, err, prof = _loop(_comp(0.0, mode), t_end_s=0.5, adc=False)
    assert np.sqrt(np.mean(err[3000:] ** 2)) < 0.1, (mode, np.sqrt(np.mean(err[3000:] ** 2)))


@pytest.mark.parametrize("param, value", [(Param.INV_COMP_DEAD_TIME_S, 6e-5),
                                          (Param.INV_COMP_BAND_A, 0.0)])
def test_bad_configuration_is_refused_at_start(param, value):
    c = ffi.new("controller_t *")
    lib.ctrl_init(c)
    prof = load_profile("yuan2020")
    for name in ("rs_ohm", "ld_h", "lq_h", "psi_f_wb", "j_kgm2", "b_nms", "ts_s"):
        setattr(c.cfg, name, getattr(prof, name))
    c.cfg.pole_pairs, c.cfg.v_dc_nom_v, c.cfg.estimator = prof.pole_pairs, prof.v_dc_v, 5.0
    c.cfg.inv_comp_mode = 4.0
    setattr(c.cfg, {Param.INV_COMP_DEAD_TIME_S: "inv_comp_dead_time_s",
                    Param.INV_COMP_BAND_A: "inv_comp_band_a"}[param], value)
    assert lib.ctrl_start(c) == -1
    assert c.state == STATE_FAULT
