"""CanLink on its own (python-can's virtual interface plays the drive), the CAN link specs and the
CAN budget. The stub behind SLCAN / socketcand is tested in tests/test_can_stub.py."""
from __future__ import annotations

import logging
import re
import uuid
from pathlib import Path

import can
import pytest

from hil_bench.loop.links import LinkError, open_link, parse_can_spec, parse_stub_can_spec
from hil_bench.loop.links.can_link import CanLink, CanSpec
from hil_bench.protocol import budget
from hil_bench.protocol.messages import MESSAGES

ROOT = Path(__file__).resolve().parents[1]
DUTY = MESSAGES["DUTY"]


@pytest.fixture
def pair(tmp_path):
    """(CanLink on a fresh virtual channel, the drive's bus on the same channel, .log path)."""
    channel = f"hil-{uuid.uuid4().hex[:8]}"
    spec = CanSpec("virtual", channel)
    log_path = tmp_path / "link.log"
    link = CanLink(can.Bus(interface="virtual", channel=channel), spec, log_path)
    drive = can.Bus(interface="virtual", channel=channel)
    yield link, drive, log_path
    link.close()
    drive.shutdown()


def _drive_send(drive, fid, data, **kw):
    drive.send(can.Message(arbitration_id=fid, data=data, is_extended_id=kw.pop("ext", False), **kw))


def test_frames_cross_both_ways_in_order(pair):
    link, drive, _ = pair
    frames = [(0x101, bytes(range(8))), (0x100, bytes(range(8, 16)))]
    link.send(frames)
    got = [drive.recv(1.0), drive.recv(1.0)]
    assert [(m.arbitration_id, bytes(m.data), m.is_extended_id, m.is_fd) for m in got] == \
        [(f, d, False, False) for f, d in frames]
    _drive_send(drive, 0x181, b"\x01" * 8)
    _drive_send(drive, 0x180, b"\x02" * 8)
    assert link.recv_until(lambda fid, p: fid == 0x180, 1.0) == (0x180, b"\x02" * 8)


def test_unknown_ids_are_counted_and_passed_on_extended_and_remote_dropped(pair):
    link, drive, _ = pair
    _drive_send(drive, 0x7E5, b"\xAA" * 8)                 # 11-bit, not in the DBC: passed on
    _drive_send(drive, 0x180, b"\x00" * 8, ext=True)       # 29-bit: no DBC message has one
    drive.send(can.Message(arbitration_id=0x180, is_remote_frame=True, dlc=8, is_extended_id=False))
    _drive_send(drive, 0x180, DUTY.pack_values((1, 0.5, 0.5, 0.5)))
    others: list[int] = []
    got = link.recv_until(lambda fid, p: fid == 0x180, 1.0, on_frame=lambda f, p: others.append(f))
    assert got is not None and got[0] == 0x180
    assert others == [0x7E5]
    stats = link.stats()
    assert stats["can_unknown_ids"] == 2 and stats["remote_frames"] == 1


def test_wrong_dlc_is_counted_dropped_and_reported_once(pair, caplog):
    link, drive, _ = pair
    with caplog.at_level(logging.WARNING, logger="hil_bench.loop.links.can"):
        _drive_send(drive, 0x181, b"\x01" * 6)
        _drive_send(drive, 0x181, b"\x01" * 7)
        _drive_send(drive, 0x180, b"\x00" * 8)
        others: list[int] = []
        got = link.recv_until(lambda fid, p: fid == 0x180, 1.0, on_frame=lambda f, p: others.append(f))
    assert got == (0x180, b"\x00" * 8)
    assert others == []                                   # never handed on, never decoded
    assert link.stats()["length_errors"] == 2
    messages = [r.getMessage() for r in caplog.records]
    assert len(messages) == 1 and "TELEM (0x181) with 6 octets, the DBC says 8" in messages[0]


def test_bus_off_error_frame_ends_the_link_with_a_clear_message(pair):
    link, drive, _ = pair
    drive.send(can.Message(arbitration_id=0x004, is_error_frame=True, data=[0, 0x10, 0, 0, 0, 0, 0, 0]))
    assert link.recv(0.5) == []
    assert link.stats()["error_frames"] == 1 and link.stats()["bus_state_changes"] == 1
    drive.send(can.Message(arbitration_id=0x040, is_error_frame=True, data=[0] * 8))
    with pytest.raises(LinkError, match=r"bus-off \(error frame class 0x040\)"):
        link.recv(0.5)


