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
* nor at the end: the server is stopped on a thread of its own, the recording is finalised
  without waiting for it (foxglove-sdk's ``stop`` waits for every connection, and one that never
  completes its WebSocket handshake, an idle TCP connection, holds it for ever);
* the per-cycle channels reach a viewer decimated to ``rate_hz`` per channel (the newest record
  of a batch, at most once per 1/rate_hz of wall time): a 10 kHz run does not flood a browser.
  /events, /faults and /link/stats go out whole (a few rows per second);
* every /events row is kept, and a viewer that subscribes to ``/events/history`` (a channel of
  the viewer only, not of the recording) is sent all of them: a late viewer sees what happened
  before it joined;
* with no client subscribed the live view costs the recorder one walk of each batch in C (it
  keeps the /events rows for late viewers).

A viewer's operator inputs (docs/foxglove.md "Operator inputs") are checked here (JSON, type,
the scenario's range), pushed into the engine's mailbox (live.h) and recorded on /events by the
engine, applied or refused; what the engine cannot take (a full mailbox, inputs after its last
cycle) is recorded as refused too, by a summary row or by the recorder at the end.

foxglove-sdk starts Rust threads, so the server is started in the recorder process, after the
fork, never in the bench's.
"""
from __future__ import annotations

import ipaddress
import json
import logging
import math
import os
import re
import socket
import threading
import time
from dataclasses import dataclass

from hil_bench.plant_rt._plant_c import ffi, lib

from . import channels as chans

from .live_defaults import (DEFAULT_BACKLOG, DEFAULT_HOST, DEFAULT_PORT,  # noqa: F401
                            DEFAULT_RATE_HZ, DEFAULT_WAIT_S)
#: topics every row of which goes to the viewer (rare rows that mean something one by one)
EVERY_ROW_TOPICS = (chans.EVENTS, chans.FAULTS, chans.LINK_STATS)
#: the viewer-only channel that sends a subscriber every /events row of the run so far
EVENTS_HISTORY = chans.EVENTS + "/history"
#: picks per batch at most (a batch beyond it: the picks cut are counted, never an error)
PICKS_PER_BATCH = 4096
#: after the recording is complete, how long the recorder lets foxglove-sdk close its clients'
#: connections cleanly before the process exits (a connection that never completed its handshake
#: would hold the sdk's stop for ever; the process's exit closes it)
STOP_GRACE_S = 2.0


@dataclass(frozen=True)
class LiveOptions:
    """``bench run --live``: where the server listens and how much it sends."""

    port: int = DEFAULT_PORT          # 0: any free port (the recorder says which)
    host: str = DEFAULT_HOST          # --live-host: the address to bind (a warning if not loopback)
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
    #: --live-wait: the run starts when the first viewer subscribes, at most this long [s]
    #: (None: at once)
    wait_s: float | None = None
    #: the run can be paused (lockstep): a pause then has a holder (below); False in real time,
    #: where the engine refuses a pause
    can_pause: bool = True
    #: the scenario's limits of an operator's speed reference [rpm] and load torque [N m]
    #: (either sign), with the reason a value beyond is refused (``hil_bench.scenario.operator_limits``)
    speed_max_rpm: float = math.inf
    speed_why: str = ""
    load_max_nm: float = math.inf
    load_why: str = ""

    def __post_init__(self) -> None:
        if not 0 <= int(self.port) <= 65535:
            raise ValueError(f"--live {self.port}: a TCP port is 0..65535")
        if not self.rate_hz > 0:
            raise ValueError(f"--live-rate {self.rate_hz:g}: the viewer rate is > 0 Hz")
        if not str(self.host).strip():
            raise ValueError("--live-host '': give an address to listen on (127.0.0.1: this "
                             "machine only; 0.0.0.0: every interface)")
        if self.wait_s is not None and not (self.wait_s > 0 and math.isfinite(self.wait_s)):
            raise ValueError(f"--live-wait {self.wait_s:g}: the time to wait for a viewer is a "
                             f"number of seconds > 0")

    @property
    def url(self) -> str:
        return ws_url(self.host, self.port)


class LiveViewError(RuntimeError):
    """The live view could not start (the port is taken, foxglove-sdk missing)."""


def ws_url(host: str, port: int) -> str:
    """The ws:// URL of a server bound to ``host`` (an IPv6 literal in brackets)."""
    h = host.strip("[]")
    return f"ws://[{h}]:{port}" if ":" in h else f"ws://{h}:{port}"


