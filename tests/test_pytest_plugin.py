"""The pytest plugin (entry point pytest11, hil_bench.pytest_plugin), as a downstream project
meets it: a pytest run in a folder of its own, outside this repository's test session."""
from __future__ import annotations

import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

TESTS = '''
import hil_bench

def test_the_link_fixture(hil_link):
    assert hil_link.spec == "stub-socketcand" and hil_link.is_stub

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
    assert props["gong_g2_500rpm/G2.sf/paper"] == "7.5" and props["gong_g2_500rpm/G2.sf/unit"] == "rpm"
    assert props["gong_g2_500rpm/integrity"] == "ok"
    assert Path(props["gong_g2_500rpm/recording"]).parent == recordings
    assert float(props["gong_g2_500rpm/metrics/t_end_s"]) == pytest.approx(0.3999)
    passing = next(c for c in junit.iter("testcase") if c.get("name") == "test_the_link_fixture")
    assert list(passing.iter("property")) == []          # no run, no property
