"""The live view and the people and programs at the other end of its port (docs/foxglove.md):
a connection that never speaks does not cost the recording, the clients are counted as what they
are, a run can wait for its viewer, listen beyond loopback with a warning, and a late viewer gets
the run's /events rows.

Nothing here waits on a time: each test waits on a condition, bounded only so that a broken bench
fails instead of hanging.
"""
from __future__ import annotations

import re
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from hil_bench.loop.runner import Runner
from hil_bench.record.live_view import (EVENTS_HISTORY, LiveOptions, is_loopback, stats_line,
                                        ws_url)
from hil_bench.record.recorder import partial_path
from hil_bench.scenario import load_scenario
from tests.test_live_view import Viewer, _connect, _recording

REPO = Path(__file__).resolve().parents[1]


def _plant_rows(path: Path) -> int:
    _chans, rows = _recording(path)
    return sum(1 for topic, _t in rows if topic == "/plant/state")


def test_an_idle_connection_held_by_the_bench_process_does_not_cost_the_recording(tmp_path):
    """A TCP connection to the --live port that never speaks (no WebSocket handshake), held by
    the process that runs the bench until after the run: foxglove-sdk's stop would wait for it
    for ever. The recording is complete all the same, every time (three runs here; the tool
    tools/live_view_idle.py does ten from the command line)."""
    scn = load_scenario("gong_g2_500rpm")
    every = scn.recording.decimate
    for i in range(3):
        out = tmp_path / f"idle{i}.mcap"
        runner = Runner(scn, "stub", out, False, live=LiveOptions(port=0))
        held: list[socket.socket] = []
        runner.on_live = lambda port: held.append(socket.create_connection(("127.0.0.1", port)))
        try:
            result = runner.run()
        finally:
            for s in held:
                s.close()
        assert held, "the live view never listened"
        # what this is about: the recording, whole (a run that ends early for another reason,
        # the lockstep wait on a loaded machine, still leaves it whole)
        assert "recorder" not in (result.error or ""), result.error
        assert result.recording == out and out.exists() and not partial_path(out).exists()
        assert result.cycles_done > 0 and _plant_rows(out) >= result.cycles_done // every


def test_bench_run_with_an_idle_connection_held_by_its_parent(tmp_path):
    """The same from the command line: the parent (a CI harness, here the test) connects to the
    port the bench prints and holds the connection until the bench has exited."""
    out = tmp_path / "cli.mcap"
    proc = subprocess.Popen([sys.executable, "-m", "hil_bench", "run", "gong_g2_500rpm",
                             "--live", "0", "--no-progress", "--out", str(out)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    held = None
    lines = []
    try:
        for line in proc.stderr:
            lines.append(line)
            m = re.search(r"ws://127\.0\.0\.1:(\d+)", line)
            if m:
                held = socket.create_connection(("127.0.0.1", int(m.group(1))))
                break
        err = "".join(lines) + proc.stderr.read()
        proc.wait(timeout=600)
    finally:
        if held is not None:
            held.close()
        if proc.poll() is None:
            proc.kill()
    assert held is not None, err
    assert "recorder" not in err and "Traceback" not in err, err
    assert out.exists() and not partial_path(out).exists(), err
    from hil_bench.record.recording import load_recording

    done = int(load_recording(out, topics=["/events"]).metadata["run_result"]["cycles_done"])
    every = load_scenario("gong_g2_500rpm").recording.decimate
    assert done > 0 and _plant_rows(out) >= done // every, err
    assert proc.returncode == 0 or "run ended early" in err, err


class Idle(threading.Thread):
    """A WebSocket client that completes the handshake, reads what the server sends until its
    channels are advertised, and then holds the connection without subscribing."""

    def __init__(self, port: int):
        super().__init__(daemon=True)
        self.port = port
        self.registered = threading.Event()
        self.release = threading.Event()
        self.error: BaseException | None = None

    def run(self) -> None:
        import json

        try:
            with _connect(self.port) as ws:
                while not self.registered.is_set():
                    j = json.loads(ws.recv(timeout=60))
                    if j.get("op") == "advertise":   # sent after the server registered us
                        self.registered.set()
                self.release.wait(600)
        except BaseException as exc:  # noqa: BLE001
            self.error = exc
            self.registered.set()


def test_live_wait_starts_the_run_at_the_first_subscriber_and_clients_are_counted(tmp_path):
    """--live-wait: three clients that connect and never subscribe do not start the run; the
    one that subscribes does. After the run: 4 clients connected, 1 subscribed (it was "0
    client(s)" for 50 connected clients that did not subscribe), on the line and in the file."""
    scn = load_scenario("gong_g2_500rpm")
    out = tmp_path / "wait.mcap"
    runner = Runner(scn, "stub", out, False, live=LiveOptions(port=0, wait_s=600.0))
    idle: list[Idle] = []
    viewers: list[Viewer] = []

    def on_live(port: int) -> None:
        def clients() -> None:
            for _ in range(3):
                idle.append(Idle(port))
                idle[-1].start()
            for c in idle:
                c.registered.wait(120)
            viewers.append(Viewer(port, ("/plant/state",)))
            viewers[0].start()
        threading.Thread(target=clients, daemon=True).start()

    runner.on_live = on_live
    try:
        result = runner.run()
    finally:
        for c in idle:
            c.release.set()
    assert result.ok, result.error
    assert result.cycles_done == result.cycles_planned
    assert all(c.error is None for c in idle), [c.error for c in idle]
    assert viewers and viewers[0].done.wait(60) and viewers[0].error is None
    stats = result.live_stats
    assert stats["clients_connected"] == 4 and stats["clients_subscribed"] == 1, stats
    line = " ".join(stats_line(stats).split())
    assert "live view: 4 client(s) connected, 1 subscribed" in line, line
    from tests.test_live_view import _live_metadata

    assert _live_metadata(result.recording) == stats


def test_live_wait_without_a_viewer_is_an_error_naming_the_port(tmp_path):
    scn = load_scenario("gong_g2_500rpm")
    runner = Runner(scn, "stub", tmp_path / "nobody.mcap", False,
                    live=LiveOptions(port=0, wait_s=0.5))
    result = runner.run()
    assert result.cycles_done == 0 and not result.ok
    port = runner.live_port
    assert f"--live-wait 0.5: no viewer subscribed to ws://127.0.0.1:{port} within 0.5 s; the " \
           f"run did not start" in result.error, result.error


def _bench(*args: str, timeout: float = 600) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "hil_bench", *args], capture_output=True,
                          text=True, timeout=timeout)


