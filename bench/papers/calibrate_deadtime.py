"""Closed-loop calibration of the inverter non-linearity against Yuan et al.'s THD (claim Y4).

    .venv/bin/python -m hil_bench.papers.calibrate_deadtime               # the calibrated point
    .venv/bin/python -m hil_bench.papers.calibrate_deadtime --sweep       # THD vs dead time and load
    .venv/bin/python -m hil_bench.papers.calibrate_deadtime --fit         # solve dead_time_s for 8.06 %

Yuan et al. (IEEE Access 2020, section III.A, Fig. 2, and IV.C, Fig. 18) report the phase-a
current spectrum at 10 rpm WITHOUT inverter-nonlinearity compensation: 5th 4.08 %, 7th 4.11 %,
THD 8.06 % (and 7.03 % at 50 rpm). The harmonics come from the inverter, so this harness closes
the loop with the TRUE rotor angle and speed (an ideal encoder): the estimator plays no part.

Controller (a Python copy of the firmware stub's defaults, firmware_stub/src/controller.c):
  * current loop: PI on d and q, bandwidth wc = 2 pi / (20 Ts) (500 Hz at 10 kHz),
    kp_q = Lq wc, kp_d = Ld wc, ki = Rs wc, decoupling feed-forward
    v_d += -w_e Lq i_q, v_q += w_e (Ld i_d + psi_f), circular limit 0.98 V_dc / sqrt(3);
  * speed loop every period: kp = J w_s / k_t, ki = kp w_s / 4, w_s = 62.83 rad/s;
  * currents from plant.sample() at t_k (ADC off here: exact), angle advanced by w_e Ts/2 for
    the voltage (it acts from t_k + t_d over the period), min-max (SVPWM) duties on the nominal
    bus; no dead-time compensation.
THD: hil_bench.papers.metrics.locked_spectrum of the plant's true phase-a current sampled at t_k
(least squares on its true angle), over
the last ``periods`` whole fundamental periods (harmonics 2..50).
"""
from __future__ import annotations

import argparse
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from hil_bench.plant_rt.plant import Plant
from hil_bench.plant_rt.profile import MotorProfile, load_profile

from .metrics import locked_spectrum

RPM = 2.0 * math.pi / 60.0
S3 = math.sqrt(3.0)

#: Yuan et al., section III.A / IV.C: phase-current spectrum without compensation
YUAN_10RPM = {"thd_pct": 8.06, "h5_pct": 4.08, "h7_pct": 4.11}
YUAN_50RPM = {"thd_pct": 7.03, "h5_pct": 4.62, "h7_pct": 4.36}

#: The calibration operating point (see plant_rt/README.md "Calibration of the Yuan profile")
CAL_RPM = 10.0
CAL_LOAD_NM = 0.5                      # 10 % of the assumed rated 5 N m
CAL_CUR_BW_RAD_S = 2.0 * math.pi * 50  # current-loop bandwidth of the calibration loop
CAL_SETTLE_S = 0.6
CAL_PERIODS = 2
STUB_CUR_BW_RAD_S = None               # None: the stub's default 2 pi / (20 Ts)


@dataclass
class FocGains:
    kp_d: float
    kp_q: float
    ki_dq: float
    kp_w: float
    ki_w: float
    v_max: float
    iq_max: float


def stub_gains(prof: Any, v_dc_v: float, iq_max_a: float,
               cur_bw_rad_s: float | None = None) -> FocGains:
    """The firmware stub's gains for a profile (controller.c ctrl_start): kp_q = Lq wc,
    kp_d = Ld wc, ki = Rs wc with wc = cur_bw_rad_s (default 2 pi / (20 Ts))."""
    wc = cur_bw_rad_s if cur_bw_rad_s is not None else 2.0 * math.pi / (20.0 * prof.ts_s)
    kt = 1.5 * prof.pole_pairs * prof.psi_f_wb
    ws = 62.83
    kp_w = prof.j_kgm2 * ws / kt
    return FocGains(kp_d=prof.ld_h * wc, kp_q=prof.lq_h * wc, ki_dq=prof.rs_ohm * wc,
                    kp_w=kp_w, ki_w=kp_w * ws * 0.25, v_max=0.98 * v_dc_v / S3, iq_max=iq_max_a)


class _Pi:
    def __init__(self, kp: float, ki: float, lim: float):
        self.kp, self.ki, self.lim, self.integ = kp, ki, lim, 0.0

    def step(self, err: float, ts: float, lo: float | None = None, hi: float | None = None) -> float:
        lo = -self.lim if lo is None else lo
        hi = self.lim if hi is None else hi
        nxt = self.integ + self.ki * ts * err
        u = self.kp * err + nxt
        if u > hi:
            u = hi
            if err < 0.0:
                self.integ = nxt
        elif u < lo:
            u = lo
            if err > 0.0:
                self.integ = nxt
        else:
            self.integ = nxt
        self.integ = min(max(self.integ, lo), hi)
        return u


