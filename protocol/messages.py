"""Python codec of the HIL message set, derived at import from protocol/hil.dbc (via cantools).

One ``Message`` per DBC message, in ``MESSAGES`` (by name) and ``BY_ID`` (by frame id)::

    from hil_bench.protocol.messages import MESSAGES, decode, State
    SENSE = MESSAGES["SENSE"]
    data = SENSE.pack_values((k, i_a, i_b, i_c))        # physical, in signal (start-bit) order
    msg, values = decode(0x100, data)                     # -> (SENSE, {"seq": k, "i_a": ..., ...})

Encoding rule (identical to the generated C code, protocol/c/hil_msgs.c):
``raw = round_half_away_from_zero((value - offset) / scale)`` evaluated in IEEE binary64, then checked
against the DBC range expressed as raw (``raw_min..raw_max``, the encodings of the DBC [min|max]). A value
outside raises ``SignalRangeError`` naming ``MESSAGE.signal``, unless ``saturate=True`` (then it is clamped
to the range). NaN always raises. IEEE float signals are checked against [min|max] and sent as binary32.
cantools rounds half to even; the two differ only on exact ties (q = n + 0.5 in binary64).

Angles (cyclic signals: ``rad``, one turn over the raw range) wrap instead of raising:
``raw = round_half_away(angle / scale) mod 65536`` for any finite angle (2 pi and -2 pi encode as 0).

Decoding: ``physical = raw * scale + offset`` exactly as cantools computes it (integers stay ``int`` for
scale 1 / offset 0). Signals whose table names a raw value outside the range (DUTY raw 65535 = ``OFF``)
decode to the plain number (``1.99997`` for OFF): test the raw value (``unpack_raw``, ``DUTY_RAW_OFF``).

Fast path: a ``struct.Struct`` layout derived from the signal positions (every message of the DBC is
byte-aligned); a generic bit-level codec is used for any message that is not.
"""
from __future__ import annotations

import math
import struct
from enum import IntEnum, IntFlag
from operator import mul
from typing import Callable, Iterable, Mapping, Sequence

from . import dbc
from .dbc import SignalSpec, round_half_away
from .errors import LengthError, ProtocolError, SignalRangeError, UnknownMessageError

__all__ = [
    "PROTO_VERSION", "Message", "MESSAGES", "BY_ID", "decode", "DUTY_RAW_OFF",
    "Param", "Estimator", "State", "Fault", "Command", "HelloStatus", "ConfigStatus", "Mode",
    "HelloFlag", "SenseAuxFlag",
    "ProtocolError", "UnknownMessageError", "LengthError", "SignalRangeError",
]

#: Protocol version (the trailing number of the DBC VERSION string); HELLO.proto_version carries it.
PROTO_VERSION: int = dbc.proto_version()

Encoder = Callable[[object, bool], "int | float"]


# ---------------------------------------------------------------------------------------------------------
# Per-signal encoders (physical -> raw), built from the SignalSpec
# ---------------------------------------------------------------------------------------------------------

def _checked_encoder(s: SignalSpec) -> Encoder:
    """The complete rule with error messages: choice names, NaN, range, saturation. Used as slow path."""
    qname = s.qualified_name
    by_name = {name: raw for raw, name in s.choices.items()}

    def encode(value: object, saturate: bool) -> int | float:
        if isinstance(value, str):
            if value in by_name:
                return by_name[value]
            known = ", ".join(by_name) if by_name else "the signal has no value table"
            raise SignalRangeError(f"{qname}: unknown choice {value!r} ({known})")
        try:
            v = float(value)  # type: ignore[arg-type]
        except OverflowError:
            v = math.copysign(math.inf, value)  # type: ignore[arg-type]
        except (TypeError, ValueError):
            raise SignalRangeError(f"{qname}: not a number: {value!r}") from None
        if math.isnan(v):
            raise SignalRangeError(f"{qname}: NaN cannot be encoded")
        if s.is_float:
            if s.minimum <= v <= s.maximum:
                return v
            if saturate:
                return float(min(max(v, s.minimum), s.maximum))
            raise SignalRangeError(f"{qname} = {value!r} is outside [{s.minimum}, {s.maximum}]")
        q = (v - s.offset) / s.scale
        if s.is_cyclic:
            if not math.isfinite(q):
                raise SignalRangeError(f"{qname}: an angle must be finite, got {value!r}")
            return dbc.wrap_raw(q, s.length_bits)
        r = round_half_away(q) if math.isfinite(q) else (math.inf if q > 0 else -math.inf)
        if s.raw_min <= r <= s.raw_max:
            return r
        if saturate:
            return s.raw_min if r < s.raw_min else s.raw_max
        raise SignalRangeError(
            f"{qname} = {value!r} is outside [{s.minimum}, {s.maximum}] {s.unit}".rstrip())

    return encode


