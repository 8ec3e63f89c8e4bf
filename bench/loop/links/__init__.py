"""Links to the controller under test, chosen by a spec string (``--link``).

==============================================================  ================================================
spec                                                            meaning
==============================================================  ================================================
``stub`` (default)                                              start the C firmware stub on a new pty
``sil``                                                         software in the loop: the firmware's C in this
                                                                process, called from the engine's thread, the
                                                                serial framing in memory (links/sil.py)
``serial:<port-or-url>[@baud]``                                 a real drive on a UART, or any pyserial URL
                                                                (``socket://host:port``); default 3 000 000 baud
``can:<interface>:<channel>[@bitrate][,fd][,data_bitrate=N]``   a drive on any python-can interface (socketcan,
``[,key=value...]``                                             pcan, kvaser, vector, slcan, socketcand, virtual,
                                                                ...); default 1 Mbit/s; ``key=value`` go to
                                                                ``can.Bus`` (e.g. ``host=``, ``port=`` for
                                                                socketcand, ``tty_baudrate=`` for slcan)
``can[:<interface>[:<channel>]][@bitrate][...][,context=NAME]`` what the spec leaves out (interface, channel, bit
                                                                rate, fd, data bit rate, other Bus arguments)
                                                                comes from python-can's own configuration:
                                                                ``can.rc``, ``CAN_INTERFACE`` / ``CAN_CHANNEL`` /
                                                                ``CAN_BITRATE`` / ``CAN_CONFIG`` (``_<NAME>``
                                                                with a context), ~/.canrc and the other
                                                                config files (section ``[NAME]``, else
                                                                ``[default]``): ``can.util.load_config``
``stub-slcan[@bitrate][,fd][,data_bitrate=N]``                  the stub as a USB-CAN adapter speaking SLCAN on a
                                                                pty, opened with python-can's slcan interface
``stub-socketcand[@bitrate]``                                   the stub as a socketcand server on loopback TCP,
                                                                opened with python-can's socketcand interface
``stub-socketcan[:<iface>][@bitrate][,fd][,data_bitrate=N]``    the stub on a SocketCAN interface (default vcan0;
                                                                needs kernel CAN), python-can's socketcan
``pil-qemu[:<elf>]``                                            the firmware cross-compiled for a Cortex-M4F
                                                                (firmware_stub/port/cortex_m) in QEMU's
                                                                netduinoplus2 (STM32F405), USART1 on a pty
                                                                (qemu.py; lockstep)
==============================================================  ================================================

Bit rates are integers or take a k/M suffix (``500k``, ``1M``). On interfaces whose bit rate is set
outside the bench (socketcan: ``ip link``; socketcand: the server) the given rate only feeds the link
budget, so give the bus's real rate.

Backends are imported only when chosen (python-can's ``BACKENDS`` pattern).
"""
from __future__ import annotations

import os
import re
from dataclasses import dataclass
from pathlib import Path

from .base import Link, LinkError

DEFAULT_SERIAL_BAUD = 3_000_000
DEFAULT_CAN_BITRATE = 1_000_000
DEFAULT_STUB_SOCKETCAN_IFACE = "vcan0"
STUB_CAN_MODES = {"stub-slcan": "slcan", "stub-socketcand": "socketcand", "stub-socketcan": "socketcan"}

_KIND = re.compile(r"([a-z][a-z0-9-]*)(.*)\Z", re.S)
_RATE = re.compile(r"(\d+(?:\.\d+)?)([kKmM]?)\Z")


@dataclass
class OpenedLink:
    link: Link
    #: the controller process the bench started and ends: StubProcess (hil_stub) or QemuProcess
    #: (pil-qemu); None for a drive
    stub: object | None

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


def parse_rate(text: str, what: str, spec: str) -> int:
    """``1000000``, ``1M``, ``500k``, ``83.3k`` -> bit/s."""
    m = _RATE.match(text.strip())
    if not m:
        raise LinkError(f"bad {what} {text!r} in link spec {spec!r}: use a number of bit/s, e.g. "
                        f"1000000, 1M or 500k")
    value = float(m.group(1)) * {"": 1, "k": 1e3, "m": 1e6}[m.group(2).lower()]
    if value <= 0:
        raise LinkError(f"bad {what} {text!r} in link spec {spec!r}: must be > 0")
    return int(round(value))


