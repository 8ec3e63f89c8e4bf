"""Read a recording back, from the file alone, in one streaming pass.

``load_recording(path, topics=..., fields=..., windows=...)`` reads the MCAP record by record
(one chunk in memory at a time) and keeps only what is asked for: the topics, the fields of
each, and the rows whose ``t_s`` lies in the given time windows. Memory is what is kept, not the
file's size; time is linear in the file. With no arguments it keeps everything (small files,
tests).

Decoding. Channels of this bench are protobuf messages (``bench/record/channels.py``). A channel whose
fields are all fixed-width has one byte layout for every message; the reader checks each
message's length and tag octets and decodes a chunk's worth with one numpy call, falling back to
``google.protobuf`` for any message that does not match. Recordings of earlier versions (JSON
channels) are read too.

Damage. Every chunk's CRC is checked. A chunk whose data is damaged is counted in
``unreadable_chunks`` and skipped, and reading goes on with the next record. A record with an
opcode MCAP does not define (this bench never writes one: a zeroed or flipped opcode, typically
a chunk's) is skipped by its length and listed in ``unknown_records`` with its byte offset. Damage
to the record framing itself, or a file cut short, stops the reading there: ``truncated`` says
where. The channels and schemas a damaged chunk held are taken from the summary section when a
later message needs them; without a summary such messages are counted (``orphan_messages``, with
the byte offset in ``damage``) and reading goes on. ``bench recover`` copies every intact chunk of
such a file into a new one.
"""
from __future__ import annotations

import json
import math
from collections import defaultdict
from dataclasses import dataclass, field
from pathlib import Path
from typing import Iterable

import numpy as np
from mcap.exceptions import McapError
from mcap.reader import breakup_chunk
from mcap.records import Attachment, Channel, Chunk, Footer, Message, Metadata, Schema
from mcap.stream_reader import StreamReader

from hil_bench.errors import BenchError

from . import channels as chans

#: the smallest MCAP file: magic, header record, footer record, magic (the MCAP specification)
MIN_MCAP_OCTETS = 8 + 9 + 8 + 9 + 20 + 8
RECORD_SIZE_LIMIT = 256 * 1024 * 1024   # a corrupted length field must not allocate gigabytes


class RecordingError(BenchError, ValueError):
    """The file is not a readable recording of this bench. ``damaged``: the file looks like an
    MCAP file that damage made unreadable (``bench recover`` may help), False when it is not one
    (no MCAP magic at either end) or a valid MCAP file of someone else (NotABenchRecording)."""

    def __init__(self, message: str, damaged: bool = True):
        super().__init__(message)
        self.damaged = damaged


class NotABenchRecording(RecordingError):
    """A valid, undamaged MCAP file that this bench did not write: no run metadata, no attached
    scenario. Nothing to recover."""

    def __init__(self, message: str):
        super().__init__(message, damaged=False)


#: the MCAP magic, at the start and at the end of every finalised MCAP file
MCAP_MAGIC = b"\x89MCAP0\r\n"


def looks_like_mcap(path: Path) -> bool:
    """The MCAP magic at the start or at the end of the file (damage may take one of them)."""
    try:
        with open(path, "rb") as f:
            head = f.read(len(MCAP_MAGIC))
            size = f.seek(0, 2)
            f.seek(max(0, size - len(MCAP_MAGIC)))
            tail = f.read(len(MCAP_MAGIC))
    except OSError:
        return False
    return head == MCAP_MAGIC or tail == MCAP_MAGIC


