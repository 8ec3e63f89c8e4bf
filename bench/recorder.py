"""MCAP recorder: one file per run, JSON channels with JSON schemas (they open in Foxglove).

Scalars are separate fields so Foxglove plots them directly. A value that does not exist (no
telemetry in a cycle, NaN) is written as JSON null; readers turn it back into NaN. Log times are the run's start
(wall clock, ns) plus the simulated time, so a lockstep run plays back at plant time.
The file is chunked (zstd) with a small chunk size so that a run cut by a crash is recoverable
up to the last complete chunk (``mcap recover``); ``close()`` writes the summary and is called on
every exit path, Ctrl-C included.
"""
from __future__ import annotations

import json
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Iterable

import orjson
from mcap.writer import CompressionType, Writer

CHUNK_SIZE_BYTES = 256 * 1024
PROFILE = "hil-bench"


def number_schema(title: str, fields: Iterable[str], *, integers: Iterable[str] = (),
                  strings: Iterable[str] = (), description: str = "") -> dict[str, Any]:
    """A flat JSON schema: every field a number (or null: not available) unless listed as
    integer or string."""
    props: dict[str, Any] = {}
    for f in fields:
        props[f] = {"type": ["number", "null"]}
    for f in integers:
        props[f] = {"type": "integer"}
    for f in strings:
        props[f] = {"type": "string"}
    return {"title": title, "description": description, "type": "object",
            "properties": props, "required": sorted(props)}


@dataclass
class Channel:
    """A registered channel; ``write`` takes the simulated time and a JSON-able dict."""

    recorder: "Recorder"
    channel_id: int
    topic: str
    sequence: int = 0

    def write(self, t_s: float, message: dict[str, Any]) -> None:
        self.recorder._write(self, t_s, message)


class Recorder:
    """Writes one MCAP file. Use as a context manager; always finalised on exit."""

    def __init__(self, path: Path, chunk_size: int = CHUNK_SIZE_BYTES):
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._file = open(self.path, "wb")
        self._writer = Writer(self._file, chunk_size=chunk_size, compression=CompressionType.ZSTD)
        self._writer.start(profile=PROFILE, library="hil-bench recorder")
        self._schemas: dict[str, int] = {}
        self.start_ns = time.time_ns()
        self.closed = False
        self.messages = 0

    def channel(self, topic: str, schema: dict[str, Any]) -> Channel:
        title = schema["title"]
        if title not in self._schemas:
            self._schemas[title] = self._writer.register_schema(
                name=title, encoding="jsonschema", data=json.dumps(schema).encode())
        cid = self._writer.register_channel(topic=topic, message_encoding="json",
                                            schema_id=self._schemas[title])
        return Channel(self, cid, topic)

    def _write(self, ch: Channel, t_s: float, message: dict[str, Any]) -> None:
        t_ns = self.start_ns + int(round(t_s * 1e9))
        self._writer.add_message(channel_id=ch.channel_id, log_time=t_ns, publish_time=t_ns,
                                 sequence=ch.sequence, data=orjson.dumps(message))
        ch.sequence += 1
        self.messages += 1

    def metadata(self, name: str, data: dict[str, str]) -> None:
        self._writer.add_metadata(name=name, data={k: str(v) for k, v in data.items()})

    def attachment(self, name: str, media_type: str, data: bytes) -> None:
        now = time.time_ns()
        self._writer.add_attachment(create_time=now, log_time=now, name=name,
                                    media_type=media_type, data=data)

    def close(self) -> None:
        if self.closed:
            return
        self.closed = True
        try:
            self._writer.finish()
        finally:
            self._file.close()

    def __enter__(self) -> "Recorder":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


# -- recording in a separate process ---------------------------------------------------------
#
# The lockstep loop spends most of its Python time serialising messages. The writer below moves
# that work to a child process: the loop appends (channel, time, values) tuples to a batch and
# ships a batch every BATCH_MESSAGES through a pipe. On two cores the child writes while the loop
# waits for the controller. If the parent dies, the child sees EOF and still finalises the file.

