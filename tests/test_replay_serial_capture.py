"""The serial byte capture the bench writes beside every serial recording (engine link tap)."""
from __future__ import annotations

import json
from pathlib import Path

from hil_bench.loop.runner import run_scenario
from hil_bench.protocol.framing import Deframer
from hil_bench.record.recording import load_recording
from hil_bench.record.serial_capture import RX, TX, read_records
from hil_bench.scenario import load_scenario

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


# -- converters (python -m hil_bench.replay.serial_convert socat|raw|hex|logic) ----------------------

def _directions(path):
    recs = list(read_records(path, []))
    return recs, (b"".join(r.data for r in recs if r.direction == TX),
                  b"".join(r.data for r in recs if r.direction == RX))


def _same_cycles(a, b) -> None:
    import numpy as np

    assert a.n == b.n
    for f in ("seq", "i_abc_a", "v_dc_v", "duty_raw", "theta_hat_rad", "has_telem", "has_theta"):
        assert np.array_equal(a.rows[f], b.rows[f]), f
    assert a.hello == b.hello and a.config == b.config and a.commands == b.commands
    assert a.anomalies.summary() == b.anomalies.summary() == "none"


def _convert(argv) -> None:
    from hil_bench.replay.serial_convert import main

    assert main([str(x) for x in argv]) == 0


def test_raw_and_hex_converters_interleave_by_seq(tmp_path):
    """Two one-way dumps without time stamps (binary, xxd -p and od -An -tx1 style hex): the
    frames are interleaved by seq, so the capture replays as the bench's own capture does."""
    from hil_bench.replay import read_capture

    _recs, (tx, rx) = _directions(EX / "example.serial.bin")
    (tmp_path / "tx.bin").write_bytes(tx)
    (tmp_path / "rx.bin").write_bytes(rx)
    _convert(["raw", tmp_path / "raw.serial.bin", "--tx", tmp_path / "tx.bin",
              "--rx", tmp_path / "rx.bin"])
    ref = read_capture(EX / "example.serial.bin")
    _same_cycles(ref, read_capture(tmp_path / "raw.serial.bin"))
    # xxd -p: runs of 60 hex digits; od -An -tx1 -v: " 41 42 ..." lines
    (tmp_path / "tx.hex").write_text("\n".join(tx[i:i + 30].hex() for i in range(0, len(tx), 30)))
    (tmp_path / "rx.hex").write_text("\n".join(" " + " ".join(f"{b:02x}" for b in rx[i:i + 16])
                                               for i in range(0, len(rx), 16)) + "\n")
    _convert(["hex", tmp_path / "hex.serial.bin", "--tx", tmp_path / "tx.hex",
              "--rx", tmp_path / "rx.hex"])
    assert (tmp_path / "hex.serial.bin").read_bytes() == (tmp_path / "raw.serial.bin").read_bytes()


def test_hex_dump_that_is_not_hex(tmp_path):
    from hil_bench.replay.serial_convert import main

    (tmp_path / "tx.hex").write_text("00 01 02\n00 0g\n")
    assert main(["hex", str(tmp_path / "o.bin"), "--tx", str(tmp_path / "tx.hex")]) == 2


def test_socat_converter(tmp_path):
    """A socat -x -v log (both directions, time stamps, the text column beside the hex)."""
    from datetime import datetime

    from hil_bench.replay import read_capture

    recs, _ = _directions(EX / "example.serial.bin")
    t_base = 1_750_000_000_000_000_000
    out = []
    for r in recs:
        t = t_base + r.t_ns
        stamp = datetime.fromtimestamp(t // 1_000_000_000).strftime("%Y/%m/%d %H:%M:%S")
        out.append(f"{'>' if r.direction == TX else '<'} {stamp}.{t % 1_000_000_000 // 1000:06d}"
                   f"  length={len(r.data)} from=0 to={len(r.data) - 1}")
        for i in range(0, len(r.data), 16):
            part = r.data[i:i + 16]
            text = "".join(chr(b) if 32 <= b < 127 else "." for b in part)
            out.append(" " + " ".join(f"{b:02x}" for b in part).ljust(48) + "  " + text)
        out.append("--")
    (tmp_path / "socat.txt").write_text("\n".join(out) + "\n")
    _convert(["socat", tmp_path / "socat.txt", tmp_path / "s.serial.bin"])
    _same_cycles(read_capture(EX / "example.serial.bin"), read_capture(tmp_path / "s.serial.bin"))


def test_logic_analyser_converter(tmp_path):
    """Saleae Logic 2 async-serial exports, one per line (start_time [s], data), merged by time."""
    from hil_bench.replay import read_capture

    recs, _ = _directions(EX / "example.serial.bin")
    files = {TX: ["name,type,start_time,duration,data"], RX: ["name,type,start_time,duration,data"]}
    for r in recs:
        for i, b in enumerate(r.data):      # 1 ns per octet after the record's time
            t = (r.t_ns + i) * 1e-9
            files[r.direction].append(f"Async Serial,data,{t:.9f},3.3e-06,0x{b:02X}")
    (tmp_path / "tx.csv").write_text("\n".join(files[TX]) + "\n")
    (tmp_path / "rx.csv").write_text("\n".join(files[RX]) + "\n")
    _convert(["logic", tmp_path / "l.serial.bin", "--tx", tmp_path / "tx.csv",
              "--rx", tmp_path / "rx.csv"])
    _same_cycles(read_capture(EX / "example.serial.bin"), read_capture(tmp_path / "l.serial.bin"))
