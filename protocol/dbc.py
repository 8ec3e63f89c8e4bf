"""Read protocol/hil.dbc (the single source of the message set) into plain, checked specifications.

Everything the codecs, the C generator, the vector generator and the docs generator need is derived here
from the cantools database, once:

* ``message_specs()``: messages sorted by frame id, signals in start-bit order, with scale/offset,
  DBC range, raw type range and the DBC range expressed as raw integers (``raw_min``/``raw_max``);
* ``value_tables()``: the value tables, named for Python (``Param``) and C (``HIL_PARAM_``), each emitted
  once even when several messages carry it;
* ``sentinels()``: named raw values inside a signal's declared DBC range but outside its valid range
  (DUTY's raw 65535 = ``OFF``; the valid range ends at the signal attribute ``HilValidMax``);
* ``flag_tables()``: the flag bytes (HELLO.flags, SENSE_AUX.flags), whose DBC value tables name every
  combination of their bits; the bits are the single-bit entries;
* ``param_specs()``: the CONFIG parameters, one multiplexed signal of CONFIG each (multiplexer
  ``param_id``): unit, range, enum values, and the attributes ``HilParamKind``, ``HilParamDefault``,
  ``HilParamRequired``, ``HilSince``, meaning in the signal comment. For the codecs the multiplexed
  signals (all IEEE binary32 at the same bits) are one signal, ``CONFIG.value``: the wire format is the
  same for every parameter;
* ``round_half_away()``: THE rounding rule of the protocol (shared with the generated C code).

Cyclic (angle) signals: an unsigned ``rad`` signal whose raw range covers exactly one turn
(``scale * 2**length == 2 pi``) wraps: raw = round(angle / scale) mod 2**length.

Only what the naming tables below say is hand-written: how value tables are called in Python and C.
A DBC change that this module does not know how to name fails loudly (``DbcError``) instead of guessing.
"""
from __future__ import annotations

import copy
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

#: (message, signals, choice name, C macro): single named raw values outside the signal's valid range.
_SENTINEL_NAMING: tuple[tuple[str, tuple[str, ...], str, str], ...] = (
    ("DUTY", ("d_a", "d_b", "d_c"), "OFF", "HIL_DUTY_RAW_OFF"),
)

#: (Python IntFlag name, C macro prefix, the flag byte as (message, signal), meaning of each bit by name).
#: The bits themselves come from the DBC value table of the signal (its single-bit entries).
_FLAG_TABLE_NAMING: tuple[tuple[str, str, tuple[str, str], dict[str, str]], ...] = (
    ("HelloFlag", "HIL_HELLO_FLAG", ("HELLO", "flags"), {
        "DUAL_SAMPLING": "dual sampling: the host sends SENSE_DUAL every cycle",
        "TELEM_EMF": "the controller sends TELEM_EMF every cycle",
        "ENCODER_VALID": "the host sends the plant's encoder angle in SENSE_AUX.theta_enc in this session (only "
                         "when the estimator is ENCODER or the scenario asks for it); each cycle's SENSE_AUX "
                         "flag THETA_ENC_VALID decides whether that cycle's angle is valid",
    }),
    ("SenseAuxFlag", "HIL_SENSE_AUX_FLAG", ("SENSE_AUX", "flags"), {
        "DUAL_FOLLOWS": "SENSE_DUAL of this seq was sent before SENSE",
        "THETA_ENC_VALID": "theta_enc of this seq carries the plant's encoder angle; the per-cycle flag decides "
                           "(set only in sessions whose HELLO had ENCODER_VALID, and clear in a cycle whose encoder "
                           "the plant reports faulty)",
    }),
)

#: (message, name of the one signal its multiplexed signals are to the codecs, its comment, its range). The
#: multiplexed signals must share start bit, length and type: they differ only in unit, range and meaning.
_MULTIPLEXED_NAMING: tuple[tuple[str, str, str, tuple[float, float]], ...] = (
    ("CONFIG", "value", "IEEE-754 binary32, SI units of the parameter param_id names (its multiplexed signal: "
                        "unit, range, kind, default); integer, boolean and enumerated parameters as the binary32 "
                        "of the integer (4.0, 1.0).", (-3.4e38, 3.4e38)),
)
#: Signal attributes of the CONFIG parameters (the multiplexed signals of CONFIG).
PARAM_KIND_ATTRIBUTE = "HilParamKind"
PARAM_DEFAULT_ATTRIBUTE = "HilParamDefault"
PARAM_REQUIRED_ATTRIBUTE = "HilParamRequired"
SINCE_ATTRIBUTE = "HilSince"
PARAM_KINDS = ("real", "integer", "boolean", "enum")

