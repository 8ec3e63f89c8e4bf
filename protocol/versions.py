#!/usr/bin/env python3
"""The protocol's versions: the tables of each released version, their hashes, what changed, and what a
session of an older minor version leaves out.

**The rule.** Every change to the tables (a message, a signal's layout or range, a value-table entry, a
CONFIG parameter's unit, kind, range or default) is a new version: the DBC's ``VERSION`` string says it,
``python protocol/versions.py --record`` writes its tables to ``protocol/versions/<version>.json`` and
their SHA-256 to ``protocol/versions/versions.toml``, and ``NOTES`` below says in words what the tables
cannot (a new field's meaning, how an older peer is served). ``tests/test_protocol_versions.py`` hashes
the tables of protocol/hil.dbc and fails when they differ from the hash recorded for the DBC's version: a
table that changed without a new version cannot pass. Comments and meanings are not hashed (rewording a
meaning is not a protocol change; changing what a parameter does is, and takes a new version by hand).

Versions are ``major.minor``. A new minor only adds (a message, a signal in bits that were 0, a value-table
entry, a parameter): a drive of an older minor keeps working against a newer host, which sends it only
what its version knows (docs/protocol.md 6.1 and section 10). A new major breaks that and is refused at
HELLO (VERSION_MISMATCH).

``python protocol/gen_docs.py`` writes the changelog of docs/protocol.md section 10 from the snapshots
(``markdown_changelog``): per version, per message, value table and parameter, what was added or changed.
"""
from __future__ import annotations

import argparse
import hashlib
import json
import sys
import tomllib
from dataclasses import dataclass
from pathlib import Path

from hil_bench.protocol import dbc

VERSIONS_DIR = Path(__file__).resolve().with_name("versions")
HASHES = VERSIONS_DIR / "versions.toml"

#: What the tables cannot say, per version: meanings, compatibility, how an older peer is served.
NOTES: dict[str, tuple[str, ...]] = {
    "1.0": ("The first versioned release (the tables at commit 058c260 of 2026-11-24, the last before the "
            "first addition of 1.1): the message set, the value tables and the 62 CONFIG parameters of "
            "protocol/versions/1.0.json; its DBC is protocol/versions/1.0.dbc.",),
    "1.1": (
        "HELLO carries the version both ways: HELLO.proto_minor (bits 4..7 of the octet whose bits 0..2 are "
        "the flags; a 1.0 controller ignores them, 1.0 section 3: undefined bits are ignored on reception) and "
        "HELLO_ACK.proto_minor (bits 4..7 of the octet whose low bits are the status; a 1.0 controller sends "
        "0 there, its statuses being 0..5): the minor version the session speaks, the lower of the two.",
        "A 1.0 controller is served, not refused (6.1): the host sends it only what 1.0 knows, says which 1.1 "
        "features are off, and refuses, before any cycle, a scenario that needs one (a parameter of 1.1 at a "
        "value other than its default, estimator SMO_STA, CMD RESTART).",
        "The 1.1 parameters' defaults are what a 1.0 controller does: LOOP_ANGLE 0 (the loop turns with the "
        "observer's angle, as every 1.0 SMO did), INV_COMP_ENABLE 0 (no feed-forward), SMO_STA_K1_V and "
        "SMO_STA_K2_V_S 0 (the estimator that reads them is itself new).",
        "RS_OHM's range starts above 0 (1e-06 ohm, was 0): a resistance of 0 ohm was accepted and then "
        "divided by in the derived gains.",
        "CONFIG in the DBC: param_id is a multiplexer and each parameter a multiplexed signal of its own "
        "(unit, range, enum values, attributes HilParamKind, HilParamDefault, HilParamRequired, HilSince). "
        "The CONFIG frame's octets are those of 1.0 (the shared vectors msg_config_* are unchanged).",
    ),
}


# ---------------------------------------------------------------------------------------------------------
# The tables, canonical
# ---------------------------------------------------------------------------------------------------------

