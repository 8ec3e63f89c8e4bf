#!/usr/bin/env python3
"""Hou's HF-only polarity test (claim H3) under the drive's inverter compensation, measured in one
process: the control ISR (firmware_stub/src/controller.c through hil_bench.firmware_stub._fw_c)
and the C plant (plant_rt) close the loop on scenario hou_h3_ipd with the controller parameters
the runner would send (Runner.controller_params), cycle by cycle as the lockstep link does, ~100x
faster than a run through the link. docs/inverter_comp.md ("HF injection at standstill") quotes
its tables.

    .venv/bin/python tools/h3_polarity_study.py                  # residual x angle x ADC seed
    .venv/bin/python tools/h3_polarity_study.py --voltage        # the error the compensation
                                                                 # leaves at the injection frequency
    .venv/bin/python tools/h3_polarity_study.py --residuals 0,0.05 --angles 0,135,180 --seeds 1

Per run: "ok" / "WRONG" (polarity, from the final angle error), the final error in degrees
and how long the polarity test ran; "FAIL@t" where the controller faulted (STARTUP_FAILED:
undecided), with the test's last r.
"""
from __future__ import annotations

import argparse
import math

import numpy as np

from hil_bench.firmware_stub import _fw_c as fw
from hil_bench.loop.runner import Runner
from hil_bench.scenario import derive_scenario

ffi, lib = fw.ffi, fw.lib
STATE_FAULT = 4
IPD_POLARITY = 2


def run(angle_deg: float, residual: float, seed: int, t_end_s: float, plant: dict | None = None,
        trace: bool = False):
    """One start from angle_deg. Returns (outcome dict, trace dict of arrays or None)."""
    ov = [("plant.initial_theta_e_rad", math.radians(angle_deg)),
          ("controller.inverter_comp.residual", residual), ("plant.adc_seed", seed)]
    ov += list((plant or {}).items())
    scn = derive_scenario("hou_h3_ipd", f"study_{angle_deg}", tuple(ov))
    r = Runner(scn)
    pl = r.plant
    pl.set_initial(scn.initial_theta_e_rad, scn.initial_speed_rad_s)
    c = ffi.new("controller_t *")
    lib.ctrl_init(c)
    c.cfg.estimator = float(int(scn.estimator))
    for p, v in r.controller_params().items():
        if lib.ctrl_param_set(ffi.addressof(c.cfg), int(p), float(v)) != 0:
            raise SystemExit(f"parameter {p.name} = {v} refused")
    if lib.ctrl_start(c) != 0:
        raise SystemExit("ctrl_start refused the configuration")
    lib.ctrl_set_speed_ref(c, 0.0)
    smp = ffi.new("ctrl_sample_t *")
    tr = {k: [] for k in ("ipd", "v_obs", "v_plant")} if trace else None
    out, h = None, ffi.NULL
    for k in range(int(round(t_end_s / r.ts_s))):
        m = pl.sample()
        smp.i_a_a, smp.i_b_a, smp.i_c_a = m.i_a_a, m.i_b_a, m.i_c_a
        smp.v_dc_v, smp.v_dc_valid = m.v_dc_v, 1
        out = lib.ctrl_step(c, smp)
        h = c.hfi_out
        if out.state == STATE_FAULT:
            r_last = h.pol_metric if h != ffi.NULL else math.nan
            return dict(fault=True, t_s=k * r.ts_s, r=r_last), tr
        if trace and h != ffi.NULL:
            s = pl.snapshot()   # the plant's voltage averaged over the period just ended
            tr["ipd"].append(h.ipd_state)
            tr["v_obs"].append(complex(c.v_ab_acted_v.x, c.v_ab_acted_v.y))
            tr["v_plant"].append(complex(s.v_alpha_v, s.v_beta_v))
        pl.step(*out.duty_abc)
    s = pl.snapshot()
    err = math.degrees(math.remainder(out.theta_hat_rad - s.theta_e_rad, 2 * math.pi))
    return dict(fault=False, err_deg=err, state=h.ipd_state, r=h.pol_metric, se=h.pol_se,
                t_pol_s=h.pol_time_s), ({k: np.asarray(v) for k, v in tr.items()} if trace else None)


def cell(o: dict) -> str:
    if o["fault"]:
        return f"FAIL@{o['t_s'] * 1e3:.0f}ms(r={o['r']:+.4f})"
    if o["state"] == IPD_POLARITY:
        return f"testing(r={o['r']:+.4f})"
    return f"{'ok' if abs(o['err_deg']) < 90 else 'WRONG'}{o['err_deg']:+.2f}/{o['t_pol_s'] * 1e3:.0f}ms"


def voltage(residuals, t_end_s: float) -> None:
    """The error between the voltage the observers are handed and the plant's, over the polarity
    test, at the injection's own sequence, the opposite one and the 2nd harmonic."""
    fi = 1250.0
    for res in residuals:
        for name, plant in (("ADC on", {}), ("ADC off", {"plant.adc_model": False})):
            _, tr = run(180, res, 1, t_end_s, plant, trace=True)
            w = tr["ipd"] == IPD_POLARITY
            if not w.any():
                print(f"residual {res:g} {name}: no polarity test in {t_end_s} s")
                continue
            t = np.nonzero(w)[0] * 1e-4
            e = tr["v_obs"][w] - tr["v_plant"][w]

            def tone(z, f):
                return abs(np.mean(z * np.exp(-2j * math.pi * f * t)))
            print(f"residual {res:4g} {name:7s}: injection {tone(tr['v_plant'][w], -fi):.2f} V; "
                  f"error rms {np.sqrt(np.mean(abs(e) ** 2)):.3f} V, at the injection's sequence "
                  f"{tone(e, -fi):.3f} V, opposite {tone(e, fi):.3f} V, 2nd harmonic "
                  f"{tone(e, 2 * fi):.3f}/{tone(e, -2 * fi):.3f} V")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--residuals", default="0,0.05,0.1,1")
    ap.add_argument("--angles", default="0,45,90,135,180")
    ap.add_argument("--seeds", type=int, default=8, help="ADC noise seeds 1..N")
    ap.add_argument("--t-end", type=float, default=0.6, help="seconds per start")
    ap.add_argument("--voltage", action="store_true")
    a = ap.parse_args()
    residuals = [float(x) for x in a.residuals.split(",")]
    if a.voltage:
        voltage(residuals, 0.12)
        return
    for res in residuals:
        for ang in (float(x) for x in a.angles.split(",")):
            cells = [cell(run(ang, res, seed, a.t_end)[0]) for seed in range(1, a.seeds + 1)]
            print(f"residual {res:4g} {ang:5g} deg: " + " ".join(cells), flush=True)


if __name__ == "__main__":
    main()