#: Signal attribute (FLOAT, physical) ending the valid range of a signal below its declared DBC maximum.
VALID_MAX_ATTRIBUTE = "HilValidMax"
#: Message attribute (ENUM) saying when a message is sent; its values and their wording in the docs.
SENT_ATTRIBUTE = "HilSent"
SENT_WORDING = {
    "OnEvent": "event",
    "EveryControlCycle": "every cycle",
    "EveryControlCycleIfFlag": "every cycle if the HELLO flag asks",
    "EveryHeartbeatWhileIdle": "while idle",
}


@dataclass(frozen=True)
class FlagBit:
    """One bit of a flags byte. The DBC comment of the signal describes it as ``bit<N> ...``."""

    name: str
    bit: int
    meaning: str

    @property
    def mask(self) -> int:
        return 1 << self.bit


@dataclass(frozen=True)
class FlagTable:
    """A flag byte: its bits (from the single-bit entries of the DBC value table) and names."""

    py_name: str
    c_prefix: str
    message: str
    signal: str
    bits: tuple[FlagBit, ...]


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


def wrap_raw(q: float, length_bits: int) -> int:
    """Raw value of a cyclic signal: ``round_half_away(q)`` modulo ``2**length_bits`` for any finite q
    (``q`` = angle / scale). The generated C code does the same (``fmod`` first, then the rounding)."""
    r = math.fmod(q, float(1 << length_bits))  # exact, keeps the sign of q: rounds like q itself
    return round_half_away(r) % (1 << length_bits)


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
    """One signal, little-endian (Intel) in the DBC; raw values are integers except for IEEE floats.

    ``minimum``/``maximum`` (and ``raw_min``/``raw_max``) are the *valid* range the codecs encode and
    ``*_is_in_range`` accept: the DBC [min|max], narrowed at the top by the signal attribute
    ``HilValidMax`` where the DBC declares one (DUTY: valid 0..1, declared 0..1.99997 so that the value
    table's OFF = raw 65535 lies inside the declared range, as CAN tools expect).
    ``dbc_minimum``/``dbc_maximum`` are the declared [min|max]. ``is_cyclic``: an angle that wraps.
    """

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
    dbc_minimum: float | int = 0
    dbc_maximum: float | int = 0
    is_cyclic: bool = False

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
        """Physical -> raw by the protocol rule, without range checks (floats: the value itself;
        cyclic signals: wrapped into one turn)."""
        if self.is_float:
            return float(physical)
        if self.is_cyclic:
            return wrap_raw(physical / self.scale, self.length_bits)
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
    send_type: str       # Vector GenMsgSendType: Cyclic (heartbeats) or NoMsgSendType
    cycle_time_ms: int   # Vector GenMsgCycleTime (0: not time-cyclic)
    sent: str = "OnEvent"  # HilSent: OnEvent, EveryControlCycle, EveryControlCycleIfFlag, EveryHeartbeatWhileIdle

    @property
    def sent_text(self) -> str:
        """When the message is sent, in the words of the docs tables."""
        text = SENT_WORDING.get(self.sent, self.sent)
        return f"{text}, {self.cycle_time_ms} ms" if self.cycle_time_ms else text

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


def use_dbc(path: Path | str) -> None:
    """Read another DBC file from now on (the generators' ``--dbc``: a test regenerates the C codec from
    a copy of hil.dbc alone). Clears every cached specification."""
    global DBC_PATH
    DBC_PATH = Path(path).resolve()
    for fn in (database, message_specs, sentinels, value_tables, flag_tables, param_specs):
        fn.cache_clear()


def proto_version_text() -> str:
    """Protocol version as written at the end of the DBC ``VERSION`` string ("1.0")."""
    version = database().version or ""
    m = re.search(r"protocol\s+(\d+)\.(\d+)\s*$", version)
    if not m:
        raise DbcError(f"{DBC_PATH}: VERSION {version!r} does not end with 'protocol <major>.<minor>'")
    return f"{int(m.group(1))}.{int(m.group(2))}"


def proto_minor() -> int:
    """The minor protocol version ("hil-bench protocol 1.1" -> 1): HELLO.proto_minor, HELLO_ACK.proto_minor."""
    return int(proto_version_text().split(".")[1])


