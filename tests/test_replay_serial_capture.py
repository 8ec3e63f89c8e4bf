"""The serial byte capture the bench writes beside every serial recording (engine link tap)."""
from __future__ import annotations

import json
from pathlib import Path

from bench.recording import load_recording
from bench.replay.serial_capture import RX, TX, read_records
from bench.runner import run_scenario
from bench.scenario import load_scenario
from protocol.framing import Deframer

EX = Path(__file__).resolve().parents[1] / "examples" / "captures"


def test_every_octet_of_a_serial_run_is_captured(tmp_path):
    out = tmp_path / "run.mcap"
    res = run_scenario(load_scenario(EX / "replay_example.toml"), out_path=out, progress=False)
    assert res.ok, res.error
    cap = out.with_suffix(".serial.bin")
    damage: list[str] = []
    recs = list(read_records(cap, damage))
    assert not damage
    tx = b"".join(r.data for r in recs if r.direction == TX)
    rx = b"".join(r.data for r in recs if r.direction == RX)
    counters = json.loads(load_recording(out).metadata["run_result"]["counters"])
    assert len(tx) == counters["bytes_tx"] and len(rx) == counters["bytes_rx"]
    d = Deframer()
    frames = d.feed(rx)
    assert len(frames) == counters["frames_ok"] and d.crc_errors == 0
    assert len(Deframer().feed(tx)) == counters["frames_tx"]
    t = [r.t_ns for r in recs]
    assert t == sorted(t)
