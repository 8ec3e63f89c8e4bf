"""Host session (issue 9, items 4 and 10): bad controller answers are protocol errors naming the frame and
the field, never tracebacks; CMD seq counts; HEARTBEAT_PLANT while the host waits."""
from __future__ import annotations

import os
import threading
import time
import tty
from pathlib import Path

import pytest

from hil_bench.cli import main as cli_main
from hil_bench.loop.host_session import (
    ControllerFault,
    HostSession,
    ProtocolViolation,
    describe_fault_ctrl,
    fault_from_payload,
)
from hil_bench.loop.links.base import Link, LinkError
from hil_bench.protocol.framing import Deframer, encode_frame
from hil_bench.protocol.messages import (
    MESSAGES,
    Command,
    ConfigStatus,
    HelloStatus,
    Mode,
    Param,
    State,
)
from hil_bench.record.recording import load_recording

HELLO, HELLO_ACK = MESSAGES["HELLO"], MESSAGES["HELLO_ACK"]
CONFIG, CONFIG_ACK = MESSAGES["CONFIG"], MESSAGES["CONFIG_ACK"]
CMD, FAULT_CTRL, HB = MESSAGES["CMD"], MESSAGES["FAULT_CTRL"], MESSAGES["HEARTBEAT_PLANT"]


class ScriptedLink(Link):
    """An in-memory link: ``answer(fid, payload)`` returns the controller's frames for each frame sent."""

    description = "scripted link"

    def __init__(self, answer, delay_s: float = 0.0):
        super().__init__()
        self.answer = answer
        self.delay_s = delay_s
        self.sent: list[tuple[float, int, bytes]] = []
        self.queue: list[tuple[float, int, bytes]] = []

    def _write_frames(self, frames):
        now = time.monotonic()
        for fid, payload in frames:
            self.sent.append((now, fid, payload))
            for out in self.answer(fid, payload) or []:
                self.queue.append((now + self.delay_s, *out))

    def _read_frames(self, timeout_s):
        end = time.monotonic() + timeout_s
        while True:
            now = time.monotonic()
            ready = [(f, p) for t, f, p in self.queue if t <= now]
            if ready:
                self.queue = [q for q in self.queue if q[0] > now]
                return ready
            if now >= end:
                return []
            time.sleep(min(0.002, end - now))


def hello_ack(session: int, status: int = 0, version: int = 1, minor: int = 1) -> tuple[int, bytes]:
    return HELLO_ACK.frame_id, HELLO_ACK.pack_raw((version, status, minor, 0x0100, 0x3E, session))


def good_controller(fid, payload, *, config_status=0, param_offset=0, ack_len=8):
    if fid == HELLO.frame_id:
        return [hello_ack(HELLO.unpack(payload)["session"])]
    if fid == CONFIG.frame_id:
        v = CONFIG.unpack(payload)
        ack = CONFIG_ACK.pack_raw((v["param_id"] + param_offset, v["config_seq"], config_status))
        return [(CONFIG_ACK.frame_id, ack[:ack_len])]
    return []


def session_with(answer, delay_s: float = 0.0) -> tuple[HostSession, ScriptedLink]:
    link = ScriptedLink(answer, delay_s)
    return HostSession(link), link


def handshake(s: HostSession, mode=Mode.LOCKSTEP):
    return s.handshake(period_s=100e-6, estimator=1, flags=0, mode=mode, timeout_s=0.5)


# ---------------------------------------------------------------------------------------------------------
# HELLO_ACK
# ---------------------------------------------------------------------------------------------------------

def test_hello_ack_with_an_unknown_status_names_frame_field_and_value():
    s, _ = session_with(lambda f, p: [hello_ack(HELLO.unpack(p)["session"], status=9)] if f == HELLO.frame_id
                        else [])
    with pytest.raises(ProtocolViolation, match=r"HELLO_ACK: status = 9 is not in the HelloStatus table"):
        handshake(s)


