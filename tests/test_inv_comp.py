"""The inverter-error feed-forward (firmware_stub/src/inv_comp.c, float32) against independent
float64 models of the inverter's error (tests/models/inverter_comp.py).

Truth: the plant's own averaged leg (plant_rt.verify.reference.leg_average, float64), the C
plant's leg (plant_rt/c/inverter.c) and, for the dead time and node capacitance, the switch-level
leg (reference.leg_average_switched). Tolerances, all from float32:
* the drive's forward model vs the plant's leg: 3e-4 V at 540 V (|v| <= V_dc + drops: a few
  float32 ulps of 540 V, 6.1e-5 V each, over ~6 operations);
* the compensated duty vs the float64 root: 1e-6 (16 ulps of a duty near 1: the interpolation's
  numerator and denominator are differences of float32 voltages, each good to ~1e-7 V_dc);
* the voltage the plant then makes vs the command: 1e-6 V_dc (the duty's float32 error times
  V_dc).
Grid: duties over [0, 1] (including the pieces where the dead interval meets a rail), currents
from -20 A to 20 A with dense points inside the zero-crossing band, 310 V and 540 V buses.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from hil_bench.firmware_stub._binding import ffi, lib
from hil_bench.plant_rt import plant as plant_mod
from hil_bench.plant_rt.verify.reference import leg_average_switched
from tests.models.inverter_comp import Inverter, compensated_duty, linear_leg, plant_leg

#: the yuan2020 profile's calibrated leg and hou2021's (540 V, i_c scaled with the bus)
YUAN = Inverter(310.0, 1e-4, 1.78e-6, 0.8, 0.035, 0.9, 0.035, 0.155)
HOU = Inverter(540.0, 1e-4, 1.78e-6, 0.8, 0.035, 0.9, 0.035, 0.27)
DUTIES = (0.0, 0.005, 0.0178, 0.03, 0.2, 0.5, 0.77, 0.97, 0.9822, 0.995, 1.0)


def _currents(band: float) -> list[float]:
    inner = [band * x for x in (-3.0, -1.0, -0.6, -0.2, -0.01, 0.0, 0.01, 0.2, 0.6, 1.0, 3.0)]
    return sorted(set(inner + [-20.0, -10.9, -4.0, -1.0, 1.0, 4.0, 10.9, 20.0]))


def _comp(inv: Inverter, shape: int = 1):
    cfg = ffi.new("inv_comp_config_t *")
    lib.inv_comp_default_config(cfg, inv.ts_s)
    cfg.dead_time_s, cfg.v_switch_v, cfg.r_switch_ohm = inv.dead_time_s, inv.v_switch_v, inv.r_switch_ohm
    cfg.v_diode_v, cfg.r_diode_ohm, cfg.i_band_a, cfg.shape = (inv.v_diode_v, inv.r_diode_ohm,
                                                                inv.i_band_a, shape)
    s = ffi.new("inv_comp_t *")
    assert lib.inv_comp_init(s, cfg) == 0
    return s


def _plant_leg_c(inv: Inverter):
    """The C plant's averaged leg (plant_rt/c/inverter.c) with these parameters."""
    pl, pf = plant_mod.lib, plant_mod.ffi
    leg = pf.new("inverter_t *")
    assert pl.inverter_init(leg, pf.new("inverter_config_t *", {"v_dc_v": inv.v_dc_v})) == 0
    nl = dict(dead_time_s=inv.dead_time_s, ts_s=inv.ts_s, v_switch_drop_v=inv.v_switch_v,
              r_switch_ohm=inv.r_switch_ohm, v_diode_drop_v=inv.v_diode_v,
              r_diode_ohm=inv.r_diode_ohm, i_cap_band_a=inv.i_band_a)
    assert pl.inverter_set_nonlinear(leg, pf.new("inverter_nl_config_t *", nl)) == 0
    return lambda d, i: pl.inverter_leg_voltage(leg, d, i, pf.NULL)


@pytest.mark.parametrize("inv", [YUAN, HOU], ids=["310V", "540V"])
def test_drive_model_is_the_plants_leg(inv):
    """The compensation's forward model (capacitive shape) is the plant's averaged leg."""
    s = _comp(inv)
    worst = 0.0
    for d in DUTIES:
        for i in _currents(inv.i_band_a):
            worst = max(worst, abs(lib.inv_comp_leg_voltage(s, d, i, inv.v_dc_v) - plant_leg(inv, d, i)))
    assert worst < 3e-4, worst


@pytest.mark.parametrize("inv", [YUAN, HOU], ids=["310V", "540V"])
def test_compensated_duty_is_the_float64_root(inv):
    s = _comp(inv)
    worst = 0.0
    for d in DUTIES:
        for i in _currents(inv.i_band_a):
            want = compensated_duty(plant_leg, inv, d, i)
            worst = max(worst, abs(lib.inv_comp_leg_duty(s, d, i, inv.v_dc_v, ffi.NULL) - want))
    assert worst < 1e-6, worst


@pytest.mark.parametrize("inv", [YUAN, HOU], ids=["310V", "540V"])
def test_plant_makes_the_command(inv):
    """Through the C plant's own leg: wherever the command is within the leg's reach, the
    compensated duty makes exactly the commanded pole voltage; outside, the nearer limit."""
    s = _comp(inv)
    leg = _plant_leg_c(inv)
    clamped = ffi.new("int *")
    worst, n_reach = 0.0, 0
    for d in np.linspace(0.0, 1.0, 41):
        for i in _currents(inv.i_band_a):
            clamped[0] = 0
            dc = lib.inv_comp_leg_duty(s, d, i, inv.v_dc_v, clamped)
            v = leg(dc, i)
            if clamped[0]:
                # beyond the leg's range: the duty sits at the limit nearer the command
                assert dc in (0.0, 1.0) and abs(v - d * inv.v_dc_v) <= abs(leg(1.0 - dc, i) - d * inv.v_dc_v)
                continue
            n_reach += 1
            worst = max(worst, abs(v - d * inv.v_dc_v))
    assert n_reach > 0.9 * 41 * len(_currents(inv.i_band_a))
    assert worst < 1e-6 * inv.v_dc_v, worst


