"""Plant steps per second against gym-electric-motor's PMSM, same motor, same control step,
measured in the same run.

    .venv/bin/python -m hil_bench.perf.plant_vs_gem [profile] [--n N] [--gem-n N] [--effects]

Both sides simulate the profile's motor (gong2020 by default) over one control period
Ts = 100 us per step, driven by a rotating voltage (the motor runs; GEM gets the equivalent
continuous B6 action). Timed (best of --repeat):

  plant  Plant.step    one Python call per period (cffi), what a Python bench loop costs
         plant_run     n periods in one C call (duties precomputed), the engine's own speed
  GEM    env.step      gem.make("Cont-CC-PMSM-v0") with the same motor and tau, default ODE
                       solver (scipy 'dopri5'), no visualisation: what a GEM user steps
         system        the physical system alone (SynchronousMotorSystem.simulate): GEM
                       without the gym layer, default solver, and with its Euler solver
                       (one explicit step per period: fast, 1e-2-level error at this tau)

The plant's accuracy at its default substeps (RK4, 4 sub-steps per period) is ~1e-6 of rated
current (plant_rt/README.md), comparable to GEM's dopri5 defaults, far better than Euler.
``--effects`` adds the plant with the inverter non-linearity and saturation on.
"""
from __future__ import annotations

import argparse
import math
import warnings
from typing import Any

import numpy as np

from hil_bench.plant_rt.plant import Plant, ffi, lib
from hil_bench.plant_rt.profile import load_profile
from hil_bench.plant_rt.verify.gem_compare import gem_env, gem_system

from .plant_step import _time


def _duties(prof, n: int) -> np.ndarray:
    k = np.arange(n)
    th = 2 * math.pi * 50.0 * k * prof.ts_s
    return 0.5 + 0.1 * np.stack([np.cos(th - x * 2 * math.pi / 3) for x in range(3)], axis=-1)


def plant_timers(prof, n: int, **overrides) -> dict[str, tuple[int, Any]]:
    """name -> (steps, callable running them) for the plant."""
    duties = _duties(prof, n)
    plant = Plant(prof, **overrides)
    dptr = ffi.cast("const double *", ffi.from_buffer(duties))
    rows = [tuple(r) for r in duties.tolist()]
    step = plant.step

    def run_py() -> None:
        for a, b, c in rows:
            step(a, b, c)

    def run_c() -> None:
        lib.plant_run(plant._pl, dptr, n, ffi.NULL)

    run_c.keep = (duties, dptr)  # type: ignore[attr-defined]  (the buffer must outlive dptr)
    return {"Plant.step": (n, run_py), "plant_run": (n, run_c)}


def gem_timers(prof, n: int) -> dict[str, tuple[int, Any]]:
    """name -> (steps, callable running them) for GEM."""
    actions = [np.asarray(2.0 * d - 1.0) for d in _duties(prof, n)]
    out: dict[str, tuple[int, Any]] = {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        env = gem_env(prof)

        def run_env() -> None:
            for a in actions:
                env.step(a)

        out["env.step (dopri5)"] = (n, run_env)
        for solver in ("dopri5", "euler"):
            system = gem_system(prof, solver=solver, control_space="abc")

            def run_sys(system=system) -> None:
                for a in actions:
                    system.simulate(a)

            out[f"system ({solver})"] = (n, run_sys)
    return out


def measure(timers: dict[str, tuple[int, Any]], repeat: int) -> dict[str, float]:
    """Best steps/s of each timer; the timers are interleaved within every repeat so that a
    change of machine load hits all of them alike."""
    best = {k: 0.0 for k in timers}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for _ in range(repeat):
            for name, (n, fn) in timers.items():
                best[name] = max(best[name], n / _time(fn))
    return best


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("profile", nargs="?", default="gong2020")
    ap.add_argument("--n", type=int, default=100_000, help="plant steps per timing")
    ap.add_argument("--gem-n", type=int, default=2_000, help="GEM steps per timing")
    ap.add_argument("--repeat", type=int, default=7)
    ap.add_argument("--effects", action="store_true", help="also time the plant with effects on")
    args = ap.parse_args()
    prof = load_profile(args.profile)
    timers = {f"plant {k}": v for k, v in plant_timers(prof, args.n).items()}
    timers.update({f"GEM {k}": v for k, v in gem_timers(prof, args.gem_n).items()})
    if args.effects:
        timers.update({f"plant {k} (effects)": v for k, v in
                       plant_timers(prof, args.n, inverter_nonlinear=True, saturation=True).items()})
    res = measure(timers, args.repeat)
    plant = {k[len("plant "):]: v for k, v in res.items() if k.startswith("plant ") and "effects" not in k}
    gem = {k[len("GEM "):]: v for k, v in res.items() if k.startswith("GEM ")}
    print(f"profile {prof.name}, Ts = {prof.ts_s * 1e6:.0f} us, plant substeps {prof.substeps}; "
          f"best of {args.repeat} interleaved repeats; plant n = {args.n}, GEM n = {args.gem_n}")
    print(f"{'':28s}{'steps/s':>12s}{'us/step':>10s}")
    for name, sps in res.items():
        print(f"{name:28s}{sps:12.0f}{1e6 / sps:10.2f}")
    print("ratios (plant steps/s over GEM steps/s):")
    for pk, pv in plant.items():
        line = ", ".join(f"{gk} {pv / gv:6.0f}x" for gk, gv in gem.items())
        print(f"  {pk:11s} vs {line}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
