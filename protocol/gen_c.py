#!/usr/bin/env python3
"""Generate the C message codec from protocol/hil.dbc.

Writes (committed, never edited by hand):

* ``protocol/c/hil_msgs.h`` / ``hil_msgs.c``: per message a raw struct, ``pack``/``unpack``, and per signal
  ``encode`` (physical -> raw), ``decode`` (raw -> physical), ``is_in_range`` (raw within the DBC range);
  value-table enums, sentinel and flag macros. Portable C99 for the controller (TI C28x: 16-bit char):
  no heap, no 8-bit exact-width types (wire octets are ``hil_octet_t`` = ``uint_least8_t``, one octet per
  element), no type punning through pointers (floats go through a union), no implicit double promotion.
* ``protocol/c/hil_msgs_reflect.h`` / ``hil_msgs_reflect.c``: a table-driven view of the same codec
  (names, layout, scaling; pack/unpack/encode/decode by message and signal index) used by the C tests.

Usage::

    python protocol/gen_c.py            # regenerate
    python protocol/gen_c.py --check    # exit 1 with a diff if the committed files are stale
"""
from __future__ import annotations

import argparse
import difflib
import sys
from pathlib import Path

from hil_bench.protocol import dbc
from hil_bench.protocol.dbc import MessageSpec, SignalSpec

OUT_DIR = Path(__file__).resolve().parent / "c"
BANNER = ("/* GENERATED FROM hil.dbc BY protocol/gen_c.py -- DO NOT EDIT.\n"
          " * Regenerate with `python protocol/gen_c.py`; `--check` verifies the committed copy. */\n")


# ---------------------------------------------------------------------------------------------------------
# Naming and C literals
# ---------------------------------------------------------------------------------------------------------

def c_prefix(msg: MessageSpec) -> str:
    """``hil_sense_aux`` for SENSE_AUX."""
    return "hil_" + msg.name.lower()


def c_macro(msg: MessageSpec) -> str:
    """``HIL_SENSE_AUX`` for SENSE_AUX."""
    return "HIL_" + msg.name.upper()


def c_type(s: SignalSpec) -> str:
    """C type of the raw field: 8-bit raw values live in 16-bit fields (C28x has no 8-bit type)."""
    if s.is_float:
        return "float"
    bits = 16 if s.length_bits <= 16 else 32
    return f"{'int' if s.is_signed else 'uint'}{bits}_t"


def c_type_range(s: SignalSpec) -> tuple[int, int]:
    """Range of the C field type (an 8-bit signal lives in a 16-bit field and may hold more)."""
    bits = 16 if s.length_bits <= 16 else 32
    return (-(1 << (bits - 1)), (1 << (bits - 1)) - 1) if s.is_signed else (0, (1 << bits) - 1)


def c_double(x: float) -> str:
    """A C double literal that parses to exactly the same binary64 value as ``x``."""
    text = repr(float(x))
    if text in ("inf", "-inf", "nan"):
        raise ValueError(f"non-finite constant {x}")
    return text


def c_float(x: float) -> str:
    return c_double(x) + "f"


def c_int(value: int, signed: bool) -> str:
    """An exact 32-bit integer constant expression (valid with a 16-bit int, as on C28x)."""
    if not signed:
        return f"UINT32_C({value})"
    if value == -(1 << 31):
        return "(-INT32_C(2147483647) - 1)"
    return f"INT32_C({value})"


def c_string(text: str) -> str:
    return text.replace("*/", "* /")


def _signal_comment(s: SignalSpec) -> str:
    unit = f" {s.unit}" if s.unit else ""
    if s.is_float:
        return f"IEEE binary32{unit}, DBC range [{s.minimum}, {s.maximum}]"
    if s.is_identity:
        conv = "physical = raw"
    else:
        off = f" + {s.offset}" if s.offset else ""
        conv = f"physical = raw * {s.scale}{off}{unit}"
    if s.is_cyclic:
        text = f"{conv}; an angle: raw = round(value / scale) mod {s.type_max + 1} (wraps at 2 pi)"
    elif (s.dbc_minimum, s.dbc_maximum) != (s.minimum, s.maximum):
        text = (f"{conv}; valid [{s.minimum}, {s.maximum}] = raw {s.raw_min}..{s.raw_max} "
                f"(DBC declares [{s.dbc_minimum}, {s.dbc_maximum}])")
    else:
        text = f"{conv}; DBC [{s.minimum}, {s.maximum}] = raw {s.raw_min}..{s.raw_max}"
    if s.choices:
        text += "; " + ", ".join(f"{raw} = {name}" for raw, name in sorted(s.choices.items()))
    return text


