"""The firmware stub behind CAN, driven by python-can's own interfaces: an SLCAN adapter on a pty
(python-can ``slcan``) and a socketcand server on loopback TCP (python-can ``socketcand``); SocketCAN
on vcan0 where the kernel has it.

Closed loop, frames on the wire against the golden vectors, the candump log, the budget, and every
kind of bad input the stub can inject (unknown ids, wrong DLC, out-of-range duty, bus-off, an
adapter that vanishes). These tests run the real stub (build/bin/hil_stub, or $HIL_STUB).
"""
from __future__ import annotations

import json
import math
import os
import re
import select
import signal
import socket
import subprocess
import threading
import time
from pathlib import Path

import can
import cantools
import numpy as np
import pytest

import hil_bench.loop.runner as runner_mod
from hil_bench.loop.links import LinkError, open_link, parse_stub_can_spec
from hil_bench.loop.links.stub import StubProcess, stub_path
from hil_bench.loop.runner import RunAborted, Runner, run_scenario
from hil_bench.protocol.timing import PATIENCE_S
from hil_bench.protocol import budget, dbc
from hil_bench.protocol.messages import MESSAGES, Command, HelloStatus
from hil_bench.record import channels as ch
from hil_bench.record.recording import load_recording
from hil_bench.scenario import SCENARIO_DIR, load_scenario, parse_scenario

REPO = Path(__file__).resolve().parents[1]
CAN_LINKS = ["stub-slcan", "stub-socketcand"]
CAN_SCENARIO = SCENARIO_DIR / "gong_g2_500rpm_can.toml"
VECTORS = REPO / "protocol" / "vectors"
DB = cantools.database.load_file(str(dbc.DBC_PATH))


def can_scenario(duration_s: float, ts_s: float | None = None, link: str = ""):
    """gong_g2_500rpm_can, shortened (and optionally at another period; ``link``: a [link] table)."""
    text = CAN_SCENARIO.read_text() + link
    text = text.replace("duration_s = 1.5", f"duration_s = {duration_s}")
    text = text.replace("window_s = [1.0, 1.5]", f"window_s = [0.0, {duration_s}]")
    if ts_s is not None:
        text = text.replace("ts_s = 600.0e-6", f"ts_s = {ts_s!r}")
    return parse_scenario(text, Path(f"can_{duration_s}.toml"))


def frames_of(text_column) -> list[tuple[int, bytes]]:
    out = []
    for text in text_column:
        for item in str(text).split():
            fid, data = item.split("#")
            out.append((int(fid, 16), bytes.fromhex(data)))
    return out


# ------------------------------------------------------------------------------------------------------
# Closed loop
# ------------------------------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def can_runs(tmp_path_factory):
    """gong_g2_500rpm_can over the serial pty and over both CAN paths (1.5 s, 2500 cycles each)."""
    tmp = tmp_path_factory.mktemp("can_runs")
    scn = load_scenario("gong_g2_500rpm_can")
    return {spec: run_scenario(scn, link_spec=spec, out_path=tmp / f"{spec}.mcap", progress=False)
            for spec in ["stub", *CAN_LINKS]}


@pytest.mark.parametrize("spec", CAN_LINKS)
def test_closed_loop_over_can_starts_and_holds_500rpm(can_runs, spec):
    result = can_runs[spec]
    assert result.ok, result.error
    assert result.cycles_done == result.cycles_planned == 2500
    rec = load_recording(result.recording)
    assert spec.removeprefix("stub-") in rec.metadata["run"]["link"]
    assert "classic CAN 1 Mbit/s" in rec.metadata["run"]["link"]
    state = rec.topic(ch.PLANT_STATE)
    telem = rec.topic(ch.CONTROLLER_TELEMETRY)
    assert state["speed_rpm"][0] == 0.0
    last = state["t_s"] >= 1.0
    speed = state["speed_rpm"][last]
    assert np.all(np.abs(speed - 500.0) < 15.0), (speed.min(), speed.max())
    assert np.all(telem["state"][last] == 3)              # CLOSED_LOOP, sensorless
    assert np.sqrt(np.mean(telem["pee_rad"][last] ** 2)) < 0.3
    stats = result.link_stats
    assert stats["length_errors"] == stats["can_unknown_ids"] == stats["error_frames"] == 0
    assert stats["bad_duties"] == stats["telem_missing"] == stats["seq_mismatch"] == 0