def _signal(s: dbc.SignalSpec) -> dict:
    return {"name": s.name, "start_bit": s.start_bit, "length_bits": s.length_bits, "signed": s.is_signed,
            "float": s.is_float, "scale": s.scale, "offset": s.offset, "minimum": s.minimum,
            "maximum": s.maximum, "dbc_minimum": s.dbc_minimum, "dbc_maximum": s.dbc_maximum, "unit": s.unit,
            "choices": [[int(raw), str(name)] for raw, name in sorted(s.choices.items())]}


def _message(m: dbc.MessageSpec) -> dict:
    return {"name": m.name, "frame_id": m.frame_id, "length": m.length, "sender": m.sender, "sent": m.sent,
            "cycle_time_ms": m.cycle_time_ms, "signals": [_signal(s) for s in m.signals]}


def _param(p: dbc.ParamSpec) -> dict:
    return {"id": p.param_id, "name": p.name, "unit": p.unit, "kind": p.kind, "minimum": p.minimum,
            "maximum": p.maximum, "default": p.default, "values": [v for v, _ in p.values]}


def current_tables() -> dict:
    """The tables of protocol/hil.dbc as plain data: messages (the codec's view: CONFIG's multiplexed
    signals are its one value) with their signals and value tables, and the CONFIG parameters. No
    comments or meanings."""
    return {"version": dbc.proto_version_text(),
            "messages": [_message(m) for m in dbc.message_specs()],
            "params": [_param(p) for p in dbc.param_specs()]}


def tables_hash(tables: dict) -> str:
    """SHA-256 of the tables (without their version label), over canonical JSON."""
    body = {k: v for k, v in tables.items() if k != "version"}
    text = json.dumps(body, sort_keys=True, separators=(",", ":"), allow_nan=False)
    return hashlib.sha256(text.encode()).hexdigest()


def recorded_hashes() -> dict[str, str]:
    """Version -> recorded hash (protocol/versions/versions.toml)."""
    with HASHES.open("rb") as f:
        return {str(k): str(v) for k, v in tomllib.load(f).get("versions", {}).items()}


def _key(version: str) -> tuple[int, int]:
    major, minor = version.split(".")
    return int(major), int(minor)


def versions() -> list[str]:
    """Every recorded version, oldest first."""
    return sorted(recorded_hashes(), key=_key)


def snapshot(version: str) -> dict:
    """The recorded tables of a version (protocol/versions/<version>.json)."""
    path = VERSIONS_DIR / f"{version}.json"
    if not path.exists():
        raise KeyError(f"protocol version {version} has no recorded tables ({path})")
    return json.loads(path.read_text())


# ---------------------------------------------------------------------------------------------------------
# What changed
# ---------------------------------------------------------------------------------------------------------

_SIGNAL_FIELDS = ("start_bit", "length_bits", "signed", "float", "scale", "offset", "minimum", "maximum",
                  "dbc_minimum", "dbc_maximum", "unit")
_PARAM_FIELDS = ("unit", "kind", "minimum", "maximum", "default", "values")


def _fmt(x) -> str:
    if x is None:
        return "required"
    if isinstance(x, float):
        return f"{x:g}"
    return str(x)