def _option_value(text: str) -> object:
    low = text.lower()
    if low in ("true", "yes", "on"):
        return True
    if low in ("false", "no", "off"):
        return False
    for conv in (int, float):
        try:
            return conv(text)
        except ValueError:
            pass
    return text


def _parse_can_tail(head: str, options: list[str], spec: str, interface: str):
    """``channel[@bitrate]`` and the comma options -> CanSpec (python-can imported here); the
    spec's ``given`` names what it stated."""
    from .can_link import CanSpec, check_can_rates

    channel, at, rate = head.rpartition("@")
    if not at:
        channel, rate = head, ""
    bitrate = parse_rate(rate, "bit rate", spec) if rate else DEFAULT_CAN_BITRATE
    fd = False
    data_bitrate = None
    extra: dict[str, object] = {}
    given = {"bitrate"} if rate else set()
    for opt in options:
        key, eq, value = (s.strip() for s in opt.partition("="))
        if not key:
            raise LinkError(f"empty option in link spec {spec!r}")
        if key == "fd":
            fd = True if not eq else bool(_option_value(value))
            given.add("fd")
        elif key == "data_bitrate":
            if not eq or not value:
                raise LinkError(f"link spec {spec!r}: data_bitrate needs a value, e.g. data_bitrate=5M")
            data_bitrate = parse_rate(value, "data bit rate", spec)
            given.add("data_bitrate")
        elif not eq:
            raise LinkError(f"link spec {spec!r}: option {key!r} needs a value (key=value); the "
                            f"flags are 'fd'")
        else:
            extra[key] = _option_value(value)
    can_spec = CanSpec(interface=interface, channel=channel, bitrate=bitrate, fd=fd,
                       data_bitrate=data_bitrate, bitrate_given=bool(rate), options=extra,
                       given=frozenset(given | {k for k, v in (("interface", interface),
                                                               ("channel", channel)) if v}))
    check_can_rates(can_spec, spec)
    return can_spec


def parse_can_spec(spec: str):
    """``can[:<interface>[:<channel>]][@bitrate][,fd][,data_bitrate=N][,context=NAME]
    [,key=value...]`` -> CanSpec. What the spec leaves out comes from python-can's own
    configuration (``can.util.load_config``, section/suffix ``context``): can_link.py."""
    from .can_link import CAN_SPEC_USAGE, with_python_can_config

    body = spec[len("can"):] if spec.startswith("can") else spec
    head, *options = body.split(",")
    where, at, rate = head.rpartition("@") if "@" in head else (head, "", "")
    if where and not where.startswith(":"):
        raise LinkError(f"link spec {spec!r}: {CAN_SPEC_USAGE}")
    interface, _, channel = where[1:].partition(":")
    if where and not interface.strip():
        raise LinkError(f"link spec {spec!r}: {CAN_SPEC_USAGE}")
    can_spec = _parse_can_tail(channel.strip() + at + rate, options, spec, interface.strip())
    return with_python_can_config(can_spec, spec)


def parse_stub_can_spec(kind: str, tail: str, spec: str):
    """``stub-slcan...``, ``stub-socketcand...``, ``stub-socketcan[:iface]...`` -> CanSpec (the
    channel is filled in by the stub launcher, except the SocketCAN interface)."""
    mode = STUB_CAN_MODES[kind]
    head, *options = tail.split(",")
    if mode == "socketcan":
        iface = head[1:] if head.startswith(":") else head
        if not iface or iface.startswith("@"):
            iface = DEFAULT_STUB_SOCKETCAN_IFACE + iface
        head = iface
    elif head and not head.startswith("@"):
        raise LinkError(f"link spec {spec!r}: use {kind}[@bitrate][,fd][,data_bitrate=N]")
    else:
        head = "stub" + head
    can_spec = _parse_can_tail(head, options, spec, mode)
    can_spec.bitrate_given = True   # the stub's bus runs at whatever rate the spec says
    if mode == "socketcand" and can_spec.fd:
        raise LinkError(f"link spec {spec!r}: python-can's socketcand interface carries classic CAN "
                        f"only: drop ',fd'")
    return can_spec