@pytest.mark.parametrize("spec", CAN_LINKS)
def test_one_message_set_serves_both_links(can_runs, spec):
    """Lockstep and the same frames: the run over CAN is the run over the serial pty, value for value."""
    serial = load_recording(can_runs["stub"].recording)
    over_can = load_recording(can_runs[spec].recording)
    for topic, fields in ((ch.PLANT_STATE, ("i_a_a", "i_b_a", "theta_e_rad", "omega_m_rad_s")),
                          (ch.CONTROLLER_TELEMETRY, ("theta_hat_rad", "omega_hat_rad_s", "duty_a"))):
        for f in fields:
            np.testing.assert_array_equal(serial.topic(topic)[f], over_can.topic(topic)[f], err_msg=f)


@pytest.mark.parametrize("spec", CAN_LINKS)
def test_candump_log_parses_and_holds_every_frame(can_runs, spec):
    result = can_runs[spec]
    log_path = result.recording.with_suffix(".log")
    msgs = list(can.LogReader(log_path))
    assert len(msgs) == result.link_stats["frames_tx"] + result.link_stats["frames_rx"]
    assert all(not m.is_extended_id and not m.is_fd and m.dlc == 8 for m in msgs)
    stamps = [m.timestamp for m in msgs]
    assert stamps == sorted(stamps)
    tx = [(m.arbitration_id, bytes(m.data)) for m in msgs if not m.is_rx]
    rx = [(m.arbitration_id, bytes(m.data)) for m in msgs if m.is_rx]
    frames = load_recording(result.recording).topic(ch.LINK_FRAMES)
    recorded_tx, recorded_rx = frames_of(frames["tx"]), frames_of(frames["rx"])
    assert rx == recorded_rx                              # everything received, in order
    assert tx[:len(recorded_tx)] == recorded_tx           # everything sent, then the final STOP
    assert [MESSAGES["CMD"].unpack(p)["command"] for _, p in tx[len(recorded_tx):]] == [Command.STOP]
    # one SENSE per cycle, one more per re-send (a loaded host's late answers: timing, 6.5); one
    # DUTY per cycle, one more per answer to a re-send; and nothing lost
    stats = result.link_stats
    assert sum(1 for fid, _ in tx if fid == 0x100) == 2500 + stats["retries"]
    assert sum(1 for fid, _ in rx if fid == 0x180) == 2500 + stats["resend_answers"]
    assert stats["lost_frames"] == 0


# ------------------------------------------------------------------------------------------------------
# Budget
# ------------------------------------------------------------------------------------------------------

def refused(scn, spec: str, out: Path) -> str:
    """A budget refusal happens before anything is recorded: the error, and no file."""
    with pytest.raises(RunAborted) as info:
        run_scenario(scn, link_spec=spec, out_path=out, progress=False)
    assert not out.exists()
    return str(info.value)


def test_budget_refuses_the_10khz_scenario_naming_the_highest_rate_that_fits(tmp_path):
    error = refused(load_scenario("gong_g2_500rpm"), "stub-slcan", tmp_path / "refused.mcap")
    fits = budget.can_max_rate_hz(1e6, budget.TELEM_EMF)      # the scenario sends TELEM_EMF
    assert "10000 Hz control rate needed" in error
    assert f"fits at most {fits:.0f} Hz" in error and "classic CAN 1 Mbit/s" in error


def test_budget_refuses_the_can_scenario_at_500kbit(tmp_path):
    error = refused(can_scenario(0.1), "stub-socketcand@500k", tmp_path / "refused.mcap")
    assert "1667 Hz control rate needed" in error
    assert f"fits at most {budget.can_max_rate_hz(5e5, 0):.0f} Hz" in error


