"""The live view: a Foxglove WebSocket server in the recorder process (docs/foxglove.md).

``bench run --live [PORT]`` serves every channel of the recording, with the schemas the
recording has (protobuf, :mod:`.channels`), to Foxglove or Lichtblick while the run goes on. It
is fed from the recorder's side of the shared-memory ring: each batch the recorder drains for
the MCAP file is offered to :meth:`LiveView.feed`, which picks in C (``live_pick``, live.h) the
records a viewer asked for and hands them to foxglove-sdk's server. So

* the engine never waits for a viewer: it writes into the ring as ever, and the recorder never
  blocks on a socket (foxglove-sdk queues each client's messages in Rust, at most
  ``backlog`` of them, and drops the oldest of a client that does not read: it does not say how
  many, only logs "outbox for client ADDR full", at most once per 30 s; :meth:`LiveView.stats`
  counts those reports, what the bench sent and what it cut itself);
* the per-cycle channels reach a viewer decimated to ``rate_hz`` per channel (the newest record
  of a batch, at most once per 1/rate_hz of wall time): a 10 kHz run does not flood a browser.
  /events, /faults and /link/stats go out whole (a few rows per second);
* with no client subscribed the live view costs the recorder one attribute test per batch.

foxglove-sdk starts Rust threads, so the server is started in the recorder process, after the
fork, never in the bench's.
"""
from __future__ import annotations

import logging
import os
import re
import threading
import time
from dataclasses import dataclass

from hil_bench.plant_rt._plant_c import ffi, lib

from . import channels as chans

DEFAULT_PORT = 8765
DEFAULT_RATE_HZ = 50.0
DEFAULT_BACKLOG = 256
#: topics every row of which goes to the viewer (rare rows that mean something one by one)
EVERY_ROW_TOPICS = (chans.EVENTS, chans.FAULTS, chans.LINK_STATS)
#: picks per batch at most (a batch beyond it: the picks cut are counted, never an error)
PICKS_PER_BATCH = 4096


@dataclass(frozen=True)
class LiveOptions:
    """``bench run --live``: where the server listens and how much it sends."""

    port: int = DEFAULT_PORT          # 0: any free port (the recorder says which)
    host: str = "127.0.0.1"
    rate_hz: float = DEFAULT_RATE_HZ  # per channel, for the per-cycle channels
    backlog: int = DEFAULT_BACKLOG    # messages queued per client before the oldest is dropped
    #: the recorder stays below every other task (SCHED_BATCH, nice 19) as without a viewer; a
    #: run paced for watching (--pace) sets it False: the rows reach the viewer while new on a
    #: loaded machine too
    background: bool = True
    #: the scenario's [live] inputs: a viewer's operator inputs are applied (else refused)
    inputs: bool = False
    #: why an operator input is refused when ``inputs`` is False (the /events row says it)
    refused_why: str = "the scenario does not allow operator inputs ([live] inputs = false)"

    def __post_init__(self) -> None:
        if not 0 <= int(self.port) <= 65535:
            raise ValueError(f"--live {self.port}: a TCP port is 0..65535")
        if not self.rate_hz > 0:
            raise ValueError(f"--live-rate {self.rate_hz:g}: the viewer rate is > 0 Hz")


class LiveViewError(RuntimeError):
    """The live view could not start (the port is taken, foxglove-sdk missing)."""


#: what a viewer may publish (client-publish, JSON): topic -> (live.h kind, JSON key, what)
OPERATOR_TOPICS = {
    "/operator/speed_ref": ("LIVE_IN_SPEED_REF", "rpm", "speed reference"),
    "/operator/load": ("LIVE_IN_LOAD", "nm", "load torque"),
    "/operator/pause": ("LIVE_IN_PAUSE", None, "pause"),
    "/operator/resume": ("LIVE_IN_RESUME", None, "resume"),
}
RAD_S_PER_RPM = 2.0 * 3.141592653589793 / 60.0
#: what foxglove-sdk logs (logger foxglove.websocket.connected_client.send_lossy, INFO) when it
#: drops a client's oldest queued frames (send_lossy.rs; throttled to one line per 30 s per
#: process, whatever the client)
SDK_DROP_MESSAGE = re.compile(r"outbox for client (\S+) full")