def spec_max_cycle_rate_hz(spec: str, flags: int) -> tuple[float, str] | None:
    """(highest control rate, the link's name) a link spec carries with the HELLO ``flags``'
    frames, from the spec alone (serial baud rate, CAN bit rates: protocol/budget.py), so that a
    scenario the link cannot carry is refused before the port is opened; None when only the
    opened link can tell (the stub's links)."""
    from hil_bench.protocol import budget

    m = _KIND.match(spec)
    kind, tail = (m.group(1), m.group(2)) if m else ("", spec)
    rest = tail[1:] if tail.startswith(":") else tail
    if kind == "serial" and rest:
        url, baud = parse_serial_spec(rest)
        return budget.serial_max_rate_hz(baud, flags), f"serial {url} at {baud} baud"
    if kind == "can":
        cs = parse_can_spec(spec)
        return (budget.can_max_rate_hz(cs.bitrate, flags, fd=cs.fd,
                                       data_bitrate=cs.data_bitrate if cs.fd else None),
                f"CAN {cs.interface}:{cs.channel} at {cs.bitrate} bit/s")
    return None


#: every kind of link spec, for "did you mean" (the table above)
LINK_KINDS = ("stub", "sil", "serial", "can", *STUB_CAN_MODES, "pil-qemu")
LINK_USAGE = ("use 'stub', 'sil', 'serial:<port>[@baud]', 'can:<interface>:<channel>[@bitrate][,fd]', "
              "'can' (python-can's configuration), 'stub-slcan', 'stub-socketcand', "
              "'stub-socketcan[:<iface>]' or 'pil-qemu[:<elf>]' (docs/protocol.md 8)")
#: options of the stub's CAN links besides the python-can Bus's own keyword arguments
_STUB_CAN_OPTIONS = ("fd", "data_bitrate")


def _bus_options(interface: str) -> set[str] | None:
    """The keyword arguments python-can's Bus of ``interface`` names (None: it cannot tell)."""
    import inspect

    try:
        import can

        module, cls = can.interfaces.BACKENDS[interface]
        bus = getattr(__import__(module, fromlist=[cls]), cls)
        names = set()
        for klass in (bus, can.BusABC):
            names |= {p for p in inspect.signature(klass.__init__).parameters if p != "self"}
        return names - {"args", "kwargs", "config"}
    except Exception:  # noqa: BLE001 - an interface that does not load: its Bus says what is wrong
        return None


