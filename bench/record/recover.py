"""``bench recover DAMAGED.mcap [-o FIXED.mcap] [--force]``: copy every intact record of a damaged recording.

The output (default ``<DAMAGED>.recovered.mcap`` beside it) is never an existing file unless ``--force``:
it is written to ``.<output>.partial`` and renamed when complete (never over its own input, even
through a link).

A reader that streams an MCAP file stops at the first bad record, so 8 flipped bytes in the middle of a
file lose its second half. This tool works at the MCAP record level (the ``mcap`` library's record
classes and chunk CRCs) and does not look inside messages, so it works for any message encoding:

1. **Scan.** From the magic on (when the magic itself is damaged, from the first intact record a scan
   finds: the magic is 8 octets of framing, the records after it carry their own lengths and CRCs), read
   one record at a time (opcode, length, body). A record is *intact*
   when its body parses and writes back to exactly the same octets with the library's own encoder
   (which also re-computes an attachment's CRC), and a chunk also decompresses to its declared size with
   a matching CRC and holds only intact records. A record that is not intact is skipped: by its length
   field if the record that follows it there is intact, else by scanning forward, octet by octet, to the
   next position where an intact chunk or attachment (both CRC-checked) or a chain of two intact records
   starts. The octets passed over are counted.
2. **Write.** The schemas and channels found anywhere (in chunks, outside them, in the summary section of
   a finalised file), then every message of every intact chunk in file order, then the metadata and
   attachment records, into a new MCAP file written by the ``mcap`` library (zstd chunks, indexes,
   summary), so readers that need a summary open it.

Messages whose channel definition was lost with a damaged chunk (and is not in a summary) cannot be
written: they are counted as orphans. The summary printed says what was recovered and what was lost.
"""
from __future__ import annotations

import io
import mmap
import zlib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Iterator

import numpy as np
from mcap.data_stream import ReadDataStream, RecordBuilder
from mcap.opcode import Opcode
from mcap.records import (
    Attachment,
    AttachmentIndex,
    Channel,
    Chunk,
    ChunkIndex,
    DataEnd,
    Footer,
    Header,
    Message,
    MessageIndex,
    Metadata,
    MetadataIndex,
    Schema,
    Statistics,
    SummaryOffset,
)
from mcap.writer import CompressionType, Writer

from hil_bench.errors import BenchError

from .atomic import partial_path, publish

MAGIC = b"\x89MCAP0\r\n"
_RECORDS = {
    Opcode.HEADER: Header, Opcode.FOOTER: Footer, Opcode.SCHEMA: Schema, Opcode.CHANNEL: Channel,
    Opcode.MESSAGE: Message, Opcode.CHUNK: Chunk, Opcode.MESSAGE_INDEX: MessageIndex,
    Opcode.CHUNK_INDEX: ChunkIndex, Opcode.ATTACHMENT: Attachment, Opcode.ATTACHMENT_INDEX: AttachmentIndex,
    Opcode.STATISTICS: Statistics, Opcode.METADATA: Metadata, Opcode.METADATA_INDEX: MetadataIndex,
    Opcode.SUMMARY_OFFSET: SummaryOffset, Opcode.DATA_END: DataEnd,
}
_CHUNK_RECORDS = (Opcode.SCHEMA, Opcode.CHANNEL, Opcode.MESSAGE)
_CRC_CHECKED = (Opcode.CHUNK, Opcode.ATTACHMENT)


class RecoverError(BenchError, ValueError):
    """The input cannot be recovered at all (not an MCAP file, unreadable, or nothing intact)."""


