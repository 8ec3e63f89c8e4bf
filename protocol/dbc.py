"""Read protocol/hil.dbc (the single source of the message set) into plain, checked specifications.

Everything the codecs, the C generator, the vector generator and the docs generator need is derived here
from the cantools database, once:

* ``message_specs()``: messages sorted by frame id, signals in start-bit order, with scale/offset,
  DBC range, raw type range and the DBC range expressed as raw integers (``raw_min``/``raw_max``);
* ``value_tables()``: the value tables, named for Python (``Param``) and C (``HIL_PARAM_``), each emitted
  once even when several messages carry it;
* ``sentinels()``: named raw values that lie outside a signal's range (DUTY's raw 65535 = ``OFF``);
* ``round_half_away()``: THE rounding rule of the protocol (shared with the generated C code).

Only what the naming tables below say is hand-written: how value tables are called in Python and C.
A DBC change that this module does not know how to name fails loudly (``DbcError``) instead of guessing.
"""
from __future__ import annotations

import functools
import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Mapping

import cantools

DBC_PATH = Path(__file__).resolve().with_name("hil.dbc")


class DbcError(RuntimeError):
    """The DBC uses something this protocol layer does not support, or a naming table is out of date."""


# ---------------------------------------------------------------------------------------------------------
# Naming tables (the only hand-written part): value table -> Python enum / C enum prefix.
# ---------------------------------------------------------------------------------------------------------

#: (Python IntEnum name, C constant prefix, C typedef, signals carrying the table as (message, signal))
_VALUE_TABLE_NAMING: tuple[tuple[str, str, str, tuple[tuple[str, str], ...]], ...] = (
    ("Param", "HIL_PARAM", "hil_param_t", (("CONFIG", "param_id"), ("CONFIG_ACK", "param_id"))),
    ("Estimator", "HIL_EST", "hil_estimator_t", (("HELLO", "estimator"), ("TELEM", "estimator"))),
    ("State", "HIL_STATE", "hil_state_t",
     (("HEARTBEAT_PLANT", "state"), ("HEARTBEAT_CTRL", "state"), ("TELEM", "state"))),
    ("Fault", "HIL_FAULT", "hil_fault_t", (("FAULT_PLANT", "code"), ("FAULT_CTRL", "code"))),
    ("Command", "HIL_CMD", "hil_command_t", (("CMD", "command"),)),
    ("HelloStatus", "HIL_HELLO_STATUS", "hil_hello_status_t", (("HELLO_ACK", "status"),)),
    ("ConfigStatus", "HIL_CONFIG_STATUS", "hil_config_status_t", (("CONFIG_ACK", "status"),)),
    ("Mode", "HIL_MODE", "hil_mode_t", (("HELLO", "mode"),)),
)

#: (message, signals, choice name, C macro): single named raw values outside the signal's DBC range.
_SENTINEL_NAMING: tuple[tuple[str, tuple[str, ...], str, str], ...] = (
    ("DUTY", ("d_a", "d_b", "d_c"), "OFF", "HIL_DUTY_RAW_OFF"),
)


@dataclass(frozen=True)
class FlagBit:
    """One bit of a flags byte. The DBC comment of the signal describes it as ``bit<N> ...``."""

    name: str
    bit: int
    meaning: str

    @property
    def mask(self) -> int:
        return 1 << self.bit


#: HELLO.flags (see the DBC comment of HELLO.flags; a test checks the comment names every bit).
HELLO_FLAGS: tuple[FlagBit, ...] = (
    FlagBit("DUAL_SAMPLING", 0, "dual sampling: the host sends SENSE_DUAL every cycle"),
    FlagBit("TELEM_EMF", 1, "the controller sends TELEM_EMF every cycle"),
    FlagBit("ENCODER_VALID", 2, "SENSE_AUX.theta_enc carries the true encoder angle"),
)
#: SENSE_AUX.flags (see the DBC comment of SENSE_AUX.flags).
SENSE_AUX_FLAGS: tuple[FlagBit, ...] = (
    FlagBit("DUAL_FOLLOWS", 0, "SENSE_DUAL follows for this seq"),
    FlagBit("THETA_ENC_VALID", 1, "theta_enc is valid"),
)


