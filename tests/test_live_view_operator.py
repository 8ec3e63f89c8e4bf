"""Operator inputs through the live view (docs/foxglove.md "Operator inputs"): every input a viewer
publishes is recorded on /events, applied or refused, whatever it is and whenever it comes; a
pause has a holder that is still connected.

The clients speak the Foxglove WebSocket protocol by hand (tests/test_live_view.py). Nothing here
waits on a time: each test waits on a condition (a client saw the run, the run ended), bounded
only so that a broken bench fails instead of hanging.
"""
from __future__ import annotations

import json
import re
import struct
import threading
import time
from pathlib import Path

import pytest

from hil_bench.loop.runner import Runner, new_live_inbox
from hil_bench.plant_rt._plant_c import ffi, lib
from hil_bench.record.live_view import OPERATOR_TOPICS, LiveOptions, LiveView, stats_line
from hil_bench.scenario import derive_scenario
from tests.test_live_view import OP_MESSAGE_DATA, Viewer, _connect, _events

#: a run that does not end within this is a bench that hangs (the test fails, it does not wait on)
RUN_BOUND_S = 300.0


class Publisher(Viewer):
    """Advertises every operator topic (client-publish, JSON); subscribes to ``topics``; once it
    has seen ``after`` messages (the run is going) publishes each (topic, payload octets) of
    ``sends`` in order. ``leave``: then closes its connection at once (a viewer that goes away);
    else it reads until the server closes."""

    def __init__(self, port: int, sends: list[tuple[str, bytes]], *, after: int = 5,
                 leave: bool = False, topics: tuple[str, ...] = ("/plant/state",)):
        super().__init__(port, topics)
        self.sends, self.after, self.leave = sends, after, leave
        self.published = threading.Event()
        self.ids = {topic: i + 1 for i, topic in enumerate(OPERATOR_TOPICS)}

    def _publish(self, ws) -> bool:
        """Publish ``sends`` (once); True if the client leaves now."""
        if self.published.is_set():
            return False
        for topic, payload in self.sends:
            ws.send(struct.pack("<BI", 1, self.ids[topic]) + payload)
        self.published.set()
        return self.leave

    def run(self) -> None:
        try:
            with _connect(self.port) as ws:
                while True:
                    try:
                        m = ws.recv(timeout=60)
                    except Exception:   # noqa: BLE001 - closed by the server: the run's end
                        break
                    if isinstance(m, str):
                        j = json.loads(m)
                        if j["op"] == "serverInfo":
                            ws.send(json.dumps({"op": "advertise", "channels": [
                                {"id": i, "topic": t, "encoding": "json", "schemaName": "hil.Op"}
                                for t, i in self.ids.items()]}))
                            if self.after == 0 and self._publish(ws):
                                return
                        elif j["op"] == "advertise":
                            self._subscribe(ws, j["channels"])
                        elif j["op"] == "status":
                            self._status(ws, j)
                    elif m[0] == OP_MESSAGE_DATA:
                        self.messages.append((0, 0, b""))
                        if len(self.messages) >= self.after and self._publish(ws):
                            return   # the with block closes the connection
        except BaseException as exc:  # noqa: BLE001 - the test reports it
            self.error = exc
        finally:
            self.done.set()


def _run_with(tmp_path: Path, make_client, *, inputs: bool = True, pace: float | None = 1.0,
              live: LiveOptions | None = None):
    """G2 (``[live] inputs`` as given) with one client, the run in a thread of its own: a run
    that does not end within RUN_BOUND_S is stopped and the test fails. The run starts once the
    client has subscribed (--live-wait), and lasts 1.5 s of wall time at least (--pace 1): the
    client sees it going however loaded the machine."""
    scn = derive_scenario("gong_g2_500rpm", "gong_g2_500rpm", [("live.inputs", inputs)])
    runner = Runner(scn, "stub", tmp_path / "op.mcap", False,
                    live=live or LiveOptions(port=0, wait_s=RUN_BOUND_S), pace=pace)
    clients = []

    def on_live(port: int) -> None:
        clients.append(make_client(port))
        clients[0].start()

    runner.on_live = on_live
    out = {}
    t = threading.Thread(target=lambda: out.setdefault("result", runner.run()), daemon=True)
    t.start()
    t.join(RUN_BOUND_S)
    if t.is_alive():
        runner.engine.request_stop()
        t.join(60)
        pytest.fail(f"the run did not end within {RUN_BOUND_S:g} s (it stayed paused?)")
    result = out["result"]
    assert result.ok, result.error
    assert result.cycles_done == result.cycles_planned
    assert clients and clients[0].done.wait(60)
    assert clients[0].error is None, repr(clients[0].error)
    assert clients[0].published.is_set(), "the run ended before the client published"
    return result, clients[0]


