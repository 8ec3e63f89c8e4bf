"""MCAP recorder: a child process that drains the cycle engine's shared-memory ring into MCAP.

Data path. The bench maps a shared ring (``plant_rt/c/rec_ring.h``) before it forks the
recorder. The C cycle engine writes every recorded message into it already encoded (protobuf,
``bench/record/channels.py``); the recorder only copies records out and hands them to the ``mcap``
writer (zstd chunks). The engine never blocks on the recorder: in real time it drops and counts
a row the ring cannot take; in lockstep it waits a bounded time first (engine.h). The bench
writes the few messages of its own (set-up frames, events, final statistics) into the same ring
while the engine is not running, so the ring always has one producer.

Control (channels, metadata, attachments, close) goes through a pipe. Metadata and attachments
are written as they arrive; messages in ring order.

Files are never lost or overwritten (bench/record/atomic.py): the recording's name is taken by
creating ``.<name>.partial`` beside it exclusively (O_EXCL: two runs never share a name; a default
name that is taken becomes the next free one, ``reserve_recording``); the recording is written
there and renamed into place when it is finalised (normal end, Ctrl-C, a killed bench: the
recorder sees the pipe close and still finalises). The serial byte capture beside it is written
the same way and renamed with it, and the recording's ``sidecar<suffix>`` metadata gives its
size, SHA-256 and run id (``bench check`` compares: bench/record/sidecars.py). An existing target
is refused unless ``force``, and so are the side files a run writes beside it
(``<name>.serial.bin``, ``<name>.log``: ``SIDE_SUFFIXES``); with ``force`` they are moved to
``.<name>.replaced`` before the run starts and removed once the new recording is in place, so a
run that fails never leaves the old file at its path. If the recorder itself fails (disk full, an
unwritable folder) it says why in one line, the bench ends the run, and the partial file keeps
every complete chunk (``bench recover``).

A recorder that is killed (SIGKILL, the OOM killer) cannot finalise anything, so what it has is
on disk as soon as it has it: the MCAP header right after start, every schema and channel as it is
registered (also outside the chunks: the chunk that carries them may never be written), the
metadata and attachments as they arrive, every chunk when it closes. The bench side turns a
closed pipe into ``RecorderError("recorder process (pid N) for PATH died (killed by signal S)
...")`` wherever it talks to the recorder.
"""
from __future__ import annotations

import hashlib
import json
import mmap
import os
import struct
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from mcap.records import Channel, Schema

from hil_bench.errors import BenchError
from hil_bench.plant_rt._plant_c import ffi, lib

from . import channels as chans
from . import sidecars
from .atomic import (
    abandoned,
    fsync_dir,
    keep_abandoned,
    move_to_replaced,
    numbered,
    partial_path,
    publish,
    take_exclusive,
)

CHUNK_SIZE_BYTES = 256 * 1024
PROFILE = "hil-bench"
RING_CAPACITY_BYTES = 64 * 1024 * 1024   #: ~9 s of a 10 kHz G2 run at ~700 octets per cycle
READ_BATCH_BYTES = 4 * 1024 * 1024
STALL_TIMEOUT_S = 5.0     #: a recorder that drains nothing and uses no CPU this long while closing is stalled
#: a recorder that uses CPU is working, however slowly a busy host lets it: waited for this long at most
WORKING_LIMIT_S = 600.0


def process_cpu_s(pid: int) -> float | None:
    """CPU time [s] a process has used: /proc/PID/schedstat (nanoseconds), else user + system
    from /proc/PID/stat (clock ticks of 10 ms, where a starved process's few milliseconds a
    second may not show); None if neither can be read."""
    try:
        with open(f"/proc/{pid}/schedstat", "rb") as f:
            return int(f.read().split()[0]) * 1e-9
    except (OSError, ValueError, IndexError):
        pass
    try:
        with open(f"/proc/{pid}/stat", "rb") as f:
            stat = f.read().decode(errors="replace")
        fields = stat[stat.rfind(")") + 2:].split()
        return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")
    except (OSError, ValueError, IndexError):
        return None


def process_runnable(pid: int) -> bool:
    """The process waits for a CPU or runs (state R): a busy host starves it, it is not stuck
    (a stopped process is T, a blocked one S or D)."""
    try:
        with open(f"/proc/{pid}/stat", "rb") as f:
            stat = f.read().decode(errors="replace")
        return stat[stat.rfind(")") + 2:].split()[0] == "R"
    except (OSError, IndexError):
        return False
FINISH_TIMEOUT_S = 60.0   #: ... and with the ring empty, to write the file's summary
EXIT_WAIT_S = 5.0         #: a recorder whose pipe closed is reaped within this (SIGKILL under load)
_REC_HEADER = struct.Struct("<IHHq")


class RecorderError(BenchError, RuntimeError):
    """The recorder cannot write the recording (message names the cause and the path)."""


#: files a run writes beside its recording X.mcap (sidecars.py): the serial byte capture (serial
#: links, docs/replay.md) and the candump log (CAN links); refused like the recording itself
SIDE_SUFFIXES = sidecars.SIDE_SUFFIXES


def check_target(path: Path, force: bool, *, option: str = "--out",
                 side_suffixes: tuple[tuple[str, str], ...] = SIDE_SUFFIXES) -> None:
    """Refuse a target that exists (unless force) or cannot be a file, before anything runs; and
    the side files the run writes beside it (``side_suffixes``: suffix, what) the same way."""
    if path.is_dir():
        raise RecorderError(f"{option} {path}: is a directory; give a file name (e.g. {path}/run.mcap)")
    if path.exists() and not force:
        raise RecorderError(f"{option} {path}: file exists; refusing to overwrite a recording "
                            f"(use --force to replace it)")
    for suffix, what in side_suffixes:
        side = path.with_suffix(suffix)
        if side.is_dir():
            raise RecorderError(f"{option} {path}: {side} (the run's {what}) is a directory")
        if side.exists() and not force:
            raise RecorderError(f"{option} {path}: {side} exists (the run's {what} would replace it); "
                                f"refusing to overwrite it (move it, choose another {option}, or use "
                                f"--force to replace both)")
    parent = path.parent if str(path.parent) else Path(".")
    try:
        parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise RecorderError(f"cannot create the recordings folder {parent}: {exc.strerror}") from None
    if not os.access(parent, os.W_OK):
        raise RecorderError(f"cannot write recordings into {parent}: permission denied")


