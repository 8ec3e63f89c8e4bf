"""bench run --live: the Foxglove WebSocket protocol, spoken by a client of our own, during a run.

The client is `websockets` speaking the Foxglove WebSocket protocol by hand (subprotocol
``foxglove.sdk.v1``, which foxglove-sdk 0.30 serves; ``foxglove.websocket.v1`` offered as well):
JSON ``serverInfo`` / ``advertise`` / ``subscribe``, binary ``messageData`` (opcode 1, u32
subscription id, u64 log time, payload). It checks what a viewer relies on against the
recording the same run wrote: the advertised channels and their schemas are the recording's,
and a /plant/state message decoded with the *advertised* schema is the recording's row of the
same time.
"""
from __future__ import annotations

import base64
import fcntl
import json
import re
import struct
import termios
import threading
import time
from pathlib import Path

import pytest

import websockets.sync.client as ws_sync   # a test dependency (pyproject [test]): never skipped
from mcap.reader import make_reader

from hil_bench.loop.runner import Runner
from hil_bench.record.live_view import EVENTS_HISTORY, LiveOptions, stats_line, viewer_dropped
from hil_bench.scenario import load_scenario

SUBPROTOCOLS = ["foxglove.sdk.v1", "foxglove.websocket.v1"]
OP_MESSAGE_DATA = 1


#: a stalled viewer's socket receive buffer: fixed (no autotuning), so what the kernel holds for
#: it is bounded (tens of KiB) and foxglove-sdk's queue must overflow: a run's live data (about
#: 1 MB at --live-rate 1e6) would otherwise fit in autotuned loopback buffers on some runs
STALLED_RCVBUF = 32 * 1024


def _connect(port: int, rcvbuf: int | None = None, **kw):
    import socket

    deadline = time.monotonic() + 20.0
    while True:
        try:
            sock = None
            if rcvbuf is not None:
                sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
                sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, rcvbuf)
                sock.connect(("127.0.0.1", port))
                kw["sock"] = sock
            return ws_sync.connect(f"ws://127.0.0.1:{port}", subprotocols=SUBPROTOCOLS,
                                   open_timeout=5, **kw)
        except OSError:
            if sock is not None:
                sock.close()
            if time.monotonic() > deadline:
                raise
            time.sleep(0.02)


class Viewer(threading.Thread):
    """Connects once the live view listens, subscribes to ``topics`` as they are advertised,
    reads until the server closes (the run's end), or, ``stall``, stops reading once
    subscribed and only holds the connection open."""

    def __init__(self, port: int, topics: tuple[str, ...] | None, stall: bool = False):
        super().__init__(daemon=True)
        self.port, self.topics, self.stall = port, topics, stall
        self.subprotocol = None
        self.advertised: dict[int, dict] = {}
        self.subscribed: dict[int, int] = {}    # subscription id -> channel id
        self.messages: list[tuple[int, int, bytes]] = []   # (channel id, log time, payload)
        self.error: BaseException | None = None
        self.unread_octets = 0
        self.retries = 0                        # subscriptions sent again (_status)
        self.done = threading.Event()
        self.release = threading.Event()

    def _subscribe(self, ws, channels) -> None:
        subs = []
        for c in channels:
            if self.topics is None or c["topic"] in self.topics:
                sid = len(self.subscribed) + 1
                self.subscribed[sid] = c["id"]
                subs.append({"id": sid, "channelId": c["id"]})
        if subs:
            ws.send(json.dumps({"op": "subscribe", "subscriptions": subs}))

    def _status(self, ws, j: dict) -> None:
        """foxglove-sdk 0.30 can answer a subscription sent the moment a channel was advertised
        (a client connected before the run registered its channels) with "Unknown channel ID:
        N": the channel is advertised but not yet subscribable. Subscribe again a moment later,
        as a patient viewer would (seen about one run in four on a loaded machine)."""
        m = re.match(r"Unknown channel ID: (\d+)", j.get("message", ""))
        if m is None or self.retries >= 100:
            return
        self.retries += 1
        cid = int(m.group(1))
        time.sleep(0.02)
        subs = [{"id": sid, "channelId": c} for sid, c in self.subscribed.items() if c == cid]
        if subs:
            ws.send(json.dumps({"op": "subscribe", "subscriptions": subs}))

    def run(self) -> None:
        try:
            ws = _connect(self.port, max_queue=4 if self.stall else 4096,
                          rcvbuf=STALLED_RCVBUF if self.stall else None)
            with ws:
                self.subprotocol = ws.subprotocol
                while True:
                    try:
                        m = ws.recv(timeout=30)
                    except Exception:   # noqa: BLE001 - closed by the server: the run's end
                        break
                    if isinstance(m, str):
                        j = json.loads(m)
                        if j["op"] == "advertise":
                            for c in j["channels"]:
                                self.advertised[c["id"]] = c
                            self._subscribe(ws, j["channels"])
                        elif j["op"] == "status":
                            self._status(ws, j)
                    elif m[0] == OP_MESSAGE_DATA:
                        sid, t_ns = struct.unpack_from("<IQ", m, 1)
                        self.messages.append((self.subscribed[sid], t_ns, bytes(m[13:])))
                        if self.stall and len(self.messages) >= 1:
                            self._hold(ws)
                            break
        except BaseException as exc:  # noqa: BLE001 - the test reports it
            self.error = exc
        finally:
            self.done.set()

    def _hold(self, ws) -> None:
        """Read nothing more: the server's data for us piles up in the kernel, then in its
        per-client queue. Measure what lies unread in our socket until the test lets go."""
        sock = ws.socket
        while not self.release.wait(0.05):
            buf = bytearray(4)
            fcntl.ioctl(sock.fileno(), termios.FIONREAD, buf)
            self.unread_octets = max(self.unread_octets, struct.unpack("i", buf)[0])


