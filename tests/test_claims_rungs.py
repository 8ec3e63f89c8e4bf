"""``bench claims --run --link LINK`` (issue 21, item 5): the claims' scenarios on the host stub
and on another controller, each verdict beside the host stub's; one run at a time on a link that
is a single device."""
from __future__ import annotations

from hil_bench.cli import main as cli_main
from hil_bench.papers.report import default_jobs
from hil_bench.papers.rungs import jobs_for, run_rungs, slug


def test_a_single_device_runs_one_scenario_at_a_time():
    assert jobs_for("serial:/dev/ttyUSB0@3000000", 4) == 1
    assert jobs_for("can:pcan:PCAN_USBBUS1@1M", None) == 1
    assert jobs_for("pil-qemu", None) == default_jobs()
    assert jobs_for("stub-slcan", 3) == 3
    assert jobs_for("sil", 2) == 2          # the firmware in each run's own process
    assert slug("serial:/dev/ttyUSB0@3000000") == "serial_dev_ttyUSB0_3000000"


def test_g2_on_a_second_rung_sits_beside_the_stubs(tmp_path):
    """The stub behind python-can's socketcand interface as the 'other controller': the same
    firmware, another link (CAN at 1 Mbit/s: slower than G2's 10 kHz, run in lockstep anyway)."""
    rg = run_rungs(tmp_path, "stub-socketcand", only=["G2"], jobs=1)
    pairs = rg.pairs()
    assert pairs and all(b is not None for _, b in pairs)
    assert not rg.differences(), rg.differences()
    text = (tmp_path / "rungs.md").read_text()
    assert f"{len(pairs)} of {len(pairs)} verdicts the same on both rungs" in text
    assert (tmp_path / "recordings" / "stub" / "G2.mcap").exists() or \
        list((tmp_path / "recordings" / "stub").glob("*.mcap"))
    assert list((tmp_path / "recordings" / "stub-socketcand").glob("*.mcap"))


def test_an_unknown_claim_is_an_error_not_a_traceback(tmp_path, capsys):
    assert cli_main(["claims", "--run", "--link", "pil-qemu", "--only", "Z9",
                     "--out", str(tmp_path)]) == 2
    assert "unknown claim(s) Z9" in capsys.readouterr().err


def test_a_devices_runs_never_go_to_a_cluster(tmp_path, capsys):
    """The drive on /dev/ttyUSB0 is on this machine: --scheduler is refused before any run (the
    stub's, QEMU's and the SIL link's runs start their controller where they run: those may)."""
    assert cli_main(["claims", "--run", "--link", "serial:/dev/ttyUSB0@3000000", "--only", "G2",
                     "--scheduler", "tcp://127.0.0.1:1", "--out", str(tmp_path)]) == 2
    assert "the device is on this machine" in " ".join(capsys.readouterr().err.split())
    assert not (tmp_path / "recordings").exists()