def test_can_fd_with_bit_rate_switch_carries_a_faster_loop_end_to_end(tmp_path):
    ts = budget.can_fit_period_us(1e6, 0, fd=True, data_bitrate=5e6) * 1e-6     # 275 us
    scn = can_scenario(0.2, ts_s=ts)
    assert "fits at most 1852 Hz" in refused(scn, "stub-slcan", tmp_path / "classic.mcap")
    result = run_scenario(scn, link_spec="stub-slcan@1M,fd,data_bitrate=5M",
                          out_path=tmp_path / "fd.mcap", progress=False)
    assert result.ok, result.error
    msgs = list(can.LogReader(tmp_path / "fd.log"))
    assert msgs and all(m.is_fd and m.bitrate_switch for m in msgs)
    assert {m.is_rx for m in msgs} == {True, False}


# ------------------------------------------------------------------------------------------------------
# Bad input from the controller: counted, said, recording finalised
# ------------------------------------------------------------------------------------------------------

def run_injected(tmp_path, spec: str, inject: str, duration_s: float = 0.3, link: str = ""):
    out = tmp_path / f"{inject.replace('@', '_')}.mcap"
    t0 = time.monotonic()
    result = Runner(can_scenario(duration_s, link=link), link_spec=spec, out_path=out, progress=False,
                            stub_args=("--inject", inject)).run()
    return result, time.monotonic() - t0, load_recording(out)


def last_stats(rec) -> dict:
    stats = rec.topic(ch.LINK_STATS)
    return {k: stats[k][-1] for k in stats}


@pytest.mark.parametrize("spec", CAN_LINKS)
def test_unknown_ids_are_counted_and_the_run_goes_on(tmp_path, spec):
    """The stub sends a frame of id 0x7E5 (outside the DBC) before every TELEM from cycle 300 on:
    200 cycles. A busy host that re-sends a late cycle gets that cycle's TELEM again, with its
    0x7E5 before it: every unknown frame is counted, each one right before a TELEM on the wire."""
    result, _, rec = run_injected(tmp_path, spec, "unknown-id@300")
    assert result.ok, result.error
    msgs = list(can.LogReader(result.recording.with_suffix(".log")))
    logged = [k for k, m in enumerate(msgs) if m.arbitration_id == 0x7E5]
    telem = 385                                                    # TELEM (protocol/hil.dbc)
    assert all(msgs[k + 1].arbitration_id == telem for k in logged)   # each right before a TELEM
    telems_after = sum(1 for m in msgs[logged[0]:] if m.arbitration_id == telem)
    assert len(logged) == telems_after >= 200                      # 200 without a re-send
    unknown = result.link_stats["unknown_ids"]
    assert result.link_stats["can_unknown_ids"] == unknown == len(logged)
    assert last_stats(rec)["unknown_ids"] == unknown              # in the recording too
    if not result.link_stats.get("resend_answers"):
        assert unknown == 200


@pytest.mark.parametrize("spec", CAN_LINKS)
def test_wrong_dlc_is_counted_never_decoded_and_the_run_goes_on(tmp_path, spec, caplog):
    result, _, rec = run_injected(tmp_path, spec, "wrong-dlc@300")
    assert result.ok, result.error
    assert result.link_stats["length_errors"] == 1 and result.link_stats["telem_missing"] == 1
    assert last_stats(rec)["length_errors"] == 1
    telem = rec.topic(ch.CONTROLLER_TELEMETRY)
    k = int(np.flatnonzero(telem["seq"] == 300)[0])
    assert math.isnan(telem["theta_hat_rad"][k]) and not math.isnan(telem["theta_hat_rad"][k + 1])
    events = rec.topic(ch.EVENTS)
    said = [t for k, t in zip(events["kind"], events["text"]) if k == "length_error"]
    assert len(said) == 1 and "TELEM (0x181) with 6 octets, the DBC says 8" in said[0]