@dataclass
class Report:
    source: Path
    output: Path | None = None
    size: int = 0
    chunks_ok: int = 0
    chunks_bad: int = 0
    records_bad: int = 0                     # records other than chunks that were not intact
    bytes_skipped: int = 0
    skipped: list[tuple[int, int, str]] = field(default_factory=list)   # (offset, octets, why)
    messages: dict[str, int] = field(default_factory=dict)              # topic -> messages written
    orphans: int = 0                         # messages whose channel definition was lost
    metadata: list[str] = field(default_factory=list)
    attachments: list[str] = field(default_factory=list)
    had_footer: bool = False

    @property
    def messages_total(self) -> int:
        return sum(self.messages.values())

    def text(self) -> str:
        lines = [f"{self.source}: {self.size} octets; {self.chunks_ok} intact chunk(s) copied, "
                 f"{self.chunks_bad} damaged chunk(s) and {self.records_bad} other damaged record(s) skipped; "
                 f"{self.bytes_skipped} octets skipped in {len(self.skipped)} region(s)"
                 + ("" if self.had_footer else "; no footer (the file was cut short)")]
        for offset, length, why in self.skipped[:20]:
            lines.append(f"  skipped {length} octets at {offset}: {why}")
        if len(self.skipped) > 20:
            lines.append(f"  ... {len(self.skipped) - 20} more regions")
        lines.append(f"messages recovered: {self.messages_total}"
                     + (f"; {self.orphans} orphaned (their channel definition was lost)" if self.orphans else ""))
        for topic, n in sorted(self.messages.items()):
            lines.append(f"  {topic}: {n}")
        lines.append(f"metadata: {', '.join(self.metadata) or 'none'}; attachments: "
                     f"{', '.join(self.attachments) or 'none'}")
        if self.output is not None:
            lines.append(f"written: {self.output}")
        return "\n".join(lines)


def _serialise(record) -> bytes:
    b = RecordBuilder()
    record.write(b)
    return b.end()


def _parse(buf, pos: int, end_limit: int):
    """(record, end) if an intact record starts at ``pos``, else (None, why). Chunks are expanded into
    ``(chunk, inner_records)``."""
    if pos + 9 > end_limit:
        return None, "cut short"
    opcode = buf[pos]
    cls = _RECORDS.get(opcode)
    if cls is None:
        return None, f"unknown opcode 0x{opcode:02X}"
    length = int.from_bytes(buf[pos + 1:pos + 9], "little")
    end = pos + 9 + length
    if end > end_limit:
        return None, f"{Opcode(opcode).name} of {length} octets runs past the end of the file"
    raw = bytes(buf[pos:end])
    try:
        stream = ReadDataStream(io.BytesIO(raw[9:]))
        record = cls.read(stream, length) if cls is Message else cls.read(stream)
        if _serialise(record) != raw:
            return None, f"{Opcode(opcode).name} does not parse back to its octets (damaged)"
    except Exception as exc:  # noqa: BLE001 - any failure to parse means "not intact"
        return None, f"{Opcode(opcode).name} does not parse ({type(exc).__name__})"
    if isinstance(record, Chunk):
        inner = _chunk_records(record)
        if isinstance(inner, str):
            return None, inner
        return (record, inner), end
    return record, end


def _chunk_records(chunk: Chunk):
    """The records of a chunk, or why it is not intact."""
    try:
        if chunk.compression == "zstd":
            import zstandard

            data = zstandard.ZstdDecompressor().decompress(chunk.data, max_output_size=chunk.uncompressed_size)
        elif chunk.compression == "lz4":
            import lz4.frame

            data = lz4.frame.decompress(chunk.data)
        elif chunk.compression == "":
            data = chunk.data
        else:
            return f"chunk compression {chunk.compression!r} unknown"
    except Exception as exc:  # noqa: BLE001
        return f"chunk does not decompress ({type(exc).__name__})"
    if len(data) != chunk.uncompressed_size:
        return f"chunk decompresses to {len(data)} octets, expected {chunk.uncompressed_size}"
    if chunk.uncompressed_crc and zlib.crc32(data) != chunk.uncompressed_crc:
        return "chunk CRC mismatch"
    out, pos = [], 0
    while pos < len(data):
        record, end = _parse(data, pos, len(data))
        if record is None or data[pos] not in _CHUNK_RECORDS:
            return f"chunk holds a damaged record at {pos}: {end if record is None else 'not allowed'}"
        out.append(record)
        pos = end
    return out