def test_live_wait_and_host_on_the_command_line(tmp_path):
    """--live-wait with nobody coming: exit 1, one line naming the port; bad values of
    --live-wait and --live-host: exit 2, one line, nothing written."""
    r = _bench("run", "gong_g2_500rpm", "--live", "0", "--live-wait", "0.5", "--no-progress",
               "--out", str(tmp_path / "w.mcap"))
    said = " ".join(r.stderr.split())
    assert r.returncode == 1, said
    assert re.search(r"waiting up to 0.5 s for a viewer to subscribe on ws://127.0.0.1:\d+", said)
    assert re.search(r"--live-wait 0.5: no viewer subscribed to ws://127.0.0.1:(\d+) within 0.5 s",
                     said), said
    assert "Traceback" not in said
    for bad, why in ((["--live-wait", "0"], "--live-wait 0: the time to wait for a viewer"),
                     (["--live-wait", "nan"], "--live-wait nan: the time to wait"),
                     (["--live-host", ""], "--live-host '': give an address to listen on"),
                     (["--live", "0", "--live-host", "no.such.host.invalid"],
                      "live view: cannot listen on no.such.host.invalid:0")):
        d = tmp_path / f"bad{len(list(tmp_path.iterdir()))}"
        d.mkdir()
        r = _bench("run", "gong_g2_500rpm", *bad, "--no-progress", "--out", str(d / "x.mcap"))
        said = " ".join(r.stderr.split())
        assert r.returncode == 2 and why in said and "Traceback" not in said, (bad, said)
        assert not list(d.iterdir()), bad