@pytest.mark.parametrize("spec", CAN_LINKS)
def test_out_of_range_duty_is_refused_and_previous_duty_held(tmp_path, spec):
    result, _, rec = run_injected(tmp_path, spec, "bad-duty@300")
    assert result.ok, result.error
    assert result.link_stats["bad_duties"] == 1
    telem = rec.topic(ch.CONTROLLER_TELEMETRY)
    k = int(np.flatnonzero(telem["seq"] == 300)[0])
    assert telem["duty_a"][k] == telem["duty_a"][k - 1]
    assert "bad_duty" in list(rec.topic(ch.EVENTS)["kind"])


def test_garbage_on_can_is_frames_outside_the_dbc(tmp_path):
    result, _, _ = run_injected(tmp_path, "stub-socketcand", "garbage@400")
    assert result.ok, result.error
    # one per received frame (2 a cycle), and one more for the final CMD STOP if its answer
    # arrives before the counters are read; a busy host's re-sent cycles are frames received too
    unknown = result.link_stats["can_unknown_ids"]
    known = {m.frame_id for m in DB.messages}
    on_wire = sum(1 for m in can.LogReader(result.recording.with_suffix(".log"))
                  if not m.is_error_frame and m.arbitration_id not in known)
    # (the STOP's answer may be on the wire after the counters were read)
    assert unknown >= 200 and on_wire - 1 <= unknown <= on_wire, (unknown, on_wire)
    if not result.link_stats.get("retries"):
        assert unknown in (200, 201)


def test_bus_off_over_socketcand_ends_the_run_at_once(tmp_path):
    result, elapsed, rec = run_injected(tmp_path, "stub-socketcand", "bus-off@200", duration_s=2.0)
    assert result.cycles_done == 200
    assert "bus-off (error frame class 0x040)" in result.error and "at cycle 200" in result.error
    assert elapsed < 3.0
    assert rec.truncated is None and len(rec.topic(ch.PLANT_STATE)["t_s"]) == 200
    assert rec.metadata["run_result"]["error"] == result.error
    errors = [m for m in can.LogReader(result.recording.with_suffix(".log")) if m.is_error_frame]
    assert len(errors) == 1


def test_bus_off_over_slcan_is_silence_then_a_clear_timeout(tmp_path):
    # Lawicel has no asynchronous error report: the adapter's F flags say it, frames stop; the
    # host finds the silence after its patience (1 s here: what this tests is the silence)
    result, elapsed, rec = run_injected(tmp_path, "stub-slcan", "bus-off@200", duration_s=2.0,
                                        link="\n[link]\npatience_s = 1.0\n")
    assert result.cycles_done == 200
    assert "at cycle 200" in result.error and "no DUTY(200) 1 s (patience_s) after its SENSE" in result.error
    assert "nothing at all (the controller is silent)" in result.error
    assert rec.truncated is None and len(rec.topic(ch.PLANT_STATE)["t_s"]) == 200


@pytest.mark.parametrize("spec", CAN_LINKS)
def test_adapter_vanishing_mid_run_ends_it_within_a_second(tmp_path, spec, monkeypatch):
    """SIGKILL the stub (the adapter and the drive behind it) while cycles flow."""
    opened = {}
    real_open_link = runner_mod.open_link

    def capture(*args, **kwargs):
        opened["link"] = real_open_link(*args, **kwargs)
        return opened["link"]

    monkeypatch.setattr(runner_mod, "open_link", capture)
    out = tmp_path / "vanish.mcap"
    runner = Runner(can_scenario(5.0), link_spec=spec, out_path=out, progress=False)
    killed_at = {}

    def killer():
        deadline = time.monotonic() + 20
        while time.monotonic() < deadline and (getattr(runner, "engine", None) is None
               or runner.engine.cycles_done < 300):
            time.sleep(0.002)
        os.kill(opened["link"].stub.proc.pid, signal.SIGKILL)
        killed_at["t"] = time.monotonic()

    thread = threading.Thread(target=killer)
    thread.start()
    result = runner.run()
    ended = time.monotonic()
    thread.join()
    assert ended - killed_at["t"] < 1.0
    assert "controller stub killed by signal 9" in result.error, result.error
    assert 300 <= result.cycles_done < runner.n_cycles
    rec = load_recording(out)
    assert rec.truncated is None
    assert len(rec.topic(ch.PLANT_STATE)["t_s"]) == result.cycles_done
    assert rec.metadata["run_result"]["error"] == result.error
    logged = list(can.LogReader(out.with_suffix(".log")))       # finalised and readable too
    assert sum(1 for m in logged if m.arbitration_id == 0x180) >= 300


