"""Benchmark: the firmware on the Cortex-M4F target (QEMU's netduinoplus2): footprint, stack and
instructions per control ISR, per estimator; and how fast a lockstep run goes on it.

    python -m hil_bench.perf.target                     # footprint + ISR per case (about 2 min)
    python -m hil_bench.perf.target --write-docs        # ... and fills docs/ports.md's generated blocks
    python -m hil_bench.perf.target --check-docs        # docs/ports.md's footprint block against the ELF
    python -m hil_bench.perf.target --speed [--repeats 3]   # full G2 (15 000 cycles): wall and CPU
    python -m hil_bench.perf.target --compare-rows A.mcap B.mcap   # every recorded row, compared

Footprint: flash and RAM from the ELF's section headers (read here, no toolchain needed): flash =
vectors + text (with rodata) + exception index + the load image of .data; static RAM = the stats
block + .data + .bss; the stack is reserved at the top of SRAM. Each ISR case runs a bundled
scenario cut to ``--seconds`` (1.0 s: 10 000 cycles at 10 kHz; its later events dropped) on
``--link pil-qemu`` (lockstep, ``-icount shift=0``: one guest instruction per ns of virtual
time) and reads the target's own figures (target_stats.h): the stack's high-water mark from the
paint, and the control ISR's instructions (SENSE decoded, ``ctrl_step``, TELEM / TELEM_EMF /
DUTY encoded and framed into the transmit ring; the octets leave afterwards). These are
instructions, not cycles: on silicon the same firmware counts DWT->CYCCNT cycles instead (flash
wait states, FPU divides and the pipeline make a cycle count larger). G2's case is the cut the
tests run (tests/test_pil_qemu.py, ``G2_SHORT``), so they check the docs' figure against their own.

``--speed`` runs the whole G2 (``gong_g2_500rpm``, 15 000 cycles) on ``--link pil-qemu`` and on
the host stub, one after the other, ``--repeats`` times, and reports the wall time, cycles per
second, and the CPU seconds: of this process (the engine thread, the bench's Python), of its
child processes (the emulator or the stub, the recorder) and of the emulator alone (what it used
by /proc, kept in the recording's ``target`` metadata), and cycles per CPU second of everything.
The machine is shared: the load average before each run is printed beside it. It uses only what
the bench's API had before this benchmark (``run_scenario``, ``load_scenario``), so the same file
measures an older checkout: ``OLD/.venv/bin/python bench/perf/target.py --speed``.
"""
from __future__ import annotations

import argparse
import json
import os
import re
import resource
import statistics
import struct
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

#: (bundled scenario, what it exercises)
CASES = [
    ("gong_g2_500rpm", "tanh SMO (Gong), 500 rpm"),
    ("yuan_y1_conventional", "sign SMO + LPF + PLL (Yuan), inverter compensation"),
    ("yuan_y1_improved", "sigmoid SMO (Yuan), inverter compensation"),
    ("beyond_hfi_speed", "HF injection + IPD (Hou's HFI-SDFT)"),
]
#: G2 as tests/test_pil_qemu.py cuts it (G2_SHORT): the tests compare its ISR figure with the docs'
CASE_SECONDS = 1.0
DOC = Path(__file__).resolve().parents[2] / "docs" / "ports.md"
_BLOCK = re.compile(r"(<!-- BEGIN GENERATED: (\w+) -->\n)(.*?)(<!-- END GENERATED: \2 -->)", re.S)


# ---- footprint, from the ELF ------------------------------------------------------------------
def _cstr(data: bytes, at: int) -> str:
    return data[at:data.index(b"\0", at)].decode()


def read_elf(elf: Path) -> tuple[dict[str, int], dict[str, int]]:
    """(section name -> size, symbol name -> value) of a 32-bit little-endian ELF."""
    data = elf.read_bytes()
    if data[:4] != b"\x7fELF" or data[4] != 1 or data[5] != 1:
        raise ValueError(f"{elf}: not a 32-bit little-endian ELF")
    shoff, = struct.unpack_from("<I", data, 0x20)
    shentsize, shnum, shstrndx = struct.unpack_from("<HHH", data, 0x2E)
    # name, type, flags, addr, offset, size, link, info, addralign, entsize
    headers = [struct.unpack_from("<10I", data, shoff + i * shentsize) for i in range(shnum)]
    names_at = headers[shstrndx][4]
    sections = {_cstr(data, names_at + h[0]): h[5] for h in headers[1:]}
    symbols: dict[str, int] = {}
    for h in headers:
        if h[1] == 2:                                   # SHT_SYMTAB, its names in section h[6]
            strtab_at = headers[h[6]][4]
            for off in range(h[4], h[4] + h[5], 16):    # Elf32_Sym: name, value, size, info...
                name_off, value = struct.unpack_from("<II", data, off)
                if name_off:
                    symbols[_cstr(data, strtab_at + name_off)] = value
    return sections, symbols