def is_loopback(host: str) -> bool:
    """True if every address ``host`` names is a loopback address (127.0.0.0/8, ::1); a name
    that does not resolve is not (the server then says it cannot listen)."""
    h = host.strip("[]")
    try:
        return ipaddress.ip_address(h).is_loopback
    except ValueError:
        pass
    try:
        addrs = {a[4][0] for a in socket.getaddrinfo(h, None)}
    except (OSError, UnicodeError):
        return False
    try:
        return bool(addrs) and all(ipaddress.ip_address(a.split("%")[0]).is_loopback
                                   for a in addrs)
    except ValueError:
        return False


def host_warning(host: str) -> str | None:
    """What the bench says when the live view listens beyond this machine (None on loopback)."""
    if is_loopback(host):
        return None
    return (f"live view: --live-host {host} is not a loopback address: anyone who can reach this "
            f"machine on that port can watch the run (and steer it, if the scenario allows "
            f"operator inputs); the Foxglove WebSocket has no authentication")


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
#: ... and when a client completed its WebSocket handshake (server.rs register_client; its Python
#: listener has no connect callback in 0.30)
SDK_CONNECT_MESSAGE = re.compile(r"^Registered client (\S+)")


class _SdkLog(logging.Handler):
    """foxglove-sdk's log lines the live view counts, its only word on two figures its Python
    API (0.30) does not give: the frames it dropped for a client that does not read ("outbox for
    client ADDR full") and the clients that connected ("Registered client ADDR")."""

    def __init__(self) -> None:
        super().__init__(logging.INFO)
        self.reports = 0
        self.clients: list[str] = []
        self.connected = 0

    def emit(self, record: logging.LogRecord) -> None:
        text = record.getMessage()
        if SDK_CONNECT_MESSAGE.match(text):
            self.connected += 1
            return
        m = SDK_DROP_MESSAGE.search(text)
        if m is None:
            return
        self.reports += 1
        if m.group(1) not in self.clients:
            self.clients.append(m.group(1))


def _listen_to_sdk_log(fox) -> _SdkLog:
    """Route foxglove-sdk's Rust log (INFO) into Python logging, to a handler of ours only (the
    "foxglove" logger does not propagate: nothing is printed). FOXGLOVE_LOG_LEVEL above INFO
    silences the reports: the figure then says so (``sdk_log``)."""
    handler = _SdkLog()
    log = logging.getLogger("foxglove")
    log.setLevel(logging.INFO)
    log.propagate = False
    log.addHandler(handler)
    try:
        fox.set_log_level("INFO")
    except Exception:  # noqa: BLE001 - an sdk without the bridge: the reports stay 0 (said so)
        handler.reports = -1
    return handler


def _say(line: str) -> None:
    """One line on the bench's stderr, from the recorder process (the operator at the terminal
    sees what a viewer did to the run while it happens)."""
    try:   # the descriptor itself: the process's sys.stderr may be a copy of its parent's
        os.write(2, (line + "\n").encode("utf-8", "replace"))
    except OSError:
        pass


def _text_bytes(text: str) -> bytes:
    """``text`` for the mailbox: UTF-8, cut to LIVE_INPUT_TEXT - 1 octets at a character's
    boundary (an /events row is a protobuf string: it must stay valid UTF-8)."""
    data = text.encode("utf-8", "replace")[:lib.LIVE_INPUT_TEXT - 1]
    return data.decode("utf-8", "ignore").encode("utf-8")


