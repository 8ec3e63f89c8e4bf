"""The pytest plugin (entry point pytest11, hil_bench.pytest_plugin), as a downstream project
meets it: a pytest run in a folder of its own, outside this repository's test session."""
from __future__ import annotations

import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

TESTS = '''
import pytest

import hil_bench

def test_the_link_fixture(hil_link):
    assert hil_link.spec == "stub-socketcand" and hil_link.is_stub and not hil_link.is_drive

@pytest.mark.hil_drive
def test_only_on_a_real_drive(hil_link):
    raise AssertionError("a hil_drive test ran on the bundled stub")

def test_short_startup_fails_its_claims(hil_run):
    # 10 kHz does not fit classic CAN in real time; in lockstep it only runs slower
    result = hil_run("gong_g2_500rpm", overrides={"scenario.duration_s": 0.4,
                                                  "metrics.window_s": [0.2, 0.4]},
                     allow_slow_link=True)
    assert result.run.link == "stub-socketcand"
    result.assert_claims()
'''


@pytest.fixture(scope="module")
def downstream(tmp_path_factory):
    """One pytest run of a small downstream test file, on the stub behind python-can's
    socketcand interface: (completed process, JUnit XML root, recordings folder)."""
    root = tmp_path_factory.mktemp("downstream")
    (root / "test_downstream.py").write_text(TESTS)
    recordings = root / "recs"
    proc = subprocess.run(
        [sys.executable, "-m", "pytest", "-p", "no:cacheprovider", "-rA",
         "--hil-link", "stub-socketcand", "--hil-recordings", str(recordings),
         "--junitxml", str(root / "junit.xml"), "test_downstream.py"],
        cwd=root, capture_output=True, text=True, timeout=600)
    return proc, ET.parse(root / "junit.xml").getroot(), recordings


def test_help_lists_the_options():
    out = subprocess.run([sys.executable, "-m", "pytest", "--help"], capture_output=True,
                         text=True, timeout=120).stdout
    for option in ("--hil-link=SPEC", "--hil-stub=PATH", "--hil-recordings=DIR"):
        assert option in out
    assert "hil_link (string):" in out or "hil_link (string)" in out


def test_the_link_option_reaches_the_fixture_and_the_run(downstream):
    proc, junit, _ = downstream
    assert "PASSED test_downstream.py::test_the_link_fixture" in proc.stdout, proc.stdout
    assert "hil-bench " in proc.stdout and "link stub-socketcand (" in proc.stdout   # header


def test_a_failed_claim_shows_the_table_and_names_the_recording(downstream):
    proc, _, recordings = downstream
    assert proc.returncode == 1
    out = proc.stdout
    assert "ClaimsNotReproduced: claims not reproduced: G2.sf INVALID; G2.pee INVALID" in out
    # the failure points at the test's line, not into assert_claims (__tracebackhide__)
    assert "result.assert_claims()" in out and "raise ClaimsNotReproduced" not in out
    assert "def assert_claims" not in out
    assert "claim  quantity" in out and "[1] not G2's set-up (run G2): window" in out
    recording = recordings / "test_downstream.py_test_short_startup_fails_its_claims-1.mcap"
    assert recording.is_file()
    section = out.split("hil-bench recordings", 1)[1]
    assert str(recording) in section.splitlines()[1]


def test_measured_values_are_junit_properties(downstream):
    _, junit, recordings = downstream
    case = next(c for c in junit.iter("testcase") if c.get("name") == "test_short_startup_fails_its_claims")
    props = {p.get("name"): p.get("value") for p in case.iter("property")}
    assert props["gong_g2_500rpm/G2.sf/verdict"] == "INVALID"
    # the controller that answered (its HELLO_ACK as recorded), not the link string
    controller = props["gong_g2_500rpm/controller"]
    assert controller.startswith("fw 0x0100 (protocol 1.1, estimators 0x") and "hil_stub" in controller
    assert props["gong_g2_500rpm/G2.sf/paper"] == "7.5" and props["gong_g2_500rpm/G2.sf/unit"] == "rpm"
    assert props["gong_g2_500rpm/integrity"] == "ok"
    assert Path(props["gong_g2_500rpm/recording"]).parent == recordings
    assert float(props["gong_g2_500rpm/metrics/t_end_s"]) == pytest.approx(0.3999)
    passing = next(c for c in junit.iter("testcase") if c.get("name") == "test_the_link_fixture")
    assert list(passing.iter("property")) == []          # no run, no property


