"""CAN backend: the HIL messages as CAN frames through any python-can interface.

One message = one data frame: 11-bit identifier = message id, data = the payload (docs/protocol.md,
section 1), classic CAN or, with ``fd``, CAN FD (bit rate switch when a data bit rate is given).
python-can does every interface (socketcan, pcan, kvaser, vector, slcan, socketcand, virtual, ...);
this module only maps frames, counts what does not belong, keeps a candump log and turns interface
failures into :class:`LinkError` with a message naming the interface and what happened.

Received frames:

* ids in the DBC with the DBC length: passed on;
* 11-bit ids not in the DBC: counted (``can_unknown_ids``) and passed on, so the runner records them
  the way it records them on the serial link (``unknown_ids``); 29-bit ids and remote frames are
  counted and dropped (no message of the DBC has them);
* a known id with another length (wrong DLC): counted (``length_errors``), dropped, reported once per
  id on the ``hil_bench.loop.links.can`` logger (a payload of the wrong size is never decoded);
* error frames (SocketCAN error classes, socketcand ``< error >``): counted (``error_frames``);
  controller state changes (error warning/passive) are counted (``bus_state_changes``); a bus-off
  ends the run with :class:`LinkError`;
* a line the interface cannot parse (python-can's slcan raises ValueError on a malformed line; a
  socketcand gateway's line with an id, timestamp or data that is not what socketcand sends, or
  octets that are not ASCII): counted (``rx_malformed``, a link counter like a bad CRC on serial:
  a problem of the run unless ``[link] allow`` allows it), reported once on the logger, skipped;
  the frames around it pass. python-can's socketcand interface turns such a line into a CanError
  carrying its traceback and keeps the line in its buffer, so the socketcand bus here is python-can's
  with its own receive parser (:class:`SocketcandBus`).

An adapter that vanishes (USB unplugged, socketcand server gone, stub killed) raises LinkError on the
next read or write.
"""
from __future__ import annotations

import logging
import re
import select
import socket
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import can
from can.interfaces.socketcand.socketcand import SocketCanDaemonBus

from hil_bench.protocol import budget
from hil_bench.protocol.messages import BY_ID

from hil_bench.protocol.timing import PATIENCE_S

from .base import Link, LinkError

log = logging.getLogger("hil_bench.loop.links.can")

DEFAULT_BITRATE = 1_000_000
#: a send that cannot complete this long means the adapter or the bus is gone. A send blocks when
#: what was sent before is not taken: a USB adapter (or the stub behind an SLCAN pty) that a busy
#: host stopped for a while is late, not gone (docs/protocol.md 6.5), so it gets the patience; an
#: adapter that vanished fails its write at once (EIO)
SEND_TIMEOUT_S = PATIENCE_S
#: socketcand greeting / open / rawmode answers: the patience too (a busy host delays the daemon's
#: answer; a refused or closed connection fails at once)
HANDSHAKE_TIMEOUT_S = PATIENCE_S
SOCKETCAND_DEFAULT_PORT = 29536  #: socketcand's default TCP port

# linux/can/error.h: error classes in the id of an error frame, controller status in data[1]
CAN_ERR_CRTL = 0x004
CAN_ERR_BUSOFF = 0x040
CAN_ERR_RESTARTED = 0x100
CAN_ERR_CRTL_STATE = 0x04 | 0x08 | 0x10 | 0x20 | 0x40   # rx/tx warning, rx/tx passive, active again

#: python-can interfaces whose bit rate is set outside the process (ip link, the socketcand server)
#: or that have none: the spec's bit rate only feeds the budget.
_NO_BITRATE_ARG = {"socketcan", "socketcand", "virtual", "udp_multicast"}

COUNTERS = ("can_unknown_ids", "length_errors", "error_frames", "bus_state_changes", "send_failures",
            "remote_frames", "rx_malformed")