# ------------------------------------------------------------------------------------------------------
# Codec vectors over CAN
# ------------------------------------------------------------------------------------------------------

def message_vectors() -> list[dict]:
    index = json.loads((VECTORS / "index.json").read_text())["cases"]
    cases = [json.loads((VECTORS / f"{n}.json").read_text()) | {"case": n} for n in index]
    return [c for c in cases if c["kind"] == "message"]


def start_stub(mode: str, *args: str, tmp_path: Path | None = None) -> StubProcess:
    spec = parse_stub_can_spec(f"stub-{mode}", "", f"stub-{mode}")
    return StubProcess(tuple(args), mode=mode, can_spec=spec,
                       capture_path=tmp_path / f"{mode}.log" if tmp_path else None)


def exchange(link, frames, expect: int, timeout_s: float = 5.0) -> list[tuple[int, bytes]]:
    got: list[tuple[int, bytes]] = []
    for i in range(0, len(frames), 4):
        link.send(frames[i:i + 4])
    deadline = time.monotonic() + timeout_s
    while len(got) < expect and time.monotonic() < deadline:
        got += link.recv(0.1)
    return got


@pytest.mark.parametrize("mode", ["slcan", "socketcand"])
def test_every_vector_crosses_the_adapter_ends_byte_for_byte(mode, tmp_path):
    """The stub in --echo mode returns every frame: the C SLCAN / socketcand codecs carry each golden
    payload unchanged both ways, and cantools decodes what came back to the vector's values."""
    cases = message_vectors()
    frames = [(c["frame_id"], (VECTORS / f"{c['case']}.bin").read_bytes()) for c in cases]
    stub = start_stub(mode, "--echo", tmp_path=tmp_path)
    try:
        got = exchange(stub.link, frames, len(frames))
    finally:
        assert stub.stop() == 0
    assert got == frames
    for c, (fid, payload) in zip(cases, got):
        assert payload.hex().upper() == c["payload_hex"].upper()
        # (CONFIG as the codecs see it: cantools decodes the multiplexed message by the parameter's
        # own signal, and a vector's param_id need not name a parameter)
        decoded = dbc.codec_message(c["name"]).decode(payload, decode_choices=False)
        assert set(decoded) == set(c["signals"]), c["case"]
    assert len(list(can.LogReader(tmp_path / f"{mode}.log"))) == 2 * len(frames)


@pytest.mark.parametrize("mode", ["slcan", "socketcand"])
def test_the_stub_decodes_the_hello_vectors_sent_over_can(mode):
    """HELLO vectors (payloads as encoded by the reference encoder) to the real session over CAN: the
    C decoder's view of every field shows in the HELLO_ACK (status and echoed session)."""
    hello_ack = MESSAGES["HELLO_ACK"]
    cases = [c for c in message_vectors() if c["name"] == "HELLO"]
    assert len(cases) >= 6
    stub = start_stub(mode)
    try:
        for c in cases:
            payload = (VECTORS / f"{c['case']}.bin").read_bytes()
            v = DB.decode_message("HELLO", payload, decode_choices=False, scaling=True)
            stub.link.send([(0x020, payload)])
            ack = stub.link.recv_until(lambda fid, p: fid == 0x021, 2.0)
            assert ack is not None, c["case"]
            a = hello_ack.unpack(ack[1])
            supported = int(a["estimators"])      # the stub's capability mask, bit n = estimator n
            if v["proto_version"] != 1:
                status = HelloStatus.VERSION_MISMATCH
            elif v["estimator"] >= 16 or not (supported >> int(v["estimator"])) & 1:
                status = HelloStatus.ESTIMATOR_UNSUPPORTED
            elif v["period_us"] < 10.0:
                status = HelloStatus.PERIOD_UNSUPPORTED
            else:
                status = HelloStatus.OK
            assert (a["session"], a["status"]) == (v["session"], status), c["case"]
    finally:
        assert stub.stop() == 0