def _recording(path: Path):
    """The recording's channels (topic -> (schema name, encoding, schema data)) and its
    messages by (topic, log time)."""
    with open(path, "rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        chans = {c.topic: (summary.schemas[c.schema_id].name, summary.schemas[c.schema_id].encoding,
                           summary.schemas[c.schema_id].data, c.message_encoding)
                 for c in summary.channels.values()}
        rows = {}
        for _schema, channel, message in reader.iter_messages():
            rows[(channel.topic, message.log_time)] = message.data
    return chans, rows


def _advertised_as_recorded(viewer, path: Path):
    """The channels the viewer was told of, checked against the recording's: the same topics,
    each with the recording's schema (name, encoding, data) and message encoding. Returns the
    advertised channels by topic, the recording's messages by (topic, log time) and the
    message class of /plant/state built from what the viewer was told, nothing of ours."""
    from google.protobuf import descriptor_pb2, descriptor_pool, message_factory

    chans, rows = _recording(path)
    advertised = {c["topic"]: c for c in viewer.advertised.values()}
    # the recording's channels, and the viewer's own /events/history (late viewers' /events rows)
    assert set(advertised) == set(chans) | {EVENTS_HISTORY}
    assert advertised[EVENTS_HISTORY]["schema"] == advertised["/events"]["schema"]
    advertised.pop(EVENTS_HISTORY)
    for topic, c in advertised.items():
        name, encoding, data, msg_encoding = chans[topic]
        assert (c["schemaName"], c["schemaEncoding"], c["encoding"]) == (name, encoding, msg_encoding)
        assert base64.b64decode(c["schema"]) == data, topic
    state = advertised["/plant/state"]
    fds = descriptor_pb2.FileDescriptorSet.FromString(base64.b64decode(state["schema"]))
    pool = descriptor_pool.DescriptorPool()
    for fd in fds.file:
        pool.Add(fd)
    cls = message_factory.GetMessageClass(pool.FindMessageTypeByName(state["schemaName"]))
    return advertised, rows, cls


def _run(tmp_path: Path, *, live: LiveOptions, pace: float | None, make_viewer, **kw):
    scn = load_scenario("gong_g2_500rpm")
    out = tmp_path / "live.mcap"
    runner = Runner(scn, "stub", out, False, live=live, pace=pace, **kw)
    viewers = []

    def on_live(port: int) -> None:
        v = make_viewer(port)
        v.start()
        viewers.append(v)

    runner.on_live = on_live
    result = runner.run()
    return result, viewers