@dataclass
class CanSpec:
    """What ``--link can:...`` names: a python-can interface and channel, the bus bit rates, options."""

    interface: str
    channel: str
    bitrate: int = DEFAULT_BITRATE
    fd: bool = False
    data_bitrate: int | None = None
    bitrate_given: bool = True
    options: dict[str, object] = field(default_factory=dict)   #: extra keyword arguments of can.Bus
    #: what the link spec stated (interface, channel, bitrate, fd, data_bitrate)
    given: frozenset[str] = frozenset({"interface", "channel", "bitrate"})
    #: which values came from python-can's configuration, and its context ("" if none did)
    config_note: str = ""

    @property
    def bus_name(self) -> str:
        name = budget.can_link_name(self.bitrate, self.fd, self.data_bitrate)
        if self.bitrate_given or self.interface not in _NO_BITRATE_ARG:
            return name
        return f"{name} (assumed: give the bus's @bitrate)"


def check_can_rates(can_spec: CanSpec, spec: str) -> None:
    """The data bit rate needs FD and cannot be below the nominal one."""
    if can_spec.data_bitrate is not None and not can_spec.fd:
        raise LinkError(f"link spec {spec!r}: data_bitrate needs CAN FD: add ',fd'")
    if can_spec.data_bitrate is not None and can_spec.data_bitrate < can_spec.bitrate:
        raise LinkError(f"link spec {spec!r}: the data bit rate ({can_spec.data_bitrate}) is "
                        f"below the nominal bit rate ({can_spec.bitrate})")


CAN_SPEC_USAGE = ("use can:<interface>:<channel>[@bitrate][,fd][,data_bitrate=N], e.g. "
                  "can:socketcan:can0@500000, can:pcan:PCAN_USBBUS1@1M, can:slcan:/dev/ttyACM0@1M, "
                  "can:socketcand:can0,host=10.0.0.5,port=29536; or leave out what python-can's "
                  "configuration gives (can, can:pcan, can,context=lab2)")


#: what python-can's configuration may fill in that the bench reads itself (the rest goes to can.Bus)
_CONFIG_FIELDS = ("interface", "channel", "bitrate", "fd", "data_bitrate")