def duties_min_max(v_alpha: float, v_beta: float, v_dc: float) -> tuple[float, float, float]:
    va = v_alpha
    vb = -0.5 * v_alpha + 0.5 * S3 * v_beta
    vc = -0.5 * v_alpha - 0.5 * S3 * v_beta
    cm = 0.5 * (max(va, vb, vc) + min(va, vb, vc))
    return tuple(min(max(0.5 + (v - cm) / v_dc, 0.0), 1.0) for v in (va, vb, vc))  # type: ignore[return-value]


def run_foc(plant: Plant, speed_ref_rad_s: float, n_periods: int, *, load_nm: float = 0.0,
            iq_max_a: float | None = None, id_ref_a: float = 0.0,
            cur_bw_rad_s: float | None = None) -> np.ndarray:
    """Ideal-encoder FOC of the stub's design for n_periods; returns the true phase currents
    (n, 3) at the sampling instants t_1 .. t_n, the speed and the true electrical angle at the
    same instants as a (n, 5) array."""
    prof = plant.params
    g = stub_gains(prof, prof.v_dc_v,
                   iq_max_a if iq_max_a is not None else 3.0 * plant.profile.rated["current_a"],
                   cur_bw_rad_s)
    kt = 1.5 * prof.pole_pairs * prof.psi_f_wb
    pi_d = _Pi(g.kp_d, g.ki_dq, g.v_max)
    pi_q = _Pi(g.kp_q, g.ki_dq, g.v_max)
    pi_w = _Pi(g.kp_w, g.ki_w, g.iq_max)
    pi_w.integ = (load_nm + prof.b_nms * speed_ref_rad_s) / kt  # start near the operating point
    plant.set_initial(0.3, speed_ref_rad_s)
    plant.set_load_torque(load_nm)
    ts, p, vdc = prof.ts_s, prof.pole_pairs, prof.v_dc_v
    out = np.empty((n_periods, 5))
    for k in range(n_periods):
        m = plant.sample()
        s = plant.snapshot()  # ideal encoder: true angle and speed at t_k
        th, we = s.theta_e_rad, s.omega_e_rad_s
        ia, ib = m.i_a_a, m.i_b_a
        ial = ia
        ibe = (ia + 2.0 * ib) / S3
        c, sn = math.cos(th), math.sin(th)
        i_d = ial * c + ibe * sn
        i_q = -ial * sn + ibe * c
        iq_ref = pi_w.step(speed_ref_rad_s - s.omega_m_rad_s, ts)
        ff_d = -we * prof.lq_h * i_q
        ff_q = we * (prof.ld_h * i_d + prof.psi_f_wb)
        v_d = pi_d.step(id_ref_a - i_d, ts, -g.v_max - ff_d, g.v_max - ff_d) + ff_d
        vq_lim = math.sqrt(max(g.v_max ** 2 - v_d ** 2, 0.0))
        v_q = pi_q.step(iq_ref - i_q, ts, -vq_lim - ff_q, vq_lim - ff_q) + ff_q
        thp = th + we * 0.5 * ts
        c, sn = math.cos(thp), math.sin(thp)
        plant.step(*duties_min_max(v_d * c - v_q * sn, v_d * sn + v_q * c, vdc))
        s = plant.snapshot()
        out[k] = (s.i_a_a, s.i_b_a, s.i_c_a, s.omega_m_rad_s, s.theta_e_rad)
    return out


@dataclass
class ThdResult:
    rpm: float
    load_nm: float
    cur_bw_rad_s: float | None
    thd_pct: float
    h5_pct: float
    h7_pct: float
    fundamental_a: float
    speed_ripple_rpm: float


def measure_thd(prof: MotorProfile, rpm: float, load_nm: float, *, settle_s: float = CAL_SETTLE_S,
                periods: int = CAL_PERIODS, cur_bw_rad_s: float | None = CAL_CUR_BW_RAD_S,
                **overrides: Any) -> ThdResult:
    """Phase-a current THD of the ideal-encoder FOC at rpm with a constant load torque."""
    plant = Plant(prof, **overrides)
    f1 = rpm / 60.0 * prof.pole_pairs
    n = int(round((settle_s + periods / f1) / prof.ts_s))
    rec = run_foc(plant, rpm * RPM, n, load_nm=load_nm, cur_bw_rad_s=cur_bw_rad_s)
    n_win = int(round(periods / f1 / prof.ts_s))
    spec = locked_spectrum(rec[-n_win:, 0], rec[-n_win:, 4], 1.0 / prof.ts_s)
    h = spec.harmonics
    fund = spec.fundamental_amplitude
    speed = rec[-n_win:, 3] / RPM
    return ThdResult(rpm, load_nm, cur_bw_rad_s, spec.thd_percent, spec.harmonic_percent(5), spec.harmonic_percent(7), fund,
                     float(speed.max() - speed.min()))