def _uses_s32(s: SignalSpec) -> bool:
    """Integer signals whose raw range fits int32 are rounded with the signed helper (angles: their own)."""
    return not s.is_float and not s.is_cyclic and (s.is_signed or s.length_bits < 32)


# ---------------------------------------------------------------------------------------------------------
# Bit layout -> C statements
# ---------------------------------------------------------------------------------------------------------

def _octet_parts(s: SignalSpec) -> list[tuple[int, int, int, int]]:
    """(octet index, first bit in octet, bit count, shift of that piece inside the raw value)."""
    parts = []
    bit, end = s.start_bit, s.start_bit + s.length_bits
    while bit < end:
        octet, low = divmod(bit, 8)
        count = min(8 - low, end - bit)
        parts.append((octet, low, count, bit - s.start_bit))
        bit += count
    return parts


def _mask(count: int) -> str:
    return f"0x{(1 << count) - 1:X}u"


def _pack_statements(msg: MessageSpec) -> list[str]:
    owned: dict[int, int] = {}
    for s in msg.signals:
        for octet, _low, count, _shift in _octet_parts(s):
            owned[octet] = owned.get(octet, 0) + count
    lines = [f"    dst[{i}] = 0u;" for i in range(msg.length) if owned.get(i, 0) != 8 or
             sum(1 for s in msg.signals for p in _octet_parts(s) if p[0] == i) > 1]
    for s in msg.signals:
        src = f"src->{s.name}"
        lines.append(f"    u = hil_f32_to_bits({src});" if s.is_float else f"    u = (uint32_t){src};")
        for octet, low, count, shift in _octet_parts(s):
            piece = f"(u >> {shift})" if shift else "u"
            if count == 8 and low == 0 and owned.get(octet) == 8:
                lines.append(f"    dst[{octet}] = (hil_octet_t)({piece} & 0xFFu);")
            else:
                value = f"({piece} & {_mask(count)})"
                if low:
                    value = f"({value} << {low})"
                lines.append(f"    dst[{octet}] = (hil_octet_t)(dst[{octet}] | {value});")
    return lines


def _unpack_statements(msg: MessageSpec) -> list[str]:
    lines = []
    for s in msg.signals:
        pieces = []
        for octet, low, count, shift in _octet_parts(s):
            term = f"((uint32_t)src[{octet}] & 0xFFu)"
            if low:
                term = f"({term} >> {low})"
            if count != 8:
                term = f"({term} & {_mask(count)})"
            if shift:
                term = f"({term} << {shift})"
            pieces.append(term)
        lines.append("    u = " + "\n        | ".join(pieces) + ";")
        dst = f"dst->{s.name}"
        if s.is_float:
            lines.append(f"    {dst} = hil_f32_from_bits(u);")
        elif s.is_signed:
            lines.append(f"    {dst} = ({c_type(s)})hil_sign_extend(u, {s.length_bits}u);")
        else:
            lines.append(f"    {dst} = ({c_type(s)})u;")
    return lines


# ---------------------------------------------------------------------------------------------------------
# hil_msgs.h / hil_msgs.c
# ---------------------------------------------------------------------------------------------------------

class _Names:
    """Guards against two generated identifiers colliding."""

    def __init__(self) -> None:
        self.seen: set[str] = set()

    def __call__(self, name: str) -> str:
        if name in self.seen:
            raise dbc.DbcError(f"generated C identifier {name} is not unique")
        self.seen.add(name)
        return name