def _cycle(text: str) -> int:
    return int(re.search(r"\(cycle (\d+)\)", text).group(1))


def test_a_pause_is_released_when_the_viewer_that_holds_it_disconnects(tmp_path, capfd):
    """A viewer pauses the run and goes away without a resume: the run goes on (every cycle
    runs), the resume is on /events saying why, at the cycle of the pause (nothing ran while
    paused), and the bench said so on stderr while it happened."""
    result, _ = _run_with(tmp_path, lambda port: Publisher(
        port, [("/operator/pause", b"{}")], leave=True))
    events = _events(result.recording)
    pause = [e for e in events if e[1] == "operator_pause"]
    resume = [e for e in events if e[1] == "operator_resume"]
    assert len(pause) == 1 and len(resume) == 1, events
    assert "the viewer that paused the run disconnected" in resume[0][2], resume
    assert _cycle(pause[0][2]) == _cycle(resume[0][2])
    assert result.live_stats["pauses_released"] == 1, result.live_stats
    said = " ".join(capfd.readouterr().err.split())
    assert re.search(r"viewer client \d+ paused the run", said), said
    assert re.search(r"viewer client \d+, which paused the run, disconnected: the run goes on",
                     said), said
    assert "pause(s) released because the viewer that held it disconnected" in " ".join(
        stats_line(result.live_stats).split())


#: what viewers sent in the attacks (issue 28), each with the reason its refusal must give
BAD_INPUTS = [
    ("/operator/speed_ref", b"[" * 20000 + b"]" * 20000, "JSON nested too deeply"),
    ("/operator/speed_ref", b'{"rpm": 1e308}', "outside +-"),
    ("/operator/speed_ref", b'{"rpm": true}', "rpm is a JSON bool, not a number"),
    ("/operator/speed_ref", b'{"rpm": "700"}', "rpm is a JSON str, not a number"),
    ("/operator/speed_ref", b'{"rpm": NaN}', "rpm is not a finite number"),
    ("/operator/speed_ref", b'{"rpm": 700, "speed": 1}', "unexpected key(s) speed"),
    ("/operator/speed_ref", b'\xff\xfe', "expected JSON"),
    ("/operator/load", b'{"nm": 1e6}', "the scenario's load limit"),
    ("/operator/load", b'[0.5]', 'expected JSON {"nm": number}'),
]


def test_every_input_is_recorded_and_bad_ones_are_refused_with_the_reason(tmp_path):
    """Deeply nested JSON, a speed of 1e308, true and "700" for a speed, NaN, a stray key, bytes
    that are not UTF-8, a load beyond the scenario's: each is refused on /events with its reason,
    in the order sent; the one good input after them is applied. Nothing of the SDK's log."""
    sends = [(topic, payload) for topic, payload, _ in BAD_INPUTS]
    sends.append(("/operator/speed_ref", b'{"rpm": 600}'))
    result, _ = _run_with(tmp_path, lambda port: Publisher(port, sends))
    rows = [e for e in _events(result.recording) if e[1].startswith("operator")]
    assert len(rows) == len(sends), rows
    for (topic, _payload, why), (_t, kind, text) in zip(BAD_INPUTS, rows):
        assert kind == "operator_refused", (why, text)
        assert topic in text and why in text, (why, text)
        text.encode("utf-8")   # a protobuf string: valid UTF-8 (it was read back)
    assert rows[-1][1] == "operator" and "speed reference 600 rpm" in rows[-1][2], rows[-1]
    # the limits are the scenario's: 1e308 rpm is refused naming TELEM.omega_hat's range
    assert "TELEM.omega_hat" in rows[1][2], rows[1]
    stats = result.live_stats
    assert stats["operator_inputs"] == len(sends) and stats["operator_inputs_lost"] == 0, stats


def _wait_for(cond, what: str, bound_s: float = 60.0) -> None:
    end = time.monotonic() + bound_s
    while not cond():
        if time.monotonic() > end:
            pytest.fail(f"{what}: not within {bound_s:g} s")
        time.sleep(0.01)