class _SdkDropReports(logging.Handler):
    """Counts foxglove-sdk's "outbox for client ADDR full" log lines (its only word on the frames
    it dropped for a client that does not read) and keeps the clients they name."""

    def __init__(self) -> None:
        super().__init__(logging.INFO)
        self.reports = 0
        self.clients: list[str] = []

    def emit(self, record: logging.LogRecord) -> None:
        m = SDK_DROP_MESSAGE.search(record.getMessage())
        if m is None:
            return
        self.reports += 1
        if m.group(1) not in self.clients:
            self.clients.append(m.group(1))


def _listen_to_sdk_log(fox) -> _SdkDropReports:
    """Route foxglove-sdk's Rust log (INFO) into Python logging, to a handler of ours only (the
    "foxglove" logger does not propagate: nothing is printed). FOXGLOVE_LOG_LEVEL above INFO
    silences the reports: the figure then says so (``sdk_log``)."""
    handler = _SdkDropReports()
    log = logging.getLogger("foxglove")
    log.setLevel(logging.INFO)
    log.propagate = False
    log.addHandler(handler)
    try:
        fox.set_log_level("INFO")
    except Exception:  # noqa: BLE001 - an sdk without the bridge: the reports stay 0 (said so)
        handler.reports = -1
    return handler


class _Listener:
    """Counts each channel's subscribers and takes what viewers publish (foxglove-sdk calls it
    on its own threads)."""

    def __init__(self, view: "LiveView") -> None:
        self.view = view

    def on_subscribe(self, client, channel) -> None:
        self.view.clients_seen.add(client.id)
        self.view._subscribed(channel.topic, +1)

    def on_unsubscribe(self, client, channel) -> None:
        self.view._subscribed(channel.topic, -1)

    def on_client_advertise(self, client, channel) -> None:
        with self.view._lock:
            self.view._client_channels[(client.id, channel.id)] = channel.topic

    def on_client_unadvertise(self, client, client_channel_id) -> None:
        with self.view._lock:
            self.view._client_channels.pop((client.id, client_channel_id), None)

    def on_message_data(self, client, client_channel_id, data) -> None:
        self.view._operator_input(client.id, client_channel_id, bytes(data))


