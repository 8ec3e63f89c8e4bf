"""The file descriptor the C cycle engine does its link I/O on, for every kind of link.

* A pty (the stub), a serial port, a ``socket://`` URL: the link's own descriptor; the engine
  reads and writes the serial framing on it directly.
* SocketCAN (python-can's ``socketcan`` interface): the bus's raw CAN socket; the engine reads
  and writes ``struct can_frame`` / ``canfd_frame`` on it directly.
* Software in the loop (``--link sil``): no descriptor; the engine calls the firmware's SIL port
  in its own thread (``sil``, plant_rt/c/engine_sil.h).
* Every other backend (python-can's slcan, socketcand, pcan, kvaser, vector, ...; pyserial URL
  handlers without a descriptor such as ``rfc2217://``): a bridge. The engine gets one end of
  a ``socketpair``; two Python threads move data between the other end and the backend
  (frames as ``struct can_frame`` datagrams on a SOCK_SEQPACKET pair for CAN; bytes on a
  SOCK_STREAM pair for serial). The engine does not know the difference. A bridged link is as
  fast as its Python backend (rates in docs/performance.md); the per-cycle logic stays in C.

A backend failure on a bridge (bus-off, adapter unplugged) closes the engine's end, so the
engine ends the run as "peer closed the link", and ``error`` holds the backend's own message.
"""
from __future__ import annotations

import os
import socket
import struct
import threading

from .base import Link, LinkError

CAN_FRAME = struct.Struct("<IB3x8s")        # struct can_frame (16 octets)
CANFD_FRAME = struct.Struct("<IBBxx64s")    # struct canfd_frame (72 octets)
CAN_MTU, CANFD_MTU = CAN_FRAME.size, CANFD_FRAME.size
CANFD_BRS = 0x01


class EngineLink:
    """What the engine is handed: a descriptor, its kind, and a way to stop what feeds it."""

    def __init__(self, fd: int, kind: str, description: str, bridge=None, sil=None):
        self.fd = fd
        self.kind = kind                 # "serial", "can" or "canfd"
        self.description = description
        self.bridge = bridge
        self.sil = sil                   # software in the loop: the firmware's sil_port_t (fd -1)

    @property
    def error(self) -> str | None:
        return self.bridge.error if self.bridge is not None else None

    def extra_counters(self) -> dict[str, int]:
        return self.bridge.counters() if self.bridge is not None else {}

    def settle(self, timeout_s: float = 0.2) -> None:
        """Let a bridge pass on what the engine wrote last (before its counters are read)."""
        if self.bridge is not None:
            self.bridge.settle(timeout_s)

    def close(self) -> None:
        if self.bridge is not None:
            self.bridge.stop()


class _Bridge:
    def __init__(self, kind: int):
        self.engine_end, self._ours = socket.socketpair(socket.AF_UNIX, kind)
        self.error: str | None = None
        self._stop = threading.Event()
        self._threads: list[threading.Thread] = []

    def _start(self, *targets) -> None:
        for t in targets:
            th = threading.Thread(target=self._guard, args=(t,), daemon=True, name="hil-bridge")
            th.start()
            self._threads.append(th)

    def _guard(self, fn) -> None:
        try:
            fn()
        except (LinkError, OSError) as exc:
            if not self._stop.is_set():
                self.error = self.error or str(exc)
                self._hang_up()
        except Exception as exc:  # noqa: BLE001 - never die silently: the engine would wait
            self.error = self.error or f"link bridge failed: {type(exc).__name__}: {exc}"
            self._hang_up()

    def _hang_up(self) -> None:
        try:
            self._ours.shutdown(socket.SHUT_RDWR)
        except OSError:
            pass

    def counters(self) -> dict[str, int]:
        return {}

    def settle(self, timeout_s: float) -> None:
        """Wait until nothing the engine wrote is left unread on the pair (bounded)."""
        import select
        import time

        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            r, _, _ = select.select([self._ours], [], [], 0)
            if not r:
                time.sleep(0.005)      # the thread that read it may still be sending it
                r, _, _ = select.select([self._ours], [], [], 0)
                if not r:
                    return
            time.sleep(0.002)

    def stop(self) -> None:
        self._stop.set()
        self._hang_up()
        for th in self._threads:
            th.join(1.0)
        for s in (self._ours, self.engine_end):
            try:
                s.close()
            except OSError:
                pass


