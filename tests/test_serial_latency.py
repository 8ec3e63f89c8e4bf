"""A USB-serial adapter that holds the drive's answers is named, with how to fix it
(bench/loop/links/serial_link.py; docs/real-drive.md, "The adapter's latency timer"): from the
adapter's own setting, which ftdi_sio publishes in sysfs (the tests fake that file), and for any
adapter from the round trips of the set-up's requests (an emulated adapter with FTDI's 16 ms default
holds them: tests/drive_on_pty.py)."""
from __future__ import annotations

from pathlib import Path

import pytest

from hil_bench.cli import main as cli_main
from hil_bench.loop.links import serial_link
from hil_bench.loop.links.serial_link import (
    latency_timer_note,
    round_trip_note,
    usb_latency_timer_ms,
)
from hil_bench.record.recording import load_recording
from tests.drive_on_pty import EmulatedAdapter, StubOnPty

SHORT_G2 = """
[scenario]
name = "short_g2"
profile = "gong2020"
duration_s = 0.02
claims = []
[plant]
t_delay_s = 0.0
[controller]
estimator = "SMO_TANH"
speed_ref_rpm = 500
[metrics]
window_s = [0.01, 0.02]
"""


def fake_sysfs(root: Path, name: str = "ttyUSB0", latency: str | None = "16\n") -> Path:
    """/sys/bus/usb-serial/devices as ftdi_sio lays it out: <tty>/latency_timer."""
    port_dir = root / name
    port_dir.mkdir(parents=True)
    if latency is not None:
        (port_dir / "latency_timer").write_text(latency)
    return root


def test_the_latency_timer_is_read_under_the_ports_kernel_name(tmp_path):
    sysfs = fake_sysfs(tmp_path / "sys")
    dev = tmp_path / "dev"
    (dev / "serial" / "by-id").mkdir(parents=True)
    (dev / "ttyUSB0").write_text("")                       # the device node
    by_id = dev / "serial" / "by-id" / "usb-FTDI_FT232R_USB_UART_A50285BI-if00-port0"
    by_id.symlink_to("../../ttyUSB0")                     # as udev links it
    for port in (str(dev / "ttyUSB0"), str(by_id)):
        assert usb_latency_timer_ms(port, sysfs) == (16, sysfs / "ttyUSB0" / "latency_timer")


@pytest.mark.parametrize("latency, why", [("1\n", "the wanted 1 ms"), (None, "no attribute (a CP210x)"),
                                          ("x\n", "unreadable")])
def test_no_note_at_1_ms_or_without_a_readable_setting(tmp_path, latency, why):
    sysfs = fake_sysfs(tmp_path / "sys", latency=latency)
    assert latency_timer_note(str(tmp_path / "ttyUSB0"), sysfs) is None, why


def test_a_url_or_a_port_the_kernel_does_not_list_has_no_setting(tmp_path):
    sysfs = fake_sysfs(tmp_path / "sys")
    assert usb_latency_timer_ms("socket://localhost:7000", sysfs) is None
    assert usb_latency_timer_ms(str(tmp_path / "ttyS0"), sysfs) is None


def test_the_note_names_the_setting_its_cost_and_the_fix(tmp_path):
    sysfs = fake_sysfs(tmp_path / "sys")
    note = latency_timer_note("/dev/ttyUSB0", sysfs)
    path = sysfs / "ttyUSB0" / "latency_timer"
    assert note.startswith("serial /dev/ttyUSB0: the USB adapter's latency timer is 16 ms")
    assert "every lockstep cycle takes about 16 ms" in note
    assert f"`echo 1 | sudo tee {path}`" in note and "setserial /dev/ttyUSB0 low_latency" in note


def test_answers_far_further_apart_than_the_wire_time_are_called_held():
    held = round_trip_note("serial /dev/ttyUSB0 @ 1000000 baud", [0.016] * 8, [0.0161] * 7,
                           1_000_000)
    assert held is not None and ("(8 HELLO/CONFIG, each asked for once the one before was in) came "
                                 "16.1 ms or more apart (request to answer: median 16.0 ms;") in held
    assert "0.30 ms on the wire at 1000000 baud" in held
    assert round_trip_note("x", [0.016] * 7, [0.016] * 6, 1_000_000) is None    # too few to judge
    assert round_trip_note("x", [0.016] * 8, [0.016] * 3, 1_000_000) is None    # too few spacings
    assert round_trip_note("x", [0.0012] * 8, [0.0013] * 7, 1_000_000) is None  # a 1 ms timer
    # at 115 200 baud a request and its answer take 2.6 ms: 8 ms is the wire and a drive, not held
    assert round_trip_note("x", [0.008] * 8, [0.008] * 7, 115_200) is None
    assert round_trip_note("x", [0.016] * 8, [0.016] * 7, 115_200) is not None
    # judged on the closest spacing: a prompt drive on a busy host (most answers delayed, one not)
    # is not held; an adapter holds every answer, whatever the host adds to some
    assert round_trip_note("x", [0.0041] * 8, [0.0042] * 6 + [0.0004], 1_000_000) is None
    assert round_trip_note("x", [0.016] * 8, [0.016] * 6 + [0.5], 1_000_000) is not None
    # the first request finds the adapter's timer at any point and a late request finds it part
    # run: short round trips, the answers still a timer apart (measured beside the load harness)
    measured = [0.0017, 0.0172, 0.0138, 0.016, 0.016, 0.016, 0.016, 0.016]
    assert round_trip_note("x", measured, [0.0183, 0.0139, 0.0161, 0.0161, 0.0161, 0.0161, 0.0161],
                           1_000_000) is not None


