"""What makes the HF current differ between N and S alignment (Hou et al., section 3).

    .venv/bin/python -m hil_bench.plant_rt.verify.saturation_study [--profile hou2021]

Hou et al. inject a rotating HF voltage (1250 Hz, 6 V) at standstill and identify the N pole as
the direction in which the induced HF current vector is largest. With the linear model the
current ellipse is symmetric (+d and -d peaks equal): the polarity is invisible. With the
d-axis saturation of plant_rt/c/pmsm_machine.h (L_inc falls for i_d > 0) the flux swing
psi_h = U / w_h drives a larger current towards N (i_d > 0, the iron saturates further) than
towards S. This script measures, on the C plant at standstill (dynamometer at 0 rpm: the rotor
cannot move):

  * no bias: the d-current peaks towards N and S of the HF response. The asymmetry is SECOND
    order in the HF amplitude: (i_N - i_S) / I_h ~= (|dL/di| / L)(0) * I_h / 2 (the 1/2:
    in steady state the resistance forces a zero MEAN current, so the flux swing is not centred
    on psi_f and half the asymmetry goes into that shift), i.e. ~0.7 % for the 0.3 A HF
    current: ~2 mA, below half an LSB of a +-10 A 12-bit ADC: Hou's amplitude comparison needs
    averaging over many HF cycles (the SDFT does that) or a larger HF current;
  * with a d-current bias +-I_b (the "pulse" variant: a DC d current towards N, then towards S),
    the HF amplitude itself changes to first order, U / (w L_inc(+-I_b)): ratio
    L_inc(-I_b) / L_inc(+I_b), ~1.2 at half rated current.
Peaks are measured with a fine control period (Ts / 16, t_delay 0: 128 samples per HF cycle)
so they are the waveform's, and also at the profile's 10 kHz (8 samples per cycle: what the
controller's ADC sees, phase dependent).
"""
from __future__ import annotations

import argparse
import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import brentq

from hil_bench.plant_rt.plant import Plant
from hil_bench.plant_rt.profile import MotorProfile, load_profile

from . import reference
from .openloop import duties_from_alphabeta

HOU_U_V = 6.0
HOU_F_HZ = 1250.0


@dataclass
class HfPeaks:
    i_n_a: float        # largest d current towards N (i_d > 0) [A]
    i_s_a: float        # largest d current towards S (-i_d) [A]
    i_mean_a: float     # mean d current (bias + rectification) [A]
    amplitude_a: float  # half the peak-to-peak HF d current [A]

    @property
    def ratio_ns(self) -> float:
        return self.i_n_a / self.i_s_a


def hf_response(prof: MotorProfile, *, bias_a: float = 0.0, theta_e_rad: float = 0.0,
                u_v: float = HOU_U_V, f_hz: float = HOU_F_HZ, fine: int = 16,
                cycles: int = 20, settle_s: float = 0.06) -> HfPeaks:
    """Rotating HF injection u_d = U sin(w t), u_q = U cos(w t) in the rotor frame (aligned
    estimate), standstill, optional d-current bias from a DC d voltage R * bias."""
    ts = prof.ts_s / fine
    plant = Plant(prof, saturation=True, ts_s=ts, t_delay_s=0.0, dyno=True, dyno_speed_rad_s=0.0)
    plant.set_initial(theta_e_rad, 0.0)
    n_settle = int(round(settle_s / ts))
    n_cyc = int(round(cycles / f_hz / ts))
    k = np.arange(n_settle + n_cyc)
    t_mid = (k + 0.5) * ts  # the vector of period k acts over [t_k, t_k + Ts]: its middle
    w = 2.0 * math.pi * f_hz
    # average of U sin / U cos over the period (exact for the averaged inverter)
    gain = math.sin(0.5 * w * ts) / (0.5 * w * ts)
    v_d = prof.rs_ohm * bias_a + gain * u_v * np.sin(w * t_mid)
    v_q = gain * u_v * np.cos(w * t_mid)
    c, s = math.cos(theta_e_rad), math.sin(theta_e_rad)
    duties = duties_from_alphabeta(v_d * c - v_q * s, v_d * s + v_q * c, prof.v_dc_v)
    out = plant.run(duties)
    i_d = out["i_d_a"][n_settle:]
    mean = float(i_d.mean())
    return HfPeaks(float(i_d.max()), float(-i_d.min()), mean, 0.5 * float(i_d.max() - i_d.min()))