def with_python_can_config(spec: CanSpec, link_spec: str) -> CanSpec:
    """``spec`` (a ``can...`` link spec, parsed) completed the python-can way: what it leaves out
    -- interface, channel, bit rate, FD, data bit rate, any other Bus argument -- from
    ``can.util.load_config(config=<what the spec gives>, context=<its context= option>)``, i.e.
    from ``can.rc``, then ``CAN_INTERFACE`` / ``CAN_CHANNEL`` / ``CAN_BITRATE`` / ``CAN_CONFIG``
    (with ``_<CONTEXT>`` first when a context is given), then the config files (~/.canrc,
    ~/.can, ~/can.conf, /etc/can.conf; section ``[<context>]``, then ``[default]``). The link
    spec always wins. The result says which values came from there (``config_note``: the run's
    link description, recorded with the run)."""
    options = dict(spec.options)
    context = options.pop("context", None)
    context = None if context in (None, "") else str(context)
    given: dict[str, object] = {k: getattr(spec, k) for k in _CONFIG_FIELDS if k in spec.given}
    given.update(options)
    where = f" (context {context!r})" if context else ""
    if not given.get("interface") and not _configured_interface(context):
        raise LinkError(f"link spec {link_spec!r} names no CAN interface and python-can's "
                        f"configuration{where} has none (CAN_INTERFACE, interface = ... in "
                        f"~/.canrc): {CAN_SPEC_USAGE}")
    try:
        cfg = dict(can.util.load_config(config=given, context=context))
    except can.CanInterfaceNotImplementedError as exc:
        known = ", ".join(sorted(can.interfaces.VALID_INTERFACES))
        name = repr(given["interface"]) if given.get("interface") else \
            "(from python-can's configuration)"
        raise LinkError(f"link spec {link_spec!r}: CAN interface {name} is not available here: "
                        f"{exc} (python-can interfaces: {known})") from None
    except (ValueError, TypeError, KeyError) as exc:
        raise LinkError(f"link spec {link_spec!r}: python-can's configuration{where} is not "
                        f"usable: {type(exc).__name__}: {exc}") from None
    from_config = [k for k in _CONFIG_FIELDS
                   if k not in given and cfg.get(k) not in (None, "", False)]
    if cfg.get("channel") in (None, ""):
        raise LinkError(f"link spec {link_spec!r} names no CAN channel and python-can's "
                        f"configuration{where} has none (CAN_CHANNEL, channel = ... in "
                        f"~/.canrc): {CAN_SPEC_USAGE}")
    timing = cfg.get("timing")
    bitrate = cfg.get("bitrate")
    if bitrate is None and timing is not None:       # f_clock, brp, tseg1 ... in the config
        bitrate = getattr(timing, "nom_bitrate", None) or getattr(timing, "bitrate", None)
        from_config.append("bitrate")
    data_bitrate = cfg.get("data_bitrate")
    if data_bitrate is None and timing is not None and hasattr(timing, "data_bitrate"):
        data_bitrate = timing.data_bitrate
    try:
        out = CanSpec(interface=str(cfg["interface"]), channel=str(cfg["channel"]),
                      bitrate=int(bitrate) if bitrate is not None else DEFAULT_BITRATE,
                      fd=bool(cfg.get("fd", False)),
                      data_bitrate=int(data_bitrate) if data_bitrate is not None else None,
                      bitrate_given=bitrate is not None,
                      options={k: v for k, v in cfg.items() if k not in _CONFIG_FIELDS},
                      given=spec.given)
    except (TypeError, ValueError) as exc:
        raise LinkError(f"link spec {link_spec!r}: python-can's configuration gives a bad value: "
                        f"{exc}") from None
    if from_config:
        names = {"bitrate": "bit rate", "data_bitrate": "data bit rate"}
        what = ", ".join(names.get(k, k) for k in sorted(set(from_config), key=from_config.index))
        out.config_note = (f"{what} from python-can's configuration"
                           + (f", context {context!r}" if context else ""))
    check_can_rates(out, link_spec)
    return out


def _configured_interface(context: str | None) -> bool:
    """Does any of python-can's configuration sources name an interface (load_config's own
    sources, in its order)? Without one, load_config only says 'Unknown interface type None'."""
    util = can.util
    sources = (lambda: can.rc, lambda: util.load_environment_config(context),
               lambda: util.load_environment_config(),
               lambda: util.load_file_config(None, context) if context else {},
               lambda: util.load_file_config())
    return any(cfg.get("interface") or cfg.get("bustype") for cfg in (s() for s in sources))


def _bus_kwargs(spec: CanSpec) -> dict[str, object]:
    kwargs = dict(spec.options)
    iface = spec.interface
    if iface not in _NO_BITRATE_ARG and not (iface == "slcan" and spec.fd):
        kwargs.setdefault("bitrate", spec.bitrate)
    if iface == "socketcand":
        kwargs.setdefault("host", "127.0.0.1")
        kwargs.setdefault("port", SOCKETCAND_DEFAULT_PORT)
        kwargs.setdefault("tcp_tune", True)   # TCP_NODELAY: without it Nagle + delayed ACK cost ~40 ms
    if spec.fd:
        if iface == "socketcand":
            raise LinkError("python-can's socketcand interface carries classic CAN only: drop ',fd' "
                            "from the link spec")
        if iface != "slcan":
            kwargs["fd"] = True
            if spec.data_bitrate is not None:
                kwargs.setdefault("data_bitrate", spec.data_bitrate)
    return kwargs


