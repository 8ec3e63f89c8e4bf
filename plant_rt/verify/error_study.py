"""Measure the plant's RK4 global error against the solve_ivp reference, vs substeps.

    .venv/bin/python -m hil_bench.plant_rt.verify.error_study [--periods N] [--substeps 1,2,4,8] [profiles...]
    .venv/bin/python -m hil_bench.plant_rt.verify.error_study --switching [--nonlinear] --periods 100

Scenario per profile (the hardest case the bench should meet: the highest electrical frequency
with rated-level currents and a full transient):
  * rotor at 2x rated mechanical speed, theta_e(0) = 0, zero initial currents;
  * a rotor-synchronous voltage vector for the operating point i_d = 0, i_q = rated current
    (hil_bench.plant_rt.verify.openloop.synchronous), switched on at t = 0 (the plant holds its initial 0.5 duties
    for the first t_delay, i.e. a short circuit) -> an electrical transient at omega_e that
    decays with L/R, then the operating point;
  * a load torque that balances the operating-point torque and friction (speed ~ constant);
  * V_dc raised, where the profile's bus is too low for that voltage in the linear modulation
    range, to sqrt(3) |v| / 0.9 (the integrator error depends on omega_e h, L, R and the currents,
    not on V_dc itself); the table prints the V_dc used;
  * N periods (default 500 = 50 ms); errors are maxima over all sampling instants.

Error columns: max |i_abc - i_abc_ref| [A], the same relative to rated current, max speed error
[rad/s], max electrical-angle error [rad]. The reference itself (DOP853, rtol 1e-10) is checked
by integrating it twice, in the stationary flux-linkage and the dq current formulation.

--switching: the plant's switching inverter mode against the switch-level reference
(switching_ref.py, solve_ivp restarted at every switching instant), same scenario (the currents
compared at the period starts, the carrier valleys); --nonlinear adds the profile's dead time,
drops and node capacitance (to both).
"""
from __future__ import annotations

import argparse
import math
from dataclasses import dataclass

import numpy as np

from hil_bench.plant_rt.plant import Plant
from hil_bench.plant_rt.profile import MotorProfile, load_profile

from . import openloop, reference, switching_ref

PROFILES = ("gong2020", "hou2021", "yuan2020")
SUBSTEPS = (1, 2, 3, 4, 6, 8, 16)


@dataclass
class Scenario:
    profile: MotorProfile
    overrides: dict
    duties: np.ndarray
    omega_m0: float
    load_nm: float
    ref: reference.ReferenceResult | switching_ref.SwitchingResult
    ref_frame_diff_a: float


def build_scenario(profile: MotorProfile, periods: int, t_delay_s: float | None = None,
                   switching: bool = False, nonlinear: bool = False) -> Scenario:
    """The 2x-rated-speed scenario for a profile (optionally with another computation delay; on
    the switching inverter, with its non-linearity)."""
    r = profile.rated
    w_m = 2.0 * r["speed_rad_s"]
    w_e = profile.pole_pairs * w_m
    i_q = r["current_a"]
    v_d, v_q = openloop.operating_point_voltage(profile, w_e, 0.0, i_q)
    v_dc = max(profile.v_dc_v, math.sqrt(3.0) * math.hypot(v_d, v_q) / 0.9)
    overrides = {"v_dc_v": v_dc}
    if t_delay_s is not None:
        overrides["t_delay_s"] = t_delay_s
    if switching:
        overrides["inverter"] = "switching"
    if nonlinear:
        overrides["inverter_nonlinear"] = True
    params = dict(profile.plant_params(), **overrides)
    p = _Obj(params)
    duties = openloop.synchronous(p, periods, theta_e0_rad=0.0, omega_e_rad_s=w_e, v_d_v=v_d, v_q_v=v_q)
    torque = 1.5 * profile.pole_pairs * profile.psi_f_wb * i_q
    load = torque - profile.b_nms * w_m
    if switching:
        ref = switching_ref.simulate(params, duties, omega_m0=w_m, load_torque_nm=load, options=params)
        return Scenario(profile, overrides, duties, w_m, load, ref, math.nan)
    ref = reference.simulate(params, duties, omega_m0=w_m, load_torque_nm=load)
    ref_dq = reference.simulate(params, duties, omega_m0=w_m, load_torque_nm=load, frame="dq")
    diff = float(np.abs(ref.i_abc_a - ref_dq.i_abc_a).max())
    return Scenario(profile, overrides, duties, w_m, load, ref, diff)


