"""Host side of the link session (docs/protocol.md section 6): handshake, configuration, commands.

Every frame that crosses the link here is passed to ``on_frame(direction, frame_id, payload)``
so the recorder keeps it.

Whatever the controller answers, a bad answer is a :class:`ProtocolViolation` (a ``LinkError``) whose
message names the frame, the field and the value: a HELLO_ACK or CONFIG_ACK of the wrong length, a
status outside its value table, a CONFIG_ACK for another parameter, a FAULT_CTRL of any length. The
runner turns it into the run's error (recording finalised, non-zero exit), never a traceback.

While it waits during the handshake and the configuration the host sends HEARTBEAT_PLANT every 100 ms
(section 6.7). CMD frames carry ``seq`` 1, 2, ... per session (section 6.3).

Versions (section 6.1, section 10): HELLO says the host's protocol version (``proto_version`` major,
``proto_minor``), HELLO_ACK the version the session speaks (the lower minor). An older minor is served:
:meth:`HostSession.serve` keeps to what that version knows, names the features that are off, and refuses
(:class:`VersionRefused`) a run that needs one of them.
"""
from __future__ import annotations

import random
import time
from typing import Callable

from hil_bench.protocol import versions
from hil_bench.protocol.dbc import proto_minor as _proto_minor
from hil_bench.protocol.messages import (
    MESSAGES,
    PROTO_VERSION,
    Command,
    ConfigStatus,
    Fault,
    HelloStatus,
    Mode,
    Param,
    State,
)

from hil_bench.protocol.timing import (HEARTBEAT_PERIOD_S, HELLO_RETRY_S, PATIENCE_S,
                                       resend_times_s)

from .links.base import Link, LinkError

FrameLog = Callable[[str, int, bytes], None]

#: the host's own minor protocol version (HELLO.proto_minor)
PROTO_MINOR: int = _proto_minor()

_HELLO = MESSAGES["HELLO"]
_HELLO_ACK = MESSAGES["HELLO_ACK"]
_CONFIG = MESSAGES["CONFIG"]
_CONFIG_ACK = MESSAGES["CONFIG_ACK"]
_CMD = MESSAGES["CMD"]
_FAULT_CTRL = MESSAGES["FAULT_CTRL"]
_HEARTBEAT_PLANT = MESSAGES["HEARTBEAT_PLANT"]
#: link counters that count serial chunks the host rejected (HEARTBEAT_PLANT.rx_errors)
_RX_ERROR_COUNTERS = ("crc_errors", "cobs_errors", "length_errors", "overruns")


class ProtocolViolation(LinkError):
    """The controller answered something the protocol does not allow; the message names frame and field."""


class VersionRefused(LinkError):
    """The controller speaks an older protocol version that lacks something the run needs."""


class ControllerFault(LinkError):
    """The controller reported a fault (FAULT_CTRL)."""

    def __init__(self, text: str, code: int | None = None, seq: int | None = None):
        super().__init__(text)
        self.code = code
        self.seq = seq


def _hex(payload: bytes) -> str:
    return " ".join(f"{b:02X}" for b in payload) or "(empty)"


def describe_fault_ctrl(payload: bytes) -> str:
    """One line about a FAULT_CTRL payload, whatever its length or code (docs/protocol.md 6.7)."""
    if len(payload) != _FAULT_CTRL.length:
        return (f"controller sent FAULT_CTRL with {len(payload)} octets (expected {_FAULT_CTRL.length}): "
                f"fault code unreadable, payload {_hex(payload)}")
    v = _FAULT_CTRL.unpack(payload)
    code, seq, detail = int(v["code"]), int(v["seq"]), int(v["detail"])
    try:
        name = Fault(code).name
    except ValueError:
        name = f"FAULT_CTRL.code = {code}, which is not in the Fault table (docs/protocol.md section 5)"
    return f"controller reported fault {name} at seq {seq} (detail {detail})"


def fault_from_payload(payload: bytes) -> ControllerFault:
    """The exception a FAULT_CTRL ends the run with (any length: a short one is named as such)."""
    text = describe_fault_ctrl(payload)
    if len(payload) != _FAULT_CTRL.length:
        return ControllerFault(text)
    v = _FAULT_CTRL.unpack(payload)
    return ControllerFault(text, int(v["code"]), int(v["seq"]))