@dataclass
class Recording:
    path: Path
    metadata: dict[str, dict[str, str]] = field(default_factory=dict)
    attachments: dict[str, bytes] = field(default_factory=dict)
    topics: dict[str, dict[str, np.ndarray]] = field(default_factory=dict)
    #: messages per topic in the whole file (every topic, kept or not)
    counts: dict[str, int] = field(default_factory=dict)
    #: schema name and encoding per topic
    schemas: dict[str, tuple[str, str]] = field(default_factory=dict)
    truncated: str | None = None    # why reading stopped early, if it did
    unreadable_chunks: int = 0      # chunks skipped because their data was damaged
    damage: list[str] = field(default_factory=list)
    #: messages on a channel whose Channel record was lost with a damaged chunk (not decoded)
    orphan_messages: int = 0
    #: records skipped because their opcode is not an MCAP one: (byte offset, opcode, length)
    unknown_records: list[tuple[int, int, int]] = field(default_factory=list)
    messages: int = 0
    bytes_read: int = 0
    file_size: int = 0
    has_footer: bool = False
    #: TELEM.estimator value -> cycles over the whole run, when counted while streaming
    #: (bench check) instead of keeping the column
    estimator_counts: dict[int, int] | None = None

    def topic(self, name: str) -> dict[str, np.ndarray]:
        if name not in self.topics:
            raise RecordingError(f"{self.path}: no channel {name!r} in the recording "
                                 f"(has: {', '.join(sorted(self.topics)) or 'none'})")
        return self.topics[name]

    @property
    def run(self) -> dict[str, str]:
        return self.metadata.get("run", {})

    @property
    def damaged(self) -> bool:
        return (self.truncated is not None or self.unreadable_chunks > 0 or bool(self.unknown_records)
                or bool(self.bad_lengths) or self.orphan_messages > 0)

    @property
    def bad_lengths(self) -> list[str]:
        return [d for d in self.damage if d.startswith("record at byte ")]

    def damage_text(self) -> str:
        """One line: what of the file could not be read, with byte offsets."""
        parts = []
        if self.truncated:
            parts.append(self.truncated)
        if self.unreadable_chunks:
            parts.append(f"{self.unreadable_chunks} unreadable chunk(s)")
        if self.unknown_records:
            where = ", ".join(f"byte {off} (opcode 0x{op:02X}, {n} octets)"
                              for off, op, n in self.unknown_records[:5])
            more = f" and {len(self.unknown_records) - 5} more" if len(self.unknown_records) > 5 else ""
            parts.append(f"{len(self.unknown_records)} record(s) with an unknown opcode skipped at "
                         f"{where}{more}")
        if self.orphan_messages:
            parts.append(f"{self.orphan_messages} message(s) on channels whose records were lost "
                         f"with a damaged chunk (not decoded)")
        bad = self.bad_lengths
        if bad:
            parts.append(f"{len(bad)} record(s) with a wrong length field ({bad[0]}"
                         + (f", and {len(bad) - 1} more" if len(bad) > 1 else "") + ")")
        return "; ".join(parts)

    def attachment_text(self, prefix: str) -> tuple[str, str] | None:
        for name, data in self.attachments.items():
            if name.startswith(prefix):
                return name, data.decode()
        return None


class _DamageAwareReader(StreamReader):
    """mcap's StreamReader skips a record whose opcode it does not know without a word; in a file
    of this bench such a record is damage (a chunk whose opcode octet was hit): report it."""

    def __init__(self, *args, on_unknown, on_length, **kwargs):
        super().__init__(*args, **kwargs)
        self._on_unknown = on_unknown
        self._on_length = on_length

    def _read_record(self, opcode: int, length: int):
        start = self._stream.count - 9          # opcode (1) and length (8) are read already
        record = super()._read_record(opcode, length)
        if record is None:
            self._on_unknown(start, opcode, length)
        elif self._stream.count - start - 9 > length:
            # the record's own fields run past its length field: that field was hit (the record
            # itself parsed; a reader that trusts the length field would lose the rest)
            self._on_length(start, opcode, length, self._stream.count - start - 9)
        return record