def proto_version() -> int:
    """The major protocol version, the number HELLO.proto_version carries ("hil-bench protocol 1.0" -> 1)."""
    return int(proto_version_text().split(".")[0])


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
    if (sig.multiplexer_ids or sig.is_multiplexer) and msg.name not in {m for m, *_ in _MULTIPLEXED_NAMING}:
        raise DbcError(f"{where}: multiplexed signals are supported only where protocol/dbc.py names the "
                       f"message's multiplexed value (_MULTIPLEXED_NAMING)")
    scale, offset = _num(sig.scale), _num(sig.offset)
    if scale == 0:
        raise DbcError(f"{where}: scale must not be 0")
    type_min, type_max = _type_range(sig.length, sig.is_signed, sig.is_float)
    minimum = _num(sig.minimum)
    maximum = _num(sig.maximum)
    dbc_min, dbc_max = minimum, maximum
    attrs = sig.dbc.attributes if sig.dbc is not None else {}
    if VALID_MAX_ATTRIBUTE in attrs:
        valid_max = _num(attrs[VALID_MAX_ATTRIBUTE].value)
        if sig.is_float or maximum is None or not (minimum or 0) <= valid_max <= maximum:
            raise DbcError(f"{where}: {VALID_MAX_ATTRIBUTE} {valid_max} must lie in the declared range "
                           f"[{minimum}, {maximum}] of an integer signal")
        maximum = valid_max
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
    cyclic = (not sig.is_float and not sig.is_signed and (sig.unit or "") == "rad" and offset == 0
              and math.isclose(scale * (1 << sig.length), 2.0 * math.pi, rel_tol=1e-15, abs_tol=0.0))
    if cyclic and (raw_min, raw_max) != (0, type_max):
        raise DbcError(f"{where}: an angle covering one turn must declare [0|{type_max * scale!r}] "
                       f"(raw 0..{type_max}), got raw {raw_min}..{raw_max}")
    return SignalSpec(
        message=msg.name, name=sig.name, start_bit=sig.start, length_bits=sig.length,
        is_signed=bool(sig.is_signed), is_float=bool(sig.is_float), scale=scale, offset=offset,
        minimum=minimum, maximum=maximum, unit=sig.unit or "", comment=sig.comment or "",
        choices=choices, type_min=type_min, type_max=type_max, raw_min=raw_min, raw_max=raw_max,
        dbc_minimum=minimum if dbc_min is None else dbc_min,
        dbc_maximum=maximum if dbc_max is None else dbc_max, is_cyclic=cyclic,
    )


def _attr(db: cantools.database.can.Database, msg: cantools.database.can.Message, name: str, default):
    """A message attribute; ENUM attributes by their value name (the DBC stores the index)."""
    definition = db.dbc.attribute_definitions.get(name) if db.dbc is not None else None
    if msg.dbc is not None and name in msg.dbc.attributes:
        value = msg.dbc.attributes[name].value
        if definition is not None and definition.type_name == "ENUM" and isinstance(value, int):
            return definition.choices[value]
        return value
    if definition is not None:
        return default if definition.default_value is None else definition.default_value
    return default


def bus_type() -> str:
    """The DBC's ``BusType`` attribute ("CAN")."""
    db = database()
    attr = db.dbc.attributes.get("BusType") if db.dbc is not None else None
    return str(attr.value) if attr is not None else ""


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
        if msg.length > 64:
            raise DbcError(f"{DBC_PATH.name}: {msg.name}: more than 64 octets")
        signals = tuple(sorted((_signal_spec(msg, s) for s in _codec_signals(msg)), key=lambda s: s.start_bit))
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
            sent=str(_attr(db, msg, SENT_ATTRIBUTE, "OnEvent")),
        ))
        if specs[-1].sent not in SENT_WORDING:
            raise DbcError(f"{DBC_PATH.name}: {msg.name}: {SENT_ATTRIBUTE} {specs[-1].sent!r} is not one of "
                           f"{sorted(SENT_WORDING)}")
    specs.sort(key=lambda m: m.frame_id)
    names = [m.name for m in specs]
    if len(set(names)) != len(names) or len({m.frame_id for m in specs}) != len(specs):
        raise DbcError(f"{DBC_PATH.name}: duplicate message name or id")
    return tuple(specs)


