"""The channels of a recording: topics, protobuf schemas, and the row encoder/decoders.

One definition: the X-macro lists of ``plant_rt/c/rec_schema.h``. The C cycle engine encodes
rows with them; this module reads their layout from the compiled module
(``rec_schema_layout()``) and builds from it

* the protobuf ``FileDescriptorSet`` written as each channel's schema (encoding ``protobuf``,
  which Foxglove decodes natively: every scalar a plottable field, NaN a plain double),
* :func:`encode_row`, a Python encoder producing exactly the C encoder's bytes (a test holds
  them equal), for the few messages Python writes (set-up frames, events, final stats),
* :class:`Layout` with the fixed byte layout of the channels that have one, so
  ``bench/record/recording.py`` decodes a whole chunk of them with one numpy call.

Field n of a channel (from 1) is protobuf field number n; every field is written every time.
"""
from __future__ import annotations

import math
import struct
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from hil_bench.plant_rt._plant_c import ffi, lib

PLANT_STATE = "/plant/state"
PLANT_SENSE = "/plant/sense"
CONTROLLER_TELEMETRY = "/controller/telemetry"
LINK_FRAMES = "/link/frames"
LINK_STATS = "/link/stats"
EVENTS = "/events"
TIMING = "/timing"
REFERENCE_PREFIX = "/reference/"
REPLAY_CONTROLLER = "/replay/controller"
REPLAY_PLANT = "/replay/plant"
FAULTS = "/faults"

PACKAGE = "hil"
MESSAGE_ENCODING = "protobuf"

# wire types and protobuf field types of the layout's type names
_WIRE = {"F64": 1, "CNT": 1, "U32": 5, "I32": 5, "STR": 2}
_SIZE = {"F64": 8, "CNT": 8, "U32": 4, "I32": 4}
_NUMPY = {"F64": "<f8", "CNT": "<f8", "U32": "<u4", "I32": "<i4"}
_STRUCT = {"F64": "d", "CNT": "d", "U32": "I", "I32": "i"}
# FieldDescriptorProto.Type; CNT (a count) travels as a double: every viewer plots it
_PB_TYPE = {"F64": 1, "CNT": 1, "U32": 7, "I32": 15, "STR": 9}
#: value a missing field reads as
MISSING = {"F64": math.nan, "CNT": 0, "U32": 0, "I32": -1, "STR": ""}
_FLOAT_TYPES = ("F64", "CNT")


def _varint(v: int) -> bytes:
    out = bytearray()
    while True:
        b = v & 0x7F
        v >>= 7
        out.append(b | (0x80 if v else 0))
        if not v:
            return bytes(out)


@dataclass(frozen=True)
class Layout:
    """One channel kind of rec_schema.h: schema name and (type, field) list in field order."""

    kind: str
    schema_name: str
    fields: tuple[tuple[str, str], ...]

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(n for _, n in self.fields)

    @property
    def types(self) -> dict[str, str]:
        return {n: t for t, n in self.fields}

    @property
    def fixed(self) -> bool:
        """Every field fixed-width: every message has the same bytes layout."""
        return all(t in _SIZE for t, _ in self.fields)

    @property
    def tags(self) -> tuple[bytes, ...]:
        return tuple(_varint((i + 1) << 3 | _WIRE[t]) for i, (t, _) in enumerate(self.fields))

    @property
    def message_dtype(self) -> np.dtype:
        """numpy dtype of one message of a fixed channel (tags as padding bytes)."""
        names, formats, offsets = [], [], []
        off = 0
        for (t, n), tag in zip(self.fields, self.tags):
            off += len(tag)
            names.append(n)
            formats.append(_NUMPY[t])
            offsets.append(off)
            off += _SIZE[t]
        return np.dtype({"names": names, "formats": formats, "offsets": offsets,
                         "itemsize": off})

    @property
    def tag_mask(self) -> tuple[np.ndarray, np.ndarray]:
        """(positions, expected bytes) of the tag octets of a fixed message."""
        pos, val = [], []
        off = 0
        for (t, _), tag in zip(self.fields, self.tags):
            for i, b in enumerate(tag):
                pos.append(off + i)
                val.append(b)
            off += len(tag) + _SIZE[t]
        return np.array(pos, dtype=np.intp), np.array(val, dtype=np.uint8)