# ---------------------------------------------------------------------------------------------------------
# Rounding rule
# ---------------------------------------------------------------------------------------------------------

def round_half_away(q: float) -> int:
    """Round ``q`` to the nearest integer, ties away from zero (2.5 -> 3, -2.5 -> -3).

    This is the protocol's rule for physical -> raw, evaluated on ``q = (value - offset) / scale`` in IEEE
    binary64; the generated C code does exactly the same (truncate, then compare the exact remainder with
    0.5). ``q`` must be finite.
    """
    r = int(q)  # truncates toward zero
    frac = q - r  # exact
    if frac >= 0.5:
        return r + 1
    if frac <= -0.5:
        return r - 1
    return r


# ---------------------------------------------------------------------------------------------------------
# Specifications
# ---------------------------------------------------------------------------------------------------------

def _num(x: float | int | None) -> float | int | None:
    """Normalise a DBC number: integral values become ``int`` (as cantools does for scale 1, offset 0)."""
    if x is None:
        return None
    f = float(x)
    return int(f) if f.is_integer() and abs(f) < 2**53 else f


@dataclass(frozen=True)
class SignalSpec:
    """One signal, little-endian (Intel) in the DBC; raw values are integers except for IEEE floats."""

    message: str
    name: str
    start_bit: int
    length_bits: int
    is_signed: bool
    is_float: bool
    scale: float | int
    offset: float | int
    minimum: float | int
    maximum: float | int
    unit: str
    comment: str
    choices: Mapping[int, str]
    type_min: float | int
    type_max: float | int
    raw_min: float | int
    raw_max: float | int

    @property
    def qualified_name(self) -> str:
        return f"{self.message}.{self.name}"

    @property
    def is_identity(self) -> bool:
        """Raw == physical (scale 1, offset 0)."""
        return self.scale == 1 and self.offset == 0

    @property
    def byte_aligned(self) -> bool:
        return self.start_bit % 8 == 0 and self.length_bits in (8, 16, 32)

    def raw_of(self, physical: float) -> int | float:
        """Physical -> raw by the protocol rule, without range checks (floats: the value itself)."""
        if self.is_float:
            return float(physical)
        return round_half_away((physical - self.offset) / self.scale)

    def physical_of(self, raw: int | float) -> int | float:
        """Raw -> physical, as cantools computes it (``raw * scale + offset``)."""
        if self.is_float or self.is_identity:
            return raw
        return raw * self.scale + self.offset


@dataclass(frozen=True)
class MessageSpec:
    name: str
    frame_id: int
    length: int
    signals: tuple[SignalSpec, ...]
    comment: str
    sender: str
    send_type: str
    cycle_time_ms: int

    def signal(self, name: str) -> SignalSpec:
        for s in self.signals:
            if s.name == name:
                return s
        raise KeyError(f"{self.name} has no signal {name!r}")


@dataclass(frozen=True)
class ValueTable:
    """A value table of the DBC with its Python and C names; ``values`` maps name -> raw value."""

    py_name: str
    c_prefix: str
    c_type: str
    signals: tuple[tuple[str, str], ...]
    values: Mapping[str, int] = field(default_factory=dict)


@dataclass(frozen=True)
class Sentinel:
    """A named raw value outside the DBC range of its signals (e.g. DUTY raw 65535 = OFF)."""

    message: str
    signals: tuple[str, ...]
    name: str
    raw: int
    c_macro: str


@functools.lru_cache(maxsize=None)
def database() -> cantools.database.can.Database:
    """The cantools database of protocol/hil.dbc (loaded once, strict)."""
    return cantools.database.load_file(str(DBC_PATH), strict=True)


def proto_version() -> int:
    """Protocol version: the trailing integer of the DBC ``VERSION`` string ("hil-bench protocol 1")."""
    version = database().version or ""
    m = re.search(r"protocol\s+(\d+)\s*$", version)
    if not m:
        raise DbcError(f"{DBC_PATH}: VERSION {version!r} does not end with 'protocol <n>'")
    return int(m.group(1))


