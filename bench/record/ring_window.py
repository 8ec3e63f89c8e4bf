"""The records a held run wrote, read back from its recording ring (plant_rt/c/live.h
``live_ring_window``): the rows hil_bench.Session's conditions and windows see are the very
messages the recorder writes into the file.

The ring is drained by the recorder process; this reads behind it, between two head counters
the script noted while the engine held (or after it ended), so the window is still in the ring as
long as it is shorter than the ring (the session steps in pieces that are: ``max_cycles``).
"""
from __future__ import annotations

import struct

import numpy as np

from hil_bench.plant_rt._plant_c import ffi, lib

from . import channels as chans
from .recording import _TopicBuffer

#: the ring's record header (rec_ring.h): payload length, channel (flags and time follow)
_HEADER = struct.Struct("<IH")


class WindowLost(RuntimeError):
    """The records asked for are no longer in the ring (the window was longer than the ring)."""


class RingWindow:
    """Reads the records of chosen channels between two head counters of a recording ring."""

    def __init__(self, ring_mem, topics: dict[int, str]):
        """``ring_mem``: the formatted ring mapping (ProcessRecorder.ring_mem); ``topics``: ring
        channel index -> topic, of the channels to decode (fixed topics, /reference/*)."""
        self._mem = ring_mem
        self._ptr = ffi.from_buffer(ring_mem)
        self._size = len(ring_mem)
        self.capacity = int(ffi.cast("uint64_t *", self._ptr)[1])   # rec_ring_header_t.capacity
        self.topics = dict(topics)
        self._buf = bytearray(0)
        self._layouts: dict[str, tuple | None] = {}

    def head(self) -> int:
        """The ring's head counter now (octets the engine has published)."""
        return int(lib.live_ring_head(self._ptr))

    def read(self, start: int, stop: int) -> dict[str, dict[str, np.ndarray]]:
        """Each wanted topic's columns (every field, ``t_s`` first) of the records published
        between head counters ``start`` and ``stop`` (the engine writes nothing meanwhile)."""
        span = stop - start
        if span <= 0:
            return {}
        if span > self.capacity:
            raise WindowLost(f"{span} octets of records asked for, the ring holds {self.capacity}")
        if len(self._buf) < span:
            self._buf = bytearray(span)
        out = ffi.from_buffer(self._buf)
        n = int(lib.live_ring_window(self._ptr, self._size, start, stop, out, span))
        if n < 0:
            raise WindowLost(f"the records between ring positions {start} and {stop} are no "
                             f"longer in the ring")
        return self._decode(memoryview(self._buf)[:n])

    def _decode(self, view: memoryview) -> dict[str, dict[str, np.ndarray]]:
        by_channel: dict[int, list[bytes]] = {}
        off, n = 0, len(view)
        unpack = _HEADER.unpack_from
        while off < n:
            length, channel = unpack(view, off)
            if channel in self.topics:
                by_channel.setdefault(channel, []).append(bytes(view[off + 16:off + 16 + length]))
            off += 16 + ((length + 7) & ~7)
        out = {}
        for channel, payloads in by_channel.items():
            topic = self.topics[channel]
            fixed = self._fixed(topic)
            if fixed is not None and all(len(p) == fixed[0].itemsize for p in payloads):
                dt, pos, val, kinds = fixed
                raw = np.frombuffer(b"".join(payloads), np.uint8).reshape(len(payloads),
                                                                            dt.itemsize)
                if (raw[:, pos] == val).all():
                    rec = raw.view(dt).reshape(len(payloads))
                    out[topic] = {n: rec[n].astype(np.float64 if k == "F64" else np.int64)
                                  for n, k in kinds}
                    continue
            kind = chans.kind_of_topic(topic)
            layout = chans.LAYOUTS[kind]
            buf = _TopicBuffer(topic, layout.schema_name, chans.MESSAGE_ENCODING,
                               chans.file_descriptor_set(), None, None)
            for p in payloads:
                buf.add(p)
            buf.flush()
            out[topic] = buf.columns()
        return out

    def _fixed(self, topic: str):
        """A fixed-width channel's message dtype, tag positions and bytes, field kinds (once
        per topic), as hil_bench.record.recording decodes a chunk; None for the others."""
        if topic not in self._layouts:
            layout = chans.LAYOUTS[chans.kind_of_topic(topic)]
            self._layouts[topic] = ((layout.message_dtype, *layout.tag_mask, layout.fields)
                                    if layout.fixed else None)
            if self._layouts[topic] is not None:
                dt, pos, val, fields = self._layouts[topic]
                self._layouts[topic] = (dt, pos, val, tuple((n, t) for t, n in fields))
        return self._layouts[topic]