class LiveView:
    """The server and its channels, one per ring channel (raw serial captures: none)."""

    def __init__(self, opts: LiveOptions, name: str, inbox_mem=None,
                 inputs_allowed: bool = False) -> None:
        """``inbox_mem``: the engine's operator-input mailbox (live.h; None: no inputs are
        served); ``inputs_allowed``: the scenario's ``[live] inputs`` (otherwise every input is
        refused, with an /events row saying why)."""
        try:
            import foxglove
            from foxglove.websocket import Capability  # noqa: F401 - present in the sdk we need
        except ImportError as exc:
            raise LiveViewError(f"live view: foxglove-sdk is not installed ({exc}); "
                                f"`pip install foxglove-sdk`") from None
        self._fox = foxglove
        self._sdk_drops = _listen_to_sdk_log(foxglove)   # before the server: the sdk's rule
        self.opts = opts
        self._lock = threading.Lock()
        self._subs: dict[str, int] = {}
        self._client_channels: dict[tuple[int, int], str] = {}
        self._inbox = None
        self.inputs_allowed = bool(inputs_allowed)
        capabilities = []
        if inbox_mem is not None:
            self._inbox = lib.live_inbox_attach(ffi.from_buffer(inbox_mem), len(inbox_mem))
            if self._inbox == ffi.NULL:
                raise LiveViewError("live view: the operator inputs' mailbox is not formatted")
            self._inbox_mem = inbox_mem
            capabilities = [foxglove.websocket.Capability.ClientPublish]
        self.context = foxglove.Context()   # this server's channels only (no global sink)
        try:
            self.server = foxglove.start_server(
                name=name, host=opts.host, port=int(opts.port), context=self.context,
                server_listener=_Listener(self), capabilities=capabilities,
                supported_encodings=[chans.MESSAGE_ENCODING, "json"],
                message_backlog_size=int(opts.backlog))
        except Exception as exc:  # noqa: BLE001 - the sdk's error type is not public
            raise LiveViewError(f"live view: cannot listen on {opts.host}:{opts.port}: "
                                f"{exc}") from None
        self.port = int(self.server.port)
        self.channels: list = []   # ring channel -> foxglove.Channel | None
        self.topics: list[str | None] = []
        self.every: list[bool] = []
        self._modes = ffi.new("int32_t[]", lib.LIVE_PICK_MAX_CHANNELS)   # all LIVE_SKIP
        self._due_ns = 0
        self._dirty = False
        self._last_channels: list[int] = []
        self._any_every = False
        self._period_ns = int(round(1e9 / opts.rate_hz))
        self._picks = ffi.new("live_pick_t[]", PICKS_PER_BATCH)
        self._cut = ffi.new("uint64_t *")
        self._any = False
        #: what the viewer was sent (each message once, whatever the number of clients), the
        #: messages times the clients subscribed to their channel, and the records it was not
        #: (picks beyond a batch's cap: :attr:`cut`)
        self.forwarded = 0
        self.client_frames = 0
        self.clients_seen: set[int] = set()
        #: operator inputs the full mailbox could not take
        self.inputs_lost = 0

    @property
    def cut(self) -> int:
        return int(self._cut[0])

    def _subscribed(self, topic: str, delta: int) -> None:
        with self._lock:
            self._subs[topic] = max(0, self._subs.get(topic, 0) + delta)
            self._any = any(self._subs.values())
            self._dirty = True

    def _set_modes(self) -> None:
        """The pick modes of the subscribed channels (after a subscription changed)."""
        with self._lock:
            subs = dict(self._subs)
            self._dirty = False
        self._last_channels = []
        self._any_every = False
        for c in range(min(len(self.topics), lib.LIVE_PICK_MAX_CHANNELS)):
            topic = self.topics[c]
            if topic is None or not subs.get(topic):
                self._modes[c] = lib.LIVE_SKIP
            elif self.every[c]:
                self._modes[c] = lib.LIVE_EVERY
                self._any_every = True
            else:
                self._last_channels.append(c)
                self._modes[c] = lib.LIVE_SKIP   # LIVE_LAST only in a batch where they are due

    def add_channel(self, topic: str, schema_name: str, schema_data: bytes) -> None:
        """The next ring channel (in the recorder's order), advertised to every client."""
        fox = self._fox
        schema = fox.Schema(name=schema_name, encoding=chans.MESSAGE_ENCODING, data=schema_data)
        self.channels.append(fox.Channel(topic, schema=schema,
                                         message_encoding=chans.MESSAGE_ENCODING,
                                         context=self.context))
        self.topics.append(topic)
        self.every.append(topic in EVERY_ROW_TOPICS)
        self._dirty = True

    def add_raw(self) -> None:
        """A ring channel the viewer never sees (a serial byte capture)."""
        self.channels.append(None)
        self.topics.append(None)
        self.every.append(False)

    def feed(self, cbuf, buf, n: int, start_ns: int) -> None:
        """Forward what the clients subscribed to out of one drained batch (``cbuf``/``buf``:
        the recorder's read buffer, ``n`` octets of ring records). Most batches cost a clock
        read: the per-cycle channels are picked only once per 1/rate_hz, all at once."""
        if not self._any:
            return
        if self._dirty:
            self._set_modes()
        now = time.monotonic_ns()
        due = now >= self._due_ns and bool(self._last_channels)
        if not (due or self._any_every):
            return
        modes = self._modes
        if due:
            for c in self._last_channels:
                modes[c] = lib.LIVE_LAST
        picked = lib.live_pick(cbuf, n, modes, len(self.topics), self._picks, PICKS_PER_BATCH,
                               self._cut)
        if due:
            for c in self._last_channels:
                modes[c] = lib.LIVE_SKIP
            self._due_ns = now + self._period_ns
        view = memoryview(buf)
        subs = self._subs
        for i in range(picked):
            p = self._picks[i]
            self.channels[p.channel].log(bytes(view[p.offset:p.offset + p.length]),
                                         log_time=start_ns + p.t_ns)
            self.client_frames += subs.get(self.topics[p.channel], 0)
        self.forwarded += picked

    def _operator_input(self, client_id: int, client_channel_id: int, data: bytes) -> None:
        """One message a viewer published: into the engine's mailbox, applied at the start of
        the engine's next cycle and recorded on /events with the client's id, or refused there
        (the engine writes the row, at the cycle it took it). Never raises into the sdk."""
        import json

        with self._lock:
            topic = self._client_channels.get((client_id, client_channel_id), "?")
        who = f"operator (viewer client {client_id}, {topic})"
        spec = OPERATOR_TOPICS.get(topic)
        kind, value, why = lib.LIVE_IN_REFUSED, 0.0, None
        if spec is None:
            why = f"not an operator topic (one of {', '.join(OPERATOR_TOPICS)})"
        else:
            name, key, what = spec
            if key is not None:
                try:
                    msg = json.loads(data)
                    value = float(msg[key])
                except (ValueError, TypeError, KeyError) as exc:
                    why = f'expected JSON {{"{key}": number}}, got {data[:60]!r} ({exc})'
                else:
                    who += f": {what} {value:g} {'rpm' if key == 'rpm' else 'N m'}"
                    if key == "rpm":
                        value *= RAD_S_PER_RPM
            else:
                who += f": {what}"
            if why is None and not self.inputs_allowed:
                why = self.opts.refused_why
            if why is None:
                kind = getattr(lib, name)
        text = who if why is None else f"{who}: refused: {why}"
        with self._lock:   # foxglove-sdk's threads: one producer at a time
            if self._inbox is None:
                return
            if lib.live_inbox_push(self._inbox, kind, client_id, value,
                                   text.encode()[:lib.LIVE_INPUT_TEXT - 1]) != 0:
                self.inputs_lost += 1

    def stats(self) -> dict:
        """The viewer's end-of-run figures (the recording's ``live_view`` metadata, the bench's
        line after the run): see :func:`stats_line`."""
        level = os.environ.get("FOXGLOVE_LOG_LEVEL", "").upper()
        return {
            "port": self.port, "rate_hz": self.opts.rate_hz, "backlog": self.opts.backlog,
            "clients": len(self.clients_seen),
            "messages_sent": self.forwarded, "client_frames_sent": self.client_frames,
            "cut_by_bench": self.cut, "operator_inputs_lost": self.inputs_lost,
            "sdk_outbox_full_reports": self._sdk_drops.reports,
            "sdk_outbox_full_clients": list(self._sdk_drops.clients),
            "sdk_log": ("unavailable" if self._sdk_drops.reports < 0 else
                        f"silenced (FOXGLOVE_LOG_LEVEL={level})"
                        if level in ("WARN", "WARNING", "ERROR", "OFF") else "info"),
        }

    def stop(self) -> None:
        try:
            self.server.stop()
        except Exception:  # noqa: BLE001 - stopping a server that failed is not news
            pass