def _header(msgs: tuple[MessageSpec, ...]) -> str:
    name = _Names()
    out = [BANNER, "#ifndef HIL_MSGS_H", "#define HIL_MSGS_H", "",
           "#include <stddef.h>", "#include <stdint.h>", "",
           "#ifdef __cplusplus", 'extern "C" {', "#endif", "",
           f"/* {c_string(dbc.database().version or '')}: message set of the hil-bench HIL link.",
           " * Structs hold RAW wire integers (IEEE float signals: float). Signals are little-endian.",
           " * encode: physical -> raw = (value - offset) / scale rounded to nearest, ties away from zero,",
           " *         evaluated in double (float if HIL_MSGS_CALC_FLOAT is defined; where double is",
           " *         binary32, e.g. TI C28x COFF ABI, both agree and may differ by 1 LSB next to a tie from",
           " *         the binary64 reference), saturated to the valid range (the DBC range, or up to the",
           " *         attribute HilValidMax); NaN encodes as 0 clamped into that range. Angles (rad, one",
           " *         turn over the raw range) wrap: raw = round(value / scale) mod 2^bits; NaN and",
           " *         infinities encode as 0. Float signals: clamped to [min, max], NaN -> 0.",
           " * decode: raw -> physical = raw * scale + offset (sentinels such as HIL_DUTY_RAW_OFF are not",
           " *         decoded: test the raw value first).",
           " * pack returns the message length or -1 (NULL pointer, size too small); unpack returns 0 or -1.",
           " * Octets of hil_octet_t are read as (octet & 0xFF). */", "",
           f"#define {name('HIL_PROTO_VERSION')} {dbc.proto_version()}u /* major: HELLO.proto_version */",
           f"#define {name('HIL_PROTO_VERSION_MINOR')} {dbc.proto_minor()}u /* HELLO.proto_minor, HELLO_ACK.proto_minor */",
           "",
           "/* One wire octet (0..255) per element; uint_least8_t is 16 bits wide on TI C28x. */",
           f"typedef uint_least8_t {name('hil_octet_t')};", ""]

    out.append("/* ---- value tables ---- */")
    for table in dbc.value_tables():
        where = ", ".join(f"{m}.{s}" for m, s in table.signals)
        out.append(f"/* {where} */")
        out.append("typedef enum {")
        items = list(table.values.items())
        for i, (vname, value) in enumerate(items):
            comma = "," if i < len(items) - 1 else ""
            out.append(f"    {name(f'{table.c_prefix}_{vname}')} = {value}{comma}")
        out.append(f"}} {name(table.c_type)};")
        out.append("")
    for sen in dbc.sentinels():
        sigs = ", ".join(sen.signals)
        out.append(f"/* {sen.message}.{{{sigs}}} raw {sen.raw} = {sen.name} (outside the DBC range). */")
        out.append(f"#define {name(sen.c_macro)} {sen.raw}u")
    out.append("")
    for table in dbc.flag_tables():
        prefix, flags, where = table.c_prefix, table.bits, f"{table.message}.{table.signal}"
        out.append(f"/* {where} bits */")
        for f in flags:
            out.append(f"#define {name(f'{prefix}_{f.name}')} 0x{f.mask:02X}u /* bit{f.bit}: {f.meaning} */")
        out.append("")

    out += _param_macros(name)

    for msg in msgs:
        p, mac = c_prefix(msg), c_macro(msg)
        out.append(f"/* ---- {msg.name}: 0x{msg.frame_id:03X}, {msg.length} octets, sent by {msg.sender} ---- */")
        if msg.comment:
            out.append(f"/* {c_string(msg.comment)} */")
        out.append(f"#define {name(mac + '_FRAME_ID')} 0x{msg.frame_id:03X}u")
        out.append(f"#define {name(mac + '_LENGTH')} {msg.length}u")
        if msg.cycle_time_ms:
            out.append(f"#define {name(mac + '_CYCLE_TIME_MS')} {msg.cycle_time_ms}u /* GenMsgCycleTime */")
        out.append("typedef struct {")
        for s in msg.signals:
            out.append(f"    {c_type(s)} {s.name}; /* {c_string(_signal_comment(s))} */")
        out.append(f"}} {name(p + '_t')};")
        out.append(f"int {name(p + '_pack')}(hil_octet_t *dst, const {p}_t *src, size_t size);")
        out.append(f"int {name(p + '_unpack')}({p}_t *dst, const hil_octet_t *src, size_t size);")
        for s in msg.signals:
            t, sp = c_type(s), f"{p}_{s.name}"
            smac = f"{mac}_{s.name.upper()}"
            if not s.is_float:
                out.append(f"#define {name(smac + '_RAW_MIN')} (({t}){c_int(int(s.raw_min), s.is_signed)})")
                out.append(f"#define {name(smac + '_RAW_MAX')} (({t}){c_int(int(s.raw_max), s.is_signed)})")
            out.append(f"{t} {name(sp + '_encode')}(float value);")
            out.append(f"float {name(sp + '_decode')}({t} raw);")
            out.append(f"int {name(sp + '_is_in_range')}({t} raw);")
        out.append("")
    out += ["#ifdef __cplusplus", "}", "#endif", "", "#endif /* HIL_MSGS_H */", ""]
    return "\n".join(out)