def recording_stamp() -> str:
    """``<date>-<time>-<ms>-<pid>`` of a default recording name: two runs started in the same
    millisecond are two processes (and a name that is taken anyway becomes the next free one:
    :func:`reserve_recording`)."""
    from datetime import datetime

    now = datetime.now()
    return f"{now:%Y%m%d-%H%M%S}-{now.microsecond // 1000:03d}-{os.getpid()}"


#: how many other names (``x-1.mcap`` ...) a default name that is taken may become
MAX_FREE_NAMES = 1000


@dataclass
class Reservation:
    """A recording's name, taken: its partial file exists (empty) and is this run's. ``replaced``:
    the files a ``force`` run moved aside (original, where it is now) until the new recording is
    in place (:meth:`drop_replaced`), or for good if the run fails (:meth:`replaced_text`)."""

    path: Path
    force: bool
    replaced: list[tuple[Path, Path]] = field(default_factory=list)
    #: the descriptor that holds the partial file's lock (atomic.take_exclusive); the recorder
    #: process inherits it and keeps it open until it has finished
    lock_fd: int | None = None
    #: partial files of writers that died, moved aside to keep what they hold (bench recover)
    abandoned: list[Path] = field(default_factory=list)

    @property
    def partial(self) -> Path:
        return partial_path(self.path)

    def drop_replaced(self) -> None:
        for _, moved in self.replaced:
            try:
                moved.unlink()
            except OSError:
                pass
        self.replaced = []

    def replaced_text(self) -> str:
        """What a failed run says about the files it replaced ("" if none)."""
        if not self.replaced:
            return ""
        return ("; the previous " + ", ".join(f"{orig.name} is kept as {moved}"
                                              for orig, moved in self.replaced))

    def release(self) -> None:
        """Nothing was written: give the name back (the empty partial file removed)."""
        try:
            if self.partial.stat().st_size == 0:
                self.partial.unlink()
        except OSError:
            pass
        self.unlock()

    def unlock(self) -> None:
        """This process's hold on the name (the recorder's copy keeps it until it finishes)."""
        if self.lock_fd is not None:
            try:
                os.close(self.lock_fd)
            except OSError:
                pass
            self.lock_fd = None


def reserve_recording(path: Path, *, force: bool = False, pick_free: bool = False,
                      side_suffixes: tuple[tuple[str, str], ...] = SIDE_SUFFIXES,
                      option: str = "--out") -> Reservation:
    """Take ``path``'s name for a new recording: check it as :func:`check_target` does, create
    its partial file exclusively and hold its lock (the recorder process inherits the hold), and
    with ``force`` move an existing recording and its side files aside (``.<name>.replaced``,
    never over an older one). A partial file whose writer holds its lock (a run writing it now)
    is never taken, with or without ``force``; one whose writer died is renamed
    ``<stem>.abandoned.mcap`` (kept: ``bench check`` reads it, ``bench recover`` copies it) and
    the name taken. ``pick_free``: a name that is taken (a file, a partial file being written
    or, without ``force``, a side file) becomes the next free one, ``x-1.mcap``, ``x-2.mcap``
    ... (default names: two runs started together in one folder both record)."""
    path = Path(path)
    kept: list[Path] = []
    for n in range(MAX_FREE_NAMES + 1):
        cand = path if n == 0 else numbered(path, n)
        if pick_free:
            sides = [cand.with_suffix(sfx) for sfx, _ in side_suffixes]
            if not force and any(os.path.lexists(p) for p in (cand, *sides)):
                continue
            if os.path.lexists(partial_path(cand)) and not abandoned(partial_path(cand)):
                continue
        check_target(cand, force, option=option, side_suffixes=side_suffixes)
        part = partial_path(cand)
        fd = take_exclusive(part)
        if fd is None and abandoned(part):
            # its writer died (no one holds its lock): what it wrote is kept, never lost
            moved = keep_abandoned(part, cand)
            if moved is not None:
                kept.append(moved)
            fd = take_exclusive(part)
        if fd is None:
            if pick_free:
                continue
            raise RecorderError(
                f"{option} {cand}: {part} is being written by another run (it holds the file); "
                f"choose another {option} (--force never takes a recording that is being written)")
        res = Reservation(cand, force, lock_fd=fd, abandoned=kept)
        if force:
            try:
                for p in (cand, *(cand.with_suffix(sfx) for sfx, _ in side_suffixes)):
                    moved = move_to_replaced(p)
                    if moved is not None:
                        res.replaced.append((p, moved))
            except OSError as exc:
                res.release()
                raise RecorderError(f"{option} {cand}: cannot move the previous file aside "
                                    f"({exc.strerror or exc})") from None
        return res
    raise RecorderError(f"{option} {path}: it and {MAX_FREE_NAMES} numbered names after it are "
                        f"taken; clean the folder or give --out")


class _CountingFile:
    """A binary file that counts and hashes what is written to it (the serial byte capture:
    the recording's ``sidecar.serial.bin`` metadata gives its size and SHA-256)."""

    def __init__(self, path: Path):
        self.path = Path(path)
        self.name = str(path)
        self._f = open(path, "wb")
        self._sha = hashlib.sha256()
        self.size = 0

    def write(self, data) -> int:
        self._sha.update(data)
        self.size += len(data)
        return self._f.write(data)

    def flush(self) -> None:
        self._f.flush()

    def close(self) -> None:
        if not self._f.closed:
            self._f.flush()
            os.fsync(self._f.fileno())
            self._f.close()

    @property
    def sha256(self) -> str:
        return self._sha.hexdigest()


def side_suffix(name: str, suffixes: tuple[tuple[str, str], ...] = SIDE_SUFFIXES) -> str:
    """The side-file suffix a file name ends with (``.serial.bin``), or its last suffix."""
    for sfx, _ in suffixes:
        if name.endswith(sfx):
            return sfx
    return Path(name).suffix


# -- the child ------------------------------------------------------------------------------