def _codec_signals(msg: cantools.database.can.Message) -> list:
    """The signals of a message as the codecs see them: a multiplexed message's multiplexed signals (one
    per parameter of CONFIG) are one signal, named by _MULTIPLEXED_NAMING, since they share the bits."""
    if not msg.is_multiplexed():
        return list(msg.signals)
    naming = {m: (name, comment, rng) for m, name, comment, rng in _MULTIPLEXED_NAMING}
    where = f"{DBC_PATH.name}: {msg.name}"
    if msg.name not in naming:
        raise DbcError(f"{where}: multiplexed messages are supported only where protocol/dbc.py names their "
                       f"multiplexed value (_MULTIPLEXED_NAMING)")
    plain = [s for s in msg.signals if not s.multiplexer_ids]
    muxed = [s for s in msg.signals if s.multiplexer_ids]
    if sum(1 for s in plain if s.is_multiplexer) != 1 or not muxed:
        raise DbcError(f"{where}: expected one multiplexer and multiplexed signals")
    layouts = {(s.start, s.length, s.is_float, s.is_signed, s.byte_order, s.scale, s.offset) for s in muxed}
    if len(layouts) != 1:
        raise DbcError(f"{where}: the multiplexed signals must share start bit, length, type and scaling: "
                       f"{sorted(layouts, key=str)}")
    if any(len(s.multiplexer_ids) != 1 for s in muxed):
        raise DbcError(f"{where}: each multiplexed signal stands for one multiplexer value")
    name, comment, (lo, hi) = naming[msg.name]
    first = muxed[0]
    value = cantools.database.can.Signal(
        name=name, start=first.start, length=first.length, byte_order=first.byte_order,
        is_signed=first.is_signed, conversion=first.conversion, minimum=lo, maximum=hi, unit="",
        comment=comment, receivers=list(first.receivers))
    return [*plain, value]


def codec_message(name: str) -> cantools.database.can.Message:
    """A cantools message with the signals the codecs see (CONFIG: param_id, config_seq, value): what the
    tests hold the codecs against, since cantools itself decodes CONFIG by its multiplexed signals."""
    msg = database().get_message_by_name(name)
    if not msg.is_multiplexed():
        return msg
    signals = [copy.copy(s) for s in _codec_signals(msg)]   # the database's own stay as they are
    for s in signals:
        s.is_multiplexer = False
    return cantools.database.can.Message(frame_id=msg.frame_id, name=msg.name, length=msg.length,
                                         signals=signals, senders=msg.senders, strict=True)


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
                raise DbcError(f"{DBC_PATH.name}: {s.qualified_name}: {choice} lies inside the valid range")
            if not s.dbc_minimum <= s.physical_of(found[0]) <= s.dbc_maximum:
                raise DbcError(f"{DBC_PATH.name}: {s.qualified_name}: {choice} (raw {found[0]}) lies outside "
                               f"the declared DBC range [{s.dbc_minimum}, {s.dbc_maximum}]")
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
    covered.update((f.message, f.signal) for f in flag_tables())
    for m in message_specs():
        for s in m.signals:
            if s.choices and (m.name, s.name) not in covered:
                raise DbcError(f"{DBC_PATH.name}: {s.qualified_name} has a value table that protocol/dbc.py "
                               "does not name: add it to _VALUE_TABLE_NAMING or _SENTINEL_NAMING")
    return tuple(tables)


@functools.lru_cache(maxsize=None)
def flag_tables() -> tuple[FlagTable, ...]:
    """The flag bytes. Their DBC value table must name every combination of the bits: 0 "NONE", each
    single bit by its name, and every other value by the names of its bits joined with "+", low bit first
    (what CAN tools then show for any flags value). The single-bit entries are the bits."""
    out = []
    for py_name, c_prefix, (msg_name, sig_name), meanings in _FLAG_TABLE_NAMING:
        s = message_spec(msg_name).signal(sig_name)
        where = f"{DBC_PATH.name}: {s.qualified_name}"
        single = {raw: name for raw, name in s.choices.items() if raw and raw & (raw - 1) == 0}
        bits = tuple(FlagBit(name, raw.bit_length() - 1, meanings.get(name, ""))
                     for raw, name in sorted(single.items()))
        if set(meanings) != {b.name for b in bits}:
            raise DbcError(f"{where}: flag bits {sorted(b.name for b in bits)} differ from the meanings "
                           f"protocol/dbc.py documents {sorted(meanings)}")
        expected = {}
        for value in range(1 << len(bits)):
            names = [b.name for i, b in enumerate(bits) if value >> i & 1]
            raw = sum(b.mask for i, b in enumerate(bits) if value >> i & 1)
            expected[raw] = "+".join(names) or "NONE"
        if dict(s.choices) != expected:
            raise DbcError(f"{where}: the value table must name every combination of the bits: expected "
                           f"{expected}, got {dict(s.choices)}")
        if any(b.bit >= s.length_bits for b in bits):
            raise DbcError(f"{where}: a flag bit lies outside the signal")
        out.append(FlagTable(py_name, c_prefix, msg_name, sig_name, bits))
    return tuple(out)