def _type_range(length: int, signed: bool, is_float: bool) -> tuple[float | int, float | int]:
    if is_float:
        return -3.4028234663852886e38, 3.4028234663852886e38
    if signed:
        return -(1 << (length - 1)), (1 << (length - 1)) - 1
    return 0, (1 << length) - 1


def _raw_bound(q: float, lo: int, hi: int) -> int:
    return min(hi, max(lo, round_half_away(q))) if math.isfinite(q) else (hi if q > 0 else lo)


def _signal_spec(msg: cantools.database.can.Message, sig: cantools.database.can.Signal) -> SignalSpec:
    where = f"{DBC_PATH.name}: {msg.name}.{sig.name}"
    if sig.byte_order != "little_endian":
        raise DbcError(f"{where}: big-endian (Motorola) signals are not supported")
    if sig.is_float and sig.length != 32:
        raise DbcError(f"{where}: only 32-bit IEEE floats are supported, got {sig.length} bits")
    if not sig.is_float and not 1 <= sig.length <= 32:
        raise DbcError(f"{where}: integer signals must be 1..32 bits, got {sig.length}")
    if sig.start + sig.length > 8 * msg.length:
        raise DbcError(f"{where}: signal does not fit in {msg.length} octets")
    if sig.multiplexer_ids or sig.is_multiplexer:
        raise DbcError(f"{where}: multiplexed signals are not supported")
    scale, offset = _num(sig.scale), _num(sig.offset)
    if scale == 0:
        raise DbcError(f"{where}: scale must not be 0")
    type_min, type_max = _type_range(sig.length, sig.is_signed, sig.is_float)
    minimum = _num(sig.minimum)
    maximum = _num(sig.maximum)
    if sig.is_float:
        minimum = type_min if minimum is None else minimum
        maximum = type_max if maximum is None else maximum
        raw_min, raw_max = minimum, maximum
    else:
        phys_lo = type_min * scale + offset
        phys_hi = type_max * scale + offset
        if scale < 0:
            phys_lo, phys_hi = phys_hi, phys_lo
        minimum = phys_lo if minimum is None else minimum
        maximum = phys_hi if maximum is None else maximum
        a = _raw_bound((minimum - offset) / scale, type_min, type_max)
        b = _raw_bound((maximum - offset) / scale, type_min, type_max)
        raw_min, raw_max = min(a, b), max(a, b)
    if minimum > maximum:
        raise DbcError(f"{where}: minimum {minimum} > maximum {maximum}")
    choices = {int(k): str(v) for k, v in (sig.choices or {}).items()}
    return SignalSpec(
        message=msg.name, name=sig.name, start_bit=sig.start, length_bits=sig.length,
        is_signed=bool(sig.is_signed), is_float=bool(sig.is_float), scale=scale, offset=offset,
        minimum=minimum, maximum=maximum, unit=sig.unit or "", comment=sig.comment or "",
        choices=choices, type_min=type_min, type_max=type_max, raw_min=raw_min, raw_max=raw_max,
    )


def _attr(db: cantools.database.can.Database, msg: cantools.database.can.Message, name: str, default):
    if msg.dbc is not None and name in msg.dbc.attributes:
        return msg.dbc.attributes[name].value
    if db.dbc is not None and name in db.dbc.attribute_definitions:
        d = db.dbc.attribute_definitions[name].default_value
        return default if d is None else d
    return default


@functools.lru_cache(maxsize=None)
def message_specs() -> tuple[MessageSpec, ...]:
    """Every message of protocol/hil.dbc, sorted by frame id; signals in start-bit order."""
    return specs_from_database(database())