def test_short_hello_ack_is_a_protocol_error():
    s, _ = session_with(lambda f, p: [(HELLO_ACK.frame_id, hello_ack(1)[1][:6])] if f == HELLO.frame_id else [])
    with pytest.raises(ProtocolViolation, match=r"HELLO_ACK has 6 octets, expected 8"):
        handshake(s)


def test_mode_unsupported_is_a_clear_refusal():
    s, _ = session_with(lambda f, p: [hello_ack(HELLO.unpack(p)["session"], HelloStatus.MODE_UNSUPPORTED)]
                        if f == HELLO.frame_id else [])
    with pytest.raises(LinkError, match=r"refused the handshake: MODE_UNSUPPORTED \(the controller does "
                                        r"not support mode REALTIME\)"):
        handshake(s, Mode.REALTIME)


def test_hello_ack_ok_with_another_protocol_version_is_a_protocol_error():
    s, _ = session_with(lambda f, p: [hello_ack(HELLO.unpack(p)["session"], 0, version=2)]
                        if f == HELLO.frame_id else [])
    with pytest.raises(ProtocolViolation, match=r"status OK but proto_version = 2"):
        handshake(s)


def test_stale_hello_ack_is_ignored_and_the_right_one_accepted():
    def answer(f, p):
        if f == HELLO.frame_id:
            sid = HELLO.unpack(p)["session"]
            return [hello_ack((sid + 1) & 0xFFFF, status=2), hello_ack(sid)]
        return []
    s, _ = session_with(answer)
    assert handshake(s)["status"] == HelloStatus.OK


# ---------------------------------------------------------------------------------------------------------
# CONFIG_ACK
# ---------------------------------------------------------------------------------------------------------

@pytest.mark.parametrize("kwargs, pattern", [
    ({"config_status": 7}, r"CONFIG_ACK for RS_OHM: status = 7 is not in the ConfigStatus table"),
    ({"ack_len": 5}, r"CONFIG_ACK for RS_OHM has 5 octets, expected 8"),
    ({"param_offset": 1}, r"CONFIG_ACK for RS_OHM \(config_seq 1\): param_id = 2, expected 1"),
])
def test_bad_config_ack_names_the_parameter_and_the_field(kwargs, pattern):
    s, _ = session_with(lambda f, p: good_controller(f, p, **kwargs))
    handshake(s)
    with pytest.raises(ProtocolViolation, match=pattern):
        s.configure({Param.RS_OHM: 0.5})


def test_config_refusal_names_parameter_value_and_status():
    s, _ = session_with(lambda f, p: good_controller(f, p, config_status=ConfigStatus.OUT_OF_RANGE))
    handshake(s)
    with pytest.raises(LinkError, match=r"rejected parameter SMO_K_V = 12.5: OUT_OF_RANGE"):
        s.configure({Param.SMO_K_V: 12.5})


def test_short_fault_ctrl_during_configuration_ends_it_clearly():
    def answer(f, p):
        if f == CONFIG.frame_id:
            return [(FAULT_CTRL.frame_id, b"\x01\x02\x03")]
        return good_controller(f, p)
    s, _ = session_with(answer)
    handshake(s)
    with pytest.raises(ControllerFault, match=r"FAULT_CTRL with 3 octets \(expected 8\).*01 02 03"):
        s.configure({Param.RS_OHM: 0.5})


def test_describe_fault_ctrl_every_case():
    ok = FAULT_CTRL.pack(code="OVERCURRENT", seq=42, detail=-7)
    assert describe_fault_ctrl(ok) == "controller reported fault OVERCURRENT at seq 42 (detail -7)"
    unknown = FAULT_CTRL.pack_raw((999, 3, 0))
    assert "FAULT_CTRL.code = 999, which is not in the Fault table" in describe_fault_ctrl(unknown)
    assert describe_fault_ctrl(b"") .startswith("controller sent FAULT_CTRL with 0 octets (expected 8)")
    assert "with 9 octets" in describe_fault_ctrl(ok + b"\x00")
    exc = fault_from_payload(ok)
    assert (exc.code, exc.seq) == (4, 42) and isinstance(exc, LinkError)
    assert fault_from_payload(b"\x01").code is None


