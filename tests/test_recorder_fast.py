"""The recorder's fast path (plant_rt/c/rec_mcap.c + bench/recorder.FastPath) writes exactly the
file mcap's own Writer writes message by message: the same bytes, chunk boundaries, message
indexes, statistics and summary, and the same serial byte capture. It is what lets the recorder
keep up at 10 kHz beside the real-time engine (docs/realtime.md, docs/performance.md)."""
from __future__ import annotations

import os

import numpy as np
import pytest

from hil_bench.plant_rt._plant_c import lib
from hil_bench.record import channels as ch
from hil_bench.record.recorder import ProcessRecorder
from hil_bench.record.recording import load_recording


def record(tmp_path, fast: bool, monkeypatch) -> tuple[bytes, bytes]:
    monkeypatch.setenv("HIL_RECORDER_FAST", "1" if fast else "0")
    monkeypatch.setenv("HIL_RECORDER_T0_NS", "1700000000000000000")
    # one name in two folders: the recording names its serial capture (sidecar metadata)
    out = tmp_path / ("fast" if fast else "slow") / "rec.mcap"
    out.parent.mkdir()
    rec = ProcessRecorder(out, ring_capacity=8 << 20)
    chans = [rec.channel(t) for t in (ch.PLANT_STATE, ch.PLANT_SENSE, ch.CONTROLLER_TELEMETRY,
                                      ch.LINK_FRAMES, ch.TIMING)]
    raw = rec.raw_capture(out.with_suffix(".serial.bin"))
    rng = np.random.default_rng(3)
    for k in range(6000):                      # several 256 kB chunks
        t_ns = k * 100_000
        state = ch.encode_row("PLANT_STATE", list(rng.normal(size=len(ch.PLANT_STATE_VALUES))))
        rows = [(chans[0], state),
                (chans[1], ch.encode_row("SENSE", (k * 1e-4, k, 1.0, -0.5, -0.5, 310.0, np.nan))),
                (chans[2], ch.encode_row("TELEMETRY", {"t_s": k * 1e-4, "seq": k,
                                                       "theta_hat_rad": float(rng.random())})),
                (chans[3], ch.encode_row("FRAMES", (k * 1e-4, k, "101#07" * (k % 5), "180#00")))]
        if k % 7 == 0:
            rows.append((chans[4], ch.encode_row("TIMING", {"t_s": k * 1e-4, "seq": k})))
        for c, data in rows:
            while lib.rec_ring_write(rec.ring, c.index, t_ns, data, len(data)) != 0:
                pass
        payload = bytes([k % 2]) + bytes(rng.integers(0, 256, 30, dtype=np.uint8))
        while lib.rec_ring_write(rec.ring, raw, t_ns + 1, payload, len(payload)) != 0:
            pass
    rec.metadata("run", {"scenario": "fast_path"})
    rec.close()
    return out.read_bytes(), out.with_suffix(".serial.bin").read_bytes()


def _sha_masked(data: bytes) -> bytes:
    import re

    at = data.find(b"sha256")
    assert at > 0
    tail = re.sub(rb"[0-9a-f]{64}", b"0" * 64, data[at:at + 120], count=1)
    return data[:at] + tail + data[at + 120:]


def test_fast_and_slow_paths_write_the_same_bytes(tmp_path, monkeypatch):
    fast, fast_raw = record(tmp_path, True, monkeypatch)
    slow, slow_raw = record(tmp_path, False, monkeypatch)
    assert len(fast) > 4 * 256 * 1024            # several chunks, compressed
    # the recording's sidecar.serial.bin metadata holds the capture's SHA-256, and the capture's
    # end record the time of the close (below): that hash is the one field that may differ
    assert _sha_masked(fast) == _sha_masked(slow)
    # the same records; the end record (direction 2, the close's note) carries the time of the
    # close (CLOCK_MONOTONIC), the one field two recordings cannot share
    from hil_bench.record.serial_capture import END_OF_RUN, RECORD

    end = RECORD.size + len(END_OF_RUN.encode())
    assert fast_raw[:-end] == slow_raw[:-end] and len(fast_raw) > 6000 * 31
    assert fast_raw[-end + 8:] == slow_raw[-end + 8:] == bytes([2]) + \
        len(END_OF_RUN).to_bytes(4, "little") + END_OF_RUN.encode()
    rec = load_recording(tmp_path / "fast" / "rec.mcap")
    assert rec.counts[ch.PLANT_STATE] == 6000 and rec.counts[ch.TIMING] == 858
    assert rec.unreadable_chunks == 0 and rec.truncated is None


def test_the_fast_path_is_the_one_taken(tmp_path, monkeypatch):
    """With the mcap version installed the recorder takes the fast path (it falls back to the
    slow one only when mcap keeps its state differently)."""
    import io

    from mcap.writer import Writer

    from hil_bench.record.recorder import FastPath

    assert FastPath.install(Writer(io.BytesIO()), 256 * 1024) is not None