def test_a_hil_drive_test_is_skipped_on_the_bundled_stub(downstream):
    proc, junit, _ = downstream
    assert "SKIPPED [1] " in proc.stdout and "needs a real drive" in proc.stdout, proc.stdout
    case = next(c for c in junit.iter("testcase") if c.get("name") == "test_only_on_a_real_drive")
    assert case.find("skipped") is not None


def test_a_drive_on_a_slower_link_runs_in_lockstep_as_on_the_stub(tmp_path):
    """docs/api.md and examples/firmware_ci run the same tests on the stub and with
    `--hil-link serial:/dev/ttyUSB0@3000000`: G2's 10 kHz does not fit 3 Mbaud in real time, so
    a lockstep run there is slower than real time, never refused (before: every hil_run and
    hil_session on such a drive raised RunAborted, "cannot carry this scenario")."""
    from tests.drive_on_pty import StubOnPty

    (tmp_path / "test_one.py").write_text(
        "def test_one(hil_run):\n"
        "    r = hil_run('gong_g2_500rpm', overrides={'scenario.duration_s': 0.2,\n"
        "                                             'metrics.window_s': [0.1, 0.2]})\n"
        "    assert r.integrity.ok and r.run.error is None, r.summary()\n")
    with StubOnPty("serial") as drive:
        proc = _pytest(tmp_path, "--hil-link", f"serial:{drive.path}@3000000", "test_one.py")
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "1 passed" in proc.stdout


def test_the_link_kinds():
    from hil_bench.pytest_plugin import HilLink

    assert HilLink("serial:/dev/ttyUSB0@3000000").is_drive
    assert HilLink("can:pcan:PCAN_USBBUS1@1M").is_drive and HilLink("can").is_drive
    for bundled in ("stub", "stub-slcan", "sil", "pil-qemu", "pil-qemu:fw.elf"):
        assert not HilLink(bundled).is_drive


def _pytest(root: Path, *args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "pytest", "-p", "no:cacheprovider", *args],
                          cwd=root, capture_output=True, text=True, timeout=300)


@pytest.mark.parametrize("link, words", [
    ("", "--hil-link is empty (an unset variable, e.g. $HIL_LINK?)"),
    ("stub:anything", "did you mean 'stub'"),
    ("stub-slcan,bitrat=1M", "did you mean 'bitrate'"),
    ("serail:/dev/ttyUSB0", "did you mean 'serial'"),
])
def test_an_empty_or_unknown_link_is_a_usage_error_not_the_stub(tmp_path, link, words):
    """Before: --hil-link "" (an unset $HIL_LINK in CI) or stub:ANYTHING ran the bundled stub
    and said "1 passed"."""
    (tmp_path / "test_one.py").write_text("def test_one(hil_run):\n"
                                          "    hil_run('gong_g2_500rpm')\n")
    proc = _pytest(tmp_path, "--hil-link", link, "test_one.py")
    assert proc.returncode == 4, proc.stdout + proc.stderr        # pytest's usage error
    assert words in proc.stderr and "passed" not in proc.stdout


def test_no_deprecation_warning_under_this_pytest(tmp_path):
    """-W error::DeprecationWarning, with the header (not -q): before, the plugin read
    config.inicfg, deprecated (PytestRemovedIn10Warning) and an INTERNALERROR under -W error."""
    (tmp_path / "test_plain.py").write_text("def test_plain():\n    pass\n")
    (tmp_path / "pytest.ini").write_text("[pytest]\nhil_link = stub\n")
    proc = _pytest(tmp_path, "-W", "error::DeprecationWarning", "test_plain.py")
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "inicfg" not in proc.stdout + proc.stderr and "INTERNALERROR" not in proc.stdout
    assert "hil-bench " in proc.stdout and "link stub (" in proc.stdout   # the ini's link, said
    markers = _pytest(tmp_path, "--markers").stdout
    assert "@pytest.mark.hil_drive" in markers