def test_every_frame_goes_to_the_candump_log(pair):
    link, drive, log_path = pair
    link.send([(0x020, bytes(8)), (0x030, bytes(range(8)))])
    _drive_send(drive, 0x021, b"\x11" * 8)
    _drive_send(drive, 0x181, b"\x22" * 5)                 # dropped (wrong DLC) but logged
    assert link.recv_until(lambda fid, p: fid == 0x021, 1.0) is not None
    link.recv(0.1)
    link.close()
    msgs = list(can.LogReader(log_path))
    assert [(m.arbitration_id, bytes(m.data), m.is_rx) for m in msgs] == [
        (0x020, bytes(8), False), (0x030, bytes(range(8)), False), (0x021, b"\x11" * 8, True),
        (0x181, b"\x22" * 5, True)]
    assert {m.channel for m in msgs} == {link.log_channel} and link.log_channel.startswith("hil-")


def test_can_fd_frames_carry_the_same_payloads(tmp_path):
    channel = f"hil-{uuid.uuid4().hex[:8]}"
    spec = CanSpec("virtual", channel, fd=True, data_bitrate=5_000_000)
    link = CanLink(can.Bus(interface="virtual", channel=channel), spec)
    drive = can.Bus(interface="virtual", channel=channel)
    try:
        link.send([(0x100, bytes(range(8)))])
        m = drive.recv(1.0)
        assert (m.is_fd, m.bitrate_switch, bytes(m.data)) == (True, True, bytes(range(8)))
        assert link.max_cycle_rate_hz(0) == pytest.approx(budget.can_max_rate_hz(1e6, 0, True, 5e6))
    finally:
        link.close()
        drive.shutdown()


def test_an_interface_that_fails_to_send_raises_link_error(pair):
    link, drive, _ = pair
    link.bus.shutdown()                                   # the adapter is gone
    with pytest.raises(LinkError, match="sending 100#.* failed"):
        link.send([(0x100, bytes(8))])
    assert link.stats()["send_failures"] == 1


# -- link specs ---------------------------------------------------------------------------------------

@pytest.mark.parametrize("spec, expect", [
    ("can:socketcan:can0@500000", ("socketcan", "can0", 500_000, False, None, {})),
    ("can:pcan:PCAN_USBBUS1@1M", ("pcan", "PCAN_USBBUS1", 1_000_000, False, None, {})),
    ("can:kvaser:0@500k,fd,data_bitrate=2M", ("kvaser", "0", 500_000, True, 2_000_000, {})),
    ("can:slcan:/dev/ttyACM0@1M,tty_baudrate=115200",
     ("slcan", "/dev/ttyACM0", 1_000_000, False, None, {"tty_baudrate": 115200})),
    ("can:socketcand:can0,host=10.0.0.5,port=29536",
     ("socketcand", "can0", 1_000_000, False, None, {"host": "10.0.0.5", "port": 29536})),
    ("can:slcan:socket://127.0.0.1:5000@250k", ("slcan", "socket://127.0.0.1:5000", 250_000, False, None, {})),
])
def test_can_specs_parse(spec, expect):
    s = parse_can_spec(spec)
    assert (s.interface, s.channel, s.bitrate, s.fd, s.data_bitrate, s.options) == expect


@pytest.mark.parametrize("kind, tail, expect", [
    ("stub-slcan", "", ("slcan", 1_000_000, False, None)),
    ("stub-slcan", "@500k", ("slcan", 500_000, False, None)),
    ("stub-slcan", "@1M,fd,data_bitrate=5M", ("slcan", 1_000_000, True, 5_000_000)),
    ("stub-socketcand", "", ("socketcand", 1_000_000, False, None)),
    ("stub-socketcan", "", ("socketcan", 1_000_000, False, None)),
    ("stub-socketcan", ":vcan1@500k", ("socketcan", 500_000, False, None)),
])
def test_stub_can_specs_parse(kind, tail, expect):
    s = parse_stub_can_spec(kind, tail, kind + tail)
    assert (s.interface, s.bitrate, s.fd, s.data_bitrate) == expect
    if kind == "stub-socketcan":
        assert s.channel == ("vcan1" if "vcan1" in tail else "vcan0")