_KIND_MACRO = {"real": "HIL_PARAM_KIND_REAL", "integer": "HIL_PARAM_KIND_INTEGER",
               "boolean": "HIL_PARAM_KIND_BOOLEAN", "enum": "HIL_PARAM_KIND_ENUM"}


def _param_macros(name: _Names) -> list[str]:
    """Per CONFIG parameter (a multiplexed signal of CONFIG in the DBC): its kind, the range the reference
    drive accepts, its default (or that it is required) and the minor version that added it."""
    out = ["/* ---- CONFIG parameters: one multiplexed signal of CONFIG each (DBC attributes HilParamKind,",
           " * HilParamDefault, HilParamRequired, HilSince; range = the signal's [min|max], what the reference",
           " * drive accepts). Values travel as binary32 in CONFIG.value. ---- */"]
    for i, kind in enumerate(dbc.PARAM_KINDS):
        out.append(f"#define {name(_KIND_MACRO[kind])} {i}u")
    major = dbc.proto_version()
    for p in dbc.param_specs():
        mac = f"HIL_PARAM_{p.name}"
        since_major, since_minor = (int(x) for x in p.since.split("."))
        if since_major != major:
            raise dbc.DbcError(f"CONFIG.{p.name}: HilSince {p.since} is not of major version {major}")
        out.append(f"/* {p.name} ({p.unit}): {c_string(p.kind)}"
                   + (", " + ", ".join(f"{v} = {c_string(m)}" for v, m in p.values) if p.values else "") + " */")
        out.append(f"#define {name(mac + '_KIND')} {_KIND_MACRO[p.kind]}")
        out.append(f"#define {name(mac + '_MIN')} {c_float(p.minimum)}")
        out.append(f"#define {name(mac + '_MAX')} {c_float(p.maximum)}")
        out.append(f"#define {name(mac + '_REQUIRED')} {1 if p.default is None else 0}u")
        out.append(f"#define {name(mac + '_DEFAULT')} {c_float(0.0 if p.default is None else p.default)}"
                   + (" /* none: required */" if p.default is None else ""))
        out.append(f"#define {name(mac + '_SINCE_MINOR')} {since_minor}u")
    out.append("")
    return out


_HELPERS_COMMON = r"""
/* Wire floats are IEEE-754 binary32: refuse to build anywhere else. */
typedef char hil_float_is_binary32[(sizeof(float) == sizeof(uint32_t) && FLT_MANT_DIG == 24
                                    && FLT_MAX_EXP == 128 && FLT_RADIX == 2) ? 1 : -1];

#if defined(HIL_MSGS_CALC_FLOAT)
typedef float hil_calc_t;  /* cheaper on an FPU without double; may differ by 1 LSB next to a tie */
#define HIL_CALC_FMOD fmodf
#else
typedef double hil_calc_t; /* the reference: identical to protocol/messages.py */
#define HIL_CALC_FMOD fmod
#endif
"""

_HELPER_F32 = r"""
static uint32_t hil_f32_to_bits(float value)
{
    union { float f; uint32_t u; } pun;
    pun.f = value;
    return pun.u;
}

static float hil_f32_from_bits(uint32_t bits)
{
    union { float f; uint32_t u; } pun;
    pun.u = bits;
    return pun.f;
}

static float hil_f32_clamp(float value, float lo, float hi)
{
    if (isnan(value)) {
        value = 0.0f;
    }
    if (value < lo) {
        return lo;
    }
    if (value > hi) {
        return hi;
    }
    return value;
}
"""

_HELPER_SEXT = r"""
/* Two's complement of a `bits`-wide field (1..32) to int32_t, without implementation-defined casts. */
static int32_t hil_sign_extend(uint32_t u, uint32_t bits)
{
    uint32_t sign = (uint32_t)1u << (bits - 1u);
    uint32_t mask = (bits >= 32u) ? UINT32_C(0xFFFFFFFF) : ((sign << 1) - 1u);
    u &= mask;
    if ((u & sign) != 0u) {
        return -(int32_t)((~u) & mask) - 1;
    }
    return (int32_t)u;
}
"""

