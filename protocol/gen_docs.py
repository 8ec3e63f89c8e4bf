#!/usr/bin/env python3
"""Fill the generated sections of docs/protocol.md from the DBC, the encoder, protocol/budget.py,
protocol/params.py, protocol/timing.py and protocol/versions.py (the changelog).

A generated section sits between ``<!-- BEGIN GENERATED: <name> -->`` and ``<!-- END GENERATED: <name> -->``;
everything else in the document is hand-written. Usage::

    python protocol/gen_docs.py           # rewrite the sections
    python protocol/gen_docs.py --check   # exit 1 with a diff if docs/protocol.md is stale
"""
from __future__ import annotations

import argparse
import difflib
import re
import sys
from pathlib import Path

from hil_bench.protocol import budget, dbc, framing, timing, versions
from hil_bench.protocol.messages import MESSAGES

DOC = Path(__file__).resolve().parents[1] / "docs" / "protocol.md"


def _hex(data: bytes) -> str:
    return " ".join(f"{b:02X}" for b in data)


def _num(x: float | int) -> str:
    """Exact and short: integers plainly, other floats by their shortest round-trip repr."""
    if isinstance(x, float) and x.is_integer() and abs(x) < 1e15:
        return str(int(x))
    return repr(x)


def section_example() -> str:
    msg = MESSAGES["SENSE"]
    values = {"seq": 1, "i_a": 1.5, "i_b": -0.75, "i_c": -0.75}
    payload = msg.pack(**values)
    header = bytes((msg.frame_id & 0xFF, msg.frame_id >> 8, len(payload)))
    crc = framing.crc16(header + payload)
    raw = header + payload + bytes((crc & 0xFF, crc >> 8))
    cobs = framing.cobs_encode(raw)
    wire = framing.encode_frame(msg.frame_id, payload)
    assert wire == cobs + b"\x00"
    raws = msg.unpack_raw(payload)
    blocks = []
    i = 0
    while i < len(cobs):
        code = cobs[i]
        blocks.append(f"`{cobs[i]:02X}` + {code - 1} octet(s) `{_hex(cobs[i + 1:i + code]) or '-'}`")
        i += code
    lines = [
        f"SENSE (id 0x{msg.frame_id:03X}) with seq = 1, i_a = 1.5 A, i_b = -0.75 A, i_c = -0.75 A:",
        "",
        "| step | octets (hex) |",
        "|---|---|",
        f"| raw signals (scale 0.001 A) | seq = {raws[0]}, i_a = {raws[1]}, i_b = {raws[2]}, i_c = {raws[3]} |",
        f"| payload (8 octets, little-endian) | `{_hex(payload)}` |",
        f"| id_lo id_hi dlc | `{_hex(header)}` |",
        f"| CRC-16/CCITT-FALSE over id, dlc, payload | 0x{crc:04X} -> `{crc & 0xFF:02X} {crc >> 8:02X}` |",
        f"| frame before COBS ({len(raw)} octets) | `{_hex(raw)}` |",
        f"| COBS ({len(cobs)} octets) | `{_hex(cobs)}` |",
        f"| on the wire, delimiter added ({len(wire)} octets) | `{_hex(wire)}` |",
        "",
        "COBS blocks: " + "; ".join(blocks) + ". Each code octet but the first stands for the 0x00 that "
        "ended the block before it.",
        "",
        f"An empty frame (dlc 0, id 0x7FF) is `{_hex(framing.encode_frame(0x7FF, b''))}`.",
    ]
    return "\n".join(lines) + "\n"


def _meaning(s: dbc.SignalSpec) -> str:
    tables = {(m, sig): t for t in dbc.value_tables() for m, sig in t.signals}
    parts = []
    if (s.message, s.name) in tables:
        t = tables[(s.message, s.name)]
        parts.append(f"value table `{t.py_name}` (C `{t.c_prefix}_*`)")
    for sen in dbc.sentinels():
        if sen.message == s.message and s.name in sen.signals:
            parts.append(f"raw {sen.raw} = {sen.name} (`{sen.c_macro}`)")
    if s.comment:
        parts.append(s.comment)
    return "; ".join(parts).replace("|", "\\|")