class SpilledChunkIndexes:
    """The writer's list of chunk indexes, kept in a temporary file instead of memory.

    mcap's ``Writer`` keeps one ``ChunkIndex`` object per chunk (a dataclass and a dict of
    per-channel offsets, about 1.7 kB) until ``finish`` writes the summary: 41 % growth of the
    recorder's memory over a 10-minute soak (24 000 chunks). Each index is serialised to its
    record bytes when the chunk closes and appended to an unnamed temporary file; ``finish``
    reads them back in order. Memory stays flat; the summary written is byte for byte the same.
    """

    class _Record:
        __slots__ = ("data",)

        def __init__(self, data: bytes):
            self.data = data

        def write(self, stream) -> None:   # what Writer.finish calls on each index
            stream.write(self.data)

    def __init__(self) -> None:
        import tempfile

        self._file = tempfile.TemporaryFile()
        self.count = 0

    def append(self, index) -> None:
        from mcap.data_stream import RecordBuilder

        rb = RecordBuilder()
        index.write(rb)
        data = rb.end()
        self._file.write(struct.pack("<I", len(data)))
        self._file.write(data)
        self.count += 1

    def __len__(self) -> int:
        return self.count

    def __iter__(self):
        self._file.flush()
        self._file.seek(0)
        for _ in range(self.count):
            (n,) = struct.unpack("<I", self._file.read(4))
            yield self._Record(self._file.read(n))
        self._file.seek(0, os.SEEK_END)

    def close(self) -> None:
        self._file.close()


def spill_chunk_indexes(writer) -> SpilledChunkIndexes | None:
    """Swap the writer's in-memory chunk index list for a SpilledChunkIndexes (before the first
    chunk). None if this mcap version keeps them differently: the recording is the same, only
    the memory grows with the run (tests/test_recording_safety.py checks the swap happens)."""
    attr = "_Writer__chunk_indices"
    if not isinstance(getattr(writer, attr, None), list) or getattr(writer, attr):
        return None
    spilled = SpilledChunkIndexes()
    setattr(writer, attr, spilled)
    return spilled


class _BatchMessageIndex:
    """A chunk's MessageIndex record of one channel, kept as numpy arrays (mcap's MessageIndex
    holds a Python tuple per message); ``write`` emits the same bytes as mcap's."""

    __slots__ = ("channel_id", "_times", "_offsets")

    def __init__(self, channel_id: int):
        self.channel_id = channel_id
        self._times: list = []
        self._offsets: list = []

    def extend(self, times, offsets) -> None:
        self._times.append(times)
        self._offsets.append(offsets)

    def write(self, stream) -> None:
        import numpy as np
        from mcap.opcode import Opcode

        t = np.concatenate(self._times) if self._times else np.zeros(0, "<u8")
        pairs = np.empty((len(t), 2), dtype="<u8")
        pairs[:, 0] = t
        pairs[:, 1] = np.concatenate(self._offsets) if self._offsets else pairs[:, 1]
        stream.start_record(Opcode.MESSAGE_INDEX)
        stream.write2(self.channel_id)
        stream.write4(len(t) * 16)
        stream.write(pairs.tobytes())
        stream.finish_record()


class FastChunkBuilder:
    """mcap's ChunkBuilder (same interface, same bytes), fed whole batches of Message records
    built in C (plant_rt/c/rec_mcap.c): the recorder spends no Python per message, which is what
    lets it keep up at 10 kHz beside the real-time engine (docs/realtime.md). Single messages
    (the slow path) go through mcap's own code."""

    def __init__(self) -> None:
        from mcap.data_stream import RecordBuilder

        self.record_writer = RecordBuilder()
        self.message_indices: dict = {}
        self.message_start_time = 0
        self.message_end_time = 0
        self.num_messages = 0

    @property
    def count(self) -> int:
        return self.record_writer.count

    def end(self):
        return self.record_writer.end()

    def add_channel(self, channel) -> None:
        channel.write(self.record_writer)

    def add_schema(self, schema) -> None:
        schema.write(self.record_writer)

    def add_message(self, message) -> None:
        import numpy as np

        if self.num_messages == 0:
            self.message_start_time = message.log_time
        else:
            self.message_start_time = min(self.message_start_time, message.log_time)
        self.message_end_time = max(self.message_end_time, message.log_time)
        index = self.message_indices.get(message.channel_id)
        if index is None:
            index = self.message_indices[message.channel_id] = _BatchMessageIndex(message.channel_id)
        index.extend(np.array([message.log_time], "<u8"), np.array([self.record_writer.count], "<u8"))
        self.num_messages += 1
        message.write(self.record_writer)

    def add_batch(self, records: bytes, entries) -> None:
        """``records``: consecutive Message records; ``entries``: rec_mcap_entry_t rows (their
        offsets from the start of ``records``, log times, channel ids)."""
        import numpy as np

        base = self.record_writer.count
        times = entries["log_time"]
        chans = entries["channel_id"]
        if self.num_messages == 0:
            self.message_start_time = int(times.min())
        else:
            self.message_start_time = min(self.message_start_time, int(times.min()))
        self.message_end_time = max(self.message_end_time, int(times.max()))
        _, first = np.unique(chans, return_index=True)
        for i in np.sort(first):             # channels in the order of their first message
            cid = int(chans[i])
            mask = chans == cid
            index = self.message_indices.get(cid)
            if index is None:
                index = self.message_indices[cid] = _BatchMessageIndex(cid)
            index.extend(times[mask].astype("<u8"), entries["offset"][mask].astype("<u8") + base)
        self.num_messages += len(entries)
        self.record_writer.write(records)

    def reset(self) -> None:
        self.message_end_time = 0
        self.message_indices.clear()
        self.message_start_time = 0
        self.record_writer.end()
        self.num_messages = 0