def viewer_dropped(stats: dict) -> int:
    """Viewer frames known to be lost for back-pressure or by the bench: the bench's own cut
    picks, plus one per foxglove-sdk overflow report (each stands for at least one frame the sdk
    dropped; it does not say how many, so this is a lower bound whenever a report was made)."""
    return int(stats.get("cut_by_bench", 0)) + max(int(stats.get("sdk_outbox_full_reports", 0)), 0)


def listening_line(port: int) -> str:
    """What the bench prints once the live view listens (bench run, bench replay)."""
    return (f"live view: Foxglove WebSocket on ws://127.0.0.1:{port} (Foxglove or Lichtblick: "
            f"Open connection, Foxglove WebSocket; docs/foxglove.md)")


def stats_line(stats: dict) -> str:
    """One line for stderr after a run with --live."""
    reports = int(stats.get("sdk_outbox_full_reports", 0))
    if reports > 0:
        sdk = (f"foxglove-sdk dropped queued frames of a client that did not read "
               f"({', '.join(stats.get('sdk_outbox_full_clients', [])) or '?'}): {reports} "
               f"overflow report(s), each at least one frame (the sdk does not count them, and "
               f"reports at most once per 30 s)")
    elif reports < 0 or stats.get("sdk_log", "info") != "info":
        sdk = f"foxglove-sdk's overflow reports not available (its log: {stats.get('sdk_log')})"
    else:
        sdk = "no client's queue overflowed (foxglove-sdk reported none)"
    return (f"live view: {stats.get('clients', 0)} client(s); {stats.get('messages_sent', 0)} "
            f"messages sent ({stats.get('client_frames_sent', 0)} client frames, the per-cycle "
            f"channels decimated to {float(stats.get('rate_hz', 0)):g} Hz by design); viewer "
            f"frames dropped: at least {viewer_dropped(stats)} ({stats.get('cut_by_bench', 0)} "
            f"cut by the bench; {sdk})")
