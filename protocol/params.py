"""What each CONFIG parameter means: unit, kind (how it travels in the binary32 CONFIG.value), range, the
enum's values, the default, the protocol version that added it, and the meaning with its formula where the
controller derives or uses it by one.

All of it is in protocol/hil.dbc, one multiplexed signal of CONFIG per parameter (multiplexer
``param_id``: its unit, range and value table; the attributes ``HilParamKind``, ``HilParamDefault``,
``HilParamRequired``, ``HilSince``; the meaning as the signal's comment), so a drive team generates its
tables from the DBC alone; this module reads it (``hil_bench.protocol.dbc.param_specs``) into plain records
for the spec (``python protocol/gen_docs.py`` writes docs/protocol.md section 6.2 from them), for the
scenario loader (``bench/scenario/scenario.py`` refuses an integer parameter given as 4.5 before anything
starts) and for the conformance kit. Tests check that the C stub's defaults, kinds and ranges
(``firmware_stub/src/ctrl_params.c`` takes its ranges from the generated ``HIL_CONFIG_<NAME>_MIN/_MAX``,
``controller.c`` its defaults) are these.

Defaults are the values a controller starts every session with (an accepted HELLO returns to them:
docs/protocol.md 6.1), the stub's. ``REQUIRED`` parameters have none: RUN before the session has set them
is an incomplete configuration (FAULT_CTRL CONFIG_INVALID, 6.3). The range is what the reference drive (the
stub) accepts; a drive may answer OUT_OF_RANGE to more (6.2).

Kinds (docs/protocol.md 6.2):

* ``real``: any finite binary32 in the parameter's unit;
* ``integer``: an integral value sent as its binary32 (4 pole pairs = 4.0);
* ``boolean``: 0.0 = off, 1.0 = on, nothing else;
* ``enum``: one of the listed integers, as binary32.

Angles and speeds: "mechanical" = of the rotor shaft, "electrical" = mechanical x pole pairs.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from . import dbc

KINDS = dbc.PARAM_KINDS

#: the default of a parameter that has none: the session must set it before RUN
REQUIRED = None


@dataclass(frozen=True)
class ParamInfo:
    name: str
    unit: str
    kind: str
    meaning: str
    values: tuple[tuple[int, str], ...] = ()   # enum: (value, meaning)
    default: float | None = REQUIRED          # REQUIRED (None): no default
    minimum: float = -math.inf                # the range the reference drive accepts, inclusive
    maximum: float = math.inf
    since: str = "1.0"                        # the protocol version that added it
    param_id: int = 0

    @property
    def required(self) -> bool:
        return self.default is REQUIRED

    def check(self, value: float) -> str | None:
        """None if ``value`` is a valid value of this kind, else why not (names the rule)."""
        if not isinstance(value, (int, float)) or isinstance(value, bool) or not math.isfinite(value):
            return f"must be a finite number, got {value!r}"
        if abs(value) > 3.4028234663852886e38:
            return f"{value!r} does not fit a binary32 CONFIG value"
        if self.kind == "real":
            return None
        if float(value) != int(value):
            return f"is an {self.kind} parameter: must be a whole number, got {value!r}"
        if self.kind == "boolean" and value not in (0, 1):
            return f"is a boolean parameter: 0 (off) or 1 (on), got {value!r}"
        if self.kind == "enum" and int(value) not in {v for v, _ in self.values}:
            allowed = ", ".join(f"{v} = {m}" for v, m in self.values)
            return f"must be one of {allowed}; got {value!r}"
        return None


def _from_dbc(p: dbc.ParamSpec) -> ParamInfo:
    return ParamInfo(name=p.name, unit=p.unit, kind=p.kind, meaning=p.meaning, values=p.values,
                     default=p.default, minimum=p.minimum, maximum=p.maximum, since=p.since,
                     param_id=p.param_id)


#: Every parameter of the DBC's Param table, in id order.
PARAMS: tuple[ParamInfo, ...] = tuple(_from_dbc(p) for p in dbc.param_specs())

BY_NAME: dict[str, ParamInfo] = {p.name: p for p in PARAMS}

#: the motor's parameters: required (no default), the host always sends them (docs/protocol.md 6.2)
MOTOR: tuple[str, ...] = tuple(p.name for p in PARAMS if p.required)


def _g(x: float) -> str:
    return f"{x:g}"


def markdown_table() -> str:
    """The parameter table of docs/protocol.md section 6.2 (written by protocol/gen_docs.py)."""
    out = ["| id | parameter | unit | kind | range | default | since | meaning |",
           "|---|---|---|---|---|---|---|---|"]
    for p in PARAMS:
        kind = p.kind
        if p.values:
            kind += ": " + ", ".join(f"{v} = {m}" for v, m in p.values)
        default = "**required**" if p.required else _g(p.default)
        meaning = p.meaning.replace("|", "\\|")
        out.append(f"| {p.param_id} | {p.name} | {p.unit} | {kind} | {_g(p.minimum)} .. {_g(p.maximum)} | "
                   f"{default} | {p.since} | {meaning} |")
    return "\n".join(out) + "\n"