class FastPath:
    """Ring records -> MCAP through FastChunkBuilder, updating the writer's statistics as
    mcap's add_message does. ``install`` returns None when this mcap version keeps its state
    differently (then the recorder takes the slow path: same file, more CPU)."""

    OUT_CAP = 1 << 20
    ENTRIES = 16384
    RAW_CAP = 1 << 20

    def __init__(self, writer, chunk_size: int):
        import numpy as np

        self.writer = writer
        self.chunk_size = chunk_size
        self.builder = FastChunkBuilder()
        writer._Writer__chunk_builder = self.builder
        self.stats = writer._Writer__statistics
        self.finalize = writer._Writer__maybe_finalize_chunk
        self.out = bytearray(self.OUT_CAP)
        self.cout = ffi.from_buffer(self.out)
        self.entries = np.zeros(self.ENTRIES, dtype=_ENTRY_DTYPE)
        self.centries = ffi.cast("rec_mcap_entry_t *", ffi.from_buffer(self.entries))
        self.raw = bytearray(self.RAW_CAP)
        self.craw = ffi.from_buffer(self.raw)
        self.res = ffi.new("rec_mcap_result_t *")
        self.map = np.zeros(0, dtype=np.int32)
        self.seqs = np.zeros(0, dtype=np.uint32)

    @classmethod
    def install(cls, writer, chunk_size: int) -> "FastPath | None":
        builder = getattr(writer, "_Writer__chunk_builder", None)
        if (builder is None or getattr(builder, "num_messages", 1) != 0
                or not hasattr(writer, "_Writer__statistics")
                or not hasattr(writer, "_Writer__maybe_finalize_chunk")
                or not hasattr(builder, "record_writer") or _ENTRY_DTYPE is None):
            return None
        return cls(writer, chunk_size)

    def set_channels(self, channel_ids: list[int], seqs: list[int]) -> None:
        """channel_ids[ring channel]: the MCAP id (-1: the serial byte capture)."""
        import numpy as np

        self.map = np.array([c if c >= 0 else -1 for c in channel_ids], dtype=np.int32)
        old = self.seqs
        self.seqs = np.zeros(len(channel_ids), dtype=np.uint32)
        self.seqs[:len(old)] = old[:len(channel_ids)]

    def messages(self, cbuf, n: int, start_ns: int, raw_file) -> int:
        """Write the ring records in cbuf[0..n) into the chunk(s) and the capture file; returns
        the messages written."""
        import numpy as np

        stats = self.stats
        cmap = ffi.cast("int32_t *", ffi.from_buffer(self.map))
        cseqs = ffi.cast("uint32_t *", ffi.from_buffer(self.seqs))
        pos, written = 0, 0
        while pos < n:
            limit = max(self.chunk_size - self.builder.count, 0)
            lib.rec_to_mcap(cbuf + pos, n - pos, cmap, len(self.map), cseqs, start_ns, limit,
                            self.cout, len(self.out), self.centries, self.ENTRIES, self.craw,
                            len(self.raw), self.res)
            r = self.res
            if r.in_used == 0:
                raise RuntimeError("recorder: a ring record larger than the fast path's buffers")
            if r.raw_len and raw_file is not None:
                raw_file.write(memoryview(self.raw)[:r.raw_len])
            k = int(r.n_entries)
            if k:
                ents = self.entries[:k]
                times = ents["log_time"]
                if stats.message_count == 0:
                    stats.message_start_time = int(times.min())
                else:
                    stats.message_start_time = min(stats.message_start_time, int(times.min()))
                stats.message_end_time = max(stats.message_end_time, int(times.max()))
                chans, first, counts = np.unique(ents["channel_id"], return_index=True,
                                                 return_counts=True)
                for j in np.argsort(first):   # first-seen order, as add_message inserts them
                    stats.channel_message_counts[int(chans[j])] += int(counts[j])
                stats.message_count += k
                self.builder.add_batch(bytes(memoryview(self.out)[:r.out_len]), ents)
                self.finalize()
                written += k
            pos += int(r.in_used)
        return written


def _entry_dtype():
    try:
        import numpy as np

        return np.dtype({"names": ["offset", "log_time", "channel_id"],
                         "formats": ["<u8", "<u8", "<u2"],
                         "offsets": [ffi.offsetof("rec_mcap_entry_t", "offset"),
                                     ffi.offsetof("rec_mcap_entry_t", "log_time"),
                                     ffi.offsetof("rec_mcap_entry_t", "channel_id")],
                         "itemsize": ffi.sizeof("rec_mcap_entry_t")})
    except Exception:  # noqa: BLE001 - an older compiled module: the slow path
        return None


_ENTRY_DTYPE = _entry_dtype()


def _close_inherited_fds(keep: tuple[int, ...]) -> None:
    """Close every descriptor above stderr but ``keep`` (the recorder's pipe to the bench)."""
    try:
        fds = [int(name) for name in os.listdir("/proc/self/fd")]
    except OSError:
        fds = list(range(3, 1024))
    for fd in fds:
        if fd > 2 and fd not in keep:
            try:
                os.close(fd)
            except OSError:
                pass


def _write_outside_chunks(f, record) -> None:
    """A Schema or Channel record straight into the data section, and to disk. The writer also
    puts it into the open chunk (written only once it holds messages); MCAP allows the duplicate
    (identical records with the same id), and a reader of a file cut before that chunk still
    knows every channel. Called only between writer operations, when the writer has flushed its
    own records (its offsets come from f.tell(), so they stay right)."""
    from mcap.data_stream import RecordBuilder

    rb = RecordBuilder()
    record.write(rb)
    f.write(rb.end())
    f.flush()