def _candidates(buf, start: int, stop: int) -> Iterator[int]:
    """Positions in [start, stop) where a record could start: a known opcode followed by a length whose
    top three octets are zero (files under 2^40 octets), found with numpy in blocks."""
    block = 1 << 20
    for a in range(start, stop, block):
        b = min(stop, a + block)
        arr = np.frombuffer(buf, dtype=np.uint8, count=min(b + 9, len(buf)) - a, offset=a)
        n = b - a
        if len(arr) < 9:
            return
        n = min(n, len(arr) - 8)
        op = arr[:n]
        mask = (op >= 1) & (op <= 0x0F) & (arr[6:6 + n] == 0) & (arr[7:7 + n] == 0) & (arr[8:8 + n] == 0)
        for i in np.flatnonzero(mask):
            yield a + int(i)


def _resync(buf, pos: int, size: int):
    """The next position after ``pos`` where an intact CRC-checked record, or two intact records in a row,
    start (``size`` if none)."""
    for p in _candidates(buf, pos + 1, size):
        record, end = _parse(buf, p, size)
        if record is None:
            continue
        if buf[p] in _CRC_CHECKED:
            return p
        after, _ = _parse(buf, end, size)
        if after is not None or (end == size - len(MAGIC) and bytes(buf[end:]) == MAGIC):
            return p
    return size


def _scan(buf, size: int, report: Report, start: int = len(MAGIC)) -> Iterator[tuple[int, object]]:
    """(offset, record) for every intact record from ``start``; chunks as (chunk, inner records)."""
    pos = start
    while pos < size:
        if pos == size - len(MAGIC) and bytes(buf[pos:]) == MAGIC:
            return
        record, end = _parse(buf, pos, size)
        if record is not None:
            yield pos, record
            pos = end
            if isinstance(record, Footer):
                report.had_footer = True
            continue
        why = end
        opcode = buf[pos]
        # the record is damaged but its length may still be right: skip it if what follows is intact
        skip_to = None
        if opcode in _RECORDS and pos + 9 <= size:
            nxt = pos + 9 + int.from_bytes(buf[pos + 1:pos + 9], "little")
            if nxt == size or (nxt < size and _parse(buf, nxt, size)[0] is not None) or \
                    (nxt == size - len(MAGIC) and bytes(buf[nxt:]) == MAGIC):
                skip_to = nxt
        if skip_to is None:
            skip_to = _resync(buf, pos, size)
        if opcode == Opcode.CHUNK:
            report.chunks_bad += 1
        else:
            report.records_bad += 1
        report.skipped.append((pos, skip_to - pos, str(why)))
        report.bytes_skipped += skip_to - pos
        pos = skip_to


def recover(source: str | Path, output: str | Path | None = None, force: bool = False) -> Report:
    """Copy every intact record of ``source`` into ``output`` (default ``<source>.recovered.mcap``).
    An existing output is refused unless ``force`` (the same rule as ``bench run --out``)."""
    from .recorder import RecorderError, check_target

    source = Path(source)
    option = "-o" if output is not None else "output"
    output = Path(output) if output is not None else source.with_name(source.stem + ".recovered.mcap")
    from .atomic import same_file

    if same_file(output, source):   # the same path, or the same file by a symbolic or hard link
        how = "" if output.resolve() == source.resolve() else f" ({source}, the same file)"
        raise RecoverError(f"{option} {output}: is the damaged file itself{how}; the output must "
                           f"be another file (refused with or without --force)")
    report = Report(source)
    try:
        f = open(source, "rb")
    except OSError as exc:
        raise RecoverError(f"{source}: cannot open: {exc.strerror}") from None
    try:
        check_target(output, force, option=option, side_suffixes=())
    except RecorderError as exc:
        f.close()
        raise RecoverError(str(exc)) from None
    with f:
        report.size = size = source.stat().st_size
        if size == 0:
            raise RecoverError(f"{source}: empty file (0 octets): nothing was recorded in it")
        magic_ok = size >= len(MAGIC) and f.read(len(MAGIC)) == MAGIC
        if size == len(MAGIC) and magic_ok:
            raise RecoverError(f"{source}: holds nothing but the MCAP magic")
        buf = mmap.mmap(f.fileno(), 0, access=mmap.ACCESS_READ)
        try:
            start = len(MAGIC) if magic_ok else _start_without_magic(buf, size, report)
            return _recover(buf, size, report, output, force, start)
        finally:
            buf.close()