def open_can_bus(spec: CanSpec, handshake_timeout_s: float = HANDSHAKE_TIMEOUT_S) -> can.BusABC:
    """A python-can Bus for the spec, or LinkError saying which interface/channel failed and why."""
    kwargs = _bus_kwargs(spec)
    where = f"CAN interface {spec.interface!r} channel {spec.channel!r}"
    old_timeout = socket.getdefaulttimeout()
    try:
        if spec.interface == "socketcand":
            # python-can reads the greeting with a blocking recv: bound it, so a server that accepts
            # but never answers cannot hang the bench
            socket.setdefaulttimeout(handshake_timeout_s)
        # the spec is complete (with_python_can_config merged the configuration once): python-can
        # must not add to it (a ~/.canrc with fd = True would change a stub link's frames)
        if spec.interface == "socketcand":
            bus = SocketcandBus(channel=spec.channel, **kwargs)
        else:
            bus = can.Bus(interface=spec.interface, channel=spec.channel, ignore_config=True,
                          **kwargs)
        if spec.interface == "slcan" and spec.fd:
            bus.set_bitrate(spec.bitrate, spec.data_bitrate)   # S<n> + Y<n> (CANable 2.0 style)
    except can.CanInterfaceNotImplementedError as exc:
        known = ", ".join(sorted(can.interfaces.VALID_INTERFACES))
        raise LinkError(f"{where} is not available here: {exc} (python-can interfaces: {known})") from None
    except Exception as exc:  # noqa: BLE001 - interfaces fail in many ways (kvaser without canlib: NameError)
        raise LinkError(f"cannot open {where}: {type(exc).__name__}: {exc}") from None
    finally:
        socket.setdefaulttimeout(old_timeout)
    sock = _socketcand_socket(bus)
    if sock is not None:
        sock.settimeout(None)
    return bus


#: what socketcand sends in rawmode (its README): "< frame <id> <secs>.<usecs> <hex data> >" with a
#: 3-digit (11-bit) or 8-digit (29-bit) hex id, "< error <id> <secs>.<usecs> ... >"
_SC_FRAME = re.compile(rb"< frame ([0-9A-Fa-f]{3}|[0-9A-Fa-f]{8}) ([0-9]+\.[0-9]+) ?((?:[0-9A-Fa-f]{2}){0,8}) >")
_SC_ERROR = re.compile(rb"< error ([0-9A-Fa-f]{3}|[0-9A-Fa-f]{8}) ([0-9]+\.[0-9]+)[ -~]* >")
_SC_IGNORED = (b"< ok >", b"< echo >")
_SC_LINE_MAX = 200          #: longer without a closing '>' is not a socketcand line (python-can: 200)