def _serve(conn, parent_end, path: str, ring_mem, ring_size: int, chunk_size: int,
           force: bool, cpus: tuple[int, ...] = (), live=None, live_inbox=None,
           background: bool = False, lock_fd: int | None = None) -> None:
    import signal as _signal

    from mcap.writer import CompressionType, Writer

    # fork copied the parent's end of the pipe: close it, or a dead parent would never show as
    # EOF here and the file would never be finalised
    parent_end.close()
    # ... and every other descriptor the parent had open: a link's pty master or socket kept
    # open here would hide the link's end from the controller (a stub blocked writing to a pty
    # whose master the bench has closed would never see EIO, nor exit)
    # (the partial file's lock stays held by this process until it has finished the file)
    _close_inherited_fds(keep=(conn.fileno(),) + ((lock_fd,) if lock_fd is not None else ()))
    _signal.signal(_signal.SIGINT, _signal.SIG_IGN)   # the parent decides when to stop
    if cpus:
        try:
            os.sched_setaffinity(0, cpus)   # real time: the engine's CPU, below the engine
        except OSError:
            pass
    if background and os.environ.get("HIL_RECORDER_BATCH", "1") != "0" and (live is None or live.background):
        # real time: throughput, not latency, every other task of the machine first, the
        # engine's deadlines above all (not with a live view: a viewer wants the rows while they
        # are new). Not in lockstep: there the engine waits for ring space, and a recorder a
        # busy machine starves at nice 19 would stall the run
        try:
            os.sched_setscheduler(0, os.SCHED_BATCH, os.sched_param(0))
            os.nice(19)
        except OSError:
            pass
    target = Path(path)
    tmp = partial_path(target)
    ring = ffi.new("rec_ring_t *")
    if lib.rec_ring_attach(ring, ffi.from_buffer(ring_mem), ring_size) != 0:
        conn.send(("error", "recorder: the shared ring is not formatted"))
        return
    live_view = None   # the live view (live_view.py): before the file, so a taken port leaves none
    if live is not None:
        from .live_view import LiveView, LiveViewError

        try:
            live_view = LiveView(live, name=f"hil-bench {target.name}", inbox_mem=live_inbox,
                                 inputs_allowed=live.inputs)
        except LiveViewError as exc:
            conn.send(("error", str(exc)))
            return
        except Exception as exc:  # noqa: BLE001 - a bug here must name itself, not kill the run silently
            conn.send(("error", f"live view: {type(exc).__name__}: {exc}"))
            return
    buf = bytearray(READ_BATCH_BYTES)
    cbuf = ffi.from_buffer(buf)
    channel_ids: list[int] = []
    raw_files: dict[int, object] = {}   # ring channel -> side file (serial byte capture)
    side_targets: dict[int, tuple[Path, str]] = {}   # id(side file) -> (its final path, run id)
    from .serial_capture import END_OF_RUN, write_end

    #: how the serial capture ends (its end record): the bench's close, unless it went away first
    closed_by = "the bench went away before the end of its run; the recorder closed the capture"
    messages = 0
    error = None
    f = None
    writer = None
    fast = None
    start_ns = 0
    seqs: list[int] = []
    try:
        f = open(tmp, "wb")
        writer = Writer(f, chunk_size=chunk_size, compression=CompressionType.ZSTD)
        spill_chunk_indexes(writer)
        fast = (FastPath.install(writer, chunk_size)
                if os.environ.get("HIL_RECORDER_FAST", "1") != "0" else None)
        writer.start(profile=PROFILE, library="hil-bench recorder")
        f.flush()   # a recorder killed from here on leaves a file that starts as an MCAP file
        schema_ids: dict[str, int] = {}
        # the run's wall-clock start: log times are start + the engine's run time (a test pins
        # it with HIL_RECORDER_T0_NS to compare two recorders byte for byte)
        start_ns = int(os.environ.get("HIL_RECORDER_T0_NS") or time.time_ns())

        def drain(budget: int | None = None) -> int:
            """Copy records out of the ring into the file until it is empty, or until
            ``budget`` octets were read (what was pending at a request: a writer that keeps the
            ring busy cannot hold a control message back for ever). Returns octets read."""
            nonlocal messages
            total = 0
            while budget is None or total < budget:
                n = lib.rec_ring_read(ring, cbuf, len(buf))
                if n == 0:
                    return total
                total += n
                if live_view is not None:
                    live_view.feed(cbuf, buf, n, start_ns)
                if fast is not None and len(raw_files) <= 1:
                    if len(fast.map) != len(channel_ids):
                        fast.set_channels(channel_ids, seqs)
                    messages += fast.messages(cbuf, n, start_ns,
                                              next(iter(raw_files.values()), None))
                    continue
                view = memoryview(buf)[:n]
                off = 0
                add = writer.add_message
                while off < n:
                    length, channel, _flags, t_ns = _REC_HEADER.unpack_from(view, off)
                    data = bytes(view[off + 16:off + 16 + length])
                    off += 16 + ((length + 7) & ~7)
                    if channel >= len(channel_ids):
                        continue   # a channel the bench never registered: cannot happen
                    side = raw_files.get(channel)
                    if side is not None:   # serial byte capture: direction octet, then octets
                        from .serial_capture import write_record

                        write_record(side, t_ns, data[0], data[1:])
                        continue
                    t = start_ns + t_ns
                    add(channel_id=channel_ids[channel], log_time=t, publish_time=t,
                        sequence=seqs[channel], data=data)
                    seqs[channel] += 1
                    messages += 1
            return total

        conn.send(("ready", str(tmp), live_view.port if live_view is not None else None))
        busy = False
        while True:
            if conn.poll(0 if busy else 0.002):
                try:
                    msg = conn.recv()
                except EOFError:
                    break   # parent gone: finalise what we have
                kind = msg[0]
                if kind == "channel":
                    _, topic, schema_name = msg
                    if schema_name not in schema_ids:
                        sid = schema_ids[schema_name] = writer.register_schema(
                            name=schema_name, encoding="protobuf",
                            data=chans.file_descriptor_set())
                        _write_outside_chunks(f, Schema(id=sid, name=schema_name, encoding="protobuf",
                                                        data=chans.file_descriptor_set()))
                    cid = writer.register_channel(topic=topic, message_encoding=chans.MESSAGE_ENCODING,
                                                  schema_id=schema_ids[schema_name])
                    _write_outside_chunks(f, Channel(id=cid, topic=topic,
                                                     message_encoding=chans.MESSAGE_ENCODING,
                                                     schema_id=schema_ids[schema_name], metadata={}))
                    if live_view is not None:
                        live_view.add_channel(topic, schema_name, chans.file_descriptor_set())
                    channel_ids.append(cid)
                    seqs.append(0)
                    conn.send(("channel_ok", len(channel_ids) - 1))
                elif kind == "rawfile":
                    from .serial_capture import write_header

                    side_path = Path(msg[1])
                    if os.path.lexists(side_path) and not force:
                        conn.send(("error", f"{side_path} exists (appeared after the check); "
                                            f"refusing to overwrite it"))
                        continue
                    # written aside, renamed with the recording (the run's name is reserved:
                    # a partial capture of that name is one a dead run left)
                    side = _CountingFile(partial_path(side_path))
                    side_targets[id(side)] = (side_path, msg[2] if len(msg) > 2 else "")
                    write_header(side)
                    raw_files[len(channel_ids)] = side
                    if live_view is not None:
                        live_view.add_raw()
                    channel_ids.append(-1)
                    seqs.append(0)
                    conn.send(("channel_ok", len(channel_ids) - 1))
                elif kind == "metadata":
                    drain(int(lib.rec_ring_pending(ring)))   # what was written before it
                    writer.add_metadata(name=msg[1], data=msg[2])
                    f.flush()
                elif kind == "attachment":
                    now = time.time_ns()
                    writer.add_attachment(create_time=now, log_time=now, name=msg[1],
                                          media_type=msg[2], data=msg[3])
                    f.flush()
                elif kind == "drain":
                    drain(int(lib.rec_ring_pending(ring)))
                    conn.send(("drained", messages))
                elif kind == "wait_viewer":
                    # --live-wait: answer once a viewer subscribed or the time is up; drain
                    # meanwhile (the bench wrote its set-up rows); a bench gone ends the wait
                    deadline = time.monotonic() + float(msg[1])
                    seen = live_view is not None and live_view.first_subscriber.is_set()
                    while live_view is not None and not seen and time.monotonic() < deadline:
                        drain()
                        if conn.poll(0):
                            break
                        seen = live_view.first_subscriber.wait(0.05)
                    try:
                        conn.send(("viewer", bool(seen)))
                    except OSError:   # the bench is gone: finalise what we have
                        break
                elif kind == "close":
                    closed_by = END_OF_RUN
                    break
            busy = drain(READ_BATCH_BYTES) > 0   # then look at the pipe again
        drain()
    except OSError as exc:
        error = f"recorder: cannot write {target}: {exc.strerror or exc}"
    except Exception as exc:  # noqa: BLE001 - report, then finalise what we can
        error = f"recorder: {type(exc).__name__}: {exc} (writing {target})"
    finally:
        live_stats = None
        if live_view is not None:
            # stop serving without waiting for the viewers: the recording is finalised first,
            # whoever holds a connection to the port (LiveView.stop)
            live_view.stop()
            if writer is not None and error is None:
                try:   # what the engine never took: every input is on /events, applied or refused
                    _write_events(writer, live_view, live_view.end_inputs(), channel_ids, seqs,
                                  fast, start_ns)
                except Exception as exc:  # noqa: BLE001
                    error = f"recorder: cannot write the operator inputs' rows: {exc}"
            live_stats = live_view.stats()
            if writer is not None and error is None:
                try:   # the viewer's end-of-run figures (docs/foxglove.md "Dropped frames")
                    writer.add_metadata(name="live_view", data={
                        k: (v if isinstance(v, str) else json.dumps(v))
                        for k, v in live_stats.items()})
                except Exception as exc:  # noqa: BLE001 - the file matters more than the figure
                    error = f"recorder: cannot write the live view's figures: {exc}"
        for side in raw_files.values():
            side_path, run_id = side_targets[id(side)]
            try:
                note = (closed_by if error is None else
                        f"the recorder failed ({error}); it closed the capture")
                write_end(side, time.monotonic_ns(), note + (f" (run {run_id})" if run_id else ""))
                side.close()
                if writer is not None and error is None:
                    writer.add_metadata(name="sidecar" + side_suffix(side_path.name), data={
                        "file": side_path.name, "bytes": str(side.size), "sha256": side.sha256,
                        "run_id": run_id})
            except OSError as exc:
                error = error or f"recorder: cannot close {side.name}: {exc.strerror}"
            except Exception as exc:  # noqa: BLE001 - the file matters more than the figure
                error = error or f"recorder: cannot note {side_path.name}: {exc}"
        finished = False
        if writer is not None:
            try:
                writer.finish()
                finished = True
            except Exception as exc:  # noqa: BLE001
                error = error or f"recorder: cannot finalise {target}: {exc}"
        if f is not None:
            try:
                f.flush()
                os.fsync(f.fileno())
                f.close()
            except (OSError, ValueError) as exc:
                error = error or f"recorder: cannot close {target}: {getattr(exc, 'strerror', exc)}"
        final = str(tmp)
        if finished and error is None:
            # the side files first, then the recording: a reader that finds the recording
            # finds its captures beside it (a run that fails leaves both under .partial names)
            for side in raw_files.values():
                side_path, _ = side_targets[id(side)]
                try:
                    publish(side.path, side_path, replace=force)
                except FileExistsError:
                    error = (f"recorder: {side_path} appeared while recording; the capture is "
                             f"kept as {side.path}")
                except OSError as exc:
                    error = f"recorder: cannot rename {side.path} to {side_path}: {exc}"
        if finished and error is None:
            try:
                publish(tmp, target, replace=force)
                final = str(target)
                fsync_dir(target)
            except FileExistsError:
                error = f"recorder: {target} appeared while recording; kept as {tmp}"
            except OSError as exc:
                error = f"recorder: cannot rename {tmp} to {target}: {exc}"
        try:
            conn.send(("closed", messages, final, error, live_stats))
        except (BrokenPipeError, OSError):
            pass
        conn.close()
        if live_view is not None:
            live_view.wait_stopped()   # bounded: the clients' clean close, never the recording