def test_a_viewer_sees_the_recordings_channels_and_decodes_plant_state(tmp_path):
    result, viewers = _run(tmp_path, live=LiveOptions(port=0), pace=1.0,
                           make_viewer=lambda port: Viewer(port, ("/plant/state",)))
    assert result.ok, result.error
    assert result.cycles_done == result.cycles_planned
    # --pace 1: cycle k starts k Ts after the first (absolute deadlines): never faster
    assert result.engine_s >= 0.99 * (result.cycles_done - 1) * result.ts_s, result.engine_s
    (viewer,) = viewers
    assert viewer.done.wait(30), "the server did not close the connection at the run's end"
    assert viewer.error is None, repr(viewer.error)
    assert viewer.subprotocol in SUBPROTOCOLS

    # decode with what the viewer was told, nothing of ours
    advertised, rows, cls = _advertised_as_recorded(viewer, result.recording)
    state = advertised["/plant/state"]
    got = [(t, payload) for cid, t, payload in viewer.messages if cid == state["id"]]
    # 1.5 s paced to real time, 50 Hz: about 75 (fewer on a loaded machine, the first ones
    # before the viewer subscribed)
    assert len(got) >= 10, len(got)
    assert len(got) <= result.wall_s * 50 + 5, f"{len(got)}: the viewer rate is not kept"
    times = [t for t, _ in got]
    assert times == sorted(times)
    for t, payload in got:
        assert rows[("/plant/state", t)] == payload   # the recording's row of that time
        msg = cls.FromString(payload)
        assert msg.ListFields(), "decoded to nothing"
    last = cls.FromString(got[-1][1])
    fields = {f.name: v for f, v in last.ListFields()}
    speed = next(v for k, v in fields.items() if "speed" in k or "omega" in k)
    assert speed > 10.0, fields   # the motor runs toward 500 rpm by the end
    # a client that reads lost nothing: the bench cut nothing, foxglove-sdk reported no overflow
    stats = result.live_stats
    assert stats["clients_connected"] == 1 and stats["clients_subscribed"] == 1, stats
    assert stats["messages_sent"] >= len(got), stats
    assert viewer_dropped(stats) == 0 and stats["sdk_outbox_full_reports"] == 0, stats
    assert _live_metadata(result.recording) == stats   # the recording says the same


def test_a_viewer_that_stops_reading_does_not_hold_the_run(tmp_path):
    """A client subscribed to every channel, sent every batch's rows (--live-rate very high),
    that reads nothing: its socket fills, foxglove-sdk drops its oldest messages, and the run
    and its recording finish whole (a live view that waited on the socket would stall the
    recorder, then the engine, and the close would time out)."""
    result, viewers = _run(tmp_path, live=LiveOptions(port=0, rate_hz=1e6, backlog=16),
                           pace=None, make_viewer=lambda port: Viewer(port, None, stall=True),
                           ring_bytes=4 * 1024 * 1024)
    (viewer,) = viewers
    try:
        assert result.ok, result.error
        assert result.cycles_done == result.cycles_planned
        assert viewer.error is None, repr(viewer.error)
        assert viewer.messages, "the viewer never got a message: it did not stall anything"
        # the viewer holds data it never read (measured 45-70 KiB: the sockets' buffers, how
        # full depends on how fast the run went); the run did not wait on it
        assert viewer.unread_octets > 16 * 1024, viewer.unread_octets
    finally:
        viewer.release.set()
        viewer.done.wait(10)
    _chans, rows = _recording(result.recording)
    state_rows = sum(1 for topic, _t in rows if topic == "/plant/state")
    every = load_scenario("gong_g2_500rpm").recording.decimate
    assert state_rows >= result.cycles_done // every, (state_rows, result.cycles_done)
    # what the viewer lost: the bench cut nothing; it sent the client far more frames than the
    # client read plus foxglove-sdk's queue of 16 (the rest were dropped by the sdk or lie in the
    # kernel's buffers); the sdk's overflow report, when it reaches the bench, names this client
    # (it did not reach it in about 1 run in 3: docs/foxglove.md "Dropped frames"); the
    # end-of-run line and the recording say the same
    stats = result.live_stats
    assert stats["sdk_log"] == "info", stats
    assert stats["cut_by_bench"] == 0
    assert stats["client_frames_sent"] > len(viewer.messages) + 16, stats
    if stats["sdk_outbox_full_reports"]:
        assert len(stats["sdk_outbox_full_clients"]) == 1 and viewer_dropped(stats) >= 1, stats
    assert _live_metadata(result.recording) == stats
    line = stats_line(stats)
    assert "viewer frames dropped: at least" in line, line