@pytest.mark.parametrize("spec, message", [
    ("can:", "use can:<interface>:<channel>"),
    ("can:pcan", "use can:<interface>:<channel>"),
    ("can:pcan:PCAN_USBBUS1@fast", "bad bit rate 'fast'"),
    ("can:pcan:PCAN_USBBUS1@1M,data_bitrate=5M", "data_bitrate needs CAN FD"),
    ("can:pcan:PCAN_USBBUS1@1M,fd,data_bitrate=500k", "data bit rate (500000) is below"),
    ("can:pcan:PCAN_USBBUS1,nonsense", "option 'nonsense' needs a value"),
    ("stub-socketcand,fd", "socketcand interface carries classic CAN only"),
    ("stub-slcan:x", "use stub-slcan[@bitrate]"),
])
def test_bad_can_specs_are_refused_naming_the_problem(spec, message):
    with pytest.raises(LinkError) as info:
        if spec.startswith("stub-"):
            kind = re.match(r"stub-[a-z]+", spec).group(0)
            parse_stub_can_spec(kind, spec[len(kind):], spec)
        else:
            parse_can_spec(spec)
    assert message in str(info.value) and spec in str(info.value)


def test_unknown_python_can_interface_is_a_clear_error():
    with pytest.raises(LinkError, match=r"CAN interface 'nosuchbus' .*not available.*python-can "
                                        r"interfaces: .*socketcand"):
        open_link("can:nosuchbus:0")


def test_socketcand_without_server_fails_fast():
    import socket

    with socket.socket() as s:                            # a port with nobody listening
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    with pytest.raises(LinkError, match=f"no socketcand server at 127.0.0.1:{port}"):
        open_link(f"can:socketcand:can0,host=127.0.0.1,port={port}")


def test_opening_a_virtual_bus_through_the_spec(tmp_path):
    opened = open_link("can:virtual:hil-spec-test@500k", capture_path=tmp_path / "v.log")
    try:
        assert "virtual hil-spec-test, classic CAN 500 kbit/s" == opened.link.description
        assert opened.link.max_cycle_rate_hz(0) == pytest.approx(5e5 / 540)
    finally:
        opened.close()
    assert (tmp_path / "v.log").exists()


# -- budget -------------------------------------------------------------------------------------------

def test_can_scenario_period_fits_classic_can_at_1mbit():
    from hil_bench.scenario import load_scenario

    scn = load_scenario("gong_g2_500rpm_can")
    ts = scn.plant_overrides["ts_s"]
    flags = budget.TELEM_EMF if scn.telemetry_emf else 0
    assert ts * 1e6 == budget.can_fit_period_us(1e6, flags) == 600.0
    assert budget.can_bus_load(1.0 / ts, 1e6, flags) == pytest.approx(0.9, abs=1e-9)
    assert budget.can_max_rate_hz(1e6, flags) > 1.0 / ts
    # the paper's 10 kHz does not fit classic CAN at 1 Mbit/s, with or without TELEM_EMF
    assert budget.can_max_rate_hz(1e6, 0) < 10_000


def test_can_budget_helpers():
    assert budget.can_link_name(1e6) == "classic CAN 1 Mbit/s"
    assert budget.can_link_name(5e5, True, 2e6) == "CAN FD 500 kbit/s, data phase 2 Mbit/s (BRS)"
    assert budget.can_bus_load(925.0, 5e5, 0) == pytest.approx(925 * 540 / 5e5)
    # 90 % of 1851.85 Hz -> 600 us; of FD 1M/5M 4416 Hz -> 251.6 us -> 275 us on the 25 us grid
    assert budget.can_fit_period_us(1e6, 0) == 600.0
    assert budget.can_fit_period_us(1e6, 0, fd=True, data_bitrate=5e6) == 275.0


def test_docs_can_table_is_current():
    text = (ROOT / "docs" / "protocol.md").read_text()
    m = re.search(r"<!-- BEGIN CAN LINK TABLE[^\n]*-->\n(.*?)<!-- END CAN LINK TABLE -->", text, re.S)
    assert m, "docs/protocol.md lacks the CAN link table markers"
    assert m.group(1) == budget.can_link_table(), "regenerate with hil_bench.protocol.budget.can_link_table()"


# -- python-can's own configuration (docs/protocol.md 8.2) ----------------------------------------

@pytest.fixture(autouse=True)
def python_can_config(tmp_path, monkeypatch):
    """Each test sees only the python-can configuration it writes: no CAN_* variables, no can.rc,
    and the config file list pointed at tmp_path/canrc (not ~/.canrc or /etc/can.conf)."""
    for var in [v for v in __import__("os").environ if v.startswith("CAN_")]:
        monkeypatch.delenv(var)
    monkeypatch.setattr(can, "rc", {})
    path = tmp_path / "canrc"
    monkeypatch.setattr(can.util, "CONFIG_FILES", [str(path)])
    return path