def specs_from_database(db: cantools.database.can.Database) -> tuple[MessageSpec, ...]:
    """Checked specifications of every message of a cantools database (also used by tests on other DBCs)."""
    specs = []
    for msg in db.messages:
        if msg.is_extended_frame or msg.frame_id > 0x7FF:
            raise DbcError(f"{DBC_PATH.name}: {msg.name}: only 11-bit ids are supported")
        if msg.is_multiplexed():
            raise DbcError(f"{DBC_PATH.name}: {msg.name}: multiplexed messages are not supported")
        if msg.length > 64:
            raise DbcError(f"{DBC_PATH.name}: {msg.name}: more than 64 octets")
        signals = tuple(_signal_spec(msg, s) for s in sorted(msg.signals, key=lambda s: s.start))
        used = 0
        for s in signals:
            mask = ((1 << s.length_bits) - 1) << s.start_bit
            if used & mask:
                raise DbcError(f"{DBC_PATH.name}: {s.qualified_name} overlaps another signal")
            used |= mask
        specs.append(MessageSpec(
            name=msg.name, frame_id=msg.frame_id, length=msg.length, signals=signals,
            comment=msg.comment or "", sender=(msg.senders or [""])[0],
            send_type=str(_attr(db, msg, "GenMsgSendType", "")),
            cycle_time_ms=int(_attr(db, msg, "GenMsgCycleTime", 0) or 0),
        ))
    specs.sort(key=lambda m: m.frame_id)
    names = [m.name for m in specs]
    if len(set(names)) != len(names) or len({m.frame_id for m in specs}) != len(specs):
        raise DbcError(f"{DBC_PATH.name}: duplicate message name or id")
    return tuple(specs)


def message_spec(name: str) -> MessageSpec:
    for m in message_specs():
        if m.name == name:
            return m
    raise KeyError(f"no message {name!r} in {DBC_PATH.name}")


@functools.lru_cache(maxsize=None)
def sentinels() -> tuple[Sentinel, ...]:
    """Named raw values outside the range of their signals, checked against the DBC."""
    out = []
    for msg_name, sig_names, choice, macro in _SENTINEL_NAMING:
        msg = message_spec(msg_name)
        raws = set()
        for sig_name in sig_names:
            s = msg.signal(sig_name)
            found = [raw for raw, name in s.choices.items() if name == choice]
            if len(found) != 1 or len(s.choices) != 1:
                raise DbcError(f"{DBC_PATH.name}: {s.qualified_name}: expected exactly the choice {choice!r}")
            if s.raw_min <= found[0] <= s.raw_max:
                raise DbcError(f"{DBC_PATH.name}: {s.qualified_name}: {choice} lies inside the signal range")
            raws.add(found[0])
        if len(raws) != 1:
            raise DbcError(f"{DBC_PATH.name}: {msg_name}: {choice} differs between {sig_names}")
        out.append(Sentinel(msg_name, sig_names, choice, raws.pop(), macro))
    return tuple(out)


@functools.lru_cache(maxsize=None)
def value_tables() -> tuple[ValueTable, ...]:
    """The DBC value tables with their Python/C names. Fails if a table is not named or differs."""
    tables = []
    covered: set[tuple[str, str]] = set()
    for py_name, c_prefix, c_type, sigs in _VALUE_TABLE_NAMING:
        values: dict[str, int] | None = None
        for msg_name, sig_name in sigs:
            s = message_spec(msg_name).signal(sig_name)
            table = {name: raw for raw, name in sorted(s.choices.items())}
            if not table:
                raise DbcError(f"{DBC_PATH.name}: {s.qualified_name} has no value table ({py_name})")
            if values is not None and table != values:
                raise DbcError(f"{DBC_PATH.name}: {s.qualified_name}: value table differs from {sigs[0]}")
            if any(not re.fullmatch(r"[A-Z][A-Z0-9_]*", n) for n in table):
                raise DbcError(f"{DBC_PATH.name}: {s.qualified_name}: choice names must be UPPER_CASE")
            if any(not 0 <= v <= 32767 for v in table.values()):
                raise DbcError(f"{DBC_PATH.name}: {s.qualified_name}: enum values must fit a 16-bit int")
            values = table
            covered.add((msg_name, sig_name))
        tables.append(ValueTable(py_name, c_prefix, c_type, sigs, values or {}))
    for sen in sentinels():
        covered.update((sen.message, s) for s in sen.signals)
    for m in message_specs():
        for s in m.signals:
            if s.choices and (m.name, s.name) not in covered:
                raise DbcError(f"{DBC_PATH.name}: {s.qualified_name} has a value table that protocol/dbc.py "
                               "does not name: add it to _VALUE_TABLE_NAMING or _SENTINEL_NAMING")
    return tuple(tables)