def footprint(elf: Path) -> dict[str, int]:
    sec, sym = read_elf(elf)
    flash = (sec.get(".isr_vector", 0) + sec.get(".text", 0) + sec.get(".ARM.exidx", 0)
             + sec.get(".data", 0))
    ram = sec.get(".hil_stats", 0) + sec.get(".data", 0) + sec.get(".bss", 0)
    return {"flash_bytes": flash, "ram_static_bytes": ram, "text": sec.get(".text", 0),
            "data": sec.get(".data", 0), "bss": sec.get(".bss", 0),
            "stats_block": sec.get(".hil_stats", 0),
            "stack_bytes": sym.get("_estack", 0) - sym.get("_sstack", 0)}


def _n(x: float) -> str:
    return f"{x:,.0f}".replace(",", " ")


def footprint_markdown(fp: dict[str, int]) -> str:
    """docs/ports.md's ``target_footprint`` block: a function of the ELF alone."""
    lines = ["| | Cortex-M4F target (`hil_fw_cm4.elf`) |", "|---|---|",
             f"| flash (vectors + text + rodata + .data's load image) | {_n(fp['flash_bytes'])} B "
             f"of 1 MiB |",
             f"| static RAM (stats block + .data + .bss) | {_n(fp['ram_static_bytes'])} B of "
             f"128 KiB (.bss {_n(fp['bss'])} B, .data {_n(fp['data'])} B, stats block "
             f"{_n(fp['stats_block'])} B) |",
             "| heap | none (no `_sbrk` in the link) |",
             f"| stack reserved | {_n(fp['stack_bytes'])} B at the top of SRAM, painted at reset "
             f"(its high-water mark: below) |"]
    return "\n".join(lines) + "\n"


# ---- ISR per case, on the target --------------------------------------------------------------
@dataclass
class CaseRow:
    case: str
    what: str
    cycles: int
    isr_mean: float
    isr_min: float
    isr_max: float
    stack_used: int
    calibration: str
    wall_s: float


def cut(name: str, seconds: float):
    """A bundled scenario cut to ``seconds`` (its later events dropped), claims read over the
    last fifth: for G2 at 1.0 s exactly tests/test_pil_qemu.py's G2_SHORT."""
    from hil_bench.scenario import derive_scenario, load_scenario

    base = load_scenario(name)
    t1 = min(seconds, base.duration_s)
    overrides = [("scenario.duration_s", t1), ("metrics.window_s", [round(t1 * 0.8, 6), t1])]
    if base.raw.get("events"):
        overrides.append(("events", []))     # steps later in the run: cut with it
    return derive_scenario(name, name, tuple(overrides), note="cut short")


def run_case(name: str, what: str, seconds: float, out: Path) -> CaseRow:
    from hil_bench.loop.runner import run_scenario

    t0 = time.monotonic()
    result = run_scenario(cut(name, seconds), link_spec="pil-qemu", out_path=out / f"{name}.mcap",
                          progress=False, force=True)
    if not result.ok:
        raise SystemExit(f"{name} on pil-qemu: {result.error}")
    t = result.target
    return CaseRow(name, what, int(t["isr_count"]), float(t["isr_instructions_mean"]),
                   float(t["isr_instructions_min"]), float(t["isr_instructions_max"]),
                   int(t["stack_used_bytes"]), t["calibration"], round(time.monotonic() - t0, 1))


def isr_markdown(rows: list[CaseRow], seconds: float) -> str:
    """docs/ports.md's ``target_isr`` block."""
    lines = [f"Measured {time.strftime('%Y-%m-%d')}. Each case: the bundled scenario cut to "
             f"{seconds:g} s ({_n(rows[0].cycles if rows else 0)} control cycles, its later events "
             f"dropped), lockstep on `--link pil-qemu`; the counter check: "
             f"{rows[0].calibration if rows else '-'}.", "",
             "| case (scenario) | control ISR, instructions: mean | min | max | stack high-water |",
             "|---|---:|---:|---:|---:|"]
    for r in rows:
        lines.append(f"| {r.what} (`{r.case}`) | {_n(r.isr_mean)} | {_n(r.isr_min)} | "
                     f"{_n(r.isr_max)} | {_n(r.stack_used)} B |")
    return "\n".join(lines) + "\n"


def render_docs(text: str, sections: dict[str, str]) -> str:
    seen = set()

    def fill(m: re.Match) -> str:
        if m.group(2) not in sections:
            return m.group(0)
        seen.add(m.group(2))
        return m.group(1) + sections[m.group(2)].rstrip("\n") + "\n" + m.group(4)

    out = _BLOCK.sub(fill, text)
    missing = set(sections) - seen
    if missing:
        raise SystemExit(f"{DOC} has no generated block {sorted(missing)}")
    return out