def test_switch_level_leg_makes_the_command():
    """Dead time and node capacitance only (the switch-level model has no slope resistance and
    no drop onset): the gate-timed leg, integrated segment by segment, makes the command."""
    t_dt, c_node = 1.78e-6, 0.9e-9
    inv = Inverter(310.0, 1e-4, t_dt, 0.0, 0.0, 0.0, 0.0, c_node * 310.0 / t_dt)
    s = _comp(inv)
    for d in (0.1, 0.35, 0.5, 0.8, 0.9):
        for i in (-6.0, -1.0, -0.2, -0.05, 0.0, 0.05, 0.2, 1.0, 6.0):
            dc = lib.inv_comp_leg_duty(s, d, i, 310.0, ffi.NULL)
            v = leg_average_switched(310.0, 1e-4, dc, i, dead_time_s=t_dt, c_node_f=c_node)
            assert v == pytest.approx(d * 310.0, abs=1e-3), (d, i)


@pytest.mark.parametrize("residual", [0.01, 0.03, 0.1, 0.5])
def test_residual_is_the_fraction_of_the_error_left(residual):
    """A drive whose estimate is (1 - r) x the plant's dead time and drops leaves the fraction r
    of the plant's error (outside the zero-crossing band, where the shapes agree exactly; the
    drops' duty split makes it exact only to first order: within 0.2 % of the error)."""
    s = _comp(YUAN.scaled(1.0 - residual))
    for d in (0.3, 0.5, 0.7):
        for i in (-10.9, -3.0, -1.0, 1.0, 3.0, 10.9):
            e0 = plant_leg(YUAN, d, i) - d * YUAN.v_dc_v
            dc = lib.inv_comp_leg_duty(s, d, i, YUAN.v_dc_v, ffi.NULL)
            e = plant_leg(YUAN, dc, i) - d * YUAN.v_dc_v
            assert e / e0 == pytest.approx(residual, abs=2e-3 + 1e-6 / abs(e0)), (d, i)


def test_linear_band_is_its_float64_root():
    s = _comp(YUAN, shape=0)
    worst = 0.0
    for d in DUTIES:
        for i in _currents(YUAN.i_band_a):
            want = compensated_duty(linear_leg, YUAN, d, i)
            worst = max(worst, abs(lib.inv_comp_leg_duty(s, d, i, YUAN.v_dc_v, ffi.NULL) - want))
            assert abs(lib.inv_comp_leg_voltage(s, d, i, YUAN.v_dc_v) - linear_leg(YUAN, d, i)) < 3e-4
    assert worst < 1e-6, worst


def test_step_observer_voltage_and_off_legs():
    s = _comp(YUAN)
    duty = ffi.new("float[3]", [0.5, 0.62, 0.38])
    cur = ffi.new("float[3]", [2.0, -0.05, -1.95])
    v = lib.inv_comp_step(s, duty, cur, 310.0)
    # nothing clamped: the model's voltage of the compensated duties is the command's
    want = [310.0 * x for x in (0.5, 0.62, 0.38)]
    assert v.x == pytest.approx((2 * want[0] - want[1] - want[2]) / 3, abs=1e-3)
    assert v.y == pytest.approx((want[1] - want[2]) / math.sqrt(3), abs=1e-3)
    assert s.clamped == 0
    assert s.duty_abc[0] > 0.5 and s.duty_abc[2] < 0.38   # i > 0 loses the dead interval
    for k in range(3):
        assert s.v_err_abc_v[k] == pytest.approx(
            plant_leg(YUAN, s.duty_abc[k], cur[k]) - s.duty_abc[k] * 310.0, abs=3e-4)
    # a leg OFF passes through, and the model claims no voltage
    duty[1] = -1.0
    v = lib.inv_comp_step(s, duty, cur, 310.0)
    assert s.duty_abc[1] == -1.0 and v.x == 0.0 and v.y == 0.0
    # a command beyond the leg's reach is clamped and flagged
    duty[1], duty[0] = 0.5, 0.999
    lib.inv_comp_step(s, duty, cur, 310.0)
    assert s.clamped == 1 and s.duty_abc[0] == 1.0


def test_prediction_and_bad_configuration():
    out = ffi.new("float[3]")
    lib.inv_comp_predict(ffi.new("float[3]", [1.0, -2.0, 1.0]), ffi.new("float[3]", [0.8, -2.2, 1.4]),
                         0.84, out)
    assert list(out) == pytest.approx([1.168, -1.832, 0.664], abs=1e-6)
    cfg = ffi.new("inv_comp_config_t *")
    s = ffi.new("inv_comp_t *")
    for field, bad in (("dead_time_s", 5e-5), ("dead_time_s", -1e-9), ("v_switch_v", -0.1),
                       ("i_band_a", 0.0), ("shape", 2), ("ts_s", 0.0), ("r_diode_ohm", math.nan)):
        lib.inv_comp_default_config(cfg, 1e-4)
        setattr(cfg, field, bad)
        assert lib.inv_comp_init(s, cfg) == -1, field