def _write_events(writer, live_view, rows, channel_ids: list[int], seqs: list[int], fast,
                  start_ns: int) -> None:
    """/events rows the recorder writes itself, after the ring's last record (the operator
    inputs the engine never took: LiveView.end_inputs), at the time of the recording's last
    message."""
    ch = live_view._events_ch
    if not rows or ch is None or ch >= len(channel_ids):
        return
    stats = getattr(writer, "_Writer__statistics", None)
    t = int(stats.message_end_time) if stats is not None and stats.message_count else start_ns
    t_s = (t - start_ns) / 1e9
    for kind, text, value in rows:
        if fast is not None and ch < len(fast.seqs):
            seq = int(fast.seqs[ch])
            fast.seqs[ch] += 1
        else:
            seq = seqs[ch]
            seqs[ch] += 1
        writer.add_message(channel_id=channel_ids[ch], log_time=t, publish_time=t, sequence=seq,
                           data=chans.encode_row("EVENT", (t_s, kind, text, value)))


# -- the bench side ---------------------------------------------------------------------------


def _empty_size() -> int:
    """Octets of what the recorder writes before any data: the magic and its header record."""
    import io

    from mcap.writer import Writer

    buf = io.BytesIO()
    Writer(buf).start(profile=PROFILE, library="hil-bench recorder")
    return len(buf.getvalue())


@dataclass
class ProcessChannel:
    """A registered channel; the bench writes through it only while the engine is not running."""

    recorder: "ProcessRecorder"
    index: int
    topic: str
    kind: str

    def write_values(self, t_s: float, values) -> None:
        self.recorder.write(self.index, t_s, chans.encode_row(self.kind, values))

    def write(self, t_s: float, message: dict[str, Any]) -> None:
        self.write_values(t_s, message)