class _TopicBuffer:
    """Rows of one topic: decoded a chunk at a time, only the wanted fields and rows."""

    def __init__(self, topic: str, schema_name: str, encoding: str, descriptor: bytes,
                 fields: Iterable[str] | None, windows, reducer=None, transform=None):
        self.topic = topic
        self.encoding = encoding
        self.windows = windows
        reducer_fields: tuple[str, ...] = ()
        if isinstance(reducer, tuple):          # (callable, the fields it reads)
            reducer, reducer_fields = reducer[0], tuple(reducer[1])
        self.reducer = reducer
        self.transform = transform
        self.layout = None
        self.msg_class = None
        if encoding == "protobuf":
            kind = next((k for k, lay in chans.LAYOUTS.items() if lay.schema_name == schema_name),
                        None)
            if kind is not None and descriptor == chans.file_descriptor_set():
                self.layout = chans.LAYOUTS[kind]
            self.schema_name = schema_name
            self.descriptor = descriptor
            names = (self.layout.names if self.layout is not None else
                     tuple(f.name for f in self._class().DESCRIPTOR.fields))
        else:
            names = None   # JSON: from the messages
        if fields is not None and names is not None:
            fields = [f for f in fields if f in names]   # a field this schema lacks stays absent
        #: the fields kept; ``decode``: those and what the reducer reads (decoded, not kept)
        self.fields = tuple(fields) if fields is not None else names
        self.decode = (None if self.fields is None else
                       tuple(dict.fromkeys(self.fields + tuple(f for f in reducer_fields
                                                               if names is None or f in names))))
        self.pending: list[bytes] = []
        self.parts: dict[str, list[np.ndarray]] = defaultdict(list)

    def _class(self):
        if self.msg_class is None:
            self.msg_class = chans.message_class(self.schema_name, self.descriptor)
        return self.msg_class

    def add(self, data: bytes) -> None:
        self.pending.append(data)

    def flush(self) -> None:
        if not self.pending:
            return
        data, self.pending = self.pending, []
        if self.encoding == "protobuf":
            cols = self._decode_protobuf(data)
        else:
            cols = self._decode_json(data)
        if self.reducer is not None:
            self.reducer(cols)
        if self.windows is not None and "t_s" in cols:
            t = cols["t_s"]
            keep = np.zeros(len(t), dtype=bool)
            for lo, hi in self.windows:
                keep |= (t >= lo) & (t <= hi)
            if not keep.all():
                cols = {k: v[keep] for k, v in cols.items()}
        if self.transform is not None:
            cols = self.transform(cols)
        for name in self.fields or cols.keys():
            if name in cols:
                self.parts[name].append(cols[name])

    def _decode_protobuf(self, data: list[bytes]) -> dict[str, np.ndarray]:
        lay = self.layout
        if lay is not None and lay.fixed:
            dt = lay.message_dtype
            if all(len(d) == dt.itemsize for d in data):
                raw = np.frombuffer(b"".join(data), dtype=np.uint8).reshape(len(data), dt.itemsize)
                pos, val = lay.tag_mask
                if (raw[:, pos] == val).all():
                    rec = raw.view(dt).reshape(len(data))
                    want = self.decode or lay.names
                    return {n: rec[n].astype(np.float64 if lay.types[n] == "F64" else np.int64)
                            for n in want}   # CNT (counts sent as doubles) back to integers
        cls = self._class()
        names = self.decode or tuple(f.name for f in cls.DESCRIPTOR.fields)
        msgs = [cls.FromString(d) for d in data]
        out = {}
        for n in names:
            vals = [getattr(m, n) for m in msgs]
            out[n] = (np.array(vals, dtype=object) if vals and isinstance(vals[0], str)
                      else np.array(vals))
        return out

    def _decode_json(self, data: list[bytes]) -> dict[str, np.ndarray]:
        rows = [json.loads(d) for d in data]
        out = {}
        for key in (self.decode or rows[0].keys()):
            vals = [r.get(key) for r in rows]
            if all(v is None or (isinstance(v, (int, float)) and not isinstance(v, bool))
                   for v in vals):
                out[key] = np.array([math.nan if v is None else v for v in vals], dtype=float)
            else:
                out[key] = np.array(vals, dtype=object)
        return out

    def columns(self) -> dict[str, np.ndarray]:
        out = {}
        for name, parts in self.parts.items():
            out[name] = np.concatenate(parts) if len(parts) > 1 else parts[0]
        return out


def _by_topic(value, topic: str):
    """A per-topic option: a dict (a topic, or "/reference/*" for every reference) or one value
    for every topic."""
    if not isinstance(value, dict):
        return value
    if topic in value:
        return value[topic]
    if topic.startswith(chans.REFERENCE_PREFIX):
        return value.get("/reference/*")
    return None


