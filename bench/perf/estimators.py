"""Benchmark: instructions per call of every estimator step in firmware_stub/src, by callgrind.

    python -m hil_bench.perf.estimators [--n 20000] [--json]

Builds bench/perf/est_callgrind.c with the firmware sources and the firmware's flags
(-std=c99 -O2 -g -DNDEBUG, i.e. CMake RelWithDebInfo, plus HIL_STRICT_FLAGS) into build/perf/,
then runs each case under ``valgrind --tool=callgrind --toggle-collect=bench_run``: only the N
step calls are counted, after a warm-up of 2000 steps. Instruction counts are deterministic (the
same binary and inputs give the same count); they are x86-64 instructions, libm included
(sinf/cosf/atan2f/expf), not C28x cycles -- compare them with each other, not with a DSP's
budget. The loop-and-call overhead (the ``empty`` case) is subtracted.

Also printed: the cost of 5th + 7th extraction per sample, GSDFT vs SDFT, beside Yuan's Table 2
(GSDFT 44.82 % less time than SDFT), for the library's protected (modulated) form and for the
papers' direct recursion, on a real phase current and on the complex alpha-beta current.
"""
from __future__ import annotations

import argparse
import json
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
SRC = REPO / "firmware_stub" / "src"
DRIVER = Path(__file__).resolve().parent / "est_callgrind.c"
OUT_DIR = REPO / "build" / "perf"
FLAGS = ["-std=c99", "-O2", "-g", "-DNDEBUG", "-Wall", "-Wextra", "-Werror", "-pedantic",
         "-Wconversion", "-Wdouble-promotion", "-Wfloat-equal", "-Wshadow", "-Wstrict-prototypes",
         "-Wmissing-prototypes"]
CORE = ["fw_math", "est_common", "est_dft", "est_sdft", "est_gsdft", "harm_comp", "est_hfi",
        "est_smo_sign"]
#: module -> driver macro; compiled in when firmware_stub/src/<module>.c exists
OPTIONAL = {"est_smo_sigmoid": "HAVE_EST_SMO_SIGMOID", "est_smo_tanh": "HAVE_EST_SMO_TANH",
            "est_delay_comp": "HAVE_EST_DELAY_COMP"}

#: (case, table label)
ESTIMATOR_CASES = [
    ("smo_sign", "est_smo_sign_step (Yuan 4-10, sign SMO + LPF + PLL)"),
    ("smo_sigmoid", "est_smo_sigmoid_step (Yuan 11-18)"),
    ("smo_tanh", "est_smo_tanh_step (Gong 8-19)"),
    ("delay_comp", "est_delay_comp_step (Gong 20-22, two samples)"),
    ("hfi_tracking", "est_hfi_step, tracking (Hou 8-20)"),
    ("hfi_ipd", "est_hfi_step, IPD converge (+ atan2, mean SDFT)"),
    ("harm_comp_gsdft_50rpm", "harm_comp_step + voltage_dq, GSDFT, 50 rpm (avg/period)"),
    ("harm_comp_sdft_50rpm", "harm_comp_step + voltage_dq, SDFT, 50 rpm (avg/period)"),
    ("sdft_1bin_real_mod", "est_sdft_step, 1 bin, real, M=24, protected"),
    ("sdft_1bin_real_direct", "est_sdft_step, 1 bin, real, M=24, direct (drifts)"),
    ("gsdft_1bin_real_mod", "est_gsdft_step, 1 bin, real, M=24, protected"),
]
#: Y6: 5th + 7th extraction per sample (form, input) -> (SDFT case, GSDFT case)
Y6_CASES = [
    ("protected (modulated + restart)", "real phase current", "sdft_57_real_mod", "gsdft_57_real_mod"),
    ("protected (modulated + restart)", "complex alpha-beta", "sdft_57_cplx_mod", "gsdft_57_cplx_mod"),
    ("protected, GSDFT with DC block", "complex alpha-beta", "sdft_57_cplx_mod", "gsdft_57_cplx_mod_dc"),
    ("papers' direct recursion", "real phase current", "sdft_57_real_direct", "gsdft_57_real_direct"),
    ("papers' direct recursion", "complex alpha-beta", "sdft_57_cplx_direct", "gsdft_57_cplx_direct"),
]
YUAN_SAVING_PCT = 44.82