class ProcessRecorder:
    """Writes one MCAP file through a recorder process. Context manager; always finalised."""

    def __init__(self, path: Path, *, force: bool = False, ring_capacity: int = RING_CAPACITY_BYTES,
                 chunk_size: int = CHUNK_SIZE_BYTES, cpus: tuple[int, ...] = (), live=None,
                 live_inbox=None, background: bool = False,
                 reservation: Reservation | None = None):
        """``cpus``: the CPUs the recorder process may run on (empty: any); ``background``: it
        yields to every other task of the machine (SCHED_BATCH, nice 19: real time, where the
        engine's deadlines come first; not in lockstep, where the engine waits for ring space).
        ``live``: a
        :class:`.live_view.LiveOptions` to serve the channels to Foxglove while recording
        (:attr:`live_port` is then the port it listens on); ``live_inbox``: the engine's
        operator-input mailbox (a formatted MAP_SHARED mapping, live.h) it pushes inputs to.
        ``reservation``: the name the caller took (:func:`reserve_recording`, with the side
        files); else the recorder takes ``path`` itself."""
        try:
            self._init(path, force, ring_capacity, chunk_size, cpus, live, live_inbox, background,
                       reservation)
        except BaseException:
            res = getattr(self, "reservation", None)
            if res is not None:
                res.release()   # nothing was written to it: the name is free again
            raise

    def _init(self, path, force, ring_capacity, chunk_size, cpus, live, live_inbox, background,
              reservation) -> None:
        import multiprocessing as mp

        if reservation is None:
            reservation = reserve_recording(Path(path), force=force, side_suffixes=())
        self.reservation = reservation
        self.path = reservation.path
        force = reservation.force
        self._proc = None
        self.ring_size = int(lib.rec_ring_mapping_size(ring_capacity))
        self.ring_mem = mmap.mmap(-1, self.ring_size)   # MAP_SHARED | MAP_ANONYMOUS: survives fork
        if lib.rec_ring_format(ffi.from_buffer(self.ring_mem), self.ring_size) != 0:
            raise RecorderError("cannot format the recording ring")
        self.ring = ffi.new("rec_ring_t *")
        lib.rec_ring_attach(self.ring, ffi.from_buffer(self.ring_mem), self.ring_size)
        ctx = mp.get_context("fork")
        self._conn, child = ctx.Pipe()
        self._proc = ctx.Process(target=_serve, args=(child, self._conn, str(self.path),
                                                      self.ring_mem, self.ring_size, chunk_size,
                                                      force, tuple(cpus), live, live_inbox,
                                                      background, reservation.lock_fd),
                                 name="hil-recorder", daemon=False)
        self._proc.start()
        child.close()
        self.channels: list[ProcessChannel] = []
        self.closed = False
        self.final_path: Path | None = None
        self.messages = 0
        self.error: str | None = None
        #: the live view's end-of-run figures (live_view.LiveView.stats), once closed
        self.live_stats: dict | None = None
        self.background = background
        first = self._request(None, "start", timeout_s=10.0)
        if first[0] != "ready":
            self._proc.join(5.0)
            raise RecorderError(self._child_error(first))
        self.live_port: int | None = first[2]

    @staticmethod
    def _child_error(msg) -> str:
        if msg[0] == "closed":
            return msg[3] or "recorder stopped"
        return str(msg[1])

    @property
    def pid(self) -> int:
        return self._proc.pid

    def alive(self) -> bool:
        return self._proc.is_alive()

    def _exit_text(self) -> str:
        """How the recorder process ended (waits a moment for it to be reaped)."""
        self._proc.join(EXIT_WAIT_S)
        code = self._proc.exitcode
        if code is None:
            return "still running, but its pipe is closed"
        return f"killed by signal {-code}" if code < 0 else f"exit code {code}"

    def _leftover(self) -> str:
        """What a dead recorder left: the partial file with what it wrote, or nothing (an empty
        or header-only partial file is removed: it holds no recorded data)."""
        part = partial_path(self.path)
        try:
            size = part.stat().st_size
        except OSError:
            self.final_path = None
            return "nothing was recorded"
        if size <= _empty_size():
            try:
                part.unlink()
            except OSError:
                return f"nothing was recorded ({part} is empty)"
            self.final_path = None
            return f"nothing was recorded (the empty {part} was removed)"
        self.final_path = part
        return f"what it wrote is in {part} (`bench check` reads it, `bench recover` copies its intact chunks)"

    def death_message(self) -> str:
        """Why the recorder is gone (its own words if it sent them)."""
        try:
            if self._conn.poll(0.5):
                msg = self._conn.recv()
                if msg[0] == "closed" and msg[3]:
                    self.error = msg[3]
                    return msg[3]
        except (EOFError, OSError):
            pass
        return (f"recorder process (pid {self._proc.pid}) for {self.path} died ({self._exit_text()}); "
                f"{self._leftover()}")

    def _cpu_s(self) -> float | None:
        """CPU time [s] the recorder process has used (None: unknown)."""
        return process_cpu_s(self._proc.pid)

    def _working(self, cpu_before: float | None) -> tuple[bool, float | None]:
        """(whether the recorder worked since ``cpu_before``: it used CPU, or it is runnable and
        waits for a CPU a busy host gives to others; its CPU time now)."""
        now = self._cpu_s()
        used = now is not None and cpu_before is not None and now > cpu_before
        return used or process_runnable(self._proc.pid), now

    def foreground(self) -> None:
        """Undo ``background`` (real time is over: no deadline left to yield to): normal policy
        and priority, so that a busy host does not starve the recorder while it finishes the
        file. Best effort: without the privilege to lower a nice value it stays at 19."""
        if not self.background:
            return
        try:
            os.sched_setscheduler(self._proc.pid, os.SCHED_OTHER, os.sched_param(0))
            os.setpriority(os.PRIO_PROCESS, self._proc.pid, 0)
        except OSError:
            pass

    def _request(self, msg, what: str, timeout_s: float = 10.0):
        """Send a control message (None: only wait) and wait for its answer. A recorder that
        died (closed pipe: EOFError, BrokenPipeError), or that is alive but neither answers nor
        uses any CPU nor waits for one for ``timeout_s`` (stuck), is a RecorderError that names
        it, never a traceback. One that uses CPU, or is runnable, is working (a busy host starves
        it, it is not lost) and is waited for, up to WORKING_LIMIT_S."""
        try:
            if msg is not None:
                self._conn.send(msg)
            start, cpu = time.monotonic(), self._cpu_s()
            while not self._conn.poll(timeout_s):
                if not self._proc.is_alive():
                    raise EOFError
                working, now = self._working(cpu)
                if not working or time.monotonic() - start > WORKING_LIMIT_S:
                    raise RecorderError(f"recorder process (pid {self._proc.pid}) for {self.path} "
                                        f"does not answer ({what}: nothing for {timeout_s:g} s and "
                                        f"no CPU used or waited for, or working for more than "
                                        f"{WORKING_LIMIT_S:g} s)")
                cpu = now
            return self._conn.recv()
        except (EOFError, OSError):   # BrokenPipeError, ConnectionResetError: OSErrors
            self.error = self.death_message()
            raise RecorderError(self.error) from None

    def channel(self, topic: str, kind: str | None = None) -> ProcessChannel:
        kind = kind or chans.kind_of_topic(topic)
        if kind is None:
            raise ValueError(f"no channel kind for topic {topic!r}")
        # synchronous: records of this channel may follow at once, and the recorder must know
        # the channel before it drains them
        reply = self._request(("channel", topic, chans.LAYOUTS[kind].schema_name), f"channel {topic}")
        if reply[0] != "channel_ok" or reply[1] != len(self.channels):
            raise RecorderError(self._child_error(reply))
        ch = ProcessChannel(self, len(self.channels), topic, kind)
        self.channels.append(ch)
        return ch

    def raw_capture(self, path: Path, run_id: str = "") -> int:
        """A ring channel whose records go to a serial byte capture beside the recording
        (bench/record/serial_capture.py: payload = direction octet + octets, time = the
        record's t_ns as it is), written aside and renamed with the recording; its end record
        names ``run_id``. Returns the channel index (engine ch_serial_raw)."""
        reply = self._request(("rawfile", str(path), run_id), f"serial capture {path}")
        if reply[0] != "channel_ok" or reply[1] != len(self.channels):
            raise RecorderError(self._child_error(reply))
        self.channels.append(ProcessChannel(self, len(self.channels), str(path), "RAW"))
        return reply[1]

    def write_raw(self, index: int, t_ns: int, data: bytes) -> None:
        """One record with its time in ns as it is (a raw capture channel)."""
        deadline = time.monotonic() + 5.0
        while lib.rec_ring_write(self.ring, index, int(t_ns), data, len(data)) != 0:
            if not self.alive() or time.monotonic() > deadline:
                return
            time.sleep(0.001)

    def write(self, index: int, t_s: float, data: bytes) -> None:
        """One message into the ring (only while no engine is writing)."""
        t_ns = int(round(t_s * 1e9))
        deadline = time.monotonic() + 5.0
        while lib.rec_ring_write(self.ring, index, t_ns, data, len(data)) != 0:
            if not self.alive() or time.monotonic() > deadline:
                return   # counted as a drop in the ring header
            time.sleep(0.001)

    def _send(self, msg) -> bool:
        """A control message; False if the recorder is gone (its death is reported by the
        bench's watch and by close(), which name the cause)."""
        try:
            self._conn.send(msg)
            return True
        except (BrokenPipeError, OSError):
            return False

    def metadata(self, name: str, data: dict[str, str]) -> None:
        self._send(("metadata", name, {k: str(v) for k, v in data.items()}))

    def attachment(self, name: str, media_type: str, data: bytes) -> None:
        self._send(("attachment", name, media_type, data))

    def wait_for_viewer(self, timeout_s: float) -> bool:
        """--live-wait: True once a viewer has subscribed to anything, False if none did within
        ``timeout_s``. The recorder keeps the time; this waits for its answer as long as it
        lives (Ctrl-C interrupts it)."""
        try:
            self._conn.send(("wait_viewer", float(timeout_s)))
            while not self._conn.poll(0.5):
                if not self._proc.is_alive():
                    raise EOFError
            reply = self._conn.recv()
        except (EOFError, OSError):
            self.error = self.death_message()
            raise RecorderError(self.error) from None
        if reply[0] != "viewer":
            raise RecorderError(self._child_error(reply))
        return bool(reply[1])

    @property
    def dropped(self) -> int:
        return int(self.ring.hdr.records_dropped)

    def close(self) -> None:
        """Drain, finalise, rename. Raises RecorderError naming the cause if that failed."""
        if self.closed:
            return
        self.closed = True
        lib.rec_ring_close(self.ring)
        self.foreground()   # the engine is done: finishing the file has no deadline to yield to
        reply = None
        pipe_closed = False
        try:
            self._conn.send(("close",))
            # the recorder drains what is left; it is stalled only if it makes no progress: no
            # record drained, no CPU used and none waited for (a recorder a busy host starves
            # is runnable, and still uses some)
            pending = lib.rec_ring_pending(self.ring)
            last_progress = time.monotonic()
            cpu = self._cpu_s()
            while reply is None and time.monotonic() - last_progress < (
                    STALL_TIMEOUT_S if pending > 0 else FINISH_TIMEOUT_S):
                if self._conn.poll(0.2):
                    msg = self._conn.recv()
                    if msg[0] == "closed":
                        reply = msg
                elif not self._proc.is_alive():
                    break
                now_pending = lib.rec_ring_pending(self.ring)
                working, now_cpu = self._working(cpu)
                if now_pending < pending or working:
                    pending = now_pending
                    last_progress = time.monotonic()
                cpu = now_cpu
        except (EOFError, OSError):   # the recorder closed its pipe: it is gone, or going
            pipe_closed = True
        finally:
            self._conn.close()
            self.reservation.unlock()   # the recorder keeps its own hold until it has finished
        if reply is None:
            self.final_path = partial_path(self.path)
            if pipe_closed:
                self._proc.join(EXIT_WAIT_S)   # killed: on a loaded machine it takes a moment
            if self._proc.is_alive():
                self._proc.kill()
                self._proc.join(5.0)
                self.error = (f"recorder process (pid {self._proc.pid}) stalled: nothing "
                              f"written and no CPU used or waited for in {STALL_TIMEOUT_S:g} s while finishing "
                              f"{self.path}; it was killed; {self._leftover()}")
            else:
                self.error = (f"recorder process (pid {self._proc.pid}) for {self.path} died "
                              f"({self._exit_text()}); {self._leftover()}")
            self.error += self.reservation.replaced_text()
            raise RecorderError(self.error)
        self._proc.join(10.0)
        _, self.messages, final, error, self.live_stats = reply
        self.final_path = Path(final)
        if error:
            self.error = error + self.reservation.replaced_text()
            raise RecorderError(self.error)
        if self.final_path == self.path:
            self.reservation.drop_replaced()   # the new recording is in place

    def __enter__(self) -> "ProcessRecorder":
        return self

    def __exit__(self, *exc) -> None:
        self.close()