def _live_metadata(path: Path) -> dict:
    """The recording's live_view metadata, decoded as LiveView.stats wrote it."""
    from hil_bench.record.recording import load_recording

    meta = load_recording(path, topics=["/events"]).metadata["live_view"]
    return {k: (v if k in ("sdk_log", "host") else json.loads(v)) for k, v in meta.items()}


def test_a_taken_port_is_a_clear_error(tmp_path):
    import socket

    from hil_bench.record.recorder import ProcessRecorder, RecorderError

    s = socket.socket()
    s.bind(("127.0.0.1", 0))
    s.listen()
    port = s.getsockname()[1]
    try:
        with pytest.raises(RecorderError, match=rf"live view: cannot listen on 127.0.0.1:{port}"):
            ProcessRecorder(tmp_path / "x.mcap", live=LiveOptions(port=port))
        assert not (tmp_path / "x.mcap").exists()
        assert not list(tmp_path.iterdir()), "a refused live view leaves no file"
    finally:
        s.close()


class Operator(Viewer):
    """A viewer that advertises one operator topic (client-publish, JSON) and, once it has seen
    ``after`` messages of what it subscribed to (the run is going), publishes ``payload`` on it
    once. It keeps every message it got (channel id, log time, payload)."""

    def __init__(self, port: int, rpm: float | None = None, after: int = 5, *,
                 topic: str = "/operator/speed_ref", payload: dict | None = None,
                 topics: tuple[str, ...] = ("/plant/state",)):
        super().__init__(port, topics)
        self.after = after
        self.topic = topic
        self.payload = payload if payload is not None else {"rpm": rpm}
        self.capabilities: list[str] = []
        self.published = False

    def run(self) -> None:
        try:
            with _connect(self.port) as ws:
                while True:
                    try:
                        m = ws.recv(timeout=30)
                    except Exception:   # noqa: BLE001 - closed by the server: the run's end
                        break
                    if isinstance(m, str):
                        j = json.loads(m)
                        if j["op"] == "serverInfo":
                            self.capabilities = j.get("capabilities", [])
                            ws.send(json.dumps({"op": "advertise", "channels": [
                                {"id": 1, "topic": self.topic, "encoding": "json",
                                 "schemaName": "hil.Operator"}]}))
                        elif j["op"] == "advertise":
                            for c in j["channels"]:
                                self.advertised[c["id"]] = c
                            self._subscribe(ws, j["channels"])
                        elif j["op"] == "status":
                            self._status(ws, j)
                    elif m[0] == OP_MESSAGE_DATA:
                        sid, t_ns = struct.unpack_from("<IQ", m, 1)
                        self.messages.append((self.subscribed[sid], t_ns, bytes(m[13:])))
                        if len(self.messages) >= self.after and not self.published:
                            payload = json.dumps(self.payload).encode()
                            ws.send(struct.pack("<BI", 1, 1) + payload)   # client message data
                            self.published = True
        except BaseException as exc:  # noqa: BLE001
            self.error = exc
        finally:
            self.done.set()