class _Listener:
    """Counts each channel's subscribers and takes what viewers publish (foxglove-sdk calls it
    on its own threads; nothing here may raise into it)."""

    def __init__(self, view: "LiveView") -> None:
        self.view = view

    def on_subscribe(self, client, channel) -> None:
        self.view._subscribed(client.id, channel.topic, +1)

    def on_unsubscribe(self, client, channel) -> None:
        self.view._subscribed(client.id, channel.topic, -1)

    def on_client_advertise(self, client, channel) -> None:
        with self.view._lock:
            self.view._client_channels[(client.id, channel.id)] = channel.topic
            self.view.clients_seen.add(client.id)

    def on_client_unadvertise(self, client, client_channel_id) -> None:
        # foxglove-sdk also calls it for every channel a client still advertised when it
        # disconnects: a pause's holder that is gone (below)
        self.view._unadvertised(client.id, client_channel_id)

    def on_message_data(self, client, client_channel_id, data) -> None:
        self.view._operator_input(client.id, client_channel_id, bytes(data))


class LiveView:
    """The server and its channels, one per ring channel (raw serial captures: none)."""

    def __init__(self, opts: LiveOptions, name: str, inbox_mem=None,
                 inputs_allowed: bool = False) -> None:
        """``inbox_mem``: the engine's operator-input mailbox (live.h; None: no inputs are
        served); ``inputs_allowed``: the scenario's ``[live] inputs`` (otherwise every input is
        refused, with an /events row saying why)."""
        from hil_bench.installation import ExtraMissing, require_extra

        try:   # foxglove.websocket.Capability: present in the sdk range pyproject.toml pins
            foxglove = require_extra("--live (the Foxglove live view)", "foxglove",
                                     "foxglove.websocket")
        except ExtraMissing as exc:
            raise LiveViewError(str(exc)) from None
        self._fox = foxglove
        self._sdk_log = _listen_to_sdk_log(foxglove)   # before the server: the sdk's rule
        self.opts = opts
        self._lock = threading.Lock()
        self._subs: dict[str, int] = {}
        self._client_channels: dict[tuple[int, int], str] = {}
        self._inbox = None
        self.inputs_allowed = bool(inputs_allowed)
        #: set when the first client subscribes to anything (--live-wait)
        self.first_subscriber = threading.Event()
        #: every /events row so far (payload, run time [ns]) and the lock that orders them with
        #: what goes out on /events (a late viewer gets each row once, on one of the channels)
        self._history: list[tuple[bytes, int]] = []
        self._history_lock = threading.Lock()
        self._events_ch: int | None = None
        self._history_channel = None
        #: client -> the history rows it was sent on /events/history before it subscribed to
        #: /events (_send_history)
        self._history_mark: dict[int, int] = {}
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
        self._stopper: threading.Thread | None = None
        #: what the viewer was sent (each message once, whatever the number of clients), the
        #: messages times the clients subscribed to their channel, and the records it was not
        #: (picks beyond a batch's cap: :attr:`cut`)
        self.forwarded = 0
        self.client_frames = 0
        #: clients seen through a callback (subscribed, advertised), and those that subscribed
        self.clients_seen: set[int] = set()
        self.clients_subscribed: set[int] = set()
        self._client_topics: dict[int, dict[str, int]] = {}
        #: operator inputs: received, lost to the full mailbox (and not yet on a summary row),
        #: the summary rows, those that came after the engine's last cycle
        self.inputs_received = 0
        self.inputs_lost = 0
        self._lost_unreported = 0
        self.lost_rows = 0
        self.inputs_after_end = 0
        self._ended = False
        self._late_rows: list[tuple[str, str, float]] = []
        #: the client whose pause holds the run (None: not paused by a viewer), and the pauses
        #: released because their holder disconnected
        self._pause_holder: int | None = None
        self.pauses_released = 0

    @property
    def cut(self) -> int:
        return int(self._cut[0])

    # -- subscriptions ------------------------------------------------------------------------

    def _subscribed(self, client_id: int, topic: str, delta: int) -> None:
        with self._lock:
            self._subs[topic] = max(0, self._subs.get(topic, 0) + delta)
            self._dirty = True
            self.clients_seen.add(client_id)
            topics = self._client_topics.setdefault(client_id, {})
            topics[topic] = max(0, topics.get(topic, 0) + delta)
            if delta > 0:
                self.clients_subscribed.add(client_id)
            elif topic == EVENTS_HISTORY:
                self._history_mark.pop(client_id, None)
        if delta > 0:
            self.first_subscriber.set()
            if topic in (EVENTS_HISTORY, chans.EVENTS):
                self._send_history(client_id, topic)

    def _send_history(self, client_id: int, topic: str) -> None:
        """A client subscribed to /events/history: every /events row of the run so far goes out
        on it. Until the same client subscribes to /events too, the rows that go out on /events
        meanwhile are kept count of and sent on /events/history once it does, so that a viewer
        misses none, whichever it subscribed to first (foxglove-sdk 0.30's Python API cannot
        address one client: every subscriber of /events/history gets them, a viewer may get a
        row twice)."""
        ch = self._history_channel
        if ch is None:
            return
        with self._history_lock:   # feed() keeps and sends /events rows under it
            on_events = self._client_topics.get(client_id, {}).get(chans.EVENTS, 0) > 0
            if topic == EVENTS_HISTORY:
                start = 0
                if not on_events:
                    self._history_mark[client_id] = len(self._history)
            else:
                start = self._history_mark.pop(client_id, None)
                if start is None:
                    return
            rows = self._history[start:]
            for data, t_ns in rows:
                ch.log(data, log_time=self._start_ns + t_ns)
            self.client_frames += len(rows) * self._subs.get(EVENTS_HISTORY, 0)
            self.forwarded += len(rows)

    _start_ns = 0

    def _set_modes(self) -> None:
        """The pick modes of the subscribed channels (after a subscription changed); /events is
        always picked (its rows are kept for late viewers)."""
        with self._lock:
            subs = dict(self._subs)
            self._dirty = False
        self._last_channels = []
        self._any_every = False
        for c in range(min(len(self.topics), lib.LIVE_PICK_MAX_CHANNELS)):
            topic = self.topics[c]
            if topic is not None and c == self._events_ch:
                self._modes[c] = lib.LIVE_EVERY
                self._any_every = True
            elif topic is None or not subs.get(topic):
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
        if topic == chans.EVENTS and self._events_ch is None:
            self._events_ch = len(self.topics)
            self._history_channel = fox.Channel(EVENTS_HISTORY, schema=schema,
                                                message_encoding=chans.MESSAGE_ENCODING,
                                                context=self.context)
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
        the recorder's read buffer, ``n`` octets of ring records), and keep its /events rows.
        The per-cycle channels are picked only once per 1/rate_hz, all at once."""
        self._start_ns = start_ns
        if self._lost_unreported:
            with self._lock:
                self._report_lost()
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
        if not picked:
            return
        view = memoryview(buf)
        subs = self._subs
        events = self._events_ch
        with self._history_lock:
            for i in range(picked):
                p = self._picks[i]
                c = p.channel
                data = bytes(view[p.offset:p.offset + p.length])
                if c == events:
                    self._history.append((data, int(p.t_ns)))
                k = subs.get(self.topics[c], 0)
                if k:
                    self.channels[c].log(data, log_time=start_ns + p.t_ns)
                    self.client_frames += k
                    self.forwarded += 1

    # -- operator inputs ------------------------------------------------------------------------

    def _parse(self, topic: str, data: bytes) -> tuple[int, float, str, str | None]:
        """What a viewer's message asks for: (live.h kind, SI value, what and who, why refused
        or None). Checks the JSON, the value's type and the scenario's range."""
        spec = OPERATOR_TOPICS.get(topic)
        if spec is None:
            return (lib.LIVE_IN_REFUSED, 0.0, "",
                    f"not an operator topic (one of {', '.join(OPERATOR_TOPICS)})")
        name, key, what = spec
        kind = getattr(lib, name)
        if key is None:
            return kind, 0.0, f": {what}", None
        unit = "rpm" if key == "rpm" else "N m"
        expected = f'expected JSON {{"{key}": number}} ({unit})'
        try:
            msg = json.loads(data)
        except RecursionError:
            return lib.LIVE_IN_REFUSED, 0.0, "", f"{expected}: JSON nested too deeply"
        except ValueError as exc:   # JSONDecodeError, UnicodeDecodeError, too many digits
            return lib.LIVE_IN_REFUSED, 0.0, "", f"{expected}, got {data[:40]!r} ({exc})"
        if not isinstance(msg, dict) or key not in msg:
            return (lib.LIVE_IN_REFUSED, 0.0, "",
                    f"{expected}, got {type(msg).__name__} {data[:40]!r}")
        extra = sorted(str(k) for k in msg if k != key)
        if extra:
            return (lib.LIVE_IN_REFUSED, 0.0, "",
                    f"{expected}: unexpected key(s) {', '.join(extra)[:40]}")
        raw = msg[key]
        if isinstance(raw, bool) or not isinstance(raw, (int, float)):
            return (lib.LIVE_IN_REFUSED, 0.0, "",
                    f"{expected}: {key} is a JSON {type(raw).__name__}, not a number "
                    f"({json.dumps(raw)[:30]})")
        try:
            value = float(raw)
        except OverflowError:
            value = math.inf
        if not math.isfinite(value):
            return lib.LIVE_IN_REFUSED, 0.0, "", f"{expected}: {key} is not a finite number"
        text = f": {what} {value:g} {unit}"
        limit, why = ((self.opts.speed_max_rpm, self.opts.speed_why) if key == "rpm" else
                      (self.opts.load_max_nm, self.opts.load_why))
        if not abs(value) <= limit:
            return (lib.LIVE_IN_REFUSED, value, text,
                    f"outside +-{limit:.4g} {unit} ({why})" if why else
                    f"outside +-{limit:.4g} {unit}")
        return kind, (value * RAD_S_PER_RPM if key == "rpm" else value), text, None

    def _operator_input(self, client_id: int, client_channel_id: int, data: bytes) -> None:
        """One message a viewer published: into the engine's mailbox, applied at the start of
        the engine's next cycle and recorded on /events with the client's id, or refused there
        (the engine writes the row, at the cycle it took it). Never raises into the sdk."""
        try:
            with self._lock:
                topic = self._client_channels.get((client_id, client_channel_id), "?")
            who = f"operator (viewer client {client_id}, {topic[:60]})"
            try:
                kind, value, what, why = self._parse(topic, data)
            except Exception as exc:  # noqa: BLE001 - whatever the message: a refusal, recorded
                kind, value, what, why = (lib.LIVE_IN_REFUSED, 0.0, "",
                                          f"unreadable message ({type(exc).__name__})")
            if why is None and not self.inputs_allowed:
                kind, why = lib.LIVE_IN_REFUSED, self.opts.refused_why
            text = f"{who}{what}" if why is None else f"{who}{what}: refused: {why}"
            self._push_input(kind, client_id, value, text)
        except Exception as exc:  # noqa: BLE001 - never into the sdk's threads: said, counted
            _say(f"live view: an operator input could not be handled: {type(exc).__name__}: "
                 f"{exc}")

    def _push_input(self, kind: int, client_id: int, value: float, text: str) -> None:
        with self._lock:   # foxglove-sdk's threads: one producer at a time
            if self._inbox is None:
                return
            self.inputs_received += 1
            if self._ended:
                self.inputs_after_end += 1
                self._late_rows.append(("operator_refused", f"{text}: refused: the run had "
                                        f"ended (it arrived after the engine's last cycle)"
                                        if kind != lib.LIVE_IN_REFUSED else
                                        f"{text} (after the engine's last cycle)", value))
                return
            self._report_lost()
            if lib.live_inbox_push(self._inbox, kind, client_id, value, _text_bytes(text)) != 0:
                self.inputs_lost += 1
                self._lost_unreported += 1
                return
            self._after_push(kind, client_id)

    def _after_push(self, kind: int, client_id: int) -> None:
        """A pause has a holder: the client that asked for it; a resume ends it (under _lock)."""
        if not self.opts.can_pause:
            return
        if kind == lib.LIVE_IN_PAUSE and self._pause_holder is None:
            self._pause_holder = client_id
            _say(f"live view: viewer client {client_id} paused the run; it goes on when a viewer "
                 f"publishes /operator/resume or client {client_id} disconnects")
        elif kind == lib.LIVE_IN_RESUME and self._pause_holder is not None:
            self._pause_holder = None
            _say(f"live view: viewer client {client_id} resumed the run")

    def _unadvertised(self, client_id: int, client_channel_id: int) -> None:
        """A client withdrew a channel, or disconnected (foxglove-sdk withdraws each of its
        channels then). A pause whose holder has no channel left to publish a resume on is
        released: the engine is told to go on, and its /events row says why."""
        try:
            with self._lock:
                self._client_channels.pop((client_id, client_channel_id), None)
                if self._pause_holder != client_id or self._ended or self._inbox is None:
                    return
                if any(c == client_id for c, _ in self._client_channels):
                    return
                self._pause_holder = None
                text = (f"operator (viewer client {client_id}): resume: the viewer that paused "
                        f"the run disconnected")
                self._report_lost()
                if lib.live_inbox_push(self._inbox, lib.LIVE_IN_RESUME, client_id, 0.0,
                                       _text_bytes(text)) != 0:
                    # the mailbox is full of inputs the engine takes at once (it reads it while
                    # paused): a pause with no holder would hold the run for ever, so keep trying
                    self._pause_holder = client_id
                    retry = threading.Timer(0.05, self._unadvertised, (client_id, -1))
                    retry.daemon = True
                    retry.start()
                    return
                self.pauses_released += 1
            _say(f"live view: viewer client {client_id}, which paused the run, disconnected: "
                 f"the run goes on")
        except Exception as exc:  # noqa: BLE001
            _say(f"live view: a viewer's disconnect could not be handled: {exc}")

    def _lost_text(self, n: int) -> str:
        return (f"operator: {n} input(s) refused: the mailbox was full ({lib.LIVE_INBOX_SLOTS} "
                f"inputs pending: they came faster than the engine takes them, once per cycle)")

    def _report_lost(self) -> None:
        """The inputs a full mailbox refused, as one summary row the engine records as refused
        (value: how many), once there is room (under _lock)."""
        n = self._lost_unreported
        if not n or self._inbox is None or self._ended:
            return
        if lib.live_inbox_push(self._inbox, lib.LIVE_IN_REFUSED, 0, float(n),
                               _text_bytes(self._lost_text(n))) == 0:
            self._lost_unreported = 0
            self.lost_rows += 1

    def end_inputs(self) -> list[tuple[str, str, float]]:
        """After the engine's last cycle (the recorder is closing): what it never took. Returns
        the /events rows (kind, text, value) the recorder writes itself: each input left in the
        mailbox and each that arrives from now on, refused, and the full mailbox's last summary.
        Called again, it returns the rows that came since."""
        rows: list[tuple[str, str, float]] = []
        with self._lock:
            first = not self._ended
            self._ended = True
            if first and self._inbox is not None:
                out = ffi.new("live_input_t *")
                while lib.live_inbox_take(self._inbox, out):
                    text = ffi.string(out.text).decode("utf-8", "replace")
                    if out.kind == lib.LIVE_IN_REFUSED:
                        rows.append(("operator_refused", f"{text} (after the engine's last "
                                                         f"cycle)", float(out.value)))
                    else:
                        rows.append(("operator_refused", f"{text}: refused: the run had ended "
                                     f"(it arrived after the engine's last cycle)",
                                     float(out.value)))
                        self.inputs_after_end += 1
            if self._lost_unreported:
                rows.append(("operator_refused", self._lost_text(self._lost_unreported),
                             float(self._lost_unreported)))
                self._lost_unreported = 0
                self.lost_rows += 1
            rows += self._late_rows
            self._late_rows = []
        return rows

    # -- the end ----------------------------------------------------------------------------------

    def stats(self) -> dict:
        """The viewer's end-of-run figures (the recording's ``live_view`` metadata, the bench's
        line after the run): see :func:`stats_line`."""
        level = os.environ.get("FOXGLOVE_LOG_LEVEL", "").upper()
        sdk_log = ("unavailable" if self._sdk_log.reports < 0 else
                   f"silenced (FOXGLOVE_LOG_LEVEL={level})"
                   if level in ("WARN", "WARNING", "ERROR", "OFF") else "info")
        with self._lock:
            connected = max(self._sdk_log.connected, len(self.clients_seen))
            return {
                "port": self.port, "host": self.opts.host, "rate_hz": self.opts.rate_hz,
                "backlog": self.opts.backlog,
                "clients_connected": connected if sdk_log == "info" else -1,
                "clients_subscribed": len(self.clients_subscribed),
                "messages_sent": self.forwarded, "client_frames_sent": self.client_frames,
                "cut_by_bench": self.cut,
                "operator_inputs": self.inputs_received,
                "operator_inputs_lost": self.inputs_lost,
                "operator_inputs_after_end": self.inputs_after_end,
                "pauses_released": self.pauses_released,
                "events_history_rows": len(self._history),
                "sdk_outbox_full_reports": self._sdk_log.reports,
                "sdk_outbox_full_clients": list(self._sdk_log.clients),
                "sdk_log": sdk_log,
            }

    def stop(self) -> None:
        """Stop serving, without waiting: foxglove-sdk's ``stop`` closes every client and then
        waits for each connection to end, and a connection that never completes its WebSocket
        handshake (an idle TCP connection) never ends. It runs on a daemon thread; the recorder
        finalises the recording meanwhile (:meth:`wait_stopped` after it)."""
        if self._stopper is not None:
            return

        def stop_server() -> None:
            try:
                self.server.stop()
            except Exception:  # noqa: BLE001 - stopping a server that failed is not news
                pass

        self._stopper = threading.Thread(target=stop_server, name="live-view-stop", daemon=True)
        self._stopper.start()

    def wait_stopped(self, grace_s: float = STOP_GRACE_S) -> bool:
        """After the recording is complete: let the clients' connections close cleanly, for at
        most ``grace_s`` (then the process's exit closes them). True if the server stopped."""
        if self._stopper is None:
            return True
        self._stopper.join(grace_s)
        return not self._stopper.is_alive()


def viewer_dropped(stats: dict) -> int:
    """Viewer frames known to be lost for back-pressure or by the bench: the bench's own cut
    picks, plus one per foxglove-sdk overflow report (each stands for at least one frame the sdk
    dropped; it does not say how many, so this is a lower bound whenever a report was made)."""
    return int(stats.get("cut_by_bench", 0)) + max(int(stats.get("sdk_outbox_full_reports", 0)), 0)


def listening_line(port: int, host: str = DEFAULT_HOST) -> str:
    """What the bench prints once the live view listens (bench run, bench replay)."""
    return (f"live view: Foxglove WebSocket on {ws_url(host, port)} (Foxglove or Lichtblick: "
            f"Open connection, Foxglove WebSocket; docs/foxglove.md)")


def waiting_line(port: int, host: str, wait_s: float) -> str:
    """What the bench prints while --live-wait holds the run."""
    return (f"live view: waiting up to {wait_s:g} s for a viewer to subscribe on "
            f"{ws_url(host, port)} (--live-wait); the run starts then")


def no_viewer_error(port: int, host: str, wait_s: float) -> str:
    return (f"--live-wait {wait_s:g}: no viewer subscribed to {ws_url(host, port)} within "
            f"{wait_s:g} s; the run did not start (is the port reachable from the viewer? "
            f"--live-host, a firewall)")


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
    connected = int(stats.get("clients_connected", -1))
    line = (f"live view: {connected if connected >= 0 else '?'} client(s) connected, "
            f"{stats.get('clients_subscribed', 0)} subscribed; {stats.get('messages_sent', 0)} "
            f"messages sent ({stats.get('client_frames_sent', 0)} client frames, the per-cycle "
            f"channels decimated to {float(stats.get('rate_hz', 0)):g} Hz by design); viewer "
            f"frames dropped: at least {viewer_dropped(stats)} ({stats.get('cut_by_bench', 0)} "
            f"cut by the bench; {sdk})")
    inputs = int(stats.get("operator_inputs", 0))
    if inputs:
        lost = int(stats.get("operator_inputs_lost", 0))
        late = int(stats.get("operator_inputs_after_end", 0))
        released = int(stats.get("pauses_released", 0))
        line += (f"; operator inputs: {inputs} received (each recorded on /events, applied or "
                 f"refused)")
        if lost:
            line += (f", {lost} refused because the engine's mailbox was full (recorded as "
                     f"summary rows)")
        if late:
            line += f", {late} after the run's last cycle (refused)"
        if released:
            line += (f", {released} pause(s) released because the viewer that held it "
                     f"disconnected")
    return line