def generated_block(text: str, name: str) -> str | None:
    for m in _BLOCK.finditer(text):
        if m.group(2) == name:
            return m.group(3)
    return None


def write_aside(path: Path, text: str) -> None:
    tmp = path.with_name(f".{path.name}.tmp{os.getpid()}")
    tmp.write_text(text)
    os.replace(tmp, path)


# ---- the rows of two runs -----------------------------------------------------------------------
#: columns measured on the host's clock, different from run to run by construction
WALL_CLOCK = {"/timing": {"start_err_us", "rtt_us", "arrival_us", "cycle_us"},
              "/link/stats": None, "/events": None}


#: heartbeats (HEARTBEAT_PLANT 0x050, HEARTBEAT_CTRL 0x051) go out when 100 ms pass without a
#: cycle: a host stall puts one between a cycle's frames in one run and not in another
HEARTBEAT_PREFIXES = ("050#", "051#")


def without_heartbeats(frames: str) -> str:
    return " ".join(f for f in str(frames).split() if not f.startswith(HEARTBEAT_PREFIXES))


def compare_rows(a_path: Path, b_path: Path) -> tuple[bool, list[str]]:
    """Every recorded row of two recordings, value for value (NaN equal to NaN), but the
    wall-clock ones: the timing columns, the handshake's row of /link/frames (seq -1: its random
    session number) and the heartbeats between a cycle's frames. (identical?, one line per topic)."""
    import numpy as np

    from hil_bench.record.recording import load_recording

    a, b = load_recording(a_path), load_recording(b_path)
    same, lines = True, []
    for topic in sorted(set(a.topics) | set(b.topics)):
        skip = WALL_CLOCK.get(topic, set())
        if skip is None:
            lines.append(f"{topic}: not compared (wall-clock rows)")
            continue
        if topic not in a.topics or topic not in b.topics:
            lines.append(f"{topic}: only in {a_path.name if topic in a.topics else b_path.name}")
            same = False
            continue
        da, db = a.topic(topic), b.topic(topic)
        keep = slice(None)
        if topic == "/link/frames":
            keep = np.asarray(da["seq"]) >= 0
            if not np.array_equal(keep, np.asarray(db["seq"]) >= 0):
                lines.append(f"{topic}: different cycles")
                same = False
                continue
        differ = []
        for col, values in da.items():
            if col in skip:
                continue
            x, y = np.asarray(values)[keep], np.asarray(db.get(col, []))[keep]
            if topic == "/link/frames" and col in ("tx", "rx"):
                x = np.asarray([without_heartbeats(v) for v in x])
                y = np.asarray([without_heartbeats(v) for v in y])
            if x.shape != y.shape:
                differ.append(f"{col} ({x.shape[0]} rows against {y.shape[0]})")
            elif x.dtype.kind in "fc":
                if not np.array_equal(x, y, equal_nan=True):
                    differ.append(col)
            elif x.tolist() != y.tolist():
                differ.append(col)
        rows = len(np.asarray(next(iter(da.values())))[keep])
        lines.append(f"{topic}: {rows} rows " + (f"DIFFER in {', '.join(differ)}" if differ
                                                 else "identical"))
        same &= not differ
    return same, lines


# ---- speed -----------------------------------------------------------------------------------
def _cpu(who: int) -> float:
    r = resource.getrusage(who)
    return r.ru_utime + r.ru_stime


def speed_run(link: str, out: Path) -> dict:
    from hil_bench.loop.runner import run_scenario
    from hil_bench.scenario import load_scenario

    scn = load_scenario("gong_g2_500rpm")
    load = os.getloadavg()[0]
    s0, c0, t0 = _cpu(resource.RUSAGE_SELF), _cpu(resource.RUSAGE_CHILDREN), time.monotonic()
    result = run_scenario(scn, link_spec=link, out_path=out / f"g2_{link}.mcap", progress=False,
                          force=True)
    wall = time.monotonic() - t0
    own, children = _cpu(resource.RUSAGE_SELF) - s0, _cpu(resource.RUSAGE_CHILDREN) - c0
    target = getattr(result, "target", {}) or {}
    emu = float(target["emulator_cpu_s"]) if target.get("emulator_cpu_s") else None
    cycles = result.cycles_done
    return {"link": link, "ok": bool(result.ok), "error": result.error, "cycles": cycles,
            "load_avg_1min": round(load, 1), "wall_s": round(wall, 2),
            "cycles_per_s": round(cycles / wall), "bench_cpu_s": round(own, 2),
            "children_cpu_s": round(children, 2),
            "emulator_cpu_s": emu, "cycles_per_cpu_s": round(cycles / max(own + children, 1e-9)),
            "isr_instructions_mean": target.get("isr_instructions_mean")}