def _fast_encoder(s: SignalSpec) -> Encoder:
    """Common-case encoder (in range, a number) falling back to ``_checked_encoder`` for anything else."""
    slow = _checked_encoder(s)
    if s.is_float:
        f_lo, f_hi = s.minimum, s.maximum

        def encode_float(value: object, saturate: bool) -> int | float:
            if type(value) is float and f_lo <= value <= f_hi:
                return value
            return slow(value, saturate)

        return encode_float

    raw_lo, raw_hi = s.raw_min, s.raw_max
    q_lo, q_hi = raw_lo - 0.5, raw_hi + 0.5  # open interval: rounding half away stays in range
    scale, offset = s.scale, s.offset

    def encode_linear(value: object, saturate: bool) -> int | float:
        if type(value) is str:
            return slow(value, saturate)
        try:
            q = (float(value) - offset) / scale  # type: ignore[arg-type]
        except (TypeError, ValueError, OverflowError):
            return slow(value, saturate)
        if q_lo < q < q_hi:
            r = int(q)
            frac = q - r
            if frac >= 0.5:
                return r + 1
            if frac <= -0.5:
                return r - 1
            return r
        return slow(value, saturate)

    if not s.is_identity:
        return encode_linear

    def encode_identity(value: object, saturate: bool) -> int | float:
        if type(value) is int and raw_lo <= value <= raw_hi:
            return value
        return encode_linear(value, saturate)

    return encode_identity


# ---------------------------------------------------------------------------------------------------------
# Raw layouts: struct (byte-aligned messages) or generic bit packing
# ---------------------------------------------------------------------------------------------------------