def changes(old: dict, new: dict) -> list[tuple[str, str]]:
    """(subject, what changed) from the tables ``old`` to ``new``: messages, signals, value-table entries,
    parameters added, removed or changed."""
    out: list[tuple[str, str]] = []
    om = {m["name"]: m for m in old["messages"]}
    nm = {m["name"]: m for m in new["messages"]}
    for name in [n for n in nm if n not in om]:
        out.append((name, f"new message, id 0x{nm[name]['frame_id']:03X}"))
    for name in [n for n in om if n not in nm]:
        out.append((name, "removed"))
    for name, m in nm.items():
        if name not in om:
            continue
        o = om[name]
        for f in ("frame_id", "length", "sender", "sent", "cycle_time_ms"):
            if o[f] != m[f]:
                out.append((name, f"{f} {_fmt(o[f])} -> {_fmt(m[f])}"))
        osig = {s["name"]: s for s in o["signals"]}
        nsig = {s["name"]: s for s in m["signals"]}
        for sname, s in nsig.items():
            where = f"{name}.{sname}"
            if sname not in osig:
                out.append((where, f"new signal: bits {s['start_bit']}..{s['start_bit'] + s['length_bits'] - 1}"))
                continue
            os_ = osig[sname]
            diffs = [f"{f} {_fmt(os_[f])} -> {_fmt(s[f])}" for f in _SIGNAL_FIELDS if os_[f] != s[f]]
            if diffs:
                out.append((where, "; ".join(diffs)))
            oc = {raw: n for raw, n in os_["choices"]}
            nc = {raw: n for raw, n in s["choices"]}
            added = [f"{raw} {n}" for raw, n in nc.items() if raw not in oc]
            gone = [f"{raw} {n}" for raw, n in oc.items() if raw not in nc]
            renamed = [f"{raw} {oc[raw]} -> {n}" for raw, n in nc.items() if raw in oc and oc[raw] != n]
            if added and not (name in ("CONFIG", "CONFIG_ACK") and sname == "param_id"):
                out.append((where, "value table: new " + ", ".join(added)))
            if gone:
                out.append((where, "value table: removed " + ", ".join(gone)))
            if renamed:
                out.append((where, "value table: renamed " + ", ".join(renamed)))
        for sname in osig:
            if sname not in nsig:
                out.append((f"{name}.{sname}", "removed"))
    op = {p["name"]: p for p in old["params"]}
    for p in new["params"]:
        where = f"CONFIG {p['id']} {p['name']}"
        if p["name"] not in op:
            default = "required" if p["default"] is None else f"default {_fmt(p['default'])}"
            out.append((where, f"new parameter: {p['kind']}, {p['unit']}, {_fmt(p['minimum'])} .. "
                               f"{_fmt(p['maximum'])}, {default}"))
            continue
        diffs = [f"{f} {_fmt(op[p['name']][f])} -> {_fmt(p[f])}" for f in _PARAM_FIELDS if op[p["name"]][f] != p[f]]
        if diffs:
            out.append((where, "; ".join(diffs)))
    for name in op:
        if name not in {p["name"] for p in new["params"]}:
            out.append((f"CONFIG {op[name]['id']} {name}", "removed"))
    return out


def markdown_changelog() -> str:
    """Section 10 of docs/protocol.md: per version, newest first, what changed from the one before (from the
    recorded tables) and the notes."""
    vs = versions()
    out = []
    for i in range(len(vs) - 1, -1, -1):
        v = vs[i]
        out.append(f"#### {v}")
        out.append("")
        out += [f"* {n}" for n in NOTES.get(v, ())]
        if i > 0:
            rows = changes(snapshot(vs[i - 1]), snapshot(v))
            out.append("")
            out.append(f"Tables, {vs[i - 1]} -> {v} (from `protocol/versions/{vs[i - 1]}.json` and `{v}.json`):")
            out.append("")
            out.append("| what | change |")
            out.append("|---|---|")
            out += [f"| {w} | {c.replace('|', '/')} |" for w, c in rows]
        out.append("")
    return "\n".join(out)


# ---------------------------------------------------------------------------------------------------------
# An older peer
# ---------------------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class Known:
    """What a session of one version knows: its parameters (name -> id), estimators and commands."""

    version: str
    params: frozenset[str]
    estimators: frozenset[str]
    commands: frozenset[str]


def _choices(tables: dict, message: str, signal: str) -> frozenset[str]:
    m = next(m for m in tables["messages"] if m["name"] == message)
    s = next(s for s in m["signals"] if s["name"] == signal)
    return frozenset(n for _, n in s["choices"])


def known(major: int, minor: int) -> Known:
    """What protocol ``major.minor`` knows: the recorded tables of that version, or today's DBC when it is
    the DBC's own version (a version newer than the DBC's knows at least what the DBC knows)."""
    version = f"{major}.{minor}"
    current = dbc.proto_version_text()
    if _key(version) >= _key(current):
        tables = current_tables()
    else:
        tables = snapshot(version)
    return Known(version, frozenset(p["name"] for p in tables["params"]),
                 _choices(tables, "HELLO", "estimator"), _choices(tables, "CMD", "command"))


