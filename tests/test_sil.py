"""Software in the loop (``--link sil``, issue 17): the firmware's C in the engine's process gives
the same run as the firmware stub on a pty.

The proof: the same scenario in lockstep, once with ``--link stub`` and once with ``--link sil``,
gives byte-identical DUTY frames, cycle by cycle, and identical recorded plant rows (every field
of every /plant/state and /plant/sense row) -- for G2 (the bundled scenario), an HFI scenario and
a scenario with link and plant faults. What may differ is said where it is allowed: the HELLO's
random session number, and heartbeats (their 100 ms clock is the wall clock on both sides).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from hil_bench.loop.runner import run_scenario
from hil_bench.protocol.messages import MESSAGES
from hil_bench.record import channels as ch
from hil_bench.record.recording import load_recording
from hil_bench.scenario import check_against_profile, load_scenario, parse_scenario

DUTY_ID = f"{MESSAGES['DUTY'].frame_id:03X}#"
TELEM_ID = f"{MESSAGES['TELEM'].frame_id:03X}#"

FAULTS = """
[scenario]
name = "sil_faults"
profile = "gong2020"
duration_s = 0.45
[plant]
initial_theta_e_rad = 0.4
t_delay_s = 0.0
[controller]
estimator = "SMO_TANH"
speed_ref_rpm = 500
[controller.params]
IQ_MAX_A = 6.0
ALIGN_I_A = 3.0
ALIGN_TIME_S = 0.2
IF_I_A = 3.0
IF_ACCEL_RAD_S2 = 60.0
HANDOVER_SPEED_RAD_S = 20.0
SMO_M_PER_A = 0.01
[metrics]
window_s = [0.0, 0.45]
[[faults]]
kind = "drop"
direction = "to_controller"
message = "SENSE"
t_s = 0.22
count = 1
[[faults]]
kind = "bitflip"
direction = "from_controller"
message = "DUTY"
t_s = 0.25
count = 1
[[faults]]
kind = "duplicate"
direction = "to_controller"
message = "SENSE"
t_s = 0.28
count = 2
[[faults]]
kind = "garbage"
direction = "to_controller"
burst = 40
t_s = 0.3
[[faults]]
kind = "delay"
direction = "from_controller"
message = "DUTY"
delay_s = 0.0005
t_s = 0.32
count = 3
[[faults]]
kind = "bitflip"
direction = "to_controller"
message = "SENSE"
t_s = 0.34
count = 1
[[faults]]
kind = "sensor_offset"
phase = "a"
offset_a = 0.3
t_s = 0.36
"""


def _run(scn, link: str, out: Path):
    result = run_scenario(scn, link_spec=link, out_path=out, progress=False, force=True)
    return result, load_recording(out)


def _frames_of(rec, prefix: str) -> list[tuple[int, str]]:
    """(cycle seq, frame) of every frame with this id the engine received, in order, less the
    answers to re-sends: on a loaded host the stub may answer a cycle late, the host re-sends it
    and the stub's cache answers again, byte for byte (docs/protocol.md 6.5: timing, not another
    run). Such an answer repeats the seq (the frame's first two octets) of one already taken."""
    frames = rec.topic(ch.LINK_FRAMES)
    out: list[tuple[int, str]] = []
    last = None
    for seq, rx in zip(frames["seq"], frames["rx"]):
        for f in str(rx).split():
            if not f.startswith(prefix):
                continue
            data = bytes.fromhex(f.split("#", 1)[1])
            own = int.from_bytes(data[:2], "little")
            if last is not None and (last - own) % 65536 < 32768:
                continue   # not after the last one taken: the cache answering a re-send
            out.append((int(seq), f))
            last = own
    return out


def _assert_same_run(scn, tmp_path: Path) -> tuple:
    stub, rec_stub = _run(scn, "stub", tmp_path / "stub.mcap")
    sil, rec_sil = _run(scn, "sil", tmp_path / "sil.mcap")
    assert (sil.end, sil.cycles_done, sil.error) == (stub.end, stub.cycles_done, stub.error)
    duty_stub, duty_sil = _frames_of(rec_stub, DUTY_ID), _frames_of(rec_sil, DUTY_ID)
    assert len(duty_stub) >= stub.cycles_done
    assert duty_sil == duty_stub          # byte for byte, cycle by cycle
    assert _frames_of(rec_sil, TELEM_ID) == _frames_of(rec_stub, TELEM_ID)
    for topic in (ch.PLANT_STATE, ch.PLANT_SENSE):
        a, b = rec_stub.topic(topic), rec_sil.topic(topic)
        assert list(a) == list(b)
        assert len(a["t_s"]) > 0
        for key in a:
            np.testing.assert_array_equal(np.asarray(b[key]), np.asarray(a[key]),
                                          err_msg=f"{topic}.{key}")
    return stub, sil, rec_stub, rec_sil


def test_g2_is_the_same_run_in_process_and_on_the_pty(tmp_path):
    _, sil, _, rec = _assert_same_run(load_scenario("gong_g2_500rpm"), tmp_path)
    assert sil.ok and sil.cycles_done == 15000
    assert "in process" in rec.metadata["run"]["controller"]


def test_hfi_is_the_same_run_in_process_and_on_the_pty(tmp_path):
    _, sil, _, _ = _assert_same_run(load_scenario("beyond_hfi_speed"), tmp_path)
    assert sil.ok


def test_faults_act_the_same_in_process_and_on_the_pty(tmp_path):
    scn = parse_scenario(FAULTS, Path("sil_faults.toml"))
    check_against_profile(scn)
    stub, sil, rec_stub, rec_sil = _assert_same_run(scn, tmp_path)
    # lost frames are decided by what arrived: the same; re-sends also count answers a busy host
    # made late on the pty (a timing statistic, docs/protocol.md 6.5): never fewer than SIL's
    assert sil.link_stats["lost_frames"] == stub.link_stats["lost_frames"] >= 2
    assert stub.link_stats["retries"] >= sil.link_stats["retries"] >= 2
    for key in ("crc_errors", "cobs_errors", "duplicates", "faults_injected", "seq_mismatch"):
        assert sil.link_stats[key] == stub.link_stats[key], key
    # the controller saw the same rejected frames (its heartbeat reports them)
    assert sil.link_stats["ctrl_rx_errors"] == stub.link_stats["ctrl_rx_errors"] > 0

    def acted(rec):
        f = rec.topic(ch.FAULTS)
        return [(int(s), str(k), str(a)) for s, k, a in zip(f["seq"], f["kind"], f["action"])
                if str(a) not in ("trace",)]
    assert acted(rec_sil) == acted(rec_stub) and len(acted(rec_sil)) >= 7


def test_a_controller_restart_in_process_is_seen_as_on_the_pty(tmp_path):
    """The power cycle happens at the fault's cycle (CMD RESTART in band, as on the pty): the
    session is gone, the bench's SENSE go unanswered, the heartbeat counter starting over is
    counted."""
    scn = parse_scenario(FAULTS.split("[[faults]]")[0] + '[[faults]]\nkind = "controller_reset"\n'
                         't_s = 0.3\n', Path("sil_reset.toml"))
    result, rec = _run(scn, "sil", tmp_path / "r.mcap")
    assert result.end == "NO_DUTY"
    assert "the bench restarted the controller at this cycle" in result.error
    assert result.cycles_done == 3000          # cycle 3000 (t = 0.3 s) is the first unanswered
    f = rec.topic(ch.FAULTS)
    traces = [t for t, a in zip(f["text"], f["action"]) if a == "trace"]
    assert len(traces) == 1 and "ctrl_resets +1" in traces[0]
    assert "controller_restart" in list(rec.topic(ch.EVENTS)["kind"])


def test_sil_refuses_stub_options():
    from hil_bench.loop.links import LinkError, open_link

    with pytest.raises(LinkError, match="--link sil: the stub options --inject"):
        open_link("sil", ("--inject", "crash@10"))
