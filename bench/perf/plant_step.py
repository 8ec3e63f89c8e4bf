"""Measure the per-call cost of Plant.step and its Python overhead.

    .venv/bin/python -m hil_bench.perf.plant_step [profile] [--n N]

Prints (best of 5 repeats, microseconds per period):
  c_loop      plant_step inside one C loop (plant_run, no snapshots): the C work alone
  cffi_direct lib.plant_step_abc called from Python (cffi call + C work)
  plant_step  Plant.step(a, b, c) (method call + cffi call + C work)
  overhead    plant_step - c_loop: what the Python API adds per period
  snapshot    Plant.snapshot() + reading 3 fields
  snapshot_to Plant.snapshot_to(buf, k) into a numpy structured array
"""
from __future__ import annotations

import argparse
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


def _time(fn) -> float:
    t0 = time.perf_counter()
    fn()
    return time.perf_counter() - t0


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("profile", nargs="?", default="gong2020")
    ap.add_argument("--n", type=int, default=200_000)
    args = ap.parse_args()
    res = measure(args.profile, args.n)
    plant = Plant.from_profile(args.profile)
    print(f"profile {args.profile}, substeps {plant.params.substeps}, n {args.n}, best of 5 [us/call]")
    for key, value in res.items():
        print(f"  {key:<12} {value:7.3f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