def quasi_static(prof: MotorProfile, bias_a: float = 0.0, u_v: float = HOU_U_V,
                 f_hz: float = HOU_F_HZ, n: int = 4096) -> tuple[float, float]:
    """d-current excursions towards N and S from the flux curve alone: the flux swings
    sinusoidally by +-U/w around a centre that, in steady state, makes the MEAN current equal
    to the bias (the resistance allows no DC voltage beyond R * bias). Resistive drop of the
    HF current neglected. Independent of the plant's integration (root finding on psi_d)."""
    p = reference.RefParams.of(dict(prof.plant_params(), saturation=True))
    dpsi = u_v / (2.0 * math.pi * f_hz)
    phase = np.sin(2.0 * math.pi * (np.arange(n) + 0.5) / n)

    def currents(centre: float) -> np.ndarray:
        return np.array([reference.i_d_of_psi(p, centre + dpsi * s, bias_a) for s in phase])

    psi0 = reference.psi_d_curve(p, bias_a)
    centre = brentq(lambda c: currents(c).mean() - bias_a, psi0 - dpsi, psi0 + dpsi, xtol=1e-15)
    i = currents(centre)
    return float(i.max() - bias_a), float(bias_a - i.min())


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--profile", default="hou2021")
    args = ap.parse_args()
    prof = load_profile(args.profile)
    p = reference.RefParams.of(dict(prof.plant_params(), saturation=True))
    ir = prof.rated["current_a"]
    print(f"profile {prof.name}: L_inc(0) = {reference.ld_inc_curve(p, 0.0) * 1e3:.4f} mH (Ld "
          f"{prof.ld_h * 1e3:.4f}), L_inc(+{ir:.2f} A) / Ld = {reference.ld_inc_curve(p, ir) / prof.ld_h:.3f}, "
          f"L_inc(-{ir:.2f} A) / Ld = {reference.ld_inc_curve(p, -ir) / prof.ld_h:.3f}")
    qs_n, qs_s = quasi_static(prof)
    print(f"quasi-static (flux curve only, zero mean current): towards N {qs_n:.4f} A, "
          f"towards S {qs_s:.4f} A, N/S {qs_n / qs_s:.4f}")
    for label, fine in (("fine (128 samples/cycle)", 16), (f"at {1 / prof.ts_s / 1e3:.0f} kHz (8 samples/cycle)", 1)):
        for theta in (0.0, math.pi):
            r = hf_response(prof, fine=fine, theta_e_rad=theta)
            print(f"no bias, rotor at {math.degrees(theta):3.0f} deg, {label}: towards N {r.i_n_a:.4f} A, "
                  f"towards S {r.i_s_a:.4f} A, N/S {r.ratio_ns:.4f}, mean {r.i_mean_a * 1e3:.2f} mA")
    for b in (0.5 * ir, ir):
        pos = hf_response(prof, bias_a=b)
        neg = hf_response(prof, bias_a=-b)
        print(f"bias +-{b:.2f} A: HF amplitude {pos.amplitude_a:.4f} A (towards N) vs {neg.amplitude_a:.4f} A "
              f"(towards S): ratio {pos.amplitude_a / neg.amplitude_a:.3f} "
              f"(L_inc(-b)/L_inc(+b) = {reference.ld_inc_curve(p, -b) / reference.ld_inc_curve(p, b):.3f})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