# ---------------------------------------------------------------------------------------------------------
# CMD seq and HEARTBEAT_PLANT
# ---------------------------------------------------------------------------------------------------------

def test_cmd_seq_counts_from_one_per_session():
    s, link = session_with(good_controller)
    handshake(s)
    s.command(Command.SET_SPEED_REF, 10.0)
    fid, payload = s.command_frame(Command.SET_IQ_REF, 1.0)
    s.send([(fid, payload)])
    s.command(Command.RUN)
    seqs = [CMD.unpack(p)["seq"] for _, f, p in link.sent if f == CMD.frame_id]
    assert seqs == [1, 2, 3]
    handshake(s)   # a new session starts again at 1
    s.command(Command.STOP)
    assert CMD.unpack([p for _, f, p in link.sent if f == CMD.frame_id][-1])["seq"] == 1
    assert s.command_frame(Command.NOP, seq=70000)[1] == CMD.pack(command=0, seq=70000 & 0xFFFF, value=0.0)


def test_heartbeat_plant_every_100ms_while_the_host_waits():
    # a slow controller: every answer takes 250 ms, so the handshake and one CONFIG take ~0.5 s
    s, link = session_with(good_controller, delay_s=0.25)
    handshake(s)
    s.configure({Param.RS_OHM: 0.5})
    beats = [(t, HB.unpack(p)) for t, f, p in link.sent if f == HB.frame_id]
    assert len(beats) >= 4, beats
    assert [int(b["counter"]) for _, b in beats] == list(range(len(beats)))
    assert all(int(b["state"]) == State.IDLE for _, b in beats)
    gaps = [b[0] - a[0] for a, b in zip(beats, beats[1:])]
    assert all(0.08 <= g <= 0.2 for g in gaps), gaps
    assert link.sent[0][1] == HELLO.frame_id                       # HELLO first, the heartbeats 100 ms on
    assert 0.08 <= beats[0][0] - link.sent[0][0] <= 0.2
    # a controller that answers at once gets no heartbeat at all: the host never waits 100 ms
    s, link = session_with(good_controller)
    handshake(s)
    s.configure({Param.RS_OHM: 0.5, Param.LD_H: 1e-3})
    assert not [f for _, f, _ in link.sent if f == HB.frame_id]


# ---------------------------------------------------------------------------------------------------------
# End to end: bench run against a controller whose HELLO_ACK is bad
# ---------------------------------------------------------------------------------------------------------

def _bad_controller(master: int, stop: threading.Event, status: int) -> None:
    d = Deframer()
    while not stop.is_set():
        try:
            data = os.read(master, 4096)
        except OSError:
            return
        for fid, payload in d.feed(data):
            if fid == HELLO.frame_id:
                sid = HELLO.unpack(payload)["session"]
                os.write(master, encode_frame(HELLO_ACK.frame_id,
                                              HELLO_ACK.pack_raw((1, status, 1, 1, 2, sid))))


def test_bench_run_against_a_bad_hello_ack_exits_non_zero_with_a_clear_message(tmp_path, capsys):
    master, slave = os.openpty()
    tty.setraw(master)
    tty.setraw(slave)
    name = os.ttyname(slave)
    stop = threading.Event()
    th = threading.Thread(target=_bad_controller, args=(master, stop, 9), daemon=True)
    th.start()
    out = tmp_path / "bad.mcap"
    try:
        rc = cli_main(["run", "gong_g2_500rpm", "--link", f"serial:{name}", "--allow-slow-link",
                       "--no-progress", "--out", str(out)])
    finally:
        stop.set()
        os.close(slave)
        os.close(master)
        th.join(timeout=2)
    err = capsys.readouterr().err
    assert rc != 0
    assert "HELLO_ACK: status = 9 is not in the HelloStatus table" in " ".join(err.split())
    assert "Traceback" not in err
    rec = load_recording(out)   # finalised and readable, and says why the run ended
    assert "HELLO_ACK" in rec.metadata["run_result"]["error"]
    assert Path(out).stat().st_size > 0