# ------------------------------------------------------------------------------------------------------
# The adapter ends themselves, on the wire (what python-can sends and expects)
# ------------------------------------------------------------------------------------------------------

class RawSlcan:
    """The stub's SLCAN adapter end on a pty, spoken to byte by byte."""

    def __init__(self):
        import tty

        master, slave = os.openpty()
        tty.setraw(master)
        tty.setraw(slave)
        self.proc = subprocess.Popen([str(stub_path()), "--slcan", f"fd:{master}"], pass_fds=(master,),
                                     stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                                     stderr=subprocess.PIPE, text=True)
        os.close(master)
        self.fd = slave
        self.pending = ""          # bytes read past the replies asked for

    def talk(self, line: str, replies: int = 1) -> str:
        """Send one line, return the next ``replies`` replies (each ends in CR or BEL; heartbeat
        frames, t051..., filtered out). It waits for them as lockstep does, up to PATIENCE_S: a
        busy host makes the adapter slower, never different (issue 26)."""
        os.write(self.fd, line.encode("latin-1") + b"\r")
        deadline = time.monotonic() + PATIENCE_S
        got: list[str] = []
        while len(got) < replies:
            left = deadline - time.monotonic()
            assert left > 0, f"{line!r}: {len(got)} of {replies} replies in {PATIENCE_S} s: {got}"
            if select.select([self.fd], [], [], left)[0]:
                self.pending += os.read(self.fd, 4096).decode("latin-1")
            while len(got) < replies and (m := re.search(r"[\r\a]", self.pending)):
                reply, self.pending = self.pending[:m.end()], self.pending[m.end():]
                if not reply.startswith("t051"):
                    got.append(reply)
        return "".join(got)

    def close(self) -> str:
        os.close(self.fd)
        _, err = self.proc.communicate(timeout=5)
        assert self.proc.returncode == 0, err
        return err


HELLO_PAYLOAD = MESSAGES["HELLO"].pack(proto_version=1, proto_minor=1, mode=0, period_us=600.0, estimator=1, flags=0,
                                       session=0x1234)


def test_slcan_adapter_end_answers_like_a_lawicel_adapter():
    a = RawSlcan()
    try:
        hello = "t0208" + HELLO_PAYLOAD.hex().upper()
        assert a.talk("V") == "V1013\r"                   # python-can get_version(): hw 10, sw 13
        assert a.talk("N") == "NHIL0\r"                   # get_serial_number() -> "HIL0"
        assert a.talk("F") == "F00\r"
        assert a.talk(hello) == "\a"                      # channel closed: not on the bus
        assert a.talk("C") == "\r"                        # what python-can sends on open:
        assert a.talk("S8") == "\r"                       #   C, S8, (empty: no data bit rate), O, O
        assert a.talk("") == "\r"
        assert a.talk("O") == "\r"
        assert a.talk("O") == "\a"                        # already open (harmless, not an error)
        assert a.talk("S6") == "\a"                       # bit rate only while closed
        reply = a.talk(hello, replies=2)                  # its "sent", then the drive's answer
        assert reply.startswith("z\r") and reply.count("\r") == 2
        line = reply.split("\r")[1]
        assert line[:5] == "t0218"
        ack = MESSAGES["HELLO_ACK"].unpack(bytes.fromhex(line[5:]))
        assert ack["session"] == 0x1234 and ack["status"] == HelloStatus.OK
        for bad in ("t12", "t0209" + "00" * 9, "t0208001122", "tXYZ8" + "00" * 8, "t8008" + "00" * 8,
                    "?", "x" * 200):
            assert a.talk(bad) == "\a", bad
        assert a.talk("T000000208" + HELLO_PAYLOAD.hex()) == "Z\r"    # 29-bit: not for the drive
        assert a.talk("r0208") == "z\r"                               # remote: not for the drive
        assert a.talk("Z1") == "\r"
        stamped = a.talk(hello, replies=2).split("\r")[1]
        assert len(stamped) == 5 + 16 + 4                             # + 4 hex digits of ms
        assert a.talk("C") == "\r"
        assert a.talk(hello) == "\a"
    finally:
        err = a.close()
    assert "host closed the link" in err
    assert "bad_commands=7" in err and "declined_commands=2" in err and "ext_ignored=1" in err