def _start_without_magic(buf, size: int, report: Report) -> int:
    """The first intact record of a file whose magic is damaged (a flipped bit in the first octets
    must not lose every intact chunk after it); the damaged start is reported as skipped."""
    if size > len(MAGIC) and _parse(buf, len(MAGIC), size)[0] is not None:
        start = len(MAGIC)                      # only the magic is damaged
    else:
        start = _resync(buf, -1, size)          # the header too: scan for the first intact record
    if start >= size:
        raise RecoverError(f"{report.source}: not an MCAP file: no MCAP magic at the start and no intact "
                           f"MCAP record anywhere in its {size} octets")
    report.skipped.append((0, start, "MCAP magic damaged" + ("" if start == len(MAGIC) else
                                                             " and no intact record before this offset")))
    report.bytes_skipped += start
    return start


def _recover(buf, size: int, report: Report, output: Path, force: bool = False,
             start: int = len(MAGIC)) -> Report:
    header: Header | None = None
    schemas: dict[int, Schema] = {}
    channels: dict[int, Channel] = {}
    chunk_offsets: list[int] = []
    loose_messages = 0
    extras: list[object] = []           # metadata and attachments, in file order
    for offset, record in _scan(buf, size, report, start):
        if isinstance(record, tuple):
            chunk_offsets.append(offset)
            report.chunks_ok += 1
            for inner in record[1]:
                if isinstance(inner, Schema):
                    schemas.setdefault(inner.id, inner)
                elif isinstance(inner, Channel):
                    channels.setdefault(inner.id, inner)
        elif isinstance(record, Header):
            header = header or record
        elif isinstance(record, Schema):
            schemas.setdefault(record.id, record)
        elif isinstance(record, Channel):
            channels.setdefault(record.id, record)
        elif isinstance(record, Message):
            chunk_offsets.append(offset)
            loose_messages += 1
        elif isinstance(record, (Metadata, Attachment)):
            extras.append(record)
    if not chunk_offsets and not extras:
        raise RecoverError(f"{report.source}: no intact chunk, message, metadata or attachment found "
                           f"({report.bytes_skipped} octets damaged)")

    tmp = partial_path(output)
    with open(tmp, "wb") as out:
        writer = Writer(out, compression=CompressionType.ZSTD)
        writer.start(profile=header.profile if header else "", library=(header.library if header else "") +
                     " (bench recover)")
        schema_ids = {sid: writer.register_schema(s.name, s.encoding, s.data) for sid, s in sorted(schemas.items())}
        channel_ids, topics = {}, {}
        for cid, c in sorted(channels.items()):
            channel_ids[cid] = writer.register_channel(c.topic, c.message_encoding,
                                                       schema_ids.get(c.schema_id, 0), c.metadata)
            topics[cid] = c.topic
        for offset in chunk_offsets:
            record, _ = _parse(buf, offset, size)
            messages = [r for r in record[1] if isinstance(r, Message)] if isinstance(record, tuple) else [record]
            for m in messages:
                cid = channel_ids.get(m.channel_id)
                if cid is None:
                    report.orphans += 1
                    continue
                writer.add_message(cid, m.log_time, m.data, m.publish_time, m.sequence)
                report.messages[topics[m.channel_id]] = report.messages.get(topics[m.channel_id], 0) + 1
        seen_meta: set[tuple] = set()
        for r in extras:
            if isinstance(r, Metadata):
                key = (r.name, tuple(sorted(r.metadata.items())))
                if key in seen_meta:
                    continue
                seen_meta.add(key)
                writer.add_metadata(r.name, r.metadata)
                report.metadata.append(r.name)
            else:
                writer.add_attachment(r.create_time, r.log_time, r.name, r.media_type, r.data)
                report.attachments.append(r.name)
        writer.finish()
    try:
        publish(tmp, output, replace=force)
    except FileExistsError:   # appeared while recovering: keep both
        raise RecoverError(f"{output} appeared while recovering; the recovered file is {tmp}") from None
    report.output = output
    return report