def speed(repeats: int, links: list[str]) -> list[dict]:
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for i in range(repeats):
            for link in links:
                row = speed_run(link, Path(tmp))
                rows.append(row)
                emu = f"{row['emulator_cpu_s']:.1f}" if row["emulator_cpu_s"] is not None else "-"
                print(f"{link:9s} #{i + 1}: {row['cycles']} cycles in {row['wall_s']:.1f} s "
                      f"({row['cycles_per_s']} cycles/s; load average {row['load_avg_1min']}); "
                      f"CPU s: bench {row['bench_cpu_s']:.2f}, children {row['children_cpu_s']:.2f}"
                      f" (emulator {emu}); {row['cycles_per_cpu_s']} cycles per CPU second"
                      + ("" if row["ok"] else f"; FAILED: {row['error']}"), flush=True)
    for link in links:
        mine = [r for r in rows if r["link"] == link and r["ok"]]
        if mine:
            print(f"{link:9s} median of {len(mine)}: wall "
                  f"{statistics.median(r['wall_s'] for r in mine):.1f} s, "
                  f"{statistics.median(r['cycles_per_s'] for r in mine):.0f} cycles/s, "
                  f"{statistics.median(r['cycles_per_cpu_s'] for r in mine):.0f} cycles per CPU "
                  f"second")
    return rows


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=CASE_SECONDS, help="simulated seconds per case")
    ap.add_argument("--cases", default="", help="comma-separated scenario names (default: all)")
    ap.add_argument("--json", action="store_true", help="also print the figures as JSON")
    ap.add_argument("--write-docs", action="store_true",
                    help=f"write the footprint and ISR blocks into {DOC.name}")
    ap.add_argument("--check-docs", action="store_true",
                    help=f"compare {DOC.name}'s footprint block with the ELF (no emulator run)")
    ap.add_argument("--speed", action="store_true", help="time the full G2 on pil-qemu and the stub")
    ap.add_argument("--repeats", type=int, default=1, help="--speed: runs per link")
    ap.add_argument("--links", default="pil-qemu,stub", help="--speed: links to time")
    ap.add_argument("--compare-rows", nargs=2, type=Path, metavar=("A.mcap", "B.mcap"),
                    help="compare every recorded row of two recordings (exit 1 if they differ)")
    args = ap.parse_args(argv)
    if args.compare_rows:
        same, lines = compare_rows(*args.compare_rows)
        print("\n".join(lines))
        print("identical" if same else "DIFFERENT")
        return 0 if same else 1
    if args.speed:
        rows = speed(args.repeats, args.links.split(","))
        if args.json:
            print(json.dumps(rows))
        return 0 if all(r["ok"] for r in rows) else 1

    from hil_bench.loop.links.qemu import firmware_elf

    elf = firmware_elf()
    fp = footprint(elf)
    foot = footprint_markdown(fp)
    if args.check_docs:
        have = generated_block(DOC.read_text(), "target_footprint")
        if have != foot:
            print(f"{DOC} is stale: its footprint block says\n{have}\nthe ELF ({elf}) gives\n{foot}"
                  f"run: python -m hil_bench.perf.target --write-docs", file=sys.stderr)
            return 1
        return 0
    print(f"{elf}: flash {fp['flash_bytes']} B (text {fp['text']}, data {fp['data']}), static RAM "
          f"{fp['ram_static_bytes']} B (data + bss {fp['data'] + fp['bss']}, stats block "
          f"{fp['stats_block']})")
    rows: list[CaseRow] = []
    chosen = [c for c in CASES if not args.cases or c[0] in args.cases.split(",")]
    print(f"\n{'case':52s} {'cycles':>6s} {'ISR instr mean':>14s} {'min':>7s} {'max':>7s} "
          f"{'stack B':>8s} {'wall s':>7s}")
    with tempfile.TemporaryDirectory() as tmp:
        for name, what in chosen:
            r = run_case(name, what, args.seconds, Path(tmp))
            rows.append(r)
            print(f"{what:52s} {r.cycles:6d} {r.isr_mean:14.0f} {r.isr_min:7.0f} {r.isr_max:7.0f} "
                  f"{r.stack_used:8d} {r.wall_s:7.1f}", flush=True)
    if rows:
        print(f"(counter check: {rows[0].calibration})")
    if args.write_docs:
        if chosen != CASES:
            raise SystemExit("--write-docs runs every case (drop --cases)")
        new = render_docs(DOC.read_text(), {"target_footprint": foot,
                                            "target_isr": isr_markdown(rows, args.seconds)})
        write_aside(DOC, new)
        print(f"wrote {DOC}")
    if args.json:
        print(json.dumps({"footprint": fp, "cases": [r.__dict__ for r in rows]}))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
