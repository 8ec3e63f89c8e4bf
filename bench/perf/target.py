"""Benchmark: the firmware on the Cortex-M4F target (QEMU's netduinoplus2): footprint, stack and
instructions per control ISR, per estimator; and the target's angle and speed against the host
build's on G2.

    python -m hil_bench.perf.target [--seconds 0.8] [--json]

Flash and RAM come from ``arm-none-eabi-size`` of ``build/cortex_m/hil_fw_cm4.elf``. Each case
runs a bundled scenario cut to ``--seconds`` on ``--link pil-qemu`` (lockstep, ``-icount
shift=0``: one guest instruction per ns of virtual time) and reads the target's own figures
(target_stats.h): the stack's high-water mark from the paint, and the control ISR's instructions
(SENSE decoded, ``ctrl_step``, TELEM / TELEM_EMF / DUTY encoded and framed into the transmit
ring; the octets leave afterwards). These are instructions, not cycles: on silicon the same
firmware counts DWT->CYCCNT cycles instead (flash wait states, FPU divides and the pipeline
make a cycle count larger).
"""
from __future__ import annotations

import argparse
import json
import subprocess
import tempfile
import time
from pathlib import Path

from hil_bench.loop.links.qemu import firmware_elf
from hil_bench.loop.runner import run_scenario
from hil_bench.record.compare import compare_recordings
from hil_bench.scenario import derive_scenario, load_scenario

#: (bundled scenario, what it exercises)
CASES = [
    ("gong_g2_500rpm", "tanh SMO (Gong), 500 rpm"),
    ("yuan_y1_conventional", "sign SMO + LPF + PLL (Yuan), 1000 rpm"),
    ("yuan_y1_improved", "sigmoid SMO (Yuan)"),
    ("beyond_hfi_speed", "HF injection + IPD (Hou's HFI-SDFT)"),
]


def footprint(elf: Path) -> dict[str, int]:
    out = subprocess.run(["arm-none-eabi-size", "-A", str(elf)], capture_output=True, text=True,
                         check=True).stdout
    sec = {}
    for line in out.splitlines():
        parts = line.split()
        if len(parts) >= 3 and parts[0].startswith("."):
            sec[parts[0]] = int(parts[1])
    flash = sec.get(".isr_vector", 0) + sec.get(".text", 0) + sec.get(".ARM.exidx", 0) + sec.get(".data", 0)
    ram = sec.get(".hil_stats", 0) + sec.get(".data", 0) + sec.get(".bss", 0)
    return {"flash_bytes": flash, "ram_static_bytes": ram, "text": sec.get(".text", 0),
            "data": sec.get(".data", 0), "bss": sec.get(".bss", 0)}


def run_case(name: str, seconds: float, out: Path, link: str) -> tuple[dict, Path, float]:
    base = load_scenario(name)
    t1 = min(seconds, base.duration_s)
    overrides = [("scenario.duration_s", t1), ("metrics.window_s", [t1 * 0.5, t1])]
    if base.raw.get("events"):
        overrides.append(("events", []))     # steps later in the run: cut with it
    scn = derive_scenario(name, name, tuple(overrides), note="cut short")
    path = out / f"{name}_{link}.mcap"
    t0 = time.monotonic()
    result = run_scenario(scn, link_spec=link, out_path=path, progress=False, force=True)
    if not result.ok:
        raise SystemExit(f"{name} on {link}: {result.error}")
    return result.target, path, time.monotonic() - t0


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=0.8, help="simulated seconds per case")
    ap.add_argument("--json", action="store_true", help="also print the figures as JSON")
    ap.add_argument("--cases", default="", help="comma-separated scenario names (default: all)")
    args = ap.parse_args(argv)
    elf = firmware_elf()
    fp = footprint(elf)
    print(f"{elf}: flash {fp['flash_bytes']} B (text {fp['text']}, data {fp['data']}), static RAM "
          f"{fp['ram_static_bytes']} B (data + bss {fp['data'] + fp['bss']}, stats block)")
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        print(f"\n{'case':48s} {'cycles':>6s} {'ISR instr mean':>14s} {'min':>7s} {'max':>7s} "
              f"{'stack B':>8s} {'wall s':>7s}")
        chosen = [c for c in CASES if not args.cases or c[0] in args.cases.split(",")]
        for name, what in chosen:
            target, _, wall = run_case(name, args.seconds, Path(tmp), "pil-qemu")
            row = dict(case=name, what=what, cycles=int(target["isr_count"]),
                       isr_mean=float(target["isr_instructions_mean"]),
                       isr_min=float(target["isr_instructions_min"]),
                       isr_max=float(target["isr_instructions_max"]),
                       stack_used=int(target["stack_used_bytes"]),
                       stack_size=int(target["stack_size_bytes"]), wall_s=round(wall, 1),
                       calibration=target["calibration"])
            rows.append(row)
            print(f"{what:48s} {row['cycles']:6d} {row['isr_mean']:14.0f} {row['isr_min']:7.0f} "
                  f"{row['isr_max']:7.0f} {row['stack_used']:8d} {wall:7.1f}")
        print(f"(counter check: {rows[0]['calibration']})")
    if args.json:
        print(json.dumps({"footprint": fp, "cases": rows}))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