def build(optional: dict[str, str]) -> tuple[Path, list[str]]:
    """Compile the driver; drop optional modules that do not compile against it."""
    OUT_DIR.mkdir(parents=True, exist_ok=True)
    exe = OUT_DIR / "est_callgrind"
    present = {m: d for m, d in optional.items() if (SRC / f"{m}.c").exists()}
    notes = []
    while True:
        srcs = [str(SRC / f"{m}.c") for m in CORE + list(present)]
        defs = [f"-D{d}" for d in present.values()]
        cmd = ["gcc", *FLAGS, *defs, f"-I{SRC}", str(DRIVER), *srcs, "-lm", "-o", str(exe)]
        res = subprocess.run(cmd, capture_output=True, text=True)
        if res.returncode == 0:
            return exe, notes
        if not present:
            sys.exit(f"build failed:\n{' '.join(cmd)}\n{res.stderr}")
        notes.append(f"optional modules {sorted(present)} did not build with the driver; "
                     f"measured without them ({res.stderr.strip().splitlines()[0]})")
        present = {}


def instructions(exe: Path, case: str, n: int) -> int | None:
    """Ir collected inside bench_run for ``case`` (None if the case is not in the build)."""
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "cg.out"
        res = subprocess.run(["valgrind", "--tool=callgrind", f"--callgrind-out-file={out}",
                              "--toggle-collect=bench_run", str(exe), case, str(n)],
                             capture_output=True, text=True)
        if res.returncode != 0:
            if "unknown or unbuilt case" in res.stderr:
                return None
            sys.exit(f"{case}: callgrind failed:\n{res.stderr[-2000:]}")
        text = out.read_text()
    m = re.search(r"^(?:summary|totals):\s+(\d+)", text, re.MULTILINE)
    if not m:
        sys.exit(f"{case}: no instruction total in the callgrind output")
    return int(m.group(1))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=20000, help="measured calls per case")
    ap.add_argument("--json", action="store_true", help="also print one JSON line per case")
    args = ap.parse_args(argv)
    if not SRC.is_dir() or not DRIVER.is_file():
        sys.exit("hil_bench.perf.estimators compiles the firmware's C sources "
                 f"({SRC}, {DRIVER.name}): run it in a checkout (an installed wheel has no C)")
    if shutil.which("valgrind") is None:
        sys.exit("valgrind not found (apt-get install valgrind)")
    exe, notes = build(OPTIONAL)
    per_call: dict[str, float] = {}

    def measure(case: str) -> float | None:
        if case not in per_call:
            ir = instructions(exe, case, args.n)
            per_call[case] = None if ir is None else ir / args.n
        return per_call[case]

    overhead = measure("empty")
    print(f"instructions per call (x86-64, callgrind, N = {args.n}, loop+call overhead "
          f"{overhead:.1f} subtracted)\n")
    print(f"{'step function':62s} {'instr/call':>10s}")
    print("-" * 74)
    rows = []
    for case, label in ESTIMATOR_CASES:
        v = measure(case)
        if v is None:
            print(f"{label:62s} {'(absent)':>10s}")
            continue
        rows.append(dict(case=case, label=label, instr_per_call=round(v - overhead, 1)))
        print(f"{label:62s} {v - overhead:10.1f}")
    print("\nY6 -- 5th + 7th extraction per sample, M = 24 (Yuan Table 2: GSDFT "
          f"{YUAN_SAVING_PCT} % less time than SDFT)\n")
    print(f"{'form':34s} {'input':20s} {'SDFT':>8s} {'GSDFT':>8s} {'GSDFT saving':>13s}")
    print("-" * 88)
    for form, inp, s_case, g_case in Y6_CASES:
        s, g = measure(s_case) - overhead, measure(g_case) - overhead
        saving = 100.0 * (1.0 - g / s)
        rows.append(dict(case=f"y6 {form} / {inp}", sdft=round(s, 1), gsdft=round(g, 1),
                         saving_pct=round(saving, 1), paper_saving_pct=YUAN_SAVING_PCT))
        print(f"{form:34s} {inp:20s} {s:8.1f} {g:8.1f} {saving:12.1f} %")
    print(f"{'':34s} {'':20s} {'':8s} {'paper':>8s} {YUAN_SAVING_PCT:12.2f} %")
    for note in notes:
        print(f"\nnote: {note}")
    if args.json:
        for r in rows:
            print(json.dumps(r))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