def _run(port: str, out: Path, tmp_path: Path) -> int:
    scn = tmp_path / "short_g2.toml"
    scn.write_text(SHORT_G2)
    return cli_main(["run", str(scn), "--link", f"serial:{port}@1000000", "--allow-slow-link",
                     "--no-progress", "--out", str(out)])


def _latency_events(out: Path) -> list[str]:
    events = load_recording(out).topic("/events")
    return [t for k, t in zip(events["kind"], events["text"]) if k == "link_latency"]


def test_bench_run_and_the_kit_say_the_adapters_16_ms_from_sysfs(tmp_path, monkeypatch, capsys):
    """A port whose ftdi_sio latency_timer reads 16 (a faked sysfs entry under the port's kernel
    name): the run says so before its cycles, records it, and runs on; the kit says it too."""
    with StubOnPty() as drive:
        port = drive.path
        monkeypatch.setattr(serial_link, "USB_SERIAL_SYSFS",
                            fake_sysfs(tmp_path / "sys", name=Path(port).name))
        out = tmp_path / "run.mcap"
        assert _run(port, out, tmp_path) == 0
        err = " ".join(capsys.readouterr().err.split())
        assert f"link: serial {port}: the USB adapter's latency timer is 16 ms" in err
        (note,) = _latency_events(out)
        assert "latency timer is 16 ms" in note
        assert cli_main(["conformance", "--link", f"serial:{port}@1000000",
                         "--estimator", "SMO_TANH"]) == 0
        said = capsys.readouterr().out
        assert f"  link: serial {port}: the USB adapter's latency timer is 16 ms" in said


def test_an_adapter_holding_the_answers_16_ms_is_found_by_the_answers_spacing(tmp_path, capsys):
    """No sysfs setting to read (a pty): an emulated adapter with FTDI's default 16 ms timer holds
    every answer, the spacing of the set-up's answers shows it, and the run says so; the same drive
    without the hold gets no note. Run a few times: the first request finds the adapter's timer at
    a different point each time (a round trip of 0.2 ms was seen), the spacings do not depend on it."""
    for attempt in range(3):
        with EmulatedAdapter(latency_ms=16) as adapter:
            out = tmp_path / f"held{attempt}.mcap"
            assert _run(adapter.path, out, tmp_path) == 0
        err = " ".join(capsys.readouterr().err.split())
        assert ("the drive's answers to the set-up (8 HELLO/CONFIG, each asked for once the one "
                "before was in) came") in err, f"set-up {attempt}"
        assert "most often a USB adapter's latency timer (FTDI: 16 ms by default)" in err
        (note,) = _latency_events(out)
        assert "came" in note and "held" not in note.split(" came ")[0]
    for attempt in range(3):
        with StubOnPty() as drive:
            out = tmp_path / f"clean{attempt}.mcap"
            assert _run(drive.path, out, tmp_path) == 0
        assert "link:" not in capsys.readouterr().err, f"set-up {attempt}"
        assert _latency_events(out) == []


def test_the_stubs_own_links_are_not_timed(tmp_path):
    """The bench's own pty to the stub (and QEMU's socket) is not a user's adapter: no note, whatever
    the host's load does to its round trips."""
    from hil_bench.loop.links import open_link

    opened = open_link("stub")
    try:
        assert opened.link.notes == [] and opened.link._judged
    finally:
        opened.close()


def test_the_spacings_tool_prints_what_the_note_judges():
    """tools/setup_spacings.py (docs/real-drive.md's figures, beside the load harness there): one
    set-up of each kind, the held one noted, the prompt one not."""
    import subprocess
    import sys

    repo = Path(__file__).resolve().parents[1]
    proc = subprocess.run([sys.executable, str(repo / "tools" / "setup_spacings.py"), "--setups", "1"],
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr
    assert "held 16 ms: 1 set-ups, first round trips" in proc.stdout
    assert "note given 1 of 1" in proc.stdout.split("prompt:")[0]
    assert "prompt: 1 set-ups" in proc.stdout and proc.stdout.rstrip().endswith("note given 0 of 1")
