"""The inverter-error feed-forward in float64, solved numerically against an inverter model.

Independent of firmware_stub/src/inv_comp.c: the compensated duty is the root d' of
    v_leg(d', i) = d V_dc
found by ``scipy.optimize.brentq`` on a forward leg model, with no closed form. Two forward
models:

* ``plant_leg``: the plant's own averaged leg in float64 (hil_bench.plant_rt.verify.reference.
  leg_average, written from the conduction intervals by the plant's reference, not from the
  firmware): the truth the compensation is meant to cancel (capacitive zero-crossing shape);
* ``linear_leg``: the same leg with the linear zero-crossing band (g = q = clamp(i / band)), the
  other shape the firmware offers, written here from its definition in docs/inverter_comp.md.

Where no d' in [0, 1] reaches the command (a leg at its limit), the nearer end is the answer.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace

from scipy.optimize import brentq

from hil_bench.plant_rt.verify.reference import RefParams, leg_average


@dataclass(frozen=True)
class Inverter:
    """One set of leg parameters: the plant's truth or a drive's estimate of it."""

    v_dc_v: float
    ts_s: float
    dead_time_s: float
    v_switch_v: float
    r_switch_ohm: float
    v_diode_v: float
    r_diode_ohm: float
    i_band_a: float

    def scaled(self, factor: float) -> "Inverter":
        """Dead time and every drop times ``factor`` (a drive's estimate with a residual
        1 - factor); the band is kept."""
        return replace(self, dead_time_s=self.dead_time_s * factor,
                       v_switch_v=self.v_switch_v * factor, r_switch_ohm=self.r_switch_ohm * factor,
                       v_diode_v=self.v_diode_v * factor, r_diode_ohm=self.r_diode_ohm * factor)

    def ref_params(self) -> RefParams:
        return RefParams(rs_ohm=1.0, ld_h=1e-3, lq_h=1e-3, psi_f_wb=0.1, pole_pairs=1, j_kgm2=1.0,
                         b_nms=0.0, v_dc_v=self.v_dc_v, ts_s=self.ts_s, t_delay_s=0.0,
                         inverter_nonlinear=True, dead_time_s=self.dead_time_s,
                         v_switch_drop_v=self.v_switch_v, r_switch_ohm=self.r_switch_ohm,
                         v_diode_drop_v=self.v_diode_v, r_diode_ohm=self.r_diode_ohm,
                         i_cap_band_a=self.i_band_a)


def plant_leg(inv: Inverter, duty: float, i_a: float) -> float:
    """Average pole voltage of the plant's leg model [V]."""
    return leg_average(inv.ref_params(), duty, i_a)[0]


def linear_leg(inv: Inverter, duty: float, i_a: float) -> float:
    """Average pole voltage with the linear zero-crossing band [V]."""
    d = inv.dead_time_s / inv.ts_s
    x = min(abs(i_a) / inv.i_band_a, 1.0)
    g = math.copysign(x, i_a) if i_a != 0.0 else 0.0
    lo, hi = min(max(duty - d, 0.0), 1.0), min(max(duty + d, 0.0), 1.0)
    share = 0.5 * (1.0 + g)
    plus_rail = share * lo + (1.0 - share) * hi
    vs = inv.v_switch_v * x + inv.r_switch_ohm * abs(i_a)
    vd = inv.v_diode_v * x + inv.r_diode_ohm * abs(i_a)
    if i_a > 0.0:
        drop = lo * vs + (1.0 - lo) * vd
    elif i_a < 0.0:
        drop = -(hi * vd + (1.0 - hi) * vs)
    else:
        drop = 0.0
    return plus_rail * inv.v_dc_v - drop


def compensated_duty(leg, inv: Inverter, duty: float, i_a: float) -> float:
    """The duty d' in [0, 1] with leg(inv, d', i) = duty V_dc (bracketed root, xtol 1e-14)."""
    target = duty * inv.v_dc_v

    def f(x: float) -> float:
        return leg(inv, x, i_a) - target

    lo, hi = f(0.0), f(1.0)
    if lo >= 0.0:
        return 0.0
    if hi <= 0.0:
        return 1.0
    return brentq(f, 0.0, 1.0, xtol=1e-14, rtol=1e-15)
