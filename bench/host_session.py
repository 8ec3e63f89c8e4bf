"""Host side of the link session (docs/protocol.md): handshake, configuration, commands.

Every frame that crosses the link here is passed to ``on_frame(direction, frame_id, payload)``
so the recorder keeps it.
"""
from __future__ import annotations

import random
import time
from typing import Callable

from protocol.messages import (MESSAGES, PROTO_VERSION, Command, ConfigStatus, Fault,
                               HelloStatus, Mode, Param)

from .links.base import Link, LinkError

HELLO_RETRY_S = 0.1
HELLO_TIMEOUT_S = 2.0
CONFIG_TIMEOUT_S = 1.0


FrameLog = Callable[[str, int, bytes], None]

_HELLO = MESSAGES["HELLO"]
_HELLO_ACK = MESSAGES["HELLO_ACK"]
_CONFIG = MESSAGES["CONFIG"]
_CONFIG_ACK = MESSAGES["CONFIG_ACK"]
_CMD = MESSAGES["CMD"]
_FAULT_CTRL = MESSAGES["FAULT_CTRL"]


class ControllerFault(LinkError):
    """The controller reported a fault (FAULT_CTRL)."""

    def __init__(self, code: int, seq: int, detail: int):
        try:
            name = Fault(code).name
        except ValueError:
            name = f"unknown code {code}"
        super().__init__(f"controller reported fault {name} at seq {seq} (detail {detail})")
        self.code = code
        self.seq = seq


def fault_from_payload(payload: bytes) -> ControllerFault:
    v = _FAULT_CTRL.unpack(payload)
    return ControllerFault(int(v["code"]), int(v["seq"]), int(v["detail"]))


class HostSession:
    """Drives HELLO -> CONFIG* -> CMD over a link."""

    def __init__(self, link: Link, on_frame: FrameLog | None = None,
                 alive: Callable[[], bool] | None = None, death_message: Callable[[], str] | None = None):
        self.link = link
        self.on_frame = on_frame or (lambda d, i, p: None)
        self.alive = alive or (lambda: True)
        self.death_message = death_message or (lambda: "controller stopped answering")
        self.session_id = random.randrange(1, 0xFFFF)
        self.hello_ack: dict | None = None
        self._config_seq = 0

    def send(self, frames: list[tuple[int, bytes]]) -> None:
        for fid, payload in frames:
            self.on_frame("tx", fid, payload)
        self.link.send(frames)

    def _on_other(self, fid: int, payload: bytes) -> None:
        self.on_frame("rx", fid, payload)
        if fid == _FAULT_CTRL.frame_id:
            raise fault_from_payload(payload)

    def handshake(self, *, period_s: float, estimator: int, flags: int,
                  mode: Mode = Mode.LOCKSTEP, timeout_s: float = HELLO_TIMEOUT_S) -> dict:
        """Send HELLO every 100 ms until the matching HELLO_ACK; raise LinkError on failure."""
        hello = _HELLO.pack(proto_version=PROTO_VERSION, mode=int(mode), period_us=period_s * 1e6,
                            estimator=int(estimator), flags=flags, session=self.session_id)
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            self.send([(_HELLO.frame_id, hello)])
            match = self.link.recv_until(
                lambda fid, p: fid == _HELLO_ACK.frame_id
                and _HELLO_ACK.unpack(p)["session"] == self.session_id,
                HELLO_RETRY_S, self._on_other)
            if match is not None:
                self.on_frame("rx", *match)
                ack = _HELLO_ACK.unpack(match[1])
                if int(ack["status"]) != HelloStatus.OK:
                    raise LinkError(f"controller refused the handshake: "
                                    f"{HelloStatus(int(ack['status'])).name} (controller "
                                    f"protocol {int(ack['proto_version'])}, ours {PROTO_VERSION})")
                self.hello_ack = ack
                return ack
            if not self.alive():
                raise LinkError(self.death_message())
        raise LinkError(f"no controller answering on {self.link.description} "
                        f"(no HELLO_ACK within {timeout_s:g} s)")

    def configure(self, params: dict[Param, float], timeout_s: float = CONFIG_TIMEOUT_S) -> None:
        """Send every parameter and wait for each CONFIG_ACK; raise naming a rejected one."""
        for param, value in params.items():
            self._config_seq = (self._config_seq + 1) & 0xFFFF
            seq = self._config_seq
            self.send([(_CONFIG.frame_id, _CONFIG.pack(param_id=int(param), config_seq=seq,
                                                       value=float(value)))])
            match = self.link.recv_until(
                lambda fid, p: fid == _CONFIG_ACK.frame_id
                and _CONFIG_ACK.unpack(p)["config_seq"] == seq,
                timeout_s, self._on_other)
            if match is None:
                if not self.alive():
                    raise LinkError(self.death_message())
                raise LinkError(f"no CONFIG_ACK for {param.name} within {timeout_s:g} s")
            self.on_frame("rx", *match)
            status = int(_CONFIG_ACK.unpack(match[1])["status"])
            if status != ConfigStatus.OK:
                raise LinkError(f"controller rejected parameter {param.name} = {value!r}: "
                                f"{ConfigStatus(status).name}")

    def command_frame(self, command: Command, value: float = 0.0, seq: int = 0) -> tuple[int, bytes]:
        return _CMD.frame_id, _CMD.pack(command=int(command), seq=seq & 0xFFFF, value=float(value))

    def command(self, command: Command, value: float = 0.0, seq: int = 0) -> None:
        self.send([self.command_frame(command, value, seq)])