def _operator_run(tmp_path: Path, inputs: bool, rpm: float | None = None, **operator):
    """G2 paced to real time with one Operator (``operator``: its topic and payload)."""
    from hil_bench.scenario import derive_scenario

    # the same name: its claims (G2) are judged as the bundled scenario's are
    scn = derive_scenario("gong_g2_500rpm", "gong_g2_500rpm", [("live.inputs", inputs)])
    out = tmp_path / "op.mcap"
    runner = Runner(scn, "stub", out, False, live=LiveOptions(port=0), pace=1.0)
    viewers = []

    def on_live(port: int) -> None:
        viewers.append(Operator(port, rpm, **operator))
        viewers[0].start()

    runner.on_live = on_live
    result = runner.run()
    assert result.ok, result.error
    viewers[0].done.wait(30)
    assert viewers[0].error is None, repr(viewers[0].error)
    assert "clientPublish" in viewers[0].capabilities
    assert viewers[0].published
    return result


def _events(path: Path) -> list[tuple[float, str, str]]:
    from hil_bench.record.recording import load_recording

    ev = load_recording(path, topics=["/events"]).topic("/events")
    return list(zip(map(float, ev["t_s"]), map(str, ev["kind"]), map(str, ev["text"])))


def test_an_operator_speed_reference_is_applied_recorded_and_no_claim_passes(tmp_path):
    import numpy as np

    from hil_bench.papers.check import check_recording
    from hil_bench.record.recording import load_recording

    result = _operator_run(tmp_path, inputs=True, rpm=700.0)
    rows = [e for e in _events(result.recording) if e[1] == "operator"]
    assert len(rows) == 1, _events(result.recording)
    t_s, _, text = rows[0]
    assert "viewer client" in text and "speed reference 700 rpm" in text, text
    cycle = int(re.search(r"\(cycle (\d+)\)", text).group(1))
    assert t_s == pytest.approx(cycle * result.ts_s, abs=1e-9)   # the row's time is its cycle's
    state = load_recording(result.recording, topics=["/plant/state"]).topic("/plant/state")
    speed = np.asarray(state["speed_rpm"])
    assert speed[-1] > 650.0, speed[-1]   # the drive followed the operator, not the scenario
    report = check_recording(result.recording)
    assert report.results and all(r.verdict == "INVALID" for r in report.results), \
        [(r.verdict, r.note) for r in report.results]
    assert report.integrity.invalid_note == "operator input during the run: see integrity"
    assert any(p.kind == "operator" for p in report.integrity.problems)


def test_an_operator_input_the_scenario_forbids_is_refused_on_events(tmp_path):
    import numpy as np

    from hil_bench.papers.check import check_recording
    from hil_bench.record.recording import load_recording

    result = _operator_run(tmp_path, inputs=False, rpm=700.0)
    events = _events(result.recording)
    assert not [e for e in events if e[1] == "operator"]
    refused = [e for e in events if e[1] == "operator_refused"]
    assert len(refused) == 1 and "[live] inputs = false" in refused[0][2], events
    speed = load_recording(result.recording, topics=["/plant/state"]).topic("/plant/state")["speed_rpm"]
    assert abs(float(np.asarray(speed)[-1]) - 500.0) < 20.0
    report = check_recording(result.recording)
    assert not any(p.kind == "operator" for p in report.integrity.problems)
    assert report.results and not any(r.verdict == "INVALID" for r in report.results)


LOAD_NM = 0.5   #: the operator's load step (G2 runs without load: the scenario has none)


def _load_column(path: Path):
    import numpy as np

    from hil_bench.record.recording import load_recording

    st = load_recording(path, topics=["/plant/state"]).topic("/plant/state")
    return np.asarray(st["t_s"], float), np.asarray(st["torque_load_nm"], float)