class _Obj:
    def __init__(self, d: dict):
        self.__dict__.update(d)


def plant_errors(sc: Scenario, substeps: int) -> dict[str, float]:
    """Max errors of the C plant (with this substeps) against the scenario's reference."""
    plant = Plant(sc.profile, substeps=substeps, **sc.overrides)
    plant.set_initial(0.0, sc.omega_m0)
    plant.set_load_torque(sc.load_nm)
    out = plant.run(sc.duties)
    return compare(out, sc.ref, sc.profile.rated["current_a"])


def compare(out: np.ndarray, ref: reference.ReferenceResult | switching_ref.SwitchingResult,
            rated_current_a: float) -> dict[str, float]:
    """Max abs errors between plant snapshots (after each period) and the reference."""
    i_c = np.stack([out["i_a_a"], out["i_b_a"], out["i_c_a"]], axis=-1)
    e_i = float(np.abs(i_c - ref.i_abc_a[1:]).max())
    e_w = float(np.abs(out["omega_m_rad_s"] - ref.omega_m_rad_s[1:]).max())
    e_th = float(np.abs(np.angle(np.exp(1j * (out["theta_e_rad"] - ref.theta_e_rad[1:])))).max())
    e_thm = (float(np.abs(out["theta_m_rad"] - ref.theta_m_rad[1:]).max())
             if hasattr(ref, "theta_m_rad") else math.nan)
    return {"current_a": e_i, "current_rel": e_i / rated_current_a, "speed_rad_s": e_w,
            "theta_e_rad": e_th, "theta_m_rad": e_thm}


def report_case(prof: MotorProfile, delay: float | None, periods: int, steps: list[int],
                worst: dict[int, float], switching: bool = False, nonlinear: bool = False) -> None:
    """Print one profile/delay block of the table; update worst[substeps] (relative error)."""
    sc = build_scenario(prof, periods, delay, switching, nonlinear)
    peak = float(np.abs(sc.ref.i_abc_a).max())
    t_delay = prof.t_delay_s if delay is None else delay
    w_e = prof.pole_pairs * sc.omega_m0
    print(f"\n{prof.name}: omega_m {sc.omega_m0:.1f} rad/s (2x rated), omega_e {w_e:.0f} rad/s, "
          f"omega_e*Ts {w_e * prof.ts_s:.3f}, V_dc {sc.overrides['v_dc_v']:.0f} V, "
          f"t_delay {t_delay * 1e6:.1f} us, rated current {prof.rated['current_a']} A, "
          f"peak |i| {peak:.2f} A" + ("" if switching else
                                      f", reference alphabeta-vs-dq {sc.ref_frame_diff_a:.1e} A")
          + (f", switching inverter{' with dead time and drops' if nonlinear else ''}"
             if switching else ""))
    print(f"  {'substeps':>8} {'max|di| [A]':>12} {'/rated':>9} {'max|dw| [rad/s]':>16} "
          f"{'max|dth_e| [rad]':>17}")
    for n in steps:
        e = plant_errors(sc, n)
        worst[n] = max(worst.get(n, 0.0), e["current_rel"])
        print(f"  {n:>8} {e['current_a']:>12.3e} {e['current_rel']:>9.2e} "
              f"{e['speed_rad_s']:>16.3e} {e['theta_e_rad']:>17.3e}")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("profiles", nargs="*", default=list(PROFILES))
    ap.add_argument("--periods", type=int, default=500)
    ap.add_argument("--substeps", default=",".join(map(str, SUBSTEPS)))
    ap.add_argument("--delays", default="profile,0",
                    help="computation delays to run, comma-separated: 'profile' and/or seconds "
                         "(0 gives the longest RK4 steps, h = Ts/substeps)")
    ap.add_argument("--switching", action="store_true",
                    help="the switching inverter mode against switching_ref.py")
    ap.add_argument("--nonlinear", action="store_true",
                    help="with --switching: the profile's dead time, drops and node capacitance on")
    args = ap.parse_args()
    steps = [int(s) for s in args.substeps.split(",")]
    delays = [None if d == "profile" else float(d) for d in args.delays.split(",")]
    worst: dict[int, float] = {}
    for name in args.profiles:
        prof = load_profile(name)
        for delay in delays:
            report_case(prof, delay, args.periods, steps, worst, args.switching, args.nonlinear)
    print("\nworst relative current error (all profiles and delays above):")
    for n in steps:
        flag = "  < 1e-4" if worst[n] < 1e-4 else ""
        print(f"  substeps {n:>3}: {worst[n]:.2e}{flag}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