def read_header(path: str | Path) -> Recording:
    """Metadata, attachments and message counts without decoding any message: from the summary
    section of a finalised file (a few reads), else by a streaming pass."""
    from mcap.reader import make_reader

    path = Path(path)
    try:
        f = open(path, "rb")
    except OSError as exc:
        raise RecordingError(f"{path}: cannot open: {exc.strerror}") from None
    with f:
        try:
            reader = make_reader(f)
            summary = reader.get_summary()
            if summary is None or summary.statistics is None:
                raise ValueError("no summary")
            rec = Recording(path)
            rec.file_size = path.stat().st_size
            rec.has_footer = True
            for m in reader.iter_metadata():
                rec.metadata[m.name] = dict(m.metadata)
            for a in reader.iter_attachments():
                rec.attachments[a.name] = bytes(a.data)
            for cid, chan in summary.channels.items():
                rec.counts[chan.topic] = int(summary.statistics.channel_message_counts.get(cid, 0))
            rec.messages = int(summary.statistics.message_count)
            return rec
        except Exception:  # noqa: BLE001 - no usable summary (a short, cut or damaged file,
            pass           # a seek before its start): read it as a stream, which says what it is
    return load_recording(path, topics=())


def load_recording(path: str | Path, topics: Iterable[str] | None = None,
                   fields: dict[str, Iterable[str]] | None = None,
                   windows=None, reduce: dict | None = None,
                   transform: dict | None = None) -> Recording:
    """Read a recording in one streaming pass.

    ``topics``: the topics to decode (None: all; ``"/reference/*"`` selects every reference
    estimator). ``fields``: per topic (``"/reference/*"`` for every reference), the fields to keep
    (default: all; only fields are decoded, never a whole message's worth). ``windows``: keep only
    rows with t_s inside one of these [t0, t1] intervals -- a list for every topic, or a dict
    topic -> list (topics it does not name keep every row). ``reduce``: topic -> callable, or
    (callable, fields it reads), called with each chunk's decoded columns of that topic before any
    window (an aggregate over the whole run in bounded memory; its fields are decoded, not kept).
    ``transform``: topic -> callable(columns) -> columns, applied to each chunk's rows after the
    window, before they are kept (e.g. keep only the frames a metric reads). Metadata, attachments
    and per-topic message counts are always read.
    """
    path = Path(path)
    rec = Recording(path)
    wanted = set(topics) if topics is not None else None

    def windows_of(topic: str):
        w = _by_topic(windows, topic) if windows is not None else None
        return [tuple(map(float, x)) for x in w] if w is not None else None
    schemas: dict[int, Schema] = {}
    channels: dict[int, Channel] = {}
    buffers: dict[int, _TopicBuffer | None] = {}

    def want_topic(topic: str) -> bool:
        if wanted is None or topic in wanted:
            return True
        return topic.startswith(chans.REFERENCE_PREFIX) and "/reference/*" in wanted

    summary_tried = [False]
    orphans: dict[int, int] = {}     # channel id -> messages whose Channel record was lost

    def from_summary() -> None:
        """Schemas and channels from the summary section (a damaged chunk may have held the
        only other copy of them)."""
        summary_tried[0] = True
        from mcap.reader import make_reader

        try:
            with open(path, "rb") as g:
                summary = make_reader(g).get_summary()
        except Exception:  # noqa: BLE001 - no usable summary (a cut file): nothing to take
            return
        if summary is None:
            return
        for sch in summary.schemas.values():
            on_record(sch)
        for chan in summary.channels.values():
            on_record(chan)

    def on_record(r) -> None:
        if isinstance(r, Message):
            chan = channels.get(r.channel_id)
            if chan is None and not summary_tried[0]:
                from_summary()
                chan = channels.get(r.channel_id)
            if chan is None:
                if r.channel_id not in orphans:
                    rec.damage.append(f"chunk or record ending at byte {f.tell()}: messages on "
                                      f"channel id {r.channel_id}, "
                                      f"whose Channel record is in no readable chunk nor in a "
                                      f"summary: not decoded")
                orphans[r.channel_id] = orphans.get(r.channel_id, 0) + 1
                rec.orphan_messages += 1
                return
            rec.counts[chan.topic] = rec.counts.get(chan.topic, 0) + 1
            rec.messages += 1
            buf = buffers.get(r.channel_id)
            if buf is not None:
                buf.add(r.data)
        elif isinstance(r, Schema):
            schemas.setdefault(r.id, r)
        elif isinstance(r, Channel):
            if r.id in channels:
                return   # the summary section repeats the channels
            channels[r.id] = r
            sch = schemas.get(r.schema_id)
            enc = r.message_encoding
            rec.schemas[r.topic] = (sch.name if sch else "", enc)
            rec.counts.setdefault(r.topic, 0)
            if want_topic(r.topic) and enc in ("protobuf", "json"):
                buffers[r.id] = _TopicBuffer(r.topic, sch.name if sch else "", enc,
                                             bytes(sch.data) if sch else b"",
                                             _by_topic(fields, r.topic) if fields else None,
                                             windows_of(r.topic),
                                             _by_topic(reduce, r.topic) if reduce else None,
                                             _by_topic(transform, r.topic) if transform else None)
            else:
                buffers[r.id] = None
        elif isinstance(r, Metadata):
            rec.metadata[r.name] = dict(r.metadata)
        elif isinstance(r, Attachment):
            rec.attachments[r.name] = bytes(r.data)
        elif isinstance(r, Footer):
            rec.has_footer = True

    def flush_all() -> None:
        for buf in buffers.values():
            if buf is not None:
                buf.flush()

    try:
        f = open(path, "rb")
    except OSError as exc:
        raise RecordingError(f"{path}: cannot open: {exc.strerror}") from None
    with f:
        rec.file_size = path.stat().st_size
        reader = _DamageAwareReader(f, skip_magic=False, validate_crcs=False, emit_chunks=True,
                                    record_size_limit=RECORD_SIZE_LIMIT,
                                    on_unknown=lambda *r: rec.unknown_records.append(r),
                                    on_length=lambda off, op, n, used: rec.damage.append(
                                        f"record at byte {off} (opcode 0x{op:02X}): length field "
                                        f"{n}, its fields take {used} octets"))
        try:
            for record in reader.records:
                if isinstance(record, Chunk):
                    try:
                        inner = breakup_chunk(record, validate_crc=True)
                    except Exception as exc:  # noqa: BLE001 - damaged chunk: skip it, go on
                        rec.unreadable_chunks += 1
                        rec.damage.append(f"chunk ending at byte {f.tell()}: "
                                          f"{type(exc).__name__}: {exc}")
                        continue
                    for r in inner:
                        on_record(r)
                    flush_all()
                else:
                    on_record(record)
                rec.bytes_read = f.tell()
        except RecordingError:
            raise
        except (McapError, EOFError, ValueError, Exception) as exc:  # noqa: BLE001
            if rec.messages == 0 and not rec.metadata and not channels and not rec.orphan_messages:
                if not looks_like_mcap(path):
                    raise RecordingError(f"{path}: not an MCAP file (no MCAP magic at its start "
                                         f"or end): not a recording of this bench",
                                         damaged=False) from None
                size = rec.file_size
                what = ("an empty file" if size == 0 else
                        f"{size} octets, too short to hold an MCAP recording"
                        if size < MIN_MCAP_OCTETS else f"{type(exc).__name__}: {exc}"
                        if str(exc) else f"it ends at octet {size}, before any complete "
                                         f"record of a run")
                raise RecordingError(f"{path}: not a readable MCAP recording ({what})",
                                     damaged=size >= MIN_MCAP_OCTETS) from None
            rec.truncated = (f"reading stopped at byte {rec.bytes_read} of {rec.file_size}: "
                             f"{type(exc).__name__}: {exc}")
        flush_all()
    if not rec.has_footer and rec.truncated is None:
        rec.truncated = f"no footer: the file ends at byte {rec.file_size} without one"
    for buf in buffers.values():
        if buf is not None:
            rec.topics[buf.topic] = buf.columns()
    return rec


__all__ = ["NotABenchRecording", "Recording", "RecordingError", "load_recording"]