def test_an_operator_load_step_is_applied_at_its_cycle_and_recorded(tmp_path):
    """A viewer publishes {"nm": 0.5} on /operator/load: one /events row of kind operator names
    the viewer and the value, its time is its stated cycle's, and the plant's load torque in
    /plant/state is 0 before that cycle and 0.5 N m from that cycle's row on (the engine records
    every cycle in full after an operator input, so the stated cycle has its row)."""
    from hil_bench.papers.check import check_recording

    result = _operator_run(tmp_path, inputs=True, topic="/operator/load",
                           payload={"nm": LOAD_NM})
    rows = [e for e in _events(result.recording) if e[1].startswith("operator")]
    assert len(rows) == 1 and rows[0][1] == "operator", rows
    t_s, _, text = rows[0]
    assert re.search(r"operator \(viewer client \d+, /operator/load\): load torque 0.5 N m", text), text
    cycle = int(re.search(r"\(cycle (\d+)\)", text).group(1))
    assert t_s == pytest.approx(cycle * result.ts_s, abs=1e-9)
    t, load = _load_column(result.recording)
    k = (t / result.ts_s + 0.5).astype(int)   # each row's cycle
    assert cycle in set(k), "the stated cycle has no /plant/state row"
    assert (load[k < cycle] == 0.0).all(), load[k < cycle].max()
    assert (load[k >= cycle] == LOAD_NM).all(), (cycle, load[k >= cycle].min())
    assert (k < cycle).sum() > 10 and (k >= cycle).sum() > 10   # the step is inside the run
    report = check_recording(result.recording)
    assert report.results and all(r.verdict == "INVALID" for r in report.results)


def test_an_operator_load_step_the_scenario_forbids_is_refused_on_events(tmp_path):
    result = _operator_run(tmp_path, inputs=False, topic="/operator/load",
                           payload={"nm": LOAD_NM})
    events = _events(result.recording)
    assert not [e for e in events if e[1] == "operator"]
    refused = [e for e in events if e[1] == "operator_refused"]
    assert len(refused) == 1, events
    assert "load torque 0.5 N m: refused:" in refused[0][2], refused
    assert "[live] inputs = false" in refused[0][2], refused
    _t, load = _load_column(result.recording)
    assert (load == 0.0).all(), load.max()   # the plant never saw it


class Pauser(Operator):
    """Publishes a pause, holds it ``hold_s`` of wall time, then a resume."""

    def __init__(self, port: int, hold_s: float):
        super().__init__(port, 0.0)
        self.hold_s = hold_s

    def run(self) -> None:
        try:
            with _connect(self.port) as ws:
                while True:
                    try:
                        m = ws.recv(timeout=30)
                    except Exception:   # noqa: BLE001 - the run's end
                        break
                    if isinstance(m, str):
                        j = json.loads(m)
                        if j["op"] == "serverInfo":
                            ws.send(json.dumps({"op": "advertise", "channels": [
                                {"id": 1, "topic": "/operator/pause", "encoding": "json",
                                 "schemaName": "hil.OperatorPause"},
                                {"id": 2, "topic": "/operator/resume", "encoding": "json",
                                 "schemaName": "hil.OperatorResume"}]}))
                        elif j["op"] == "advertise":
                            self._subscribe(ws, j["channels"])
                        elif j["op"] == "status":
                            self._status(ws, j)
                    elif m[0] == OP_MESSAGE_DATA:
                        self.messages.append((0, 0, b""))
                        if len(self.messages) >= self.after and not self.published:
                            ws.send(struct.pack("<BI", 1, 1) + b"{}")
                            time.sleep(self.hold_s)
                            ws.send(struct.pack("<BI", 1, 2) + b"{}")
                            self.published = True
        except BaseException as exc:  # noqa: BLE001
            self.error = exc
        finally:
            self.done.set()


def test_a_lockstep_run_paused_and_resumed_by_a_viewer_runs_every_cycle(tmp_path):
    from hil_bench.scenario import derive_scenario

    scn = derive_scenario("gong_g2_500rpm", "gong_g2_500rpm", [("live.inputs", True)])
    runner = Runner(scn, "stub", tmp_path / "p.mcap", False, live=LiveOptions(port=0), pace=1.0)
    viewers = []

    def on_live(port: int) -> None:
        viewers.append(Pauser(port, hold_s=1.0))
        viewers[0].start()

    runner.on_live = on_live
    result = runner.run()
    assert result.ok, result.error
    assert result.cycles_done == result.cycles_planned
    viewers[0].done.wait(30)
    assert viewers[0].error is None and viewers[0].published
    events = _events(result.recording)
    pause = [e for e in events if e[1] == "operator_pause"]
    resume = [e for e in events if e[1] == "operator_resume"]
    assert len(pause) == 1 and len(resume) == 1, events
    k_pause = int(re.search(r"\(cycle (\d+)\)", pause[0][2]).group(1))
    k_resume = int(re.search(r"\(cycle (\d+)\)", resume[0][2]).group(1))
    assert k_pause == k_resume   # nothing ran while paused
    # paced to real time, plus the second it was held
    assert result.engine_s >= 0.99 * (result.cycles_done - 1) * result.ts_s + 0.9, result.engine_s
    assert not [e for e in events if e[1] in ("operator", "operator_refused")]