_HELPER_S32 = r"""
/* Round q to nearest, ties away from zero, saturated to [lo, hi]; NaN counts as 0.
 * Truncation then an exact remainder test: no reliance on the FPU rounding mode or on lround(). */
static int32_t hil_round_sat_s32(hil_calc_t q, int32_t lo, int32_t hi)
{
    int32_t r;
    hil_calc_t frac;
    if (isnan(q)) {
        q = (hil_calc_t)0;
    }
    if (q <= (hil_calc_t)lo) {
        return lo;
    }
    if (q >= (hil_calc_t)hi) {
        return hi;
    }
    r = (int32_t)q;
    frac = q - (hil_calc_t)r;
    if (frac >= (hil_calc_t)0.5) {
        r++;
    } else if (frac <= (hil_calc_t)-0.5) {
        r--;
    }
    return r;
}
"""

_HELPER_U32 = r"""
/* As hil_round_sat_s32 for unsigned 32-bit raw values. */
static uint32_t hil_round_sat_u32(hil_calc_t q, uint32_t lo, uint32_t hi)
{
    uint32_t r;
    if (isnan(q)) {
        q = (hil_calc_t)0;
    }
    if (q <= (hil_calc_t)lo) {
        return lo;
    }
    if (q >= (hil_calc_t)hi) {
        return hi;
    }
    r = (uint32_t)q;
    if (q - (hil_calc_t)r >= (hil_calc_t)0.5) {
        r++;
    }
    return r;
}
"""


_HELPER_TURN = r"""
/* Raw value of an angle whose raw range is one turn (2^bits values, bits <= 24): q rounded to nearest,
 * ties away from zero, modulo 2^bits, for any finite q. fmod is exact and keeps the sign of q, so the
 * tie rule is that of q itself. NaN and infinities encode as 0. */
static uint32_t hil_round_turn(hil_calc_t q, uint32_t bits)
{
    int32_t n = (int32_t)((uint32_t)1u << bits);
    int32_t r;
    hil_calc_t frac;
    if (isnan(q) || isinf(q)) {
        return 0u;
    }
    q = HIL_CALC_FMOD(q, (hil_calc_t)n);
    r = (int32_t)q;
    frac = q - (hil_calc_t)r;
    if (frac >= (hil_calc_t)0.5) {
        r++;
    } else if (frac <= (hil_calc_t)-0.5) {
        r--;
    }
    if (r < 0) {
        r += n;
    }
    if (r >= n) {
        r -= n;
    }
    return (uint32_t)r;
}
"""


def _encode_body(s: SignalSpec) -> list[str]:
    t = c_type(s)
    if s.is_cyclic:
        if s.length_bits > 24:
            raise dbc.DbcError(f"{s.qualified_name}: angles of more than 24 bits are not supported")
        return [f"    return ({t})hil_round_turn((hil_calc_t)value / (hil_calc_t){c_double(s.scale)}, "
                f"{s.length_bits}u);"]
    if s.is_float:
        return [f"    return hil_f32_clamp(value, {c_float(s.minimum)}, {c_float(s.maximum)});"]
    q = "(hil_calc_t)value"
    if s.offset:
        q = f"({q} - (hil_calc_t){c_double(s.offset)})"
    if not s.is_identity:
        q = f"{q} / (hil_calc_t){c_double(s.scale)}"
    if _uses_s32(s):
        call = f"hil_round_sat_s32({q}, {c_int(int(s.raw_min), True)}, {c_int(int(s.raw_max), True)})"
    else:
        call = f"hil_round_sat_u32({q}, {c_int(int(s.raw_min), False)}, {c_int(int(s.raw_max), False)})"
    return [f"    return ({t}){call};"]


def _decode_body(s: SignalSpec) -> list[str]:
    if s.is_float:
        return ["    return raw;"]
    if s.is_identity:
        return ["    return (float)raw;"]
    expr = f"(hil_calc_t)raw * (hil_calc_t){c_double(s.scale)}"
    if s.offset:
        expr += f" + (hil_calc_t){c_double(s.offset)}"
    return [f"    return (float)({expr});"]