class CanBridge(_Bridge):
    """python-can backend <-> SOCK_SEQPACKET pair of ``struct can_frame``/``canfd_frame``."""

    def __init__(self, link: Link, fd: bool):
        super().__init__(socket.SOCK_SEQPACKET)
        self.link = link
        self.fd = fd
        link.deliver_wrong_length = True
        self._start(self._to_engine, self._from_engine)

    def _to_engine(self) -> None:
        while not self._stop.is_set():
            for fid, payload in self.link.recv(0.05):
                if len(payload) > 8 or self.fd:
                    data = CANFD_FRAME.pack(fid, len(payload), 0, bytes(payload).ljust(64, b"\0"))
                else:
                    data = CAN_FRAME.pack(fid, len(payload), bytes(payload).ljust(8, b"\0"))
                self._ours.send(data)

    def _from_engine(self) -> None:
        while not self._stop.is_set():
            data = self._ours.recv(CANFD_MTU)
            if not data:
                return   # the engine closed its end
            if len(data) == CAN_MTU:
                can_id, n, payload = CAN_FRAME.unpack(data)
            else:
                can_id, n, _flags, payload = CANFD_FRAME.unpack(data)
            self.link.send([(can_id & 0x7FF, payload[:n])])

    def counters(self) -> dict[str, int]:
        s = self.link.stats()
        return {"error_frames": s.get("error_frames", 0), "remote_frames": s.get("remote_frames", 0),
                "ext_ids": s.get("can_unknown_ids", 0), "rx_malformed": s.get("rx_malformed", 0),
                "send_failures": s.get("send_failures", 0),
                "bus_state_changes": s.get("bus_state_changes", 0)}


class ByteBridge(_Bridge):
    """A pyserial transport without a descriptor <-> SOCK_STREAM pair of raw bytes."""

    def __init__(self, transport):
        super().__init__(socket.SOCK_STREAM)
        self.transport = transport
        self._start(self._to_engine, self._from_engine)

    def _to_engine(self) -> None:
        while not self._stop.is_set():
            data = self.transport.read(0.05)
            if data:
                self._ours.sendall(data)

    def _from_engine(self) -> None:
        while not self._stop.is_set():
            data = self._ours.recv(65536)
            if not data:
                return
            self.transport.write(data)


def engine_link_for(link: Link) -> EngineLink:
    """The descriptor the engine uses for ``link`` (a bridge where the backend has none)."""
    from .serial_link import FdTransport, PySerialTransport, SerialLink
    from .sil import SilTransport

    if isinstance(link, SerialLink):
        t = link.transport
        if isinstance(t, SilTransport):
            return EngineLink(-1, "serial", link.description, sil=t.port)
        if isinstance(t, FdTransport):
            return EngineLink(t.fd, "serial", link.description)
        if isinstance(t, PySerialTransport):
            port = t.port
            fd = getattr(port, "fd", None)
            if fd is None and getattr(port, "_socket", None) is not None:
                fd = port._socket.fileno()     # pyserial's socket:// handler
            if isinstance(fd, int) and fd >= 0:
                return EngineLink(fd, "serial", link.description)
        bridge = ByteBridge(t)
        return EngineLink(bridge.engine_end.fileno(), "serial",
                          f"{link.description} (bridged)", bridge)
    from .can_link import CanLink

    if isinstance(link, CanLink):
        fd_mode = bool(getattr(link, "fd", False))
        sock = getattr(link.bus, "socket", None)
        if link.spec.interface == "socketcan" and isinstance(sock, socket.socket):
            return EngineLink(sock.fileno(), "canfd" if fd_mode else "can", link.description)
        bridge = CanBridge(link, fd_mode)
        return EngineLink(bridge.engine_end.fileno(), "canfd" if fd_mode else "can",
                          f"{link.description} (bridged)", bridge)
    raise LinkError(f"{link.description}: no way to give this link to the cycle engine")


def set_blocking(fd: int) -> None:
    """Give a descriptor back to Python code that expects blocking-with-select semantics."""
    try:
        os.set_blocking(fd, True)
    except OSError:
        pass