def calibrated_overrides(prof: MotorProfile) -> dict[str, Any]:
    """The profile's own inverter values, switched on."""
    return {"inverter_nonlinear": True}


def fit_dead_time(prof: MotorProfile, target_pct: float = YUAN_10RPM["thd_pct"], *,
                  rpm: float = CAL_RPM, load_nm: float = CAL_LOAD_NM,
                  lo_s: float = 0.5e-6, hi_s: float = 6e-6, **overrides: Any) -> tuple[float, ThdResult]:
    """Dead time [s] that gives target_pct THD (bisection; THD rises with the dead time)."""
    res = None
    for _ in range(14):
        mid = 0.5 * (lo_s + hi_s)
        res = measure_thd(prof, rpm, load_nm, inverter_nonlinear=True, dead_time_s=mid, **overrides)
        if res.thd_pct < target_pct:
            lo_s = mid
        else:
            hi_s = mid
    return 0.5 * (lo_s + hi_s), res  # type: ignore[return-value]


def _fmt(r: ThdResult) -> str:
    bw = "stub default" if r.cur_bw_rad_s is None else f"{r.cur_bw_rad_s / (2 * math.pi):.0f} Hz"
    return (f"{r.rpm:5.1f} rpm  load {r.load_nm:4.2f} N m  loop {bw:>12}  I1 {r.fundamental_a:6.3f} A  "
            f"THD {r.thd_pct:6.2f} %  5th {r.h5_pct:5.2f} %  7th {r.h7_pct:5.2f} %  "
            f"speed ripple {r.speed_ripple_rpm:.3f} rpm p-p")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--profile", default="yuan2020")
    ap.add_argument("--load", type=float, default=CAL_LOAD_NM, help="load torque [N m]")
    ap.add_argument("--sweep", action="store_true", help="THD vs dead time and load")
    ap.add_argument("--fit", action="store_true", help="solve dead_time_s for Yuan's 8.06 %%")
    args = ap.parse_args()
    prof = load_profile(args.profile)
    if args.sweep:
        for bw in (None, 2 * math.pi * 200, 2 * math.pi * 100, CAL_CUR_BW_RAD_S):
            for load in (0.25, 0.5, 5.0):
                for dt in (1e-6, 2e-6, 3e-6):
                    r = measure_thd(prof, CAL_RPM, load, inverter_nonlinear=True, dead_time_s=dt,
                                    cur_bw_rad_s=bw)
                    print(f"dead {dt * 1e6:.1f} us  " + _fmt(r))
        return 0
    if args.fit:
        dt, r = fit_dead_time(prof, load_nm=args.load)
        print(f"dead_time_s = {dt:.4g}  ->  " + _fmt(r))
        return 0
    print(f"profile {prof.name}: dead {prof.dead_time_s * 1e6:.3g} us, drops {prof.v_switch_drop_v} / "
          f"{prof.v_diode_drop_v} V, i_cap_band {prof.i_cap_band_a} A")
    g = stub_gains(prof, prof.v_dc_v, 0.0, CAL_CUR_BW_RAD_S)
    print(f"calibration loop: current bandwidth {CAL_CUR_BW_RAD_S / (2 * math.pi):.0f} Hz -> stub "
          f"CUR_KP_V_A = {g.kp_q:.4g}, CUR_KI_V_AS = {g.ki_dq:.4g}; load {args.load} N m")
    for rpm, paper in ((CAL_RPM, YUAN_10RPM), (50.0, YUAN_50RPM)):
        ideal = measure_thd(prof, rpm, args.load)
        r = measure_thd(prof, rpm, args.load, **calibrated_overrides(prof))
        stub = measure_thd(prof, rpm, args.load, cur_bw_rad_s=STUB_CUR_BW_RAD_S,
                           **calibrated_overrides(prof))
        print("ideal inverter          " + _fmt(ideal))
        print("non-linear              " + _fmt(r))
        print("non-linear, stub loop   " + _fmt(stub))
        print(f"Yuan et al.             THD {paper['thd_pct']:.2f} %  5th {paper['h5_pct']:.2f} %  "
              f"7th {paper['h7_pct']:.2f} %")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