def check_link_spec(spec: object, option: str = "--link") -> str:
    """``spec`` if it names a link this bench can open, else LinkError: an empty spec, an unknown
    kind or form (with "did you mean"), an unknown option of the stub's CAN links. Nothing is
    opened; a port or interface that is not there is said by open_link."""
    from hil_bench.errors import did_you_mean

    if not isinstance(spec, str):
        raise LinkError(f"{option} {spec!r}: a link spec is a string, e.g. 'stub' or "
                        f"'serial:/dev/ttyUSB0@3000000'")
    if not spec.strip():
        raise LinkError(f"{option} is empty (an unset variable, e.g. $HIL_LINK?): name the "
                        f"controller's link; {LINK_USAGE}")
    m = _KIND.match(spec)
    kind, tail = (m.group(1), m.group(2)) if m else ("", spec)
    head = re.split(r"[:@,]", spec, maxsplit=1)[0]
    if kind in ("stub", "sil") and tail:
        what = "firmware stub on a pty" if kind == "stub" else "firmware in this process"
        raise LinkError(f"{option} {spec!r}: '{kind}' (the bundled {what}) takes nothing after "
                        f"it; did you mean '{kind}'? (a drive: serial:<port>[@baud] or "
                        f"can:<interface>:<channel>; {LINK_USAGE})")
    if kind == "pil-qemu" and tail and not tail.startswith(":"):
        raise LinkError(f"{option} {spec!r}: use pil-qemu or pil-qemu:<path to the ELF>")
    if kind in ("serial", "can") and tail and not tail.startswith((":", "@", ",")) \
            or kind not in LINK_KINDS:
        raise LinkError(f"{option} {spec!r}: unknown link spec{did_you_mean(head, LINK_KINDS)} "
                        f"({LINK_USAGE})")
    if kind == "serial":
        rest = tail[1:] if tail.startswith(":") else tail
        if not rest:
            raise LinkError(f"{option} {spec!r}: 'serial:' needs a port, e.g. "
                            f"serial:/dev/ttyUSB0@3000000")
        port, _ = parse_serial_spec(rest)
        if "://" not in port and not os.path.exists(port):
            raise LinkError(f"{option} {spec!r}: the serial port {port} does not exist (plugged "
                            f"in? `ls /dev/serial/by-id/` lists the USB ones)")
    if kind == "pil-qemu" and tail:
        elf = tail[1:]
        if not elf or not os.path.isfile(elf):
            raise LinkError(f"{option} {spec!r}: the firmware ELF {elf or '(none given)'} does not "
                            f"exist (pil-qemu alone builds and runs the bundled Cortex-M port)")
    if kind in STUB_CAN_MODES:
        can_spec = parse_stub_can_spec(kind, tail, spec)
        known = _bus_options(STUB_CAN_MODES[kind])
        if known is not None:
            for key in can_spec.options:
                if key not in known:
                    choices = sorted(set(_STUB_CAN_OPTIONS) | known)
                    raise LinkError(f"{option} {spec!r}: unknown option {key!r} of the stub's "
                                    f"{STUB_CAN_MODES[kind]} link{did_you_mean(key, choices)} "
                                    f"(options: {', '.join(choices)})")
    return spec


def open_link(spec: str = "stub", stub_args: tuple[str, ...] = (),
              capture_path: Path | None = None) -> OpenedLink:
    """Open the link a spec names. ``capture_path``: where a backend that has a standard capture
    format writes the raw traffic beside the recording (CAN: a candump .log, written aside and
    renamed when the link closes); others ignore it."""
    check_link_spec(spec)
    m = _KIND.match(spec)
    kind, tail = (m.group(1), m.group(2)) if m else ("", spec)
    if kind == "stub" and not tail:
        from .stub import StubProcess

        stub = StubProcess(stub_args)
        return OpenedLink(stub.link, stub)
    if kind == "sil" and not tail:
        from .sil import open_sil_link

        return OpenedLink(open_sil_link(stub_args), None)
    if kind in STUB_CAN_MODES:
        from .stub import StubProcess

        can_spec = parse_stub_can_spec(kind, tail, spec)
        stub = StubProcess(stub_args, mode=STUB_CAN_MODES[kind], can_spec=can_spec,
                           capture_path=capture_path)
        return OpenedLink(stub.link, stub)
    rest = tail[1:] if tail.startswith(":") else tail
    if kind == "pil-qemu" and (not tail or tail.startswith(":")):
        from .qemu import QemuProcess

        qemu = QemuProcess(elf=Path(rest) if rest else None)
        return OpenedLink(qemu.link, qemu)
    if kind == "serial":
        from .serial_link import PySerialTransport, SerialLink

        if not rest:
            raise LinkError("link spec 'serial:' needs a port, e.g. serial:/dev/ttyUSB0@3000000")
        url, baud = parse_serial_spec(rest)
        return OpenedLink(SerialLink(PySerialTransport(url, baud), baud=baud), None)
    if kind == "can":
        from .can_link import open_can_link

        return OpenedLink(open_can_link(parse_can_spec(spec), capture_path), None)
    raise LinkError(f"unknown link spec {spec!r}: {LINK_USAGE}")


__all__ = ["Link", "LinkError", "OpenedLink", "check_link_spec", "open_link", "parse_can_spec", "parse_stub_can_spec",
           "spec_max_cycle_rate_hz"]