BATCH_MESSAGES = 512


def _serve(conn, parent_end, path: str, chunk_size: int) -> None:
    import signal as _signal

    # fork copied the parent's end of the pipe into this process: close it, or a dead parent
    # would never produce EOF here and the file would never be finalised
    parent_end.close()
    _signal.signal(_signal.SIGINT, _signal.SIG_IGN)  # the parent decides when to stop
    rec = Recorder(Path(path), chunk_size)
    channels: list[Channel] = []
    fields: list[tuple[str, ...] | None] = []
    try:
        while True:
            try:
                msg = conn.recv()
            except EOFError:
                break  # parent gone: finalise what we have
            kind = msg[0]
            if kind == "batch":
                for cid, t_s, values in msg[1]:
                    names = fields[cid]
                    channels[cid].write(t_s, values if names is None else dict(zip(names, values)))
            elif kind == "channel":
                _, topic, schema, names = msg
                channels.append(rec.channel(topic, schema))
                fields.append(names)
            elif kind == "metadata":
                rec.metadata(msg[1], msg[2])
            elif kind == "attachment":
                rec.attachment(msg[1], msg[2], msg[3])
            elif kind == "close":
                break
    finally:
        rec.close()
        try:
            conn.send(("closed", rec.messages))
        except (BrokenPipeError, OSError):
            pass
        conn.close()


@dataclass
class ProcessChannel:
    """Channel of a ProcessRecorder. ``write_values`` takes values in the ``fields`` order."""

    recorder: "ProcessRecorder"
    channel_id: int
    topic: str
    fields: tuple[str, ...] | None

    def write(self, t_s: float, message: dict[str, Any]) -> None:
        self.recorder._append(self.channel_id, t_s, message)

    def write_values(self, t_s: float, values: tuple) -> None:
        self.recorder._append(self.channel_id, t_s, values)


class ProcessRecorder:
    """Same interface as Recorder; the MCAP writing happens in a child process."""

    def __init__(self, path: Path, chunk_size: int = CHUNK_SIZE_BYTES):
        import multiprocessing as mp

        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        ctx = mp.get_context("fork")
        self._conn, child = ctx.Pipe()
        self._proc = ctx.Process(target=_serve, args=(child, self._conn, str(self.path), chunk_size),
                                 name="hil-recorder", daemon=False)
        self._proc.start()
        child.close()
        self._batch: list = []
        self._next_id = 0
        self.messages = 0
        self.closed = False

    def channel(self, topic: str, schema: dict[str, Any],
                fields: tuple[str, ...] | None = None) -> ProcessChannel:
        self._flush()
        self._conn.send(("channel", topic, schema, fields))
        ch = ProcessChannel(self, self._next_id, topic, fields)
        self._next_id += 1
        return ch

    def _append(self, cid: int, t_s: float, values) -> None:
        batch = self._batch
        batch.append((cid, t_s, values))
        if len(batch) >= BATCH_MESSAGES:
            self._flush()

    def _flush(self) -> None:
        if self._batch:
            self._conn.send(("batch", self._batch))
            self.messages += len(self._batch)
            self._batch = []

    def metadata(self, name: str, data: dict[str, str]) -> None:
        self._flush()
        self._conn.send(("metadata", name, {k: str(v) for k, v in data.items()}))

    def attachment(self, name: str, media_type: str, data: bytes) -> None:
        self._flush()
        self._conn.send(("attachment", name, media_type, data))

    def close(self) -> None:
        if self.closed:
            return
        self.closed = True
        try:
            self._flush()
            self._conn.send(("close",))
            if self._conn.poll(30.0):
                self._conn.recv()
        except (BrokenPipeError, EOFError, OSError):
            pass
        finally:
            self._conn.close()
            self._proc.join(30.0)
            if self._proc.exitcode not in (0, None):
                raise RuntimeError(f"recorder process for {self.path} failed "
                                   f"(exit code {self._proc.exitcode})")

    def __enter__(self) -> "ProcessRecorder":
        return self

    def __exit__(self, *exc) -> None:
        self.close()