def _parse_layout(text: str) -> dict[str, Layout]:
    out = {}
    for line in text.strip().splitlines():
        kind, schema, *fields = line.split()
        out[kind] = Layout(kind, schema, tuple(tuple(f.split(":", 1)) for f in fields))
    return out


#: every channel kind, in rec_kind_t order (from the compiled C)
LAYOUTS: dict[str, Layout] = _parse_layout(ffi.string(lib.rec_schema_layout()).decode())

#: topic -> kind of the fixed topics (reference channels are /reference/<name>, kind REFERENCE)
TOPIC_KIND = {PLANT_STATE: "PLANT_STATE", PLANT_SENSE: "SENSE",
              CONTROLLER_TELEMETRY: "TELEMETRY", LINK_FRAMES: "FRAMES", EVENTS: "EVENT",
              TIMING: "TIMING", LINK_STATS: "LINK_STATS",
              REPLAY_CONTROLLER: "REPLAY_CONTROLLER", REPLAY_PLANT: "REPLAY_PLANT",
              FAULTS: "FAULT"}

#: what each channel holds (docs, Foxglove layout, bench check)
DESCRIPTIONS = {
    "PLANT_STATE": "True plant state at the sampling instant t_k (voltages: averages over the "
                   "period that ended at t_k). SI units; speed_rpm mechanical.",
    "SENSE": "What the controller was sent for cycle seq (after the sensor model and the wire's "
             "fixed-point scaling); theta_enc_rad NaN when the encoder angle is not sent.",
    "TELEMETRY": "The controller's answer to cycle seq: estimated angle and speed (TELEM; NaN, "
                 "state = estimator = -1 if missing), EMF (TELEM_EMF, NaN if not sent), duties "
                 "applied (-1 = leg off), pee_rad = wrap(theta_hat - theta_true).",
    "REFERENCE": "A reference estimator run on the host on exactly the samples and voltages the "
                 "controller saw.",
    "FRAMES": "Every frame of the cycle, as sent (tx) and received (rx): space-separated "
              "candump-style ID#DATA (hex); seq -1 outside the cycles.",
    "EVENT": "Scenario events, state changes, faults and link problems.",
    "TIMING": "Wall-clock timing of each cycle (real time: period start error, SENSE -> DUTY "
              "round trip, DUTY arrival in the period, misses).",
    "LINK_STATS": "Cumulative link, engine and recorder counters; percentiles of cycle time and "
                  "period start error so far. A run writes a row every 1000 cycles, at that "
                  "cycle (in real time in a period the bench lost too), and one at the end.",
    "REPLAY_CONTROLLER": "Replay into a controller: its duties and telemetry for each recorded "
                         "cycle beside the recorded ones.",
    "REPLAY_PLANT": "Replay into the plant: its sampled phase currents under the recorded duties "
                    "beside the recorded currents.",
    "FAULT": "Every fault the run injected (plant faults on/off, each frame a link fault acted "
             "on, a controller reset), the controller's trips, and each fault's trace: the "
             "counters that moved within its detection window (docs/faults.md).",
}

# the field names every reader relies on (kept as constants for the callers)
PLANT_STATE_VALUES = LAYOUTS["PLANT_STATE"].names
PLANT_SENSE_VALUES = LAYOUTS["SENSE"].names
TELEMETRY_VALUES = LAYOUTS["TELEMETRY"].names
REFERENCE_VALUES = LAYOUTS["REFERENCE"].names
FRAMES_VALUES = LAYOUTS["FRAMES"].names
TIMING_VALUES = LAYOUTS["TIMING"].names
LINK_STATS_COUNTERS = tuple(n for t, n in LAYOUTS["LINK_STATS"].fields if t == "CNT")


def kind_of_topic(topic: str) -> str | None:
    if topic.startswith(REFERENCE_PREFIX):
        return "REFERENCE"
    return TOPIC_KIND.get(topic)