def test_live_host_beyond_loopback_is_said_and_served(tmp_path):
    """--live-host 0.0.0.0 listens on every interface with a warning; a viewer on 127.0.0.1
    reaches it. Loopback is told apart by address, not by name."""
    assert is_loopback("127.0.0.1") and is_loopback("::1") and is_loopback("localhost")
    assert not is_loopback("0.0.0.0") and not is_loopback("::")
    assert not is_loopback("no.such.host.invalid")
    assert ws_url("::1", 8765) == "ws://[::1]:8765"
    proc = subprocess.Popen([sys.executable, "-m", "hil_bench", "run", "gong_g2_500rpm",
                             "--live", "0", "--live-host", "0.0.0.0", "--live-wait", "600",
                             "--no-progress", "--out", str(tmp_path / "h.mcap")],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    viewer = None
    lines = []
    try:
        for line in proc.stderr:
            lines.append(line)
            m = re.search(r"ws://0\.0\.0\.0:(\d+)", line)
            if m:
                viewer = Viewer(int(m.group(1)), ("/plant/state",))   # on 127.0.0.1
                viewer.start()
                break
        err = " ".join(("".join(lines) + proc.stderr.read()).split())
        proc.wait(timeout=600)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert viewer is not None, err
    assert proc.returncode == 0, err
    assert "warning: live view: --live-host 0.0.0.0 is not a loopback address" in err, err
    assert viewer.done.wait(60) and viewer.error is None and viewer.messages, repr(viewer.error)


class LateViewer(Viewer):
    """Subscribes to /events/history and /events (in the order of ``topics``) and keeps what
    came on each; ``history`` is set once it has got ``want`` rows on /events/history."""

    def __init__(self, port: int, topics: tuple[str, ...], want: int):
        super().__init__(port, topics)
        self.want = want
        self.history = threading.Event()

    def _subscribe(self, ws, channels) -> None:
        import json

        subs = []
        for topic in self.topics:   # in this order, in one subscribe message
            for c in channels:
                if c["topic"] == topic:
                    sid = len(self.subscribed) + 1
                    self.subscribed[sid] = c["id"]
                    subs.append({"id": sid, "channelId": c["id"]})
        if subs:
            ws.send(json.dumps({"op": "subscribe", "subscriptions": subs}))

    def topic_of(self, cid: int) -> str:
        return self.advertised[cid]["topic"]

    def rows(self, topic: str) -> set[tuple[int, bytes]]:
        return {(t, p) for cid, t, p in list(self.messages) if self.topic_of(cid) == topic}

    def run(self) -> None:
        watcher = threading.Thread(target=self._watch, daemon=True)
        watcher.start()
        super().run()

    def _watch(self) -> None:
        while not self.done.is_set():
            if len(self.rows(EVENTS_HISTORY)) >= self.want:
                self.history.set()
                return
            time.sleep(0.005)


class Conductor(Viewer):
    """Subscribes to /events; once it has got ``rows`` of them, pauses the run, starts
    ``then()`` (a late viewer), waits until ``ready`` is set, and resumes the run."""

    def __init__(self, port: int, rows: int, then, ready: threading.Event):
        super().__init__(port, ("/events",))
        self.rows_before, self.then, self.ready = rows, then, ready
        self.resumed = threading.Event()

    def run(self) -> None:
        import json
        import struct

        from tests.test_live_view import OP_MESSAGE_DATA

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
                                {"id": 1, "topic": "/operator/pause", "encoding": "json",
                                 "schemaName": "hil.Op"},
                                {"id": 2, "topic": "/operator/resume", "encoding": "json",
                                 "schemaName": "hil.Op"}]}))
                        elif j["op"] == "advertise":
                            for c in j["channels"]:
                                self.advertised[c["id"]] = c
                            self._subscribe(ws, j["channels"])
                        elif j["op"] == "status":
                            self._status(ws, j)
                    elif m[0] == OP_MESSAGE_DATA:
                        sid, t_ns = struct.unpack_from("<IQ", m, 1)
                        self.messages.append((self.subscribed[sid], t_ns, bytes(m[13:])))
                        if len(self.messages) == self.rows_before and not self.resumed.is_set():
                            ws.send(struct.pack("<BI", 1, 1) + b"{}")      # pause
                            self.then()
                            self.ready.wait(300)
                            ws.send(struct.pack("<BI", 1, 2) + b"{}")      # resume
                            self.resumed.set()
        except BaseException as exc:  # noqa: BLE001
            self.error = exc
        finally:
            self.done.set()


