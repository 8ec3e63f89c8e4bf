"""Read a recording back into numpy arrays, from the file alone.

The reader streams the records (validating chunk and attachment CRCs), so a recording cut short
by a crash still yields every complete chunk: it is reported as truncated (with the byte offset
where reading stopped) instead of being refused.
"""
from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from mcap.exceptions import McapError
from mcap.reader import breakup_chunk
from mcap.records import Attachment, Channel, Chunk, Message, Metadata, Schema
from mcap.stream_reader import StreamReader


class RecordingError(ValueError):
    """The file is not a readable recording of this bench."""


@dataclass
class Recording:
    path: Path
    metadata: dict[str, dict[str, str]] = field(default_factory=dict)
    attachments: dict[str, bytes] = field(default_factory=dict)
    topics: dict[str, dict[str, np.ndarray]] = field(default_factory=dict)
    schemas: dict[str, dict] = field(default_factory=dict)   # topic -> JSON schema
    raw_messages: dict[str, list[dict]] = field(default_factory=dict)
    truncated: str | None = None    # why reading stopped early, if it did
    messages: int = 0

    def topic(self, name: str) -> dict[str, np.ndarray]:
        if name not in self.topics:
            raise RecordingError(f"{self.path}: no channel {name!r} in the recording "
                                 f"(has: {', '.join(sorted(self.topics)) or 'none'})")
        return self.topics[name]

    @property
    def run(self) -> dict[str, str]:
        return self.metadata.get("run", {})

    def attachment_text(self, prefix: str) -> tuple[str, str] | None:
        for name, data in self.attachments.items():
            if name.startswith(prefix):
                return name, data.decode()
        return None


def _columns(rows: list[dict]) -> dict[str, np.ndarray]:
    if not rows:
        return {}
    out: dict[str, np.ndarray] = {}
    for key in rows[0]:
        values = [r.get(key) for r in rows]
        if all(isinstance(v, (int, float)) and not isinstance(v, bool) or v is None
               for v in values):
            out[key] = np.array([math.nan if v is None else v for v in values], dtype=float)
        else:
            out[key] = np.array(values, dtype=object)
    return out


def load_recording(path: str | Path, keep_raw: bool = False) -> Recording:
    """Read every message of a recording; validates CRCs; tolerates a truncated tail."""
    path = Path(path)
    rec = Recording(path)
    channels: dict[int, Channel] = {}
    schemas: dict[int, Schema] = {}
    rows: dict[str, list[dict]] = {}

    def on_message(m: Message) -> None:
        chan = channels.get(m.channel_id)
        if chan is None:
            raise RecordingError(f"{path}: message on unknown channel id {m.channel_id}")
        try:
            rows.setdefault(chan.topic, []).append(json.loads(m.data))
        except (json.JSONDecodeError, UnicodeDecodeError) as exc:
            raise RecordingError(f"{path}: message {m.sequence} on {chan.topic} is not valid "
                                 f"JSON: {exc}") from None
        rec.messages += 1

    def on_record(r) -> None:
        if isinstance(r, Schema):
            schemas[r.id] = r
        elif isinstance(r, Channel):
            channels[r.id] = r
            sch = schemas.get(r.schema_id)
            if sch is not None and sch.encoding == "jsonschema":
                rec.schemas[r.topic] = json.loads(sch.data)
        elif isinstance(r, Message):
            on_message(r)
        elif isinstance(r, Metadata):
            rec.metadata[r.name] = dict(r.metadata)
        elif isinstance(r, Attachment):
            rec.attachments[r.name] = bytes(r.data)

    try:
        f = open(path, "rb")
    except OSError as exc:
        raise RecordingError(f"{path}: cannot open: {exc.strerror}") from None
    with f:
        reader = StreamReader(f, skip_magic=False, validate_crcs=True)
        try:
            for record in reader.records:
                if isinstance(record, Chunk):
                    for inner in breakup_chunk(record, validate_crc=True):
                        on_record(inner)
                else:
                    on_record(record)
        except RecordingError:
            raise
        except (McapError, EOFError, ValueError, Exception) as exc:  # noqa: BLE001
            if rec.messages == 0 and not rec.metadata:
                raise RecordingError(f"{path}: not a readable MCAP recording "
                                     f"({type(exc).__name__}: {exc})") from None
            rec.truncated = (f"reading stopped at byte {f.tell()} of "
                             f"{path.stat().st_size}: {type(exc).__name__}: {exc}")
    rec.topics = {t: _columns(r) for t, r in rows.items()}
    if keep_raw:
        rec.raw_messages = rows
    return rec