def test_bare_can_takes_interface_channel_and_bitrate_from_the_environment(monkeypatch):
    monkeypatch.setenv("CAN_INTERFACE", "virtual")
    monkeypatch.setenv("CAN_CHANNEL", "lab-bus")
    monkeypatch.setenv("CAN_BITRATE", "500000")
    s = parse_can_spec("can")
    assert (s.interface, s.channel, s.bitrate, s.bitrate_given, s.fd) == \
        ("virtual", "lab-bus", 500_000, True, False)
    assert s.config_note == "interface, channel, bit rate from python-can's configuration"


def test_the_link_string_wins_over_the_configuration(monkeypatch, python_can_config):
    python_can_config.write_text("[default]\ninterface = pcan\nchannel = PCAN_USBBUS1\n"
                                 "bitrate = 250000\n")
    monkeypatch.setenv("CAN_BITRATE", "500000")           # environment beats the file
    s = parse_can_spec("can:virtual:mine")
    assert (s.interface, s.channel, s.bitrate) == ("virtual", "mine", 500_000)
    assert s.config_note == "bit rate from python-can's configuration"
    s = parse_can_spec("can:virtual:mine@125k")
    assert (s.bitrate, s.config_note) == (125_000, "")
    s = parse_can_spec("can@1M")                          # interface and channel from the file
    assert (s.interface, s.channel, s.bitrate) == ("pcan", "PCAN_USBBUS1", 1_000_000)
    s = parse_can_spec("can:kvaser")                      # the channel alone from the file
    assert (s.interface, s.channel) == ("kvaser", "PCAN_USBBUS1")


def test_a_context_selects_a_section_and_its_environment_suffix(monkeypatch, python_can_config):
    python_can_config.write_text(
        "[default]\ninterface = virtual\nchannel = office\n"
        "[bench2]\ninterface = virtual\nchannel = bench2-bus\nbitrate = 500000\nfd = True\n"
        "data_bitrate = 2000000\nreceive_own_messages = True\n")
    assert parse_can_spec("can").channel == "office"
    s = parse_can_spec("can,context=bench2")
    assert (s.channel, s.bitrate, s.fd, s.data_bitrate) == ("bench2-bus", 500_000, True, 2_000_000)
    assert s.options == {"receive_own_messages": True}   # the rest goes to can.Bus
    assert s.config_note == ("interface, channel, bit rate, fd, data bit rate from python-can's "
                             "configuration, context 'bench2'")
    # the budget follows what the configuration said: FD with a 2 Mbit/s data phase
    from hil_bench.loop.links import spec_max_cycle_rate_hz

    rate, name = spec_max_cycle_rate_hz("can,context=bench2", 0)
    assert rate == pytest.approx(budget.can_max_rate_hz(500_000, 0, fd=True, data_bitrate=2_000_000))
    monkeypatch.setenv("CAN_CHANNEL_bench2", "from-env")   # CAN_<VAR>_<context> beats the file
    assert parse_can_spec("can,context=bench2").channel == "from-env"


def test_can_rc_is_read_first(monkeypatch):
    monkeypatch.setenv("CAN_INTERFACE", "pcan")
    monkeypatch.setattr(can, "rc", {"interface": "virtual", "channel": "rc-bus"})
    s = parse_can_spec("can")
    assert (s.interface, s.channel, s.bitrate_given) == ("virtual", "rc-bus", False)
    assert s.bus_name == "classic CAN 1 Mbit/s (assumed: give the bus's @bitrate)"


@pytest.mark.parametrize("setup, spec, message", [
    ({}, "can", "names no CAN interface and python-can's configuration has none (CAN_INTERFACE"),
    ({"CAN_INTERFACE": "virtual"}, "can", "names no CAN channel and python-can's configuration "
                                          "has none (CAN_CHANNEL"),
    ({}, "can,context=lab9", "configuration (context 'lab9') has none"),
    ({"CAN_INTERFACE": "nosuchbus", "CAN_CHANNEL": "0"}, "can",
     "CAN interface (from python-can's configuration) is not available here"),
    ({"CAN_INTERFACE": "virtual", "CAN_CHANNEL": "x", "CAN_CONFIG": '{"data_bitrate": 2000000}'},
     "can", "data_bitrate needs CAN FD"),
    ({}, "can:", "use can:<interface>:<channel>"),
    ({}, "canx", "unknown link spec"),
])
def test_configuration_gaps_are_named(monkeypatch, setup, spec, message):
    for k, v in setup.items():
        monkeypatch.setenv(k, v)
    with pytest.raises(LinkError) as info:
        open_link(spec) if spec == "canx" else parse_can_spec(spec)
    assert message in str(info.value) and spec in str(info.value)