class NeedsNewerVersion(ValueError):
    """A run needs what the version of its session does not have; the message names each item."""


def serve(params: dict, major: int, minor: int, needs_commands: dict[str, str] | None = None
          ) -> tuple[dict, list[str]]:
    """What a session of protocol ``major.minor`` is sent of ``params`` ({Param: value}), and the features
    left out: a parameter that version does not know is left out when its value is its default (the newer
    version's default is the older behaviour: NOTES), and the run refused (:class:`NeedsNewerVersion`)
    when it is at another value, or when a command of ``needs_commands`` (name -> what needs it) is newer."""
    from hil_bench.protocol.params import BY_NAME

    know = known(major, minor)
    served, off, needed = {}, [], []
    for p, value in params.items():
        info = BY_NAME[p.name]
        if p.name in know.params:
            served[p] = value
        elif info.default is not None and float(value) == info.default:
            off.append(f"{p.name} (added in {info.since}; left at its default {info.default:g})")
        else:
            needed.append(f"{p.name} = {float(value):g} (added in {info.since})")
    for command, why in (needs_commands or {}).items():
        if command not in know.commands:
            needed.append(f"CMD {command} ({why})")
    if needed:
        raise NeedsNewerVersion(
            f"the controller speaks protocol {major}.{minor} (HELLO_ACK.proto_minor = {minor}); this run needs "
            f"what {major}.{minor} does not have: {'; '.join(needed)}. Run it against a controller of protocol "
            f"{dbc.proto_version_text()} (docs/protocol.md section 10)")
    return served, off


def added_in(kind: str, name: str) -> str:
    """The first recorded version whose tables have ``name`` among ``kind`` ("params", "estimators",
    "commands"), or "a later version"."""
    for v in versions():
        if name in getattr(known(*map(int, v.split("."))), kind):
            return v
    return "a later version"


# ---------------------------------------------------------------------------------------------------------
# CLI
# ---------------------------------------------------------------------------------------------------------

def record() -> str:
    """Record the DBC's tables as its version; refuse to change a version already recorded."""
    tables = current_tables()
    version, digest = tables["version"], tables_hash(tables)
    hashes = recorded_hashes() if HASHES.exists() else {}
    if version in hashes and hashes[version] != digest:
        raise SystemExit(f"protocol {version} is recorded with other tables ({hashes[version][:12]}...): a "
                         f"released version never changes; raise the VERSION of protocol/hil.dbc and record that")
    path = VERSIONS_DIR / f"{version}.json"
    tmp = path.with_suffix(".json.tmp")
    tmp.write_text(json.dumps(tables, indent=1, allow_nan=False) + "\n")
    tmp.replace(path)
    hashes[version] = digest
    lines = ["# protocol version -> SHA-256 of its tables (python protocol/versions.py --record; the tables are",
             "# <version>.json beside this file; tests/test_protocol_versions.py checks the DBC against its version)",
             "[versions]"]
    lines += [f'"{v}" = "{hashes[v]}"' for v in sorted(hashes, key=_key)]
    tmp = HASHES.with_suffix(".toml.tmp")
    tmp.write_text("\n".join(lines) + "\n")
    tmp.replace(HASHES)
    return f"recorded protocol {version}: {digest}"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description="protocol versions: check or record the tables of protocol/hil.dbc")
    ap.add_argument("--record", action="store_true", help="record the DBC's tables as its VERSION")
    args = ap.parse_args(argv)
    if args.record:
        print(record())
        return 0
    tables = current_tables()
    want = recorded_hashes().get(tables["version"])
    got = tables_hash(tables)
    if want != got:
        print(f"protocol/hil.dbc: the tables of protocol {tables['version']} hash to {got[:12]}..., recorded "
              f"{(want or 'nothing')[:12]}...: a changed table needs a new VERSION (then --record)", file=sys.stderr)
        return 1
    print(f"protocol {tables['version']}: tables as recorded ({got[:12]}...)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