def _status_name(table, value: int, frame: str, context: str = "") -> str:
    try:
        return table(value).name
    except ValueError:
        known = ", ".join(f"{e.value} {e.name}" for e in table)
        raise ProtocolViolation(f"{frame}{context}: status = {value} is not in the {table.__name__} table "
                                f"({known}; docs/protocol.md section 5)") from None


def _check_length(frame: str, payload: bytes, length: int, context: str = "") -> None:
    if len(payload) != length:
        raise ProtocolViolation(f"{frame}{context} has {len(payload)} octets, expected {length} "
                                f"(payload {_hex(payload)}; docs/protocol.md section 4)")


class HostSession:
    """Drives HELLO -> CONFIG* -> CMD over a link."""

    def __init__(self, link: Link, on_frame: FrameLog | None = None,
                 alive: Callable[[], bool] | None = None, death_message: Callable[[], str] | None = None,
                 patience_s: float = PATIENCE_S, retry_timeout_s: float | None = None):
        """``patience_s``: the handshake gives up on a controller that answered nothing this long
        (``[link] patience_s``; one that died is found at once through ``alive``);
        ``retry_timeout_s``: a CONFIG without its CONFIG_ACK is re-sent this long after it was
        sent, then with the lockstep back-off (docs/protocol.md 6.2, 6.5)."""
        self.link = link
        self.patience_s = float(patience_s)
        self.resend_s = resend_times_s(*(() if retry_timeout_s is None else (retry_timeout_s,)),
                                       until_s=self.patience_s)
        self.on_frame = on_frame or (lambda d, i, p: None)
        self.alive = alive or (lambda: True)
        self.death_message = death_message or (lambda: "controller stopped answering")
        self.session_id = random.randrange(1, 0xFFFF)
        self.hello_ack: dict | None = None
        #: the minor version the session speaks (HELLO_ACK.proto_minor), once the handshake is done
        self.session_minor: int = PROTO_MINOR
        #: what the session leaves out because the controller's version lacks it (``serve``)
        self.features_off: list[str] = []
        self._config_seq = 0
        self._cmd_seq = 0
        self._hb_counter = 0
        self._hb_due: float | None = None   # None: heartbeats not started

    # -- sending ----------------------------------------------------------------------------------
    def send(self, frames: list[tuple[int, bytes]]) -> None:
        for fid, payload in frames:
            self.on_frame("tx", fid, payload)
        self.link.send(frames)

    def heartbeat_frame(self) -> tuple[int, bytes]:
        """The next HEARTBEAT_PLANT (counter +1 each call; state IDLE; the link's receive counters)."""
        stats = self.link.stats()
        rx_errors = sum(int(stats.get(k, 0)) for k in _RX_ERROR_COUNTERS)
        rx_frames = int(stats.get("frames_ok", stats.get("frames_rx", 0)))
        payload = _HEARTBEAT_PLANT.pack(counter=self._hb_counter & 0xFFFF, state=int(State.IDLE),
                                        rx_errors=rx_errors & 0xFFFF, rx_frames=rx_frames & 0xFFFF)
        self._hb_counter += 1
        return _HEARTBEAT_PLANT.frame_id, payload

    def _heartbeat_if_due(self) -> None:
        """HEARTBEAT_PLANT 100 ms after the first wait began (right after the first HELLO), then every
        100 ms; sent only between reads that found nothing to match, so it never overtakes an answer
        already on its way in a link's capture log."""
        now = time.monotonic()
        if self._hb_due is None:
            self._hb_due = now + HEARTBEAT_PERIOD_S
        elif now >= self._hb_due:
            self.send([self.heartbeat_frame()])
            self._hb_due = now + HEARTBEAT_PERIOD_S

    def _wait(self, predicate, timeout_s: float) -> tuple[int, bytes] | None:
        """recv_until in slices of at most one heartbeat period, sending HEARTBEAT_PLANT when due."""
        deadline = time.monotonic() + timeout_s
        while True:
            self._heartbeat_if_due()
            now = time.monotonic()
            if now >= deadline:
                return None
            slice_s = min(deadline - now, max(self._hb_due - now, 0.001))
            match = self.link.recv_until(predicate, slice_s, self._on_other)
            if match is not None:
                return match

    def _resends(self, timeout_s: float) -> list[float]:
        return [t for t in self.resend_s if t < timeout_s]

    def _wait_resending(self, predicate, frame: tuple[int, bytes], timeout_s: float):
        """_wait for ``timeout_s``, re-sending ``frame`` at the lockstep back-off times while nothing
        matches, and giving up at once when the controller died."""
        start = time.monotonic()
        for at in self._resends(timeout_s) + [timeout_s]:
            match = self._wait(predicate, max(0.0, start + at - time.monotonic()))
            if match is not None:
                return match
            if not self.alive():
                return None
            if at < timeout_s:
                self.send([frame])
        return None

    def _on_other(self, fid: int, payload: bytes) -> None:
        self.on_frame("rx", fid, payload)
        if fid == _FAULT_CTRL.frame_id:
            raise fault_from_payload(payload)

    # -- handshake ---------------------------------------------------------------------------------
    def handshake(self, *, period_s: float, estimator: int, flags: int,
                  mode: Mode = Mode.LOCKSTEP, timeout_s: float | None = None) -> dict:
        """Send HELLO every 100 ms until the matching HELLO_ACK (for the session's patience, or
        ``timeout_s``); raise LinkError on failure (at once when the controller died)."""
        timeout_s = self.patience_s if timeout_s is None else float(timeout_s)
        hello = _HELLO.pack(proto_version=PROTO_VERSION, proto_minor=PROTO_MINOR, mode=int(mode),
                            period_us=period_s * 1e6, estimator=int(estimator), flags=flags,
                            session=self.session_id)
        deadline = time.monotonic() + timeout_s
        wrong: dict[int, int] = {}    # session echoed instead of ours -> ACKs seen
        while time.monotonic() < deadline:
            self.send([(_HELLO.frame_id, hello)])
            retry_at = min(time.monotonic() + HELLO_RETRY_S, deadline)
            while time.monotonic() < retry_at:
                match = self._wait(lambda fid, p: fid == _HELLO_ACK.frame_id, retry_at - time.monotonic())
                if match is None:
                    break
                self.on_frame("rx", *match)
                _check_length("HELLO_ACK", match[1], _HELLO_ACK.length)
                ack = _HELLO_ACK.unpack(match[1])
                if int(ack["session"]) != self.session_id:
                    # a stale answer to an earlier HELLO: ignored (section 6.1), and remembered
                    wrong[int(ack["session"])] = wrong.get(int(ack["session"]), 0) + 1
                    continue
                return self._accept(ack, int(mode), int(estimator))
            if not self.alive():
                raise LinkError(self.death_message())
        if not self.alive():
            raise LinkError(self.death_message())
        if wrong:
            seen = ", ".join(f"0x{k:04X} ({n}x)"
                             for k, n in sorted(wrong.items(), key=lambda kv: -kv[1]))
            raise ProtocolViolation(
                f"the controller on {self.link.description} answers, but no HELLO_ACK within "
                f"{timeout_s:g} s echoed our session 0x{self.session_id:04X}: "
                f"{sum(wrong.values())} HELLO_ACK came with session {seen} "
                f"(HELLO_ACK.session must echo the HELLO's: docs/protocol.md 6.1)")
        raise LinkError(f"no controller answering on {self.link.description} "
                        f"(no HELLO_ACK within {timeout_s:g} s)")

    def _accept(self, ack: dict, mode: int, estimator: int) -> dict:
        status = int(ack["status"])
        name = _status_name(HelloStatus, status, "HELLO_ACK")
        version = int(ack["proto_version"])
        minor = int(ack["proto_minor"])
        if status != HelloStatus.OK:
            what = {
                HelloStatus.MODE_UNSUPPORTED: f" (the controller does not support mode {Mode(mode).name})",
                HelloStatus.ESTIMATOR_UNSUPPORTED: f" ({self._estimator_text(estimator, version, minor)})",
                HelloStatus.VERSION_MISMATCH: f" (controller protocol {version}, ours {PROTO_VERSION}."
                                              f"{PROTO_MINOR}: another major version)",
            }.get(HelloStatus(status), "")
            raise LinkError(f"controller refused the handshake: {name}{what}")
        if version != PROTO_VERSION:
            raise ProtocolViolation(f"HELLO_ACK: status OK but proto_version = {version}, ours is "
                                    f"{PROTO_VERSION} (docs/protocol.md section 6.1)")
        if minor > PROTO_MINOR:
            raise ProtocolViolation(f"HELLO_ACK: proto_minor = {minor}, above the host's {PROTO_MINOR}: the "
                                    f"session speaks the lower of the two (docs/protocol.md section 6.1)")
        self.session_minor = minor
        self.hello_ack = ack
        self._cmd_seq = 0   # a new session: CMD seq starts again at 1
        return ack

    @staticmethod
    def _estimator_text(estimator: int, major: int, minor: int) -> str:
        from hil_bench.protocol.messages import Estimator

        try:
            name = Estimator(estimator).name
        except ValueError:
            return f"estimator {estimator} was asked for"
        if major == PROTO_VERSION and minor < PROTO_MINOR and name not in versions.known(major, minor).estimators:
            return (f"estimator {estimator} {name} was asked for; the controller speaks protocol {major}.{minor}, "
                    f"and {name} came with {versions.added_in('estimators', name)}")
        return f"estimator {estimator} {name} was asked for"

    @property
    def version_text(self) -> str:
        """The version the session speaks, "1.1"."""
        return f"{PROTO_VERSION}.{self.session_minor}"

    def serve(self, params: dict[Param, float], *, needs_commands: dict[str, str] | None = None
              ) -> dict[Param, float]:
        """The parameters to send in this session (``hil_bench.protocol.versions.serve``): all of them when
        the controller speaks the host's version; to an older minor only what its version knows, the
        features left out listed in ``features_off``. Raises :class:`VersionRefused` naming what the run
        needs and the version lacks."""
        try:
            served, self.features_off = versions.serve(params, PROTO_VERSION, self.session_minor, needs_commands)
        except versions.NeedsNewerVersion as exc:
            raise VersionRefused(str(exc)) from None
        return served

    # -- configuration -----------------------------------------------------------------------------
    def configure(self, params: dict[Param, float], timeout_s: float | None = None) -> None:
        """Send every parameter and wait for each CONFIG_ACK, re-sending a CONFIG whose ACK has
        not come (the same octets: a controller answers every CONFIG, docs/protocol.md 6.2) on the
        lockstep back-off, for the session's patience (or ``timeout_s``); raise naming a rejected
        one, or the controller's death at once."""
        timeout_s = self.patience_s if timeout_s is None else float(timeout_s)
        for param, value in params.items():
            self._config_seq = (self._config_seq + 1) & 0xFFFF
            seq = self._config_seq
            frame = (_CONFIG.frame_id, _CONFIG.pack(param_id=int(param), config_seq=seq,
                                                    value=float(value)))
            self.send([frame])
            context = f" for {param.name}"

            def is_ack(fid: int, p: bytes, seq: int = seq, context: str = context) -> bool:
                if fid != _CONFIG_ACK.frame_id:
                    return False
                self.on_frame("rx", fid, p)
                _check_length("CONFIG_ACK", p, _CONFIG_ACK.length, context)
                return int(_CONFIG_ACK.unpack(p)["config_seq"]) == seq

            match = self._wait_resending(is_ack, frame, timeout_s)
            if match is None:
                if not self.alive():
                    raise LinkError(self.death_message())
                raise LinkError(f"no CONFIG_ACK for {param.name} within {timeout_s:g} s "
                                f"(patience_s; the CONFIG was sent {1 + len(self._resends(timeout_s))} "
                                f"times): the controller answered nothing")
            ack = _CONFIG_ACK.unpack(match[1])
            status = int(ack["status"])
            name = _status_name(ConfigStatus, status, "CONFIG_ACK", context)
            if int(ack["param_id"]) != int(param):
                raise ProtocolViolation(f"CONFIG_ACK{context} (config_seq {seq}): param_id = "
                                        f"{int(ack['param_id'])}, expected {int(param)} "
                                        f"(docs/protocol.md section 6.2)")
            if status != ConfigStatus.OK:
                raise LinkError(f"controller rejected parameter {param.name} = {value!r}: {name}")

    # -- commands ----------------------------------------------------------------------------------
    def next_cmd_seq(self) -> int:
        """The ``seq`` of the next CMD: 1 for the first of a session, +1 per CMD, modulo 65536."""
        self._cmd_seq = (self._cmd_seq + 1) & 0xFFFF
        return self._cmd_seq

    def command_frame(self, command: Command, value: float = 0.0,
                      seq: int | None = None) -> tuple[int, bytes]:
        """A CMD frame; ``seq`` defaults to the session's next CMD sequence number."""
        if seq is None:
            seq = self.next_cmd_seq()
        return _CMD.frame_id, _CMD.pack(command=int(command), seq=seq & 0xFFFF, value=float(value))

    def command(self, command: Command, value: float = 0.0, seq: int | None = None) -> None:
        self.send([self.command_frame(command, value, seq)])