def test_the_mailbox_and_the_picker_in_c():
    """live.c on its own: the mailbox keeps order and refuses when full; live_pick takes the
    last record of a LIVE_LAST channel, every record of a LIVE_EVERY one, nothing else."""
    import mmap

    from hil_bench.plant_rt._plant_c import ffi, lib

    mem = mmap.mmap(-1, int(lib.live_inbox_size()))
    assert lib.live_inbox_attach(ffi.from_buffer(mem), len(mem)) == ffi.NULL   # not formatted
    assert lib.live_inbox_format(ffi.from_buffer(mem), len(mem)) == 0
    box = lib.live_inbox_attach(ffi.from_buffer(mem), len(mem))
    for i in range(lib.LIVE_INBOX_SLOTS):
        assert lib.live_inbox_push(box, lib.LIVE_IN_LOAD, 7, float(i), b"x" * 500) == 0
    assert lib.live_inbox_push(box, lib.LIVE_IN_LOAD, 7, 99.0, b"full") == -1
    out = ffi.new("live_input_t *")
    for i in range(lib.LIVE_INBOX_SLOTS):
        assert lib.live_inbox_take(box, out) == 1
        assert (out.kind, out.client, out.value) == (lib.LIVE_IN_LOAD, 7, float(i))
        assert ffi.string(out.text) == b"x" * (lib.LIVE_INPUT_TEXT - 1)   # cut, terminated
    assert lib.live_inbox_take(box, out) == 0 and lib.live_inbox_pending(box) == 0

    ring_mem = mmap.mmap(-1, int(lib.rec_ring_mapping_size(1 << 16)))
    lib.rec_ring_format(ffi.from_buffer(ring_mem), len(ring_mem))
    ring = ffi.new("rec_ring_t *")
    lib.rec_ring_attach(ring, ffi.from_buffer(ring_mem), len(ring_mem))
    rows = [(0, 1, b"a0"), (1, 2, b"b0"), (0, 3, b"a1"), (2, 4, b"c0"), (1, 5, b"b1!"),
            (2, 6, b"c1"), (0, 7, b"a2")]
    for chan, t, data in rows:
        assert lib.rec_ring_write(ring, chan, t, data, len(data)) == 0
    buf = bytearray(1 << 16)
    n = lib.rec_ring_read(ring, ffi.from_buffer(buf), len(buf))
    modes = ffi.new("int32_t[]", [lib.LIVE_LAST, lib.LIVE_EVERY, lib.LIVE_SKIP])
    picks = ffi.new("live_pick_t[]", 8)
    cut = ffi.new("uint64_t *")
    got = lib.live_pick(ffi.from_buffer(buf), n, modes, 3, picks, 8, cut)
    seen = [(picks[i].channel, picks[i].t_ns, bytes(buf[picks[i].offset:picks[i].offset + picks[i].length]))
            for i in range(got)]
    assert seen == [(1, 2, b"b0"), (1, 5, b"b1!"), (0, 7, b"a2")]
    assert lib.live_pick(ffi.from_buffer(buf), n, modes, 3, picks, 2, cut) == 2 and cut[0] == 1