class SocketcandBus(SocketCanDaemonBus):
    """python-can's socketcand bus (connect, handshake, send) with a receive path that never raises
    on what a gateway sends: a line that is not a frame, an error or an ok is kept in ``malformed``
    (its octets, for the link to count and report) and skipped; the frames around it pass."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self._rx = bytearray()
        self._frames: list[can.Message] = []
        self.malformed: list[bytes] = []

    def _recv_internal(self, timeout):
        if not self._frames:
            sock = self._SocketCanDaemonBus__socket
            try:
                if not select.select([sock], [], [], timeout)[0]:
                    return None, False
                data = sock.recv(4096)
            except OSError as exc:
                raise can.CanError(f"Failed to receive: {exc}") from None
            if not data:
                return None, False        # the server closed: CanLink._check_peer says so
            self._rx += data
            self._parse()
        return (self._frames.pop(0) if self._frames else None), False

    def _parse(self) -> None:
        buf = self._rx
        while buf:
            start = buf.find(b"<")
            if start < 0:
                if buf.strip():
                    self.malformed.append(bytes(buf))
                buf.clear()
                break
            if buf[:start].strip():
                self.malformed.append(bytes(buf[:start]))
            end = buf.find(b">", start)
            if end < 0:
                if len(buf) - start > _SC_LINE_MAX:
                    self.malformed.append(bytes(buf[start:]))
                    buf.clear()
                else:
                    del buf[:start]       # a line split across TCP segments: wait for the rest
                break
            line = bytes(buf[start:end + 1])
            del buf[:end + 1]
            msg = self._message(line)
            if msg is not None:
                self._frames.append(msg)
            elif line not in _SC_IGNORED:
                self.malformed.append(line)

    def _message(self, line: bytes) -> can.Message | None:
        m = _SC_FRAME.fullmatch(line)
        if m is not None:
            return can.Message(timestamp=float(m.group(2)), arbitration_id=int(m.group(1), 16),
                               data=bytes.fromhex(m.group(3).decode("ascii")),
                               is_extended_id=len(m.group(1)) != 3, is_rx=True, channel=self.channel)
        m = _SC_ERROR.fullmatch(line)
        if m is not None:          # socketcand sends no error class: python-can's one zero octet
            return can.Message(timestamp=float(m.group(2)), arbitration_id=int(m.group(1), 16) & 0x1FFFFFFF,
                               is_error_frame=True, data=b"\0", is_extended_id=True, is_rx=True,
                               channel=self.channel)
        return None


def _socketcand_socket(bus: can.BusABC) -> socket.socket | None:
    """The TCP socket inside python-can's socketcand bus (to notice a server that went away: python-can
    itself reads an end of stream as silence)."""
    return getattr(bus, "_SocketCanDaemonBus__socket", None)


class CanLink(Link):
    """HIL frames over a python-can Bus."""

    def __init__(self, bus: can.BusABC, spec: CanSpec, capture_path: Path | None = None,
                 description: str | None = None):
        super().__init__()
        self.bus = bus
        self.spec = spec
        self.fd = spec.fd
        self.brs = spec.fd and spec.data_bitrate is not None
        self.description = description or (f"{spec.interface} {spec.channel}, {spec.bus_name}"
                                           + (f" ({spec.config_note})" if spec.config_note else ""))
        self.counters.extra.update({k: 0 for k in COUNTERS})
        self._warned: set[tuple[str, int]] = set()
        #: called when the interface fails, to say why if it can (StubProcess: "the stub died: ...")
        self.failure_context: Callable[[], str | None] | None = None
        self._closed = False
        self._sock = _socketcand_socket(bus)
        # slcan: python-can's recv(0) still waits for the serial port's read timeout, so further
        # frames are read only while the descriptor has data
        self._poll_fd: int | None = None
        if spec.interface == "slcan":
            try:
                self._poll_fd = bus.fileno()
            except (NotImplementedError, can.CanError):
                self._poll_fd = None
        # candump channel column: the bus name where it is one (can0, vcan0, hil0, PCAN_USBBUS1),
        # else slcan0-style (a device path or URL is no channel name)
        plain = spec.channel and re.fullmatch(r"[A-Za-z0-9_.-]+", spec.channel)
        self.log_channel = spec.channel if plain else f"{spec.interface}0"
        self.capture_path = capture_path
        self.logger = None
        self._log_lock = threading.Lock()
        #: pass frames of a known id with the wrong length on instead of dropping them (the
        #: engine's bridge: one place judges frames, the engine)
        self.deliver_wrong_length = False
        self._last_log_s = 0.0
        #: the candump log once closed and renamed into place: file, bytes, sha256 (the
        #: recording's ``sidecar.log`` metadata; bench check compares)
        self.capture_written: dict[str, str] | None = None
        if capture_path is not None:
            from hil_bench.record.atomic import partial_path

            # written aside (.<name>.partial), renamed when the link closes it
            try:
                self.logger = can.CanutilsLogWriter(str(partial_path(capture_path)),
                                                    channel=self.log_channel)
            except (OSError, ValueError) as exc:
                raise LinkError(f"cannot write the CAN log {capture_path}: {exc}") from None

    def _failure(self, text: str) -> LinkError:
        context = self.failure_context() if self.failure_context is not None else None
        return LinkError(f"{self.description}: {text}" + (f"; {context}" if context else ""))

    # -- sending ------------------------------------------------------------------------------------
    def _write_frames(self, frames):
        now = time.time()
        for fid, payload in frames:
            msg = can.Message(timestamp=now, arbitration_id=fid, data=payload, is_extended_id=False,
                              is_fd=self.fd, bitrate_switch=self.brs, is_rx=False,
                              channel=self.log_channel)
            if self.logger is not None:
                # logged before it is sent: its answer (read by another thread of the engine's
                # bridge) can then never be logged before it; a failed send ends the run
                self._log(msg)
            try:
                self.bus.send(msg, timeout=SEND_TIMEOUT_S)
            except (can.CanError, OSError) as exc:
                self.counters.extra["send_failures"] += 1
                raise self._failure(f"sending {fid:03X}#{payload.hex().upper()} failed "
                                    f"({type(exc).__name__}: {exc}); the adapter or the bus is "
                                    f"gone") from None
            self.counters.bytes_tx += len(payload)

    # -- receiving ----------------------------------------------------------------------------------
    def _recv(self, timeout_s: float) -> can.Message | None:
        try:
            msg = self.bus.recv(timeout_s)
            bad = getattr(self.bus, "malformed", None)
            while bad:
                self._on_malformed(repr(bad.pop(0))[1:])
            return msg
        except can.CanError as exc:
            raise self._failure(f"the CAN adapter stopped working ({type(exc).__name__}: {exc}); "
                                f"unplugged, crashed or closed?") from None
        except (ValueError, IndexError, UnicodeDecodeError) as exc:
            self._on_malformed(f"{type(exc).__name__}: {exc}")
            return None
        except OSError as exc:
            raise self._failure(f"reading failed ({exc}); the adapter is gone") from None

    def _on_malformed(self, what: str) -> None:
        self.counters.extra["rx_malformed"] += 1
        self._warn_once("malformed", 0, f"{self.description}: the interface received a line it cannot "
                                        f"parse ({what[:120]}); skipped and counted in rx_malformed "
                                        f"(further ones only counted)")

    def _recv_more(self) -> can.Message | None:
        if self._poll_fd is None:
            return self._recv(0.0)
        try:
            while select.select([self._poll_fd], [], [], 0)[0]:
                msg = self._recv(0.0)
                if msg is not None:
                    return msg
        except (OSError, ValueError) as exc:
            raise self._failure(f"the adapter's port failed ({exc})") from None
        return None

    def _read_frames(self, timeout_s):
        out: list[tuple[int, bytes]] = []
        msg = self._recv(timeout_s)
        if msg is None:
            self._check_peer()
            return out
        while msg is not None:
            self._take(msg, out)
            msg = self._recv_more()
        return out

    def _check_peer(self) -> None:
        """python-can's socketcand interface reads a closed connection as silence: look ourselves."""
        if self._sock is None:
            return
        try:
            readable = select.select([self._sock], [], [], 0)[0]
            closed = readable and self._sock.recv(1, socket.MSG_PEEK | socket.MSG_DONTWAIT) == b""
        except (BlockingIOError, InterruptedError):
            return
        except (OSError, ValueError) as exc:
            raise self._failure(f"the socketcand connection failed ({exc})") from None
        if closed:
            raise self._failure("the socketcand server closed the connection")

    def _log(self, msg: can.Message) -> None:
        """One line of the candump log. The engine's bridge sends and receives from two threads:
        the lines are written in the order the bench handled the frames (a sent frame just before
        it goes out), and a stamp is never earlier than the line before (an rx stamp the
        interface took just before a tx line was written is moved up to it)."""
        with self._log_lock:
            if msg.timestamp < self._last_log_s:
                msg.timestamp = self._last_log_s
            self._last_log_s = msg.timestamp
            self.logger.on_message_received(msg)

    def _take(self, msg: can.Message, out: list[tuple[int, bytes]]) -> None:
        if self.logger is not None:
            msg.channel = self.log_channel
            self._log(msg)
        extra = self.counters.extra
        if msg.is_error_frame:
            self._on_error_frame(msg)
            return
        if msg.is_remote_frame:
            extra["remote_frames"] += 1
            return
        fid = msg.arbitration_id
        data = bytes(msg.data)
        self.counters.bytes_rx += len(data)
        known = None if msg.is_extended_id else BY_ID.get(fid)
        if known is None:
            extra["can_unknown_ids"] += 1
            if not msg.is_extended_id:
                out.append((fid, data))
            return
        if len(data) != known.length:
            if self.deliver_wrong_length:   # the cycle engine judges and counts it (bridge)
                out.append((fid, data))
                return
            extra["length_errors"] += 1
            self._warn_once("dlc", fid, f"{self.description}: dropped {known.name} (0x{fid:03X}) with "
                                        f"{len(data)} octets, the DBC says {known.length} (counted in "
                                        f"length_errors; further ones only counted)")
            return
        out.append((fid, data))

    def _on_error_frame(self, msg: can.Message) -> None:
        extra = self.counters.extra
        extra["error_frames"] += 1
        cls = msg.arbitration_id & 0x1FFFFFFF
        if cls & CAN_ERR_BUSOFF:
            raise LinkError(f"{self.description}: bus-off (error frame class 0x{cls:03X}): a CAN "
                            f"controller on the bus stopped transmitting; check the bit rate, "
                            f"termination and wiring, then restart the interface")
        if cls & (CAN_ERR_CRTL | CAN_ERR_RESTARTED):
            state = msg.data[1] if len(msg.data) > 1 else 0
            if cls & CAN_ERR_RESTARTED or state & CAN_ERR_CRTL_STATE:
                extra["bus_state_changes"] += 1
        self._warn_once("error", cls, f"{self.description}: error frame class 0x{cls:03X} "
                                      f"(counted in error_frames)")

    def _warn_once(self, kind: str, key: int, text: str) -> None:
        if (kind, key) not in self._warned:
            self._warned.add((kind, key))
            log.warning(text)

    # -- budget, closing ------------------------------------------------------------------------------
    def max_cycle_rate_hz(self, flags):
        return budget.can_max_rate_hz(self.spec.bitrate, flags, fd=self.fd,
                                      data_bitrate=self.spec.data_bitrate if self.fd else None)

    def _close(self):
        if self._closed:
            return
        self._closed = True
        try:
            self.bus.shutdown()
        except Exception:  # noqa: BLE001 - a vanished adapter cannot be closed cleanly; never mask the cause
            pass
        if self.logger is not None:
            try:
                self.logger.stop()
            except OSError:
                return
            self._publish_capture()

    def _publish_capture(self) -> None:
        """The closed candump log into place (never over a file that appeared meanwhile: then it
        stays under its partial name, said on the logger)."""
        import hashlib

        from hil_bench.record.atomic import partial_path, publish

        tmp = partial_path(self.capture_path)
        sha = hashlib.sha256()
        size = 0
        try:
            with open(tmp, "rb") as f:
                for block in iter(lambda: f.read(1 << 20), b""):
                    sha.update(block)
                    size += len(block)
            publish(tmp, self.capture_path, replace=False)
        except OSError as exc:
            log.warning(f"the CAN log stays {tmp}: {exc}")
            return
        self.capture_written = {"file": self.capture_path.name, "bytes": str(size),
                                "sha256": sha.hexdigest()}


def open_can_link(spec: CanSpec, capture_path: Path | None = None) -> CanLink:
    """``--link can:...``: a drive (or anything speaking the protocol) on a python-can interface."""
    if spec.interface == "socketcand":
        _probe_socketcand(spec)
    bus = open_can_bus(spec)
    try:
        return CanLink(bus, spec, capture_path)
    except LinkError:
        bus.shutdown()
        raise


def _probe_socketcand(spec: CanSpec) -> None:
    """Fail fast and clearly when no server listens (python-can retries for 10 s, logging each try)."""
    host = str(spec.options.get("host", "127.0.0.1"))
    port = int(spec.options.get("port", SOCKETCAND_DEFAULT_PORT))   # type: ignore[arg-type]
    try:
        with socket.create_connection((host, port), timeout=2.0):
            pass
    except OSError as exc:
        raise LinkError(f"no socketcand server at {host}:{port} ({exc}); give host=... and port=... in "
                        f"the link spec") from None