def test_a_link_opened_from_the_configuration_says_so_and_the_stub_links_ignore_it(
        python_can_config, tmp_path):
    python_can_config.write_text("[default]\ninterface = virtual\nchannel = cfg-bus\n"
                                 "bitrate = 500000\nreceive_own_messages = True\n")
    opened = open_link("can")
    try:
        assert opened.link.description == ("virtual cfg-bus, classic CAN 500 kbit/s (interface, "
                                           "channel, bit rate from python-can's configuration)")
        assert opened.link.bus.receive_own_messages is True     # a configured Bus argument
    finally:
        opened.close()
    # a spec that is complete (the stub's links) gets exactly what it says: python-can does not
    # merge ~/.canrc into it (receive_own_messages would echo every frame back to the bench)
    from hil_bench.loop.links.can_link import open_can_bus

    bus = open_can_bus(CanSpec("virtual", "stub-bus"))
    try:
        assert bus.receive_own_messages is False
    finally:
        bus.shutdown()


class _FakeSocketcand:
    """A socketcand gateway on 127.0.0.1 that greets, opens, enters rawmode and then sends what the
    test gives it (bounded: one client, closed by the test)."""

    def __init__(self):
        import socket
        import threading

        self.srv = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        self.srv.bind(("127.0.0.1", 0))
        self.srv.listen(1)
        self.port = self.srv.getsockname()[1]
        self.conn = None
        self._ready = threading.Event()
        threading.Thread(target=self._serve, daemon=True).start()

    def _serve(self):
        self.srv.settimeout(10.0)
        for _ in range(3):          # the bench probes the port first (a connection closed at once)
            conn, _ = self.srv.accept()
            conn.settimeout(10.0)
            try:
                conn.sendall(b"< hi >")
                if not conn.recv(256):                      # < open can0 >
                    conn.close()
                    continue
                conn.sendall(b"< ok >")
                conn.recv(256)                              # < rawmode >
                conn.sendall(b"< ok >")
            except OSError:
                conn.close()
                continue
            self.conn = conn
            self._ready.set()
            return

    def send(self, data: bytes):
        assert self._ready.wait(10.0)
        self.conn.sendall(data)

    def close(self):
        for s in (self.conn, self.srv):
            if s is not None:
                s.close()


MALFORMED_LINES = [b"< frame ZZZ 1.000000 0102 >",                      # id not hex
                   b"< frame 040 notatime 0102 >",                       # bad timestamp
                   b"< frame 040 1.000000 0\xc3\xa9 >",                  # non-ASCII octets
                   b"< frame 040 1.000000 010 >",                        # odd number of hex digits
                   b"< frame 040 1.000000 010203040506070809 >"]         # 9 octets on classic CAN


@pytest.mark.parametrize("bad", MALFORMED_LINES)
def test_a_malformed_socketcand_line_is_a_counted_receive_error_not_the_end(bad, caplog, capsys):
    """Issue 19, point 3: a gateway's malformed line is counted (rx_malformed), reported once on the
    link's logger, the frames around it pass, and nothing raises or prints a traceback."""
    gw = _FakeSocketcand()
    try:
        opened = open_link(f"can:socketcand:can0,host=127.0.0.1,port={gw.port}")
        link = opened.link
        try:
            with caplog.at_level(logging.WARNING):
                gw.send(b"< frame 050 1.000000 0102030405060708 >" + bad +
                        b"< frame 051 1.000100 0807060504030201 >")
                got = []
                for _ in range(20):
                    got += link.recv(0.05)
                    if len(got) >= 2:
                        break
                assert got == [(0x050, bytes(range(1, 9))), (0x051, bytes(range(8, 0, -1)))]
                assert link.stats()["rx_malformed"] == 1
                gw.send(bad)                                 # a second one: counted, not re-reported
                for _ in range(5):
                    link.recv(0.05)
                assert link.stats()["rx_malformed"] == 2
        finally:
            opened.close()
    finally:
        gw.close()
    reports = [r.getMessage() for r in caplog.records if "cannot parse" in r.getMessage()]
    assert len(reports) == 1 and "rx_malformed" in reports[0], reports
    out = capsys.readouterr()
    assert "Traceback" not in out.out + out.err + caplog.text
    assert not [r for r in caplog.records if r.levelno >= logging.ERROR], caplog.text


def test_rx_malformed_is_a_link_counter_a_scenario_may_allow():
    from hil_bench.record.integrity import ALLOWABLE_COUNTERS, LINK_COUNTERS
    assert "rx_malformed" in LINK_COUNTERS and "rx_malformed" in ALLOWABLE_COUNTERS