def test_bad_live_and_pace_options_are_clear_errors(tmp_path):
    import subprocess
    import sys

    from hil_bench.loop.runner import RunAborted

    scn = load_scenario("gong_g2_500rpm")
    with pytest.raises(RunAborted, match="real-time run is paced by its own clock"):
        Runner(scn, "stub", tmp_path / "x.mcap", False, realtime=True, pace=1.0)
    with pytest.raises(RunAborted, match="the pace is > 0"):
        Runner(scn, "stub", tmp_path / "x.mcap", False, pace=0.0)
    r = subprocess.run([sys.executable, "-m", "hil_bench", "run", "gong_g2_500rpm", "--live",
                        "70000", "--out", str(tmp_path / "x.mcap")],
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 2 and "a TCP port is 0..65535" in r.stderr and "Traceback" not in r.stderr
    assert not list(tmp_path.iterdir())


# -- bench replay --live ---------------------------------------------------------------------------

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "captures" / "example.mcap"


def test_a_viewer_watches_a_replay_into_the_plant_and_its_inputs_are_refused(tmp_path):
    """bench replay --live (into the plant, paced at 0.2 x so it lasts 1.5 s): a viewer connects
    during the replay and is advertised the replay recording's channels with its schemas; a
    /plant/state message decodes with the advertised schema and is the recording's row of that
    time; the load torque it publishes is refused on /events (a replay plays the capture's own
    inputs) and changes nothing (the plant's currents still equal the recorded, bit for bit)."""
    from hil_bench.replay import ReplayOptions, read_capture, run_replay

    viewers = []

    def on_live(port: int) -> None:
        viewers.append(Operator(port, after=3, topic="/operator/load", payload={"nm": 1.0}))
        viewers[0].start()

    cap = read_capture(EXAMPLE)
    res = run_replay(cap, ReplayOptions(mode="plant", out=tmp_path / "replay.mcap", rate=0.2,
                                        live=LiveOptions(port=0), on_live=on_live))
    assert res.ok, res.error
    assert res.cycles == cap.n
    (viewer,) = viewers
    assert viewer.done.wait(30), "the server did not close the connection at the replay's end"
    assert viewer.error is None, repr(viewer.error)
    assert viewer.published, "the replay ended before the viewer saw 3 messages"

    advertised, rows, cls = _advertised_as_recorded(viewer, res.out)
    assert "/replay/plant" in advertised
    state = advertised["/plant/state"]
    got = [(t, p) for cid, t, p in viewer.messages if cid == state["id"]]
    assert len(got) >= 3, len(got)
    for t, payload in got:
        assert rows[("/plant/state", t)] == payload
        assert cls.FromString(payload).ListFields()

    events = _events(res.out)
    refused = [e for e in events if e[1] == "operator_refused"]
    assert len(refused) == 1, events
    assert "load torque 1 N m: refused: a replay plays the capture's own inputs" in refused[0][2]
    assert not [e for e in events if e[1] == "operator"]
    assert all(p["rms_error_a"] == 0.0 for p in res.compare["phases"].values()), res.compare
    assert res.live_stats is not None and res.live_stats["clients_subscribed"] == 1


def test_bench_replay_live_on_the_command_line(tmp_path):
    """The CLI: --live 0 prints where it listens and, after the replay, the viewer's figures; a
    bad port is a one-line error."""
    import subprocess
    import sys

    r = subprocess.run([sys.executable, "-m", "hil_bench", "replay", str(EXAMPLE), "--live", "0",
                        "--out", str(tmp_path / "o.mcap")], capture_output=True, text=True,
                       timeout=300)
    assert r.returncode == 0, r.stderr
    assert "live view: Foxglove WebSocket on ws://127.0.0.1:" in r.stderr, r.stderr
    said = " ".join(r.stderr.split())   # rich may wrap a line
    assert "live view: 0 client(s) connected, 0 subscribed" in said, said
    assert "viewer frames dropped: at least 0" in said, said
    r = subprocess.run([sys.executable, "-m", "hil_bench", "replay", str(EXAMPLE), "--live",
                        "70000", "--out", str(tmp_path / "x.mcap")], capture_output=True,
                       text=True, timeout=120)
    assert r.returncode == 2 and "a TCP port is 0..65535" in r.stderr and "Traceback" not in r.stderr
    assert not (tmp_path / "x.mcap").exists()
