"""Links to the controller under test, chosen by a spec string (``--link``).

==========================================  ================================================
spec                                        meaning
==========================================  ================================================
``stub`` (default)                          start the C firmware stub on a new pty
``serial:<port-or-url>[@baud]``             a real drive on a UART, or any pyserial URL
                                            (``socket://host:port``); default 3 000 000 baud
==========================================  ================================================

Backends are imported only when chosen (python-can's ``BACKENDS`` pattern).
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from .base import Link, LinkError

DEFAULT_SERIAL_BAUD = 3_000_000


@dataclass
class OpenedLink:
    link: Link
    stub: object | None  # StubProcess when the bench started the stub itself

    def close(self) -> int | None:
        if self.stub is not None:
            return self.stub.stop()
        self.link.close()
        return None


def parse_serial_spec(rest: str) -> tuple[str, int]:
    url, sep, baud = rest.rpartition("@")
    if not sep:
        return rest, DEFAULT_SERIAL_BAUD
    try:
        return url, int(baud)
    except ValueError:
        raise LinkError(f"bad baud rate {baud!r} in link spec 'serial:{rest}'") from None


def open_link(spec: str = "stub", stub_args: tuple[str, ...] = (),
              capture_path: Path | None = None) -> OpenedLink:
    """Open the link a spec names. ``capture_path``: where a backend that has a standard capture
    format writes the raw traffic beside the recording (CAN: a candump .log); others ignore it."""
    kind, _, rest = spec.partition(":")
    if kind == "stub":
        from .stub import StubProcess

        stub = StubProcess(stub_args)
        return OpenedLink(stub.link, stub)
    if kind == "serial":
        from .serial_link import PySerialTransport, SerialLink

        if not rest:
            raise LinkError("link spec 'serial:' needs a port, e.g. serial:/dev/ttyUSB0@3000000")
        url, baud = parse_serial_spec(rest)
        return OpenedLink(SerialLink(PySerialTransport(url, baud), baud=baud), None)
    raise LinkError(f"unknown link spec {spec!r}: use 'stub' or 'serial:<port>[@baud]'")


__all__ = ["Link", "LinkError", "OpenedLink", "open_link"]
