#!/usr/bin/env python3
"""Fill the generated tables of docs/real-drive.md: the TMS320F28335's SCI rates near 1 Mbaud, the
links' budgets (protocol/budget.py) and which bundled scenarios each link carries in real time and
how long their cycles take on the wire in lockstep.

A generated table sits between ``<!-- BEGIN GENERATED: <name> -->`` and ``<!-- END GENERATED:
<name> -->``; the rest of the page is written by hand. Usage::

    python tools/gen_real_drive.py           # rewrite the tables
    python tools/gen_real_drive.py --check   # exit 1 with a diff if docs/real-drive.md is stale
"""
from __future__ import annotations

import argparse
import difflib
import math
import re
import sys
from dataclasses import dataclass
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
DOC = REPO / "docs" / "real-drive.md"

# ---- the TMS320F28335's SCI (SPRS439Q "Clocking and Nomenclature"; the SCI's baud-select
# registers, TI's C28x SCI reference guides: baud = LSPCLK / ((BRR + 1) x 8), BRR 1..65535) ------
SYSCLKOUT_HZ = 150e6
#: LOSPCP -> LSPCLK = SYSCLKOUT / (2 LOSPCP), SYSCLKOUT for 0; the reset value is 2
LOSPCP_RESET = 2
LSPCLK_MAX_HZ = 75e6            #: the data sheet's maximum LSPCLK (150-MHz devices)
SCI_TOLERANCE = 0.02            #: the error two ends of an 8N1 link may have together, a design margin
#: FTDI chips divide a base clock by n + k/8 (FTDI AN232B-05): FT232R / FT-X 3 MHz, FT232H 12 MHz
FTDI_BASES_HZ = (("FT232R", 3e6), ("FT232H", 12e6))


def lspclk_hz(lospcp: int) -> float:
    return SYSCLKOUT_HZ if lospcp == 0 else SYSCLKOUT_HZ / (2 * lospcp)


def sci_baud(lspclk: float, brr: int) -> float:
    return lspclk / 16 if brr == 0 else lspclk / ((brr + 1) * 8)


def ftdi_baud(base_hz: float, baud: float) -> float:
    """The rate an FTDI chip makes for ``baud``: the divisor rounded to the nearest eighth."""
    return base_hz / (round(base_hz / baud * 8) / 8)


def _pct(x: float) -> str:
    return f"{x * 100:+.2f} %"


def _baud(x: float) -> str:
    return f"{x:,.0f}".replace(",", " ")


def table_sci_baud() -> str:
    out = ["| LOSPCP | LSPCLK | BRR | SCI baud | vs 1 Mbaud | FT232R makes | FT232H makes | |",
           "|---|---|---|---|---|---|---|---|"]
    for lospcp in (LOSPCP_RESET, 1, 0):
        lsp = lspclk_hz(lospcp)
        ideal = lsp / 8e6 - 1                           # BRR for exactly 1 Mbaud
        for brr in (math.floor(ideal), math.ceil(ideal)):
            baud = sci_baud(lsp, brr)
            ftdi = " | ".join(f"{_baud(ftdi_baud(b, baud))} ({_pct(ftdi_baud(b, baud) / baud - 1)})"
                              for _, b in FTDI_BASES_HZ)
            if lsp > LSPCLK_MAX_HZ:
                note = "LSPCLK above the data sheet's 75 MHz: not allowed"
            elif abs(baud / 1e6 - 1) <= SCI_TOLERANCE:
                note = "1 Mbaud within 2 %"
            else:
                note = f"set the adapter to {_baud(baud)}"
            reset = " (reset)" if lospcp == LOSPCP_RESET else (" (maximum)" if lsp == LSPCLK_MAX_HZ
                                                                 else "")
            out.append(f"| {lospcp} | {lsp / 1e6:g} MHz{reset} | {brr} | {_baud(baud)} | "
                       f"{_pct(baud / 1e6 - 1)} | {ftdi} | {note} |")
    return "\n".join(out) + "\n"


# ---- the links ---------------------------------------------------------------------------------

@dataclass(frozen=True)
class LinkRow:
    name: str
    serial_baud: float | None = None
    can_bitrate: float | None = None
    fd: bool = False
    data_bitrate: float | None = None

    def max_rate_hz(self, flags: int) -> float:
        from hil_bench.protocol import budget
        if self.serial_baud:
            return budget.serial_max_rate_hz(self.serial_baud, flags)
        return budget.can_max_rate_hz(self.can_bitrate, flags, fd=self.fd,
                                      data_bitrate=self.data_bitrate)


F28335_SCI = LinkRow("F28335 SCI 937 500 baud (LSPCLK 37.5 MHz, BRR 4)", serial_baud=937_500)
UART_1M = LinkRow("UART 1 Mbaud (an STM32 USART, a 1 Mbaud adapter)", serial_baud=1_000_000)
CAN_1M = LinkRow("classic CAN 1 Mbit/s (F28335 eCAN)", can_bitrate=1_000_000)
LINKS = (LinkRow("UART 921 600 baud", serial_baud=921_600), F28335_SCI, UART_1M,
         LinkRow("F28335 SCI 1 041 667 baud (LSPCLK 75 MHz, BRR 8)", serial_baud=1_041_667),
         LinkRow("UART 3 Mbaud", serial_baud=3_000_000),
         LinkRow("classic CAN 500 kbit/s", can_bitrate=500_000), CAN_1M,
         LinkRow("CAN FD 1 Mbit/s, data 5 Mbit/s (BRS)", can_bitrate=1_000_000, fd=True,
                 data_bitrate=5_000_000))