def test_inputs_a_full_mailbox_refuses_are_recorded_counted_and_printed():
    """No engine takes the mailbox: of 100 inputs it holds 64; the other 36 are refused and
    counted, and go to the engine as one summary row (value 36) as soon as there is room; what
    is still in the mailbox when the run has ended comes back for the recorder to write, each
    refused; the line after the run says it all. (In a process of its own: foxglove-sdk's Rust
    threads must never run in a process that later forks a recorder.)"""
    import multiprocessing as mp
    from concurrent.futures import ProcessPoolExecutor

    with ProcessPoolExecutor(1, mp_context=mp.get_context("spawn")) as pool:
        pool.submit(_full_mailbox).result(timeout=RUN_BOUND_S)


def _full_mailbox() -> None:
    mem = new_live_inbox()
    view = LiveView(LiveOptions(port=0), "test", inbox_mem=mem, inputs_allowed=True)
    box = lib.live_inbox_attach(ffi.from_buffer(mem), len(mem))
    client = Publisher(view.port, [("/operator/speed_ref", b'{"rpm": 100}')] * 100, after=0)
    try:
        client.start()
        # no channel to subscribe to: the client publishes once the server greeted it
        _wait_for(lambda: view.inputs_received == 100, "100 inputs received")
        assert view.inputs_lost == 36 and lib.live_inbox_pending(box) == lib.LIVE_INBOX_SLOTS
        out = ffi.new("live_input_t *")
        for _ in range(lib.LIVE_INBOX_SLOTS):   # the engine's side: take them all
            assert lib.live_inbox_take(box, out) == 1 and out.kind == lib.LIVE_IN_SPEED_REF
        (who, chan), = [k for k, t in view._client_channels.items()
                        if t == "/operator/speed_ref"]
        view._operator_input(who, chan, b'{"rpm": 100}')   # the next input: the summary first
        assert lib.live_inbox_take(box, out) == 1 and out.kind == lib.LIVE_IN_REFUSED
        assert out.value == 36.0
        assert b"36 input(s) refused: the mailbox was full" in ffi.string(out.text)
        rows = view.end_inputs()   # the run has ended: the input after the summary is left
        assert len(rows) == 1 and rows[0][0] == "operator_refused", rows
        assert "refused: the run had ended" in rows[0][1], rows
        view._operator_input(who, chan, b'{"rpm": 100}')   # and one that comes after the end
        late = view.end_inputs()
        assert len(late) == 1 and "refused: the run had ended" in late[0][1], late
        stats = view.stats()
        assert stats["operator_inputs_lost"] == 36 and stats["operator_inputs_after_end"] == 2
        line = " ".join(stats_line(stats).split())
        assert "operator inputs: 102 received" in line, line
        assert "36 refused because the engine's mailbox was full" in line, line
        assert "2 after the run's last cycle" in line, line
    finally:
        view.stop()
        client.done.wait(30)


def test_inputs_left_in_the_mailbox_at_the_end_are_written_by_the_recorder(tmp_path):
    """Inputs a viewer publishes that the engine never takes (here no engine runs at all) are in
    the recording all the same: the recorder writes each as a refused /events row when it
    closes, at the time of the recording's last message."""
    from hil_bench.record.recorder import ProcessRecorder
    from hil_bench.record import channels as ch

    mem = new_live_inbox()
    box = lib.live_inbox_attach(ffi.from_buffer(mem), len(mem))
    out = tmp_path / "left.mcap"
    rec = ProcessRecorder(out, live=LiveOptions(port=0, inputs=True), live_inbox=mem)
    client = None
    try:
        events = rec.channel(ch.EVENTS)
        events.write_values(0.25, (0.25, "scenario", "before the inputs", 0.0))
        client = Publisher(rec.live_port, [("/operator/load", b'{"nm": 0.5}'),
                                           ("/operator/speed_ref", b'{"rpm": "x"}'),
                                           ("/operator/pause", b"{}")], after=0)
        client.start()
        _wait_for(lambda: lib.live_inbox_pending(box) == 3, "3 inputs in the mailbox")
    finally:
        rec.close()
        if client is not None:
            client.done.wait(30)
    rows = _events(rec.final_path)
    assert rec.final_path == out and len(rows) == 4, rows
    left = rows[1:]
    assert all(kind == "operator_refused" and t == 0.25 for t, kind, _ in left), left
    assert "load torque 0.5 N m: refused: the run had ended" in left[0][2], left
    assert "speed_ref" in left[1][2] and "not a number" in left[1][2], left
    assert "pause: refused: the run had ended" in left[2][2], left
    assert rec.live_stats["operator_inputs_after_end"] == 2, rec.live_stats