#: a field's unit from the suffix of its name (docs/architecture.md, "Conventions": units in
#: names), longest first; the names are the one source, no second table of units to keep in step
UNIT_SUFFIXES = (("_rad_s", "rad/s"), ("_rad", "rad"), ("_rpm", "rpm"), ("_nm", "N m"),
                 ("_us", "us"), ("_s", "s"), ("_v", "V"), ("_a", "A"))


def field_unit(name: str) -> str:
    """The unit of a recorded field by its name: ``i_a_a`` -> ``"A"``, ``omega_m_rad_s`` ->
    ``"rad/s"``, ``t_s`` -> ``"s"``; ``""`` for what has none (counts, sequence numbers, states,
    texts, duties: a duty is a fraction of the PWM period, and the ``_a``/``_b``/``_c`` of
    ``duty_a`` name the phase, not amperes)."""
    if name.startswith("duty_"):
        return ""
    for suffix, unit in UNIT_SUFFIXES:
        if name.endswith(suffix):
            return unit
    return ""


# ---- encoding ------------------------------------------------------------------------------


@lru_cache(maxsize=None)
def _packer(kind: str):
    lay = LAYOUTS[kind]
    if not lay.fixed:
        return None
    fmt = "<" + "".join(f"{len(tag)}s{_STRUCT[t]}" for (t, _), tag in zip(lay.fields, lay.tags))
    return struct.Struct(fmt), lay.tags


def encode_row(kind: str, values) -> bytes:
    """The protobuf message of one row (values in field order, or a dict: missing fields read
    as NaN / 0 / -1 / ""), byte for byte what the C encoder writes."""
    lay = LAYOUTS[kind]
    if isinstance(values, dict):
        values = [values.get(n, MISSING[t]) for t, n in lay.fields]
    packed = _packer(kind)
    if packed is not None:
        st, tags = packed
        args = []
        for (t, _), tag, v in zip(lay.fields, tags, values):
            args.append(tag)
            args.append(float(v) if t in _FLOAT_TYPES else int(v))
        return st.pack(*args)
    out = bytearray()
    for (t, _), tag, v in zip(lay.fields, lay.tags, values):
        out += tag
        if t == "STR":
            data = str(v).encode()
            out += _varint(len(data)) + data
        else:
            out += struct.pack("<" + _STRUCT[t], float(v) if t in _FLOAT_TYPES else int(v))
    return bytes(out)


# ---- schemas --------------------------------------------------------------------------------


@lru_cache(maxsize=None)
def file_descriptor_set() -> bytes:
    """The serialized FileDescriptorSet of every channel message (package ``hil``)."""
    from google.protobuf import descriptor_pb2

    fds = descriptor_pb2.FileDescriptorSet()
    f = fds.file.add()
    f.name = "hil_bench_recording.proto"
    f.package = PACKAGE
    f.syntax = "proto3"
    for lay in LAYOUTS.values():
        m = f.message_type.add()
        m.name = lay.schema_name.split(".", 1)[1]
        for i, (t, n) in enumerate(lay.fields):
            fd = m.field.add()
            fd.name = n
            fd.number = i + 1
            fd.label = descriptor_pb2.FieldDescriptorProto.LABEL_OPTIONAL
            fd.type = _PB_TYPE[t]
    return fds.SerializeToString()


@lru_cache(maxsize=None)
def message_class(schema_name: str, descriptor_set: bytes | None = None):
    """A google.protobuf message class for a schema (from the file's own descriptor set if
    given): the generic decoder for messages that do not have the fixed layout."""
    from google.protobuf import descriptor_pb2, descriptor_pool, message_factory

    fds = descriptor_pb2.FileDescriptorSet.FromString(descriptor_set or file_descriptor_set())
    pool = descriptor_pool.DescriptorPool()
    for fdp in fds.file:
        pool.Add(fdp)
    return message_factory.GetMessageClass(pool.FindMessageTypeByName(schema_name))


__all__ = ["LAYOUTS", "Layout", "encode_row", "file_descriptor_set", "message_class",
           "kind_of_topic", "field_unit", "PLANT_STATE", "PLANT_SENSE", "CONTROLLER_TELEMETRY",
           "LINK_FRAMES", "LINK_STATS", "EVENTS", "TIMING", "REFERENCE_PREFIX"]