class RawSocketcand:
    def __init__(self, *extra: str):
        listener = socket.socket()
        listener.bind(("127.0.0.1", 0))
        listener.listen(1)
        self.proc = subprocess.Popen([str(stub_path()), "--socketcand", f"fd:{listener.fileno()}", *extra],
                                     pass_fds=(listener.fileno(),), stdin=subprocess.DEVNULL,
                                     stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
        self.sock = socket.create_connection(listener.getsockname(), timeout=PATIENCE_S)
        listener.close()
        self.pending = ""          # text read past the elements asked for

    def talk(self, text: str | None, replies: int = 1) -> str:
        """Send ``text``, return the next ``replies`` elements ("< ... >", heartbeat frames of
        id 051 filtered out), waiting for them up to PATIENCE_S. ``replies=0``: a command that
        must get no answer; an echo sent behind it must come back first (what came before it
        is returned), however late the host lets the stub answer (issue 26)."""
        if text is not None:
            self.sock.sendall(text.encode())
        if replies == 0:
            self.sock.sendall(b"< echo >")
        deadline = time.monotonic() + PATIENCE_S
        got: list[str] = []
        while True:
            while "<" in self.pending and ">" in self.pending:
                start = self.pending.index("<")
                end = self.pending.index(">", start) + 1
                element, self.pending = self.pending[start:end], self.pending[end:]
                if not element.startswith("< frame 051"):
                    got.append(element)
            if replies == 0 and got and got[-1] == "< echo >":
                return "".join(got[:-1])
            if replies and len(got) >= replies:
                return "".join(got)
            left = deadline - time.monotonic()
            assert left > 0, f"{text!r}: no answer in {PATIENCE_S} s, got {got}"
            self.sock.settimeout(left)
            chunk = self.sock.recv(4096)
            assert chunk, f"{text!r}: the stub closed the connection after {got}"
            self.pending += chunk.decode()

    def close(self) -> tuple[int, str]:
        self.sock.close()
        _, err = self.proc.communicate(timeout=5)
        return self.proc.returncode, err


def test_socketcand_server_end_speaks_the_raw_mode_protocol():
    s = RawSocketcand()
    send_hello = "< send 20 8 " + " ".join(f"{b:x}" for b in HELLO_PAYLOAD) + " >"
    try:
        assert s.talk(None) == "< hi >"
        assert s.talk("< rawmode >") == "< error unknown command >"     # no bus open yet
        assert s.talk("< open hil0 >") == "< ok >"
        assert s.talk("< echo >") == "< echo >"
        assert s.talk(send_hello, replies=0) == ""        # BCM mode: sent, but nothing comes back
        assert s.talk("< rawmode >") == "< ok >"
        s.sock.sendall(send_hello[:9].encode())            # a command split across TCP segments
        time.sleep(0.05)
        reply = s.talk(send_hello[9:])
        assert reply.startswith("< frame 021 ") and reply.endswith(" >")
        _, _, _, stamp, data, _ = reply.split(" ")
        assert abs(float(stamp) - time.time()) < 5.0
        ack = MESSAGES["HELLO_ACK"].unpack(bytes.fromhex(data))
        assert ack["session"] == 0x1234
        for bad in ("< send 20 9 1 2 3 4 5 6 7 8 9 >", "< send 20 2 1 >", "< send XYZ 1 1 >",
                    "< send 20 1 100 >"):
            assert s.talk(bad, replies=0) == "", bad       # malformed: counted, ignored
        assert s.talk("< bogus >") == "< error unknown command >"
        assert s.talk("< send 12345678 8 " + " ".join(["0"] * 8) + " >", replies=0) == ""  # 29-bit
    finally:
        code, err = s.close()
    assert code == 0 and "host closed the link" in err
    assert "bad_commands=6" in err and "ext_ignored=1" in err


def test_socketcand_server_refuses_another_bus_and_says_which():
    s = RawSocketcand("--bus", "hil0")
    try:
        assert s.talk(None) == "< hi >"
        assert s.talk("< open can7 >") == "< error could not open bus >"
    finally:
        code, err = s.close()
    assert code == 0 and "the client asked for bus 'can7'; this stub serves 'hil0'" in err


def test_stub_refuses_bad_options_naming_them():
    exe = str(stub_path())
    for args, text in ((["--inject", "teleport@3", "--port", "/dev/null"], "bad --inject 'teleport@3'"),
                       (["--slcan", "fd:9x"], "not a descriptor number"),
                       (["--port", "/dev/null", "--slcan", "fd:3"], "exactly one link"),
                       (["--socketcand", "127.0.0.1:99999"], "port must be a number 0..65535")):
        r = subprocess.run([exe, *args], capture_output=True, text=True, timeout=5)
        assert r.returncode in (1, 2) and text in r.stderr, (args, r.stderr)


# ------------------------------------------------------------------------------------------------------
# SocketCAN: vcan0 where the kernel has it
# ------------------------------------------------------------------------------------------------------

def socketcan_unavailable(iface: str = "vcan0") -> str | None:
    """Why SocketCAN on iface cannot be used here, or None."""
    if not hasattr(socket, "AF_CAN"):
        return "this Python has no socket.AF_CAN"
    try:
        with socket.socket(socket.AF_CAN, socket.SOCK_RAW, socket.CAN_RAW) as s:
            s.bind((iface,))
    except OSError as exc:
        return f"AF_CAN/{iface} unavailable: {exc.strerror or exc}"
    return None


def test_stub_says_why_socketcan_cannot_open():
    r = subprocess.run([str(stub_path()), "--socketcan", "nosuchcan9"], capture_output=True, text=True,
                       timeout=5)
    assert r.returncode == 1
    assert ("SocketCAN unavailable: cannot create an AF_CAN raw socket" in r.stderr
            or "no CAN interface nosuchcan9" in r.stderr), r.stderr
    with pytest.raises(LinkError, match="nosuchcan9"):
        open_link("stub-socketcan:nosuchcan9")


def test_closed_loop_over_socketcan_vcan0(tmp_path):
    why = socketcan_unavailable("vcan0")
    if why:
        pytest.skip(f"SocketCAN test skipped: {why} (needs a kernel with CAN and `ip link add dev vcan0 "
                    f"type vcan && ip link set up vcan0`)")
    result = run_scenario(can_scenario(0.6), link_spec="stub-socketcan:vcan0",
                          out_path=tmp_path / "vcan.mcap", progress=False)
    assert result.ok, result.error
    msgs = list(can.LogReader(tmp_path / "vcan.log"))
    assert len(msgs) == result.link_stats["frames_tx"] + result.link_stats["frames_rx"]


ASAN_STUB = REPO / "build-asan" / "bin" / "hil_stub"


@pytest.mark.skipif(not ASAN_STUB.exists(), reason="no sanitizer build (make sanitize)")
@pytest.mark.parametrize("spec, inject", [("stub-slcan", "wrong-dlc@100"),
                                          ("stub-socketcand", "unknown-id@100")])
def test_stub_can_ends_run_clean_under_asan_and_ubsan(tmp_path, monkeypatch, spec, inject):
    monkeypatch.setenv("HIL_STUB", str(ASAN_STUB))
    monkeypatch.setenv("ASAN_OPTIONS", "abort_on_error=1:detect_leaks=1")
    monkeypatch.setenv("UBSAN_OPTIONS", "halt_on_error=1:print_stacktrace=1")
    result = Runner(can_scenario(0.2), link_spec=spec, out_path=tmp_path / "asan.mcap",
                            progress=False, stub_args=("--inject", inject)).run()
    assert result.ok, result.error