def flag_table(py_name: str) -> FlagTable:
    for f in flag_tables():
        if f.py_name == py_name:
            return f
    raise KeyError(py_name)


@dataclass(frozen=True)
class ParamSpec:
    """One CONFIG parameter: a multiplexed signal of CONFIG (multiplexer value = ``param_id``)."""

    name: str
    param_id: int
    unit: str           # "-" for a dimensionless parameter (the DBC's empty unit)
    kind: str           # one of PARAM_KINDS
    minimum: float      # the range the reference drive accepts (inclusive)
    maximum: float
    default: float | None   # None: required (no default)
    since: str          # the protocol version that added it ("1.0", "1.1")
    meaning: str
    values: tuple[tuple[int, str], ...] = ()   # enum: (value, meaning)


def _sig_attr(db: cantools.database.can.Database, sig, name: str):
    """A signal attribute's value (ENUM by its value name), or its definition's default."""
    definition = db.dbc.attribute_definitions.get(name) if db.dbc is not None else None
    attrs = sig.dbc.attributes if sig.dbc is not None else {}
    if name in attrs:
        value = attrs[name].value
    else:
        value = None if definition is None else definition.default_value
    if definition is not None and definition.type_name == "ENUM" and isinstance(value, int):
        return definition.choices[value]
    return value


@functools.lru_cache(maxsize=None)
def param_specs() -> tuple[ParamSpec, ...]:
    """Every CONFIG parameter of the DBC, in id order, checked: one multiplexed signal per entry of the
    Param value table, named as the entry, with a kind, and a default unless required."""
    db = database()
    msg = db.get_message_by_name("CONFIG")
    where = f"{DBC_PATH.name}: CONFIG"
    mux = next((s for s in msg.signals if s.is_multiplexer), None)
    if mux is None:
        raise DbcError(f"{where}: param_id must be the multiplexer (one signal per parameter)")
    table = {int(k): str(v) for k, v in (mux.choices or {}).items()}
    out = []
    seen = set()
    for sig in msg.signals:
        if not sig.multiplexer_ids:
            continue
        pid = int(sig.multiplexer_ids[0])
        w = f"{where}.{sig.name} (m{pid})"
        if table.get(pid) != sig.name:
            raise DbcError(f"{w}: the Param table names {pid} {table.get(pid)!r}, the signal is {sig.name!r}")
        kind = str(_sig_attr(db, sig, PARAM_KIND_ATTRIBUTE))
        if kind not in PARAM_KINDS:
            raise DbcError(f"{w}: {PARAM_KIND_ATTRIBUTE} {kind!r} is not one of {PARAM_KINDS}")
        required = int(_sig_attr(db, sig, PARAM_REQUIRED_ATTRIBUTE) or 0) == 1
        default = None if required else float(_sig_attr(db, sig, PARAM_DEFAULT_ATTRIBUTE))
        since = str(_sig_attr(db, sig, SINCE_ATTRIBUTE) or "")
        if not re.fullmatch(r"\d+\.\d+", since):
            raise DbcError(f"{w}: {SINCE_ATTRIBUTE} {since!r} is not <major>.<minor>")
        values = tuple((int(k), str(v)) for k, v in sorted((sig.choices or {}).items()))
        if (kind == "enum") != bool(values):
            raise DbcError(f"{w}: an enum parameter has a value table, no other kind has one")
        lo, hi = float(sig.minimum), float(sig.maximum)
        if default is not None and not lo <= default <= hi:
            raise DbcError(f"{w}: default {default!r} outside its range [{lo!r}, {hi!r}]")
        if values and not all(lo <= v <= hi for v, _ in values):
            raise DbcError(f"{w}: enum values outside its range [{lo!r}, {hi!r}]")
        out.append(ParamSpec(name=sig.name, param_id=pid, unit=sig.unit or "-", kind=kind, minimum=lo,
                             maximum=hi, default=default, since=since, meaning=str(sig.comment or ""),
                             values=values))
        seen.add(pid)
    if seen != set(table):
        raise DbcError(f"{where}: parameters without a multiplexed signal: "
                       f"{sorted(table[p] for p in set(table) - seen)}")
    return tuple(sorted(out, key=lambda p: p.param_id))