def section_messages() -> str:
    out = [f"Bus type (DBC attribute `BusType`): {dbc.bus_type()}. Column *sent* is the DBC attribute "
           "`HilSent` (with `GenMsgCycleTime` for the heartbeats).", "",
           "| message | id hex | id dec | length | sender | sent | meaning |", "|---|---|---|---|---|---|---|"]
    for m in dbc.message_specs():
        sent = m.sent_text
        out.append(f"| [{m.name}](#{m.name.lower()}) | 0x{m.frame_id:03X} | {m.frame_id} | {m.length} | "
                   f"{m.sender} | {sent} | {m.comment} |")
    out.append("")
    for m in dbc.message_specs():
        out.append(f"#### {m.name}")
        out.append("")
        out.append(f"id 0x{m.frame_id:03X} ({m.frame_id}), {m.length} octets, sent by {m.sender}. {m.comment}")
        out.append("")
        out.append("| signal | start bit | bits | signed | scale | offset | unit | range | raw range | meaning |")
        out.append("|---|---|---|---|---|---|---|---|---|---|")
        for s in m.signals:
            kind = "float32" if s.is_float else ("yes" if s.is_signed else "no")
            raw_range = "IEEE binary32" if s.is_float else f"{s.raw_min} .. {s.raw_max}"
            rng = f"[{_num(s.minimum)}, {_num(s.maximum)}]"
            if s.is_cyclic:
                raw_range += ", wraps"
            if (s.dbc_minimum, s.dbc_maximum) != (s.minimum, s.maximum):
                rng += f" (DBC [{_num(s.dbc_minimum)}, {_num(s.dbc_maximum)}])"
            out.append(f"| {s.name} | {s.start_bit} | {s.length_bits} | {kind} | {_num(s.scale)} | "
                       f"{_num(s.offset)} | {s.unit} | {rng} | {raw_range} | "
                       f"{_meaning(s)} |")
        out.append("")
    return "\n".join(out)


def section_value_tables() -> str:
    out = []
    for t in dbc.value_tables():
        where = ", ".join(f"{m}.{s}" for m, s in t.signals)
        out.append(f"**{t.py_name}** ({where}; C `{t.c_type}`, `{t.c_prefix}_<NAME>`)")
        out.append("")
        out.append("| value | name |")
        out.append("|---|---|")
        for name, value in t.values.items():
            out.append(f"| {value} | {name} |")
        out.append("")
    for sen in dbc.sentinels():
        out.append(f"**{sen.message} {sen.name}**: raw {sen.raw} in {', '.join(sen.signals)} "
                   f"(C `{sen.c_macro}`, Python `DUTY_RAW_OFF`).")
        out.append("")
    for table in dbc.flag_tables():
        title, prefix, flags = f"{table.message}.{table.signal}", table.c_prefix, table.bits
        out.append(f"**{title}** bits (C `{prefix}_<NAME>`, Python `{table.py_name}`; the DBC value table "
                   f"names every combination, e.g. {(1 << len(flags)) - 1} = "
                   f"`{'+'.join(f.name for f in flags)}`; other bits are 0)")
        out.append("")
        out.append("| bit | mask | name | meaning |")
        out.append("|---|---|---|---|")
        for f in flags:
            out.append(f"| {f.bit} | 0x{f.mask:02X} | {f.name} | {f.meaning} |")
        out.append("")
    return "\n".join(out)


def section_params() -> str:
    from hil_bench.protocol import params

    return params.markdown_table()


SECTIONS = {
    "params": section_params,
    "example": section_example,
    "messages": section_messages,
    "value_tables": section_value_tables,
    "budget": budget.markdown_tables,
    "timing": timing.markdown_table,
    "changelog": versions.markdown_changelog,
}

_BLOCK = re.compile(r"(<!-- BEGIN GENERATED: (\w+) -->\n)(.*?)(<!-- END GENERATED: \2 -->)", re.S)


def render(text: str) -> str:
    seen = set()

    def fill(m: re.Match) -> str:
        name = m.group(2)
        if name not in SECTIONS:
            raise SystemExit(f"gen_docs: unknown generated section {name!r}")
        seen.add(name)
        return m.group(1) + SECTIONS[name]().rstrip("\n") + "\n" + m.group(4)

    out = _BLOCK.sub(fill, text)
    missing = set(SECTIONS) - seen
    if missing:
        raise SystemExit(f"gen_docs: {DOC} lacks the sections {sorted(missing)}")
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description="fill the generated sections of docs/protocol.md")
    ap.add_argument("--check", action="store_true", help="compare, do not write")
    args = ap.parse_args(argv)
    old = DOC.read_text()
    new = render(old)
    if args.check:
        if old != new:
            sys.stdout.writelines(difflib.unified_diff(old.splitlines(True), new.splitlines(True),
                                                       "docs/protocol.md (committed)", "docs/protocol.md (generated)"))
            print("gen_docs.py --check: docs/protocol.md is stale; run python protocol/gen_docs.py", file=sys.stderr)
            return 1
        return 0
    if old != new:
        DOC.write_text(new)
        print(f"wrote {DOC}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