def _range_body(s: SignalSpec) -> list[str]:
    if s.is_float:
        return [f"    return (raw >= {c_float(s.minimum)} && raw <= {c_float(s.maximum)}) ? 1 : 0;"]
    checks = []
    field_min, field_max = c_type_range(s)
    if s.raw_min > field_min:
        checks.append(f"raw >= {c_macro_signal(s)}_RAW_MIN")
    if s.raw_max < field_max:
        checks.append(f"raw <= {c_macro_signal(s)}_RAW_MAX")
    if not checks:
        return ["    (void)raw;", "    return 1;"]
    return [f"    return ({' && '.join(checks)}) ? 1 : 0;"]


def c_macro_signal(s: SignalSpec) -> str:
    return f"HIL_{s.message.upper()}_{s.name.upper()}"


def _source(msgs: tuple[MessageSpec, ...]) -> str:
    signals = [s for m in msgs for s in m.signals]
    out = [BANNER, '#include "hil_msgs.h"', "", "#include <float.h>", "#include <math.h>",
           _HELPERS_COMMON.rstrip("\n")]
    if any(s.is_float for s in signals):
        out.append(_HELPER_F32.rstrip("\n"))
    if any(s.is_signed and not s.is_float for s in signals):
        out.append(_HELPER_SEXT.rstrip("\n"))
    if any(_uses_s32(s) for s in signals):
        out.append(_HELPER_S32.rstrip("\n"))
    if any(not s.is_float and not s.is_cyclic and not _uses_s32(s) for s in signals):
        out.append(_HELPER_U32.rstrip("\n"))
    if any(s.is_cyclic for s in signals):
        out.append(_HELPER_TURN.rstrip("\n"))
    out.append("")
    for msg in msgs:
        p, mac = c_prefix(msg), c_macro(msg)
        out.append(f"/* ---- {msg.name} ---- */")
        out += [f"int {p}_pack(hil_octet_t *dst, const {p}_t *src, size_t size)", "{", "    uint32_t u;",
                f"    if (dst == NULL || src == NULL || size < {mac}_LENGTH) {{", "        return -1;", "    }"]
        out += _pack_statements(msg)
        out += [f"    return (int){mac}_LENGTH;", "}", ""]
        out += [f"int {p}_unpack({p}_t *dst, const hil_octet_t *src, size_t size)", "{", "    uint32_t u;",
                f"    if (dst == NULL || src == NULL || size < {mac}_LENGTH) {{", "        return -1;", "    }"]
        out += _unpack_statements(msg)
        out += ["    return 0;", "}", ""]
        for s in msg.signals:
            t, sp = c_type(s), f"{p}_{s.name}"
            out += [f"{t} {sp}_encode(float value)", "{"] + _encode_body(s) + ["}", ""]
            out += [f"float {sp}_decode({t} raw)", "{"] + _decode_body(s) + ["}", ""]
            out += [f"int {sp}_is_in_range({t} raw)", "{"] + _range_body(s) + ["}", ""]
    return "\n".join(out)


# ---------------------------------------------------------------------------------------------------------
# hil_msgs_reflect.h / hil_msgs_reflect.c (test support, host only)
# ---------------------------------------------------------------------------------------------------------

_REFLECT_H = r"""#ifndef HIL_MSGS_REFLECT_H
#define HIL_MSGS_REFLECT_H

/* Table-driven view of the generated codec, for tests and tools on the host (uses double).
 * Raw values travel as double: exact for integers of up to 32 bits and for binary32 floats. */

#include "hil_msgs.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef enum { HIL_SIG_UNSIGNED = 0, HIL_SIG_SIGNED = 1, HIL_SIG_FLOAT = 2 } hil_sig_kind_t;

typedef struct {
    const char *name;
    hil_sig_kind_t kind;
    uint16_t start_bit;
    uint16_t length_bits;
    double scale;
    double offset;
    double minimum;   /* DBC [min|max], physical */
    double maximum;
    double raw_min;   /* the same range as raw values */
    double raw_max;
    double type_min;  /* range of the raw field type */
    double type_max;
    int cyclic;       /* an angle: encode wraps modulo one turn instead of saturating */
} hil_signal_info_t;

typedef struct {
    const char *name;
    uint16_t frame_id;
    uint16_t length;
    uint16_t n_signals;
    const hil_signal_info_t *signals;
} hil_message_info_t;

extern const hil_message_info_t hil_messages[];
extern const size_t hil_message_count;

const hil_message_info_t *hil_message_by_name(const char *name);
const hil_message_info_t *hil_message_by_id(uint16_t frame_id);
int hil_signal_index(const hil_message_info_t *msg, const char *name); /* -1 if unknown */

/* raw[] in signal order; -1 if a raw value is outside its field type or size is too small. */
int hil_reflect_pack(const hil_message_info_t *msg, const double *raw, hil_octet_t *dst, size_t size);
int hil_reflect_unpack(const hil_message_info_t *msg, double *raw, const hil_octet_t *src, size_t size);
/* The per-signal functions of hil_msgs.h, by index: 0 on success, -1 on a bad index or raw value. */
int hil_reflect_encode(const hil_message_info_t *msg, size_t sig, float value, double *raw);
int hil_reflect_decode(const hil_message_info_t *msg, size_t sig, double raw, float *value);
int hil_reflect_is_in_range(const hil_message_info_t *msg, size_t sig, double raw, int *in_range);

#ifdef __cplusplus
}
#endif

#endif /* HIL_MSGS_REFLECT_H */
"""