#: the links of the scenario table's real-time columns
FIT_LINKS = (F28335_SCI, UART_1M, CAN_1M)


def _hz(x: float) -> str:
    return f"{math.floor(x + 1e-6):,}".replace(",", " ") + " Hz"


def table_link_budget() -> str:
    from hil_bench.protocol import budget
    flag_sets = (0, budget.TELEM_EMF, budget.DUAL_SAMPLING | budget.TELEM_EMF)
    out = ["| link | base (4 frames) | + TELEM_EMF (G2's 5 frames) | dual sampling + TELEM_EMF (6) | "
           "G2's frames of one cycle on the wire |", "|---|---|---|---|---|"]
    for link in LINKS:
        rates = " | ".join(_hz(link.max_rate_hz(f)) for f in flag_sets)
        out.append(f"| {link.name} | {rates} | "
                   f"{1e6 / link.max_rate_hz(budget.TELEM_EMF):.0f} us |")
    return "\n".join(out) + "\n"


@dataclass(frozen=True)
class ScenarioRate:
    name: str
    ts_s: float
    flags: int
    cycles: int
    realtime: bool     # the scenario runs in real time by itself ([scenario] mode)


def bundled_rates() -> list[ScenarioRate]:
    from hil_bench.plant_rt.plant import Plant
    from hil_bench.plant_rt.profile import load_profile
    from hil_bench.scenario import SCENARIO_DIR, load_scenario

    out = []
    for path in sorted(SCENARIO_DIR.glob("*.toml")):
        scn = load_scenario(path)
        params = Plant(load_profile(scn.profile), **scn.plant_overrides).params
        ts = float(params.ts_s)
        out.append(ScenarioRate(scn.name, ts, scn.hello_flags(bool(params.dual_sampling)),
                                round(scn.duration_s / ts), scn.mode == "realtime"))
    return out


def _frames(flags: int) -> str:
    from hil_bench.protocol import budget
    up, down = budget.cycle_messages(flags)
    extra = [n for n in up + down if n not in ("SENSE_AUX", "SENSE", "TELEM", "DUTY")]
    return f"{len(up) + len(down)}" + (f" (+{', '.join(extra)})" if extra else "")


def table_scenario_fit() -> str:
    head = " | ".join(f"real time on {link.name.split(' (')[0]}" for link in FIT_LINKS)
    out = [f"| scenario | control rate | frames | {head} | lockstep on the 937 500 baud SCI: "
           f"wire time per cycle, whole run at least |",
           "|---|---|---|" + "---|" * len(FIT_LINKS) + "---|"]
    for s in bundled_rates():
        rate = 1.0 / s.ts_s
        cells = []
        for link in FIT_LINKS:
            top = link.max_rate_hz(s.flags)
            cells.append(f"yes ({rate / top:.0%} of its budget)" if rate <= top * (1 + 1e-9)
                         else f"no (it carries {_hz(top)})")
        wire_s = 1.0 / F28335_SCI.max_rate_hz(s.flags)
        out.append(f"| `{s.name}` | {_baud(rate)} Hz | {_frames(s.flags)} | {' | '.join(cells)} | "
                   f"{wire_s * 1e6:.0f} us, {s.cycles * wire_s:.1f} s ({_baud(s.cycles)} cycles) |")
    return "\n".join(out) + "\n"


SECTIONS = {"sci_baud": table_sci_baud, "link_budget": table_link_budget,
            "scenario_fit": table_scenario_fit}


def render(text: str) -> str:
    for name, fn in SECTIONS.items():
        pattern = re.compile(rf"(<!-- BEGIN GENERATED: {name} -->\n)(.*?)(<!-- END GENERATED: {name} -->)", re.S)
        if not pattern.search(text):
            raise SystemExit(f"{DOC}: no generated section {name!r}")
        text = pattern.sub(lambda m: m.group(1) + fn() + m.group(3), text)
    return text


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--check", action="store_true", help="exit 1 if docs/real-drive.md is stale")
    args = ap.parse_args(argv)
    old = DOC.read_text()
    new = render(old)
    if args.check:
        if new != old:
            sys.stdout.writelines(difflib.unified_diff(old.splitlines(True), new.splitlines(True),
                                                       str(DOC), "generated"))
            print(f"{DOC} is stale: run python tools/gen_real_drive.py", file=sys.stderr)
            return 1
        return 0
    if new != old:
        tmp = DOC.with_name(DOC.name + ".tmp")
        tmp.write_text(new)
        tmp.replace(DOC)
    return 0


if __name__ == "__main__":
    sys.exit(main())