@pytest.mark.parametrize("order", [("/events", EVENTS_HISTORY), (EVENTS_HISTORY, "/events")])
def test_a_late_viewer_gets_every_events_row_of_the_run(tmp_path, order):
    """A viewer that joins after the run has written /events rows gets each of them on
    /events/history, and the rows after on /events: whatever the order of its subscriptions, no
    row of the recording up to the last one it got is missing. (A first viewer starts the run,
    --live-wait, and holds it paused while the late one joins: nothing depends on how fast the
    machine is.)"""
    from hil_bench.scenario import derive_scenario

    scn = derive_scenario("gong_g2_500rpm", "gong_g2_500rpm", [("live.inputs", True)])
    out = tmp_path / "late.mcap"
    runner = Runner(scn, "stub", out, False, live=LiveOptions(port=0, wait_s=600.0), pace=1.0)
    first: list[Conductor] = []
    late: list[LateViewer] = []
    ready = threading.Event()

    def on_live(port: int) -> None:
        def join_late() -> None:
            late.append(LateViewer(port, order, want=2))
            late[0].start()
            threading.Thread(target=lambda: (late[0].history.wait(300), ready.set()),
                             daemon=True).start()

        first.append(Conductor(port, 2, join_late, ready))   # starts the run (--live-wait)
        first[0].start()

    runner.on_live = on_live
    result = runner.run()
    assert result.ok, result.error
    assert first and first[0].done.wait(60) and first[0].error is None, repr(first[0].error)
    assert first[0].resumed.is_set() and late, "the first viewer never held the run"
    assert late[0].done.wait(60) and late[0].error is None, repr(late[0].error)
    seen_first = {(t, p) for _c, t, p in first[0].messages[:2]}
    history, live = late[0].rows(EVENTS_HISTORY), late[0].rows("/events")
    assert seen_first <= history, "rows written before the viewer joined are not in its history"
    recorded = _events_rows(result.recording)
    got = history | live
    assert got <= recorded
    last = max(t for t, _ in got)
    missing = {(t, p) for t, p in recorded if t <= last} - got
    assert not missing, sorted(t for t, _ in missing)
    assert live, "the late viewer got nothing on /events after it joined"
    assert result.live_stats["events_history_rows"] == len(recorded)


def _events_rows(path: Path) -> set[tuple[int, bytes]]:
    """The recording's /events messages as (log time, payload) (several share a time)."""
    from mcap.reader import make_reader

    with open(path, "rb") as f:
        return {(m.log_time, m.data) for _s, _c, m in make_reader(f).iter_messages(
            topics=["/events"])}


def test_foxglove_sdk_is_the_pinned_range_and_its_log_lines_are_read():
    """The live view reads two figures from foxglove-sdk's log (its Python API has none): the
    installed SDK must be in the range pyproject.toml pins (the range these tests run against),
    and the lines must be what the SDK writes (send_lossy.rs, server.rs)."""
    import importlib.metadata
    import logging
    import tomllib

    from packaging.requirements import Requirement

    from hil_bench.record.live_view import _SdkLog

    deps = tomllib.loads((REPO / "pyproject.toml").read_text())["project"][
        "optional-dependencies"]["live"]                   # the [live] extra
    req = next(Requirement(d) for d in deps if d.startswith("foxglove-sdk"))
    assert req.specifier and any(s.operator == "<" for s in req.specifier), req
    assert importlib.metadata.version("foxglove-sdk") in req.specifier, req
    h = _SdkLog()
    for text in ("Registered client 127.0.0.1:5000", "outbox for client 127.0.0.1:5000 full",
                 "Unregistered client 127.0.0.1:5000", "Registered client 127.0.0.1:5001"):
        h.emit(logging.LogRecord("foxglove", logging.INFO, "", 0, text, None, None))
    assert (h.connected, h.reports, h.clients) == (2, 1, ["127.0.0.1:5000"])


def test_perf_live_says_what_is_missing_or_wrong(tmp_path):
    """python -m hil_bench.perf.live: without websockets (the viewer's package) one line naming
    it, exit 2; bad options exit 2 with argparse's line; never a bare AssertionError."""
    shim = tmp_path / "shim" / "websockets"
    shim.mkdir(parents=True)
    (shim / "__init__.py").write_text("raise ImportError('No module named websockets')\n")
    import os

    env = dict(os.environ, PYTHONPATH=str(tmp_path / "shim"))
    r = subprocess.run([sys.executable, "-m", "hil_bench.perf.live", "--repeats", "1"],
                       capture_output=True, text=True, env=env, timeout=600, cwd=tmp_path)
    assert r.returncode == 2, r.stderr
    assert "perf.live: needs websockets" in r.stderr and "Traceback" not in r.stderr, r.stderr
    for bad, why in ((["--repeats", "0"], "--repeats 0: at least 1 run each way"),
                     (["--rate", "0"], "--rate 0: the viewer rate"),
                     (["--link", "nosuch"], "invalid choice: 'nosuch'")):
        r = subprocess.run([sys.executable, "-m", "hil_bench.perf.live", *bad],
                           capture_output=True, text=True, timeout=120)
        assert r.returncode == 2 and why in r.stderr and "Traceback" not in r.stderr, r.stderr


def test_perf_live_measures(tmp_path):
    """One repeat each way: it runs and ends with its JSON figures (no figure is judged here:
    docs/performance.md has them)."""
    import json

    r = subprocess.run([sys.executable, "-m", "hil_bench.perf.live", "--repeats", "1"],
                       capture_output=True, text=True, timeout=900, cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    fig = json.loads(r.stdout.strip().splitlines()[-1])
    assert fig["repeats"] == 1 and fig["viewer_messages_median"] > 0, fig