def struct_format(spec: dbc.MessageSpec) -> str | None:
    """``struct`` format of a message whose signals are all byte-aligned 8/16/32-bit fields, else None."""
    fmt, pos = ["<"], 0
    for s in spec.signals:
        if not s.byte_aligned or s.start_bit // 8 < pos:
            return None
        fmt.append("x" * (s.start_bit // 8 - pos))
        code = "f" if s.is_float else {8: "b", 16: "h", 32: "i"}[s.length_bits]
        fmt.append(code if (s.is_signed or s.is_float) else code.upper())
        pos = s.start_bit // 8 + s.length_bits // 8
    fmt.append("x" * (spec.length - pos))
    return "".join(fmt)


class BitLayout:
    """Generic little-endian bit packing of raw values (any start bit / length); the reference for
    the struct fast path and the fallback for layouts that struct cannot express."""

    _F32 = struct.Struct("<f")
    _U32 = struct.Struct("<I")

    def __init__(self, spec: dbc.MessageSpec):
        self.length = spec.length
        self._fields = [(s.start_bit, s.length_bits, s.is_signed, s.is_float) for s in spec.signals]

    def pack(self, *raws: int | float) -> bytes:
        word = 0
        for (start, nbits, _signed, is_float), raw in zip(self._fields, raws, strict=True):
            if is_float:
                raw = self._U32.unpack(self._F32.pack(raw))[0]
            word |= (int(raw) & ((1 << nbits) - 1)) << start
        return word.to_bytes(self.length, "little")

    def unpack_from(self, data: bytes | bytearray | memoryview) -> tuple:
        if len(data) < self.length:
            raise struct.error(f"need {self.length} octets, got {len(data)}")
        word = int.from_bytes(bytes(data[: self.length]), "little")
        out = []
        for start, nbits, signed, is_float in self._fields:
            raw = (word >> start) & ((1 << nbits) - 1)
            if is_float:
                out.append(self._F32.unpack(self._U32.pack(raw))[0])
            elif signed and raw >> (nbits - 1):
                out.append(raw - (1 << nbits))
            else:
                out.append(raw)
        return tuple(out)


# ---------------------------------------------------------------------------------------------------------
# Message
# ---------------------------------------------------------------------------------------------------------

class Message:
    """Codec of one DBC message. Values are physical (SI) unless the method name says raw."""

    def __init__(self, spec: dbc.MessageSpec):
        self.spec = spec
        self.name: str = spec.name
        self.frame_id: int = spec.frame_id
        self.length: int = spec.length
        self.signals: tuple[SignalSpec, ...] = spec.signals
        self.signal_names: tuple[str, ...] = tuple(s.name for s in spec.signals)
        self._index = {n: i for i, n in enumerate(self.signal_names)}
        self._encoders: tuple[Encoder, ...] = tuple(_fast_encoder(s) for s in spec.signals)
        self._checked: tuple[Encoder, ...] = tuple(_checked_encoder(s) for s in spec.signals)
        fmt = struct_format(spec)
        self.uses_struct: bool = fmt is not None
        layout = struct.Struct(fmt) if fmt is not None else BitLayout(spec)
        self._pack_raw = layout.pack
        self._unpack_from = layout.unpack_from
        self._scales = tuple(1 if (s.is_float or s.is_identity) else s.scale for s in spec.signals)
        self._offset_free = all(s.is_float or s.offset == 0 for s in spec.signals)
        self._lin = tuple((s.scale, s.offset, s.is_float or s.is_identity) for s in spec.signals)
        self.generic_pack_values = self.pack_values
        self.pack_values = _compile_pack_values(self)  # type: ignore[method-assign]

    def __repr__(self) -> str:
        return f"Message({self.name}, 0x{self.frame_id:03X}, {self.length} octets, {self.signal_names})"

    # -- encode ------------------------------------------------------------------------------------------
    def pack_values(self, values: Sequence[object], saturate: bool = False) -> bytes:
        """Physical values in ``signal_names`` order -> payload (``length`` octets).

        (Replaced per instance by the specialised function ``_compile_pack_values`` builds; this generic
        version is the reference it is tested against.)"""
        encoders = self._encoders
        if len(values) != len(encoders):
            raise self._count_error(values)
        return self._pack_raw(*[enc(v, saturate) for enc, v in zip(encoders, values)])

    def _count_error(self, values: object) -> ProtocolError:
        n = len(values) if hasattr(values, "__len__") else "?"  # type: ignore[arg-type]
        return ProtocolError(f"{self.name}: expected {len(self.signals)} values {self.signal_names}, got {n}")

    def pack(self, *, saturate: bool = False, **physical: object) -> bytes:
        """Physical values by signal name -> payload. Every signal must be given."""
        missing = [n for n in self.signal_names if n not in physical]
        extra = [n for n in physical if n not in self._index]
        if missing or extra:
            raise ProtocolError(f"{self.name}: missing signals {missing}, unknown signals {extra}")
        return self.pack_values([physical[n] for n in self.signal_names], saturate)

    def pack_raw(self, raws: Sequence[int | float]) -> bytes:
        """Raw wire values (integers; floats for IEEE signals) -> payload. Only the raw *type* range is
        checked (e.g. 0..65535), not the DBC range: this is how tests build out-of-range frames."""
        if len(raws) != len(self.signals):
            raise ProtocolError(f"{self.name}: expected {len(self.signals)} raw values, got {len(raws)}")
        for s, r in zip(self.signals, raws):
            ok = isinstance(r, (int, float)) if s.is_float else (isinstance(r, int) and not isinstance(r, bool))
            if not ok or not s.type_min <= r <= s.type_max:
                raise SignalRangeError(f"{s.qualified_name}: raw {r!r} is not in [{s.type_min}, {s.type_max}]")
        return self._pack_raw(*raws)

    # -- decode ------------------------------------------------------------------------------------------
    def _raw(self, data: bytes | bytearray | memoryview) -> tuple:
        try:
            return self._unpack_from(data)
        except struct.error:
            raise LengthError(f"{self.name} (0x{self.frame_id:03X}): need {self.length} octets, "
                              f"got {len(data)}") from None
        except TypeError:
            raise ProtocolError(f"{self.name}: payload must be bytes, got {type(data).__name__}") from None

    def unpack_raw(self, data: bytes | bytearray | memoryview) -> tuple:
        """Payload -> raw wire values (ints; floats for IEEE signals). Extra octets are ignored."""
        return self._raw(data)

    def unpack_values(self, data: bytes | bytearray | memoryview) -> tuple:
        """Payload -> physical values in ``signal_names`` order. Extra octets are ignored."""
        raws = self._raw(data)
        if self._offset_free:
            return tuple(map(mul, raws, self._scales))
        return tuple(r if ident else r * scale + offset for r, (scale, offset, ident) in zip(raws, self._lin))

    def unpack(self, data: bytes | bytearray | memoryview) -> dict[str, int | float]:
        """Payload -> {signal: physical}."""
        return dict(zip(self.signal_names, self.unpack_values(data)))

    # -- ranges ------------------------------------------------------------------------------------------
    def signal(self, name: str) -> SignalSpec:
        try:
            return self.signals[self._index[name]]
        except KeyError:
            raise ProtocolError(f"{self.name} has no signal {name!r} (signals: {self.signal_names})") from None

    def in_range(self, name: str, value: object) -> bool:
        """True if the physical number ``value`` encodes (rounded) into the DBC range of signal ``name``.
        Strings (choice names) and NaN are not numbers in range."""
        i = self._index.get(name)
        if i is None:
            self.signal(name)  # raises with the list of signals
        if isinstance(value, str):
            return False
        try:
            self._checked[i](value, False)
        except SignalRangeError:
            return False
        return True

    def raw_in_range(self, name: str, raw: int | float) -> bool:
        """True if a raw wire value lies in the DBC range of signal ``name`` (C: ``*_is_in_range``)."""
        s = self.signal(name)
        return (raw == raw) and s.raw_min <= raw <= s.raw_max


def _compile_pack_values(msg: "Message") -> Callable[..., bytes]:
    """Build ``pack_values`` for one message as straight-line Python (no per-signal call on the common
    path), from the SignalSpecs: in-range floats are rounded inline, anything else (ints for scaled
    signals, strings, NaN, out of range, saturation) goes through the signal's encoder."""
    lines = ["def pack_values(values, saturate=False):",
             "    try:",
             f"        {', '.join(f'v{i}' for i in range(len(msg.signals)))}, = values",
             "    except (TypeError, ValueError):",
             "        raise _count_error(values) from None"]
    for i, s in enumerate(msg.signals):
        v, r = f"v{i}", f"r{i}"
        if s.is_float:
            lines += [f"    if type({v}) is float and {float(s.minimum)!r} <= {v} <= {float(s.maximum)!r}:",
                      f"        {r} = {v}"]
        else:
            if s.is_identity:
                lines += [f"    if type({v}) is int and {s.raw_min!r} <= {v} <= {s.raw_max!r}:",
                          f"        {r} = {v}",
                          f"    el"]
            else:
                lines += ["    "]
            q = f"{v} / {float(s.scale)!r}" if s.offset == 0 else f"({v} - {float(s.offset)!r}) / {float(s.scale)!r}"
            lines[-1] += (f"if type({v}) is float and {s.raw_min - 0.5!r} < (q := {q}) < {s.raw_max + 0.5!r}:")
            lines += [f"        {r} = int(q)",
                      f"        f = q - {r}",
                      "        if f >= 0.5:",
                      f"            {r} += 1",
                      "        elif f <= -0.5:",
                      f"            {r} -= 1"]
        lines += ["    else:", f"        {r} = e{i}({v}, saturate)"]
    lines.append(f"    return _pack({', '.join(f'r{i}' for i in range(len(msg.signals)))})")
    namespace: dict[str, object] = {f"e{i}": e for i, e in enumerate(msg._encoders)}
    namespace.update(_pack=msg._pack_raw, _count_error=msg._count_error)
    source = "\n".join(lines) + "\n"
    exec(compile(source, f"<pack_values {msg.name}>", "exec"), namespace)  # noqa: S102 - source built above
    fn = namespace["pack_values"]
    fn.__doc__ = f"{msg.name}: physical values {msg.signal_names} -> {msg.length} octets."
    fn.source = source  # type: ignore[attr-defined]
    return fn  # type: ignore[return-value]


# ---------------------------------------------------------------------------------------------------------
# The message set
# ---------------------------------------------------------------------------------------------------------

MESSAGES: dict[str, Message] = {spec.name: Message(spec) for spec in dbc.message_specs()}
BY_ID: dict[int, Message] = {m.frame_id: m for m in MESSAGES.values()}


def decode(frame_id: int, data: bytes | bytearray | memoryview) -> tuple[Message, dict[str, int | float]]:
    """Frame id + payload -> (Message, {signal: physical}). The payload length must equal the DBC length."""
    msg = BY_ID.get(frame_id)
    if msg is None:
        raise UnknownMessageError(f"unknown message id 0x{frame_id:03X} ({len(data)} octets)")
    if len(data) != msg.length:
        raise LengthError(f"message 0x{frame_id:03X} {msg.name}: expected {msg.length} octets, got {len(data)}")
    return msg, msg.unpack(data)


def _enum_from_table(table: dbc.ValueTable) -> type[IntEnum]:
    enum = IntEnum(table.py_name, dict(table.values))  # type: ignore[misc]
    enum.__module__ = __name__
    enum.__doc__ = (f"Value table of {', '.join(f'{m}.{s}' for m, s in table.signals)} "
                    f"(C: {table.c_prefix}_*).")
    return enum


_ENUMS: Mapping[str, type[IntEnum]] = {t.py_name: _enum_from_table(t) for t in dbc.value_tables()}
Param = _ENUMS["Param"]
Estimator = _ENUMS["Estimator"]
State = _ENUMS["State"]
Fault = _ENUMS["Fault"]
Command = _ENUMS["Command"]
HelloStatus = _ENUMS["HelloStatus"]
ConfigStatus = _ENUMS["ConfigStatus"]
Mode = _ENUMS["Mode"]


def _flags(name: str, bits: Iterable[dbc.FlagBit]) -> type[IntFlag]:
    flag = IntFlag(name, {b.name: b.mask for b in bits})  # type: ignore[misc]
    flag.__module__ = __name__
    return flag


#: HELLO.flags bits (DUAL_SAMPLING = SENSE_DUAL every cycle, TELEM_EMF, ENCODER_VALID).
HelloFlag = _flags("HelloFlag", dbc.flag_table("HelloFlag").bits)
#: SENSE_AUX.flags bits (DUAL_FOLLOWS, THETA_ENC_VALID).
SenseAuxFlag = _flags("SenseAuxFlag", dbc.flag_table("SenseAuxFlag").bits)

_OFF = {(s.message, s.name): s.raw for s in dbc.sentinels()}
#: DUTY raw value of a disabled leg (both switches off), from the DBC value table of d_a/d_b/d_c.
DUTY_RAW_OFF: int = _OFF[("DUTY", "OFF")]