def _reflect_source(msgs: tuple[MessageSpec, ...]) -> str:
    kind = {(False, False): "HIL_SIG_UNSIGNED", (True, False): "HIL_SIG_SIGNED"}
    out = [BANNER, '#include "hil_msgs_reflect.h"', "", "#include <string.h>", ""]
    for msg in msgs:
        out.append(f"static const hil_signal_info_t {c_prefix(msg)}_signals[] = {{")
        for s in msg.signals:
            k = "HIL_SIG_FLOAT" if s.is_float else kind[(s.is_signed, False)]
            nums = [s.scale, s.offset, s.minimum, s.maximum, s.raw_min, s.raw_max, s.type_min, s.type_max]
            out.append(f'    {{"{s.name}", {k}, {s.start_bit}u, {s.length_bits}u, '
                       + ", ".join(c_double(x) for x in nums) + f", {int(s.is_cyclic)}}},")
        out.append("};")
    out.append("")
    out.append("const hil_message_info_t hil_messages[] = {")
    for msg in msgs:
        out.append(f'    {{"{msg.name}", 0x{msg.frame_id:03X}u, {msg.length}u, {len(msg.signals)}u, '
                   f"{c_prefix(msg)}_signals}},")
    out += ["};", "", "const size_t hil_message_count = sizeof hil_messages / sizeof hil_messages[0];", ""]
    out.append(r"""const hil_message_info_t *hil_message_by_name(const char *name)
{
    size_t i;
    for (i = 0u; i < hil_message_count; i++) {
        if (strcmp(hil_messages[i].name, name) == 0) {
            return &hil_messages[i];
        }
    }
    return NULL;
}

const hil_message_info_t *hil_message_by_id(uint16_t frame_id)
{
    size_t i;
    for (i = 0u; i < hil_message_count; i++) {
        if (hil_messages[i].frame_id == frame_id) {
            return &hil_messages[i];
        }
    }
    return NULL;
}

int hil_signal_index(const hil_message_info_t *msg, const char *name)
{
    uint16_t i;
    for (i = 0u; i < msg->n_signals; i++) {
        if (strcmp(msg->signals[i].name, name) == 0) {
            return (int)i;
        }
    }
    return -1;
}

static int hil_raw_ok(const hil_signal_info_t *s, double raw)
{
    double frac;
    if (s->kind == HIL_SIG_FLOAT) {
        return 1; /* any double converts; the range check is the codec's job */
    }
    if (!(raw >= s->type_min && raw <= s->type_max)) {
        return 0;
    }
    frac = raw - (double)(int64_t)raw;
    return (frac <= 0.0 && frac >= 0.0) ? 1 : 0; /* an integer (no == on doubles: -Wfloat-equal) */
}

static int hil_raws_ok(const hil_message_info_t *msg, const double *raw)
{
    uint16_t i;
    for (i = 0u; i < msg->n_signals; i++) {
        if (!hil_raw_ok(&msg->signals[i], raw[i])) {
            return 0;
        }
    }
    return 1;
}
""")
    # pack / unpack
    out += ["int hil_reflect_pack(const hil_message_info_t *msg, const double *raw, hil_octet_t *dst, size_t size)",
            "{", "    if (msg == NULL || raw == NULL || !hil_raws_ok(msg, raw)) {", "        return -1;", "    }",
            "    switch (msg->frame_id) {"]
    for msg in msgs:
        p = c_prefix(msg)
        out += [f"    case {c_macro(msg)}_FRAME_ID: {{", f"        {p}_t m;"]
        for i, s in enumerate(msg.signals):
            out.append(f"        m.{s.name} = ({c_type(s)})raw[{i}];")
        out += [f"        return {p}_pack(dst, &m, size);", "    }"]
    out += ["    default:", "        return -1;", "    }", "}", ""]
    out += ["int hil_reflect_unpack(const hil_message_info_t *msg, double *raw, const hil_octet_t *src, size_t size)",
            "{", "    if (msg == NULL || raw == NULL) {", "        return -1;", "    }",
            "    switch (msg->frame_id) {"]
    for msg in msgs:
        p = c_prefix(msg)
        out += [f"    case {c_macro(msg)}_FRAME_ID: {{", f"        {p}_t m;",
                f"        if ({p}_unpack(&m, src, size) != 0) {{", "            return -1;", "        }"]
        for i, s in enumerate(msg.signals):
            out.append(f"        raw[{i}] = (double)m.{s.name};")
        out += ["        return 0;", "    }"]
    out += ["    default:", "        return -1;", "    }", "}", ""]
    # per-signal dispatch
    for fn, sig_args, ret_doc in (
            ("encode", "float value, double *raw", None),
            ("decode", "double raw, float *value", None),
            ("is_in_range", "double raw, int *in_range", None)):
        out += [f"int hil_reflect_{fn}(const hil_message_info_t *msg, size_t sig, {sig_args})", "{",
                "    if (msg == NULL || sig >= msg->n_signals) {", "        return -1;", "    }"]
        if fn != "encode":
            out += ["    if (!hil_raw_ok(&msg->signals[sig], raw)) {", "        return -1;", "    }"]
        out.append("    switch (msg->frame_id) {")
        for msg in msgs:
            p = c_prefix(msg)
            out.append(f"    case {c_macro(msg)}_FRAME_ID:")
            out.append("        switch (sig) {")
            for i, s in enumerate(msg.signals):
                sp = f"{p}_{s.name}"
                if fn == "encode":
                    stmt = f"*raw = (double){sp}_encode(value);"
                elif fn == "decode":
                    stmt = f"*value = {sp}_decode(({c_type(s)})raw);"
                else:
                    stmt = f"*in_range = {sp}_is_in_range(({c_type(s)})raw);"
                out.append(f"        case {i}u: {stmt} return 0;")
            out += ["        default: return -1;", "        }"]
        out += ["    default:", "        return -1;", "    }", "}", ""]
    return "\n".join(out)


