"""Measure the per-call cost of Plant.step and its Python overhead, and the cost of a period in
each inverter mode.

    .venv/bin/python -m hil_bench.perf.plant_step [profile] [--n N]
    .venv/bin/python -m hil_bench.perf.plant_step [profile] --modes [--n N]

Prints (best of 5 repeats, microseconds per period):
  c_loop      plant_step inside one C loop (plant_run, no snapshots): the C work alone
  cffi_direct lib.plant_step_abc called from Python (cffi call + C work)
  plant_step  Plant.step(a, b, c) (method call + cffi call + C work)
  overhead    plant_step - c_loop: what the Python API adds per period
  snapshot    Plant.snapshot() + reading 3 fields
  snapshot_to Plant.snapshot_to(buf, k) into a numpy structured array

--modes: CPU time (getrusage, user + system) per period of plant_run in a C loop for the averaged
and the switching inverter, ideal and with dead time + drops, at two operating points of the
rotor held at 500 rpm by the dynamometer (POINTS: the steady-state voltage of i_q = 5 A, and of
no load as in Gong's G5-G7); best of 5 repeats, the four set-ups interleaved in each repeat so
that the (shared) machine's load hits them alike; ratio = switching / averaged of the same
inverter non-linearity. With dead time and drops the switching mode shortens its RK4 steps
while a current is near the drops' threshold band, so its cost depends on the operating point
(at no load the currents stay in that band).
"""
from __future__ import annotations

import argparse
import math
import resource
import time
import timeit

import numpy as np

from hil_bench.plant_rt.plant import Plant, ffi, lib, snapshot_array, snapshot_buffer


def measure(profile: str = "gong2020", n: int = 200_000, repeat: int = 5) -> dict[str, float]:
    plant = Plant.from_profile(profile)
    duties = np.tile([0.55, 0.45, 0.5], (n, 1))
    dptr = ffi.cast("const double *", ffi.from_buffer(duties))

    def c_loop() -> None:
        lib.plant_run(plant._pl, dptr, n, ffi.NULL)

    res: dict[str, float] = {}
    best = min(_time(c_loop) for _ in range(repeat))
    res["c_loop"] = best / n * 1e6
    env = {"f": lib.plant_step_abc, "pl": plant._pl, "step": plant.step, "plant": plant}
    res["cffi_direct"] = min(timeit.repeat("f(pl, 0.55, 0.45, 0.5)", globals=env, number=n, repeat=repeat)) / n * 1e6
    res["plant_step"] = min(timeit.repeat("step(0.55, 0.45, 0.5)", globals=env, number=n, repeat=repeat)) / n * 1e6
    res["overhead"] = res["plant_step"] - res["c_loop"]
    res["snapshot"] = min(timeit.repeat("s = plant.snapshot(); s.i_a_a; s.i_b_a; s.theta_e_rad",
                                        globals=env, number=n, repeat=repeat)) / n * 1e6
    rec = snapshot_array(n)
    buf = snapshot_buffer(rec)
    env.update(buf=buf, to=plant.snapshot_to)
    res["snapshot_to"] = min(timeit.repeat("to(buf, 7)", globals=env, number=n, repeat=repeat)) / n * 1e6
    return res


MODES = (("averaged", False), ("switching", False), ("averaged", True), ("switching", True))
#: operating points of --modes: (label, i_q [A]) at 500 rpm, the rotor held by the dynamometer
POINTS = (("500 rpm, duties for i_q 5 A", 5.0), ("500 rpm, no load (i_q 0.36 A)", 0.359))


def _cpu_s() -> float:
    ru = resource.getrusage(resource.RUSAGE_SELF)
    return ru.ru_utime + ru.ru_stime


def measure_modes(profile: str = "gong2020", n: int = 50_000, repeat: int = 5,
                  i_q_a: float = 5.0, rpm: float = 500.0) -> dict[tuple[str, bool], float]:
    """CPU microseconds per period of each (inverter, inverter_nonlinear) set-up at one operating
    point: the steady-state voltage of (i_d = 0, i_q_a) at rpm as min-max SVPWM duties, the rotor
    held at rpm by the dynamometer (the currents then ripple about that point; with dead time and
    drops they are smaller than i_q_a, the duties not being compensated)."""
    from hil_bench.plant_rt.verify import openloop

    probe = Plant.from_profile(profile)
    p = probe.params
    w_m = rpm / 60.0 * 2.0 * math.pi
    w_e = p.pole_pairs * w_m
    v_d, v_q = openloop.operating_point_voltage(p, w_e, 0.0, i_q_a)
    duties = np.ascontiguousarray(openloop.synchronous(p, n, theta_e0_rad=0.0, omega_e_rad_s=w_e,
                                                      v_d_v=v_d, v_q_v=v_q))
    dptr = ffi.cast("const double *", ffi.from_buffer(duties))
    plants = {m: Plant.from_profile(profile, inverter=m[0], inverter_nonlinear=m[1], dyno=True,
                                    dyno_speed_rad_s=w_m) for m in MODES}
    best = {m: math.inf for m in MODES}
    for _ in range(repeat):
        for m, plant in plants.items():
            plant.reset()
            t0 = _cpu_s()
            lib.plant_run(plant._pl, dptr, n, ffi.NULL)
            best[m] = min(best[m], _cpu_s() - t0)
    for m, plant in plants.items():
        assert plant.sw_periods == (n if m[0] == "switching" else 0)
    return {m: t / n * 1e6 for m, t in best.items()}


def _time(fn) -> float:
    t0 = time.perf_counter()
    fn()
    return time.perf_counter() - t0


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("profile", nargs="?", default="gong2020")
    ap.add_argument("--n", type=int, default=None, help="periods per repeat (default 200 000; "
                    "50 000 with --modes)")
    ap.add_argument("--modes", action="store_true", help="averaged vs switching inverter, CPU time")
    args = ap.parse_args()
    if args.modes:
        n = args.n or 50_000
        plant = Plant.from_profile(args.profile)
        ts_us = plant.params.ts_s * 1e6
        print(f"profile {args.profile}, substeps {plant.params.substeps}, n {n}, best of 5, "
              f"CPU time (getrusage) per period of plant_run [us]")
        print(f"  {'operating point':<30} {'inverter':<10} {'dead time+drops':<16} {'us/period':>9} "
              f"{'vs averaged':>11} {'of Ts':>7}")
        for label, i_q in POINTS:
            cost = measure_modes(args.profile, n, i_q_a=i_q)
            for (inv, nl), us in cost.items():
                ratio = us / cost[("averaged", nl)]
                print(f"  {label:<30} {inv:<10} {'on' if nl else 'off':<16} {us:9.3f} "
                      f"{ratio:10.2f}x {us / ts_us * 100.0:6.2f}%")
        return 0
    args.n = args.n or 200_000
    res = measure(args.profile, args.n)
    plant = Plant.from_profile(args.profile)
    print(f"profile {args.profile}, substeps {plant.params.substeps}, n {args.n}, best of 5 [us/call]")
    for key, value in res.items():
        print(f"  {key:<12} {value:7.3f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