# ---------------------------------------------------------------------------------------------------------
# CLI
# ---------------------------------------------------------------------------------------------------------

def generate() -> dict[str, str]:
    """File name -> text of every generated file."""
    msgs = dbc.message_specs()
    files = {
        "hil_msgs.h": _header(msgs),
        "hil_msgs.c": _source(msgs),
        "hil_msgs_reflect.h": BANNER + _REFLECT_H,
        "hil_msgs_reflect.c": _reflect_source(msgs),
    }
    for fname, text in files.items():
        if "int8_t" in text.replace("int_least8_t", ""):
            raise dbc.DbcError(f"{fname}: an 8-bit exact-width type slipped into the generated code")
    return files


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--check", action="store_true", help="compare with the committed files, do not write")
    ap.add_argument("--out-dir", type=Path, default=OUT_DIR, help="output directory (default protocol/c)")
    ap.add_argument("--dbc", type=Path, default=None, help="read this DBC instead of protocol/hil.dbc "
                                                            "(everything generated comes from it alone)")
    args = ap.parse_args(argv)
    if args.dbc is not None:
        dbc.use_dbc(args.dbc)
    stale = 0
    for fname, text in generate().items():
        path = args.out_dir / fname
        if args.check:
            old = path.read_text() if path.exists() else ""
            if old != text:
                stale += 1
                sys.stdout.writelines(difflib.unified_diff(
                    old.splitlines(keepends=True), text.splitlines(keepends=True),
                    fromfile=f"{path} (committed)", tofile=f"{path} (from hil.dbc)"))
        else:
            path.parent.mkdir(parents=True, exist_ok=True)
            if not path.exists() or path.read_text() != text:
                path.write_text(text)
                print(f"wrote {path}")
    if stale:
        print(f"gen_c.py --check: {stale} generated file(s) differ from hil.dbc; run python protocol/gen_c.py",
              file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
