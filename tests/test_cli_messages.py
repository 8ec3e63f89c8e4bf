"""The command line's messages on bad input (issue 28 "LOW", issue 30 item 5): one clear line that
names what and where, a "did you mean" for a mistyped name, no traceback; `bench check --json`,
`bench claims --no-progress`, tables that do not wrap in a CI log, bundled campaigns by name."""
from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
EX = REPO / "examples" / "captures"


def bench(*args, cwd=REPO, env=None, timeout=300):
    return subprocess.run([sys.executable, "-m", "hil_bench", *map(str, args)], cwd=cwd,
                          capture_output=True, text=True, timeout=timeout,
                          env=None if env is None else dict(os.environ, **env))


def one_error_line(proc) -> str:
    assert proc.returncode == 2, (proc.stdout, proc.stderr)
    assert "Traceback" not in proc.stderr
    lines = [ln for ln in proc.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("error: "), proc.stderr   # no wrapping
    return lines[0]


def test_an_unknown_plant_key_names_the_override_not_another_keys_line(tmp_path):
    """Before: "gong_g2_500rpm.toml:12: plant.t_delay_s: ... overrides.nosuch: unknown key"."""
    line = one_error_line(bench("run", "gong_g2_500rpm", "--set", "plant.nosuch=1",
                                "--out", tmp_path / "x.mcap"))
    assert line.startswith("error: bench run --set plant.nosuch=1: plant.nosuch: ")
    assert ":12:" not in line and "t_delay_s:" not in line


@pytest.mark.parametrize("args, words", [
    (["run", "gong_g2_500rmp"], "did you mean 'gong_g2_500rpm'"),
    (["run", "gong_g2_500rpm", "--set", "controler.speed_ref_rpm=1"], "did you mean 'controller'"),
    (["run", "gong_g2_500rpm", "--set", "controller.params.SMO_KV=1"], "did you mean 'SMO_K_V'"),
    (["run", "gong_g2_500rpm", "--set", "scenario.claims=[\"G22\"]"], "did you mean 'G2'"),
    (["run", "gong_g2_500rpm", "--link", "stb"], "did you mean 'stub'"),
    (["run", "gong_g2_500rpm", "--link", "stub:foo"], "did you mean 'stub'"),
    (["run", "gong_g2_500rpm", "--link", "stub-slcan,tty_baudrat=9600"], "did you mean 'tty_baudrate'"),
    (["run", "gong_g2_500rpm", "--link", ""], "--link is empty"),
    (["claims", "--only", "G22"], "did you mean 'G2'"),
    (["campaign", "g2_protectoin"], "did you mean 'g2_protection'"),
])
def test_did_you_mean(tmp_path, args, words):
    line = one_error_line(bench(*args, cwd=tmp_path))
    assert words in line, line
    assert not (tmp_path / "recordings").exists() or not any((tmp_path / "recordings").iterdir())


def test_a_missing_elf_or_port_is_said_as_such(tmp_path):
    """Before: "QEMU closed its QMP channel" and "cannot carry this scenario"."""
    line = one_error_line(bench("run", "gong_g2_500rpm", "--link", "pil-qemu:/nonexistent.elf",
                                cwd=tmp_path))
    assert "the firmware ELF /nonexistent.elf does not exist" in line
    line = one_error_line(bench("run", "gong_g2_500rpm", "--link", "serial:/nonexistent",
                                cwd=tmp_path))
    assert "the serial port /nonexistent does not exist" in line


def test_pil_qemu_without_a_checkout_says_so(monkeypatch, tmp_path):
    """An installed wheel has no firmware_stub/port/cortex_m: before, `bench conformance --link
    pil-qemu` ended in a CMake error (tests/test_wheel.py runs it from the wheel)."""
    from hil_bench.loop.links import LinkError, qemu

    monkeypatch.delenv("HIL_QEMU_ELF", raising=False)
    monkeypatch.setattr(qemu, "PORT_DIR", tmp_path / "no_port")
    monkeypatch.setattr(qemu, "BUILD_DIR", tmp_path / "no_build")
    with pytest.raises(LinkError, match=r"needs a checkout of hil-bench \(firmware_stub/port/"
                                        r"cortex_m"):
        qemu.firmware_elf()


@pytest.mark.parametrize("window, words", [
    ("5,1", "T0 must come before T1"),
    ("nan,inf", "the times must be finite"),
    ("a,b", "--window 'a,b': two times in seconds"),
    ("0.1", "two times in seconds"),
    ("100,200", "outside the capture"),
])
def test_replay_windows_are_checked(tmp_path, window, words):
    line = one_error_line(bench("replay", EX / "example.mcap", "--window", window,
                                "--out", tmp_path / "r.mcap"))
    assert words in line
    assert not (tmp_path / "r.mcap").exists() and not list(tmp_path.glob(".r.mcap*"))


@pytest.mark.parametrize("content, words", [
    (b"\x89MCAP0\r\n", "8 octets, too short to hold an MCAP recording"),
    (b"", "not an MCAP file"),
])
def test_check_of_a_tiny_file_says_what_it_is(tmp_path, content, words):
    """Before: an 8-byte file was "cannot open: Invalid argument" (a seek before its start)."""
    f = tmp_path / "tiny.mcap"
    f.write_bytes(content)
    r = bench("check", f)
    assert r.returncode == 2 and words in r.stderr and "Invalid argument" not in r.stderr
    assert "bench recover" not in r.stderr   # nothing in it to recover


@pytest.fixture(scope="module")
def g2_window_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("window") / "w.mcap"
    proc = bench("run", "gong_g2_500rpm", "--no-progress", "--out", out,
                 "--set", "scenario.duration_s=0.3", "--set", "metrics.window_s=[0.2, 0.3]")
    return proc, out


def test_set_metrics_window_says_which_figures_it_moved(g2_window_run):
    proc, _ = g2_window_run
    assert proc.returncode == 0, proc.stderr
    assert ("note: --set metrics.window_s: the metrics above are over 0.2..0.3 s; G2.sf, "
            "G2.sf.telemetry, G2.pee, G2.thd, G2.current keep their claim's own window 1..1.5 s"
            in proc.stderr), proc.stderr


def test_piped_tables_do_not_wrap(g2_window_run):
    """A pipe (CI log) gets a 200-column console: each table row is one line."""
    proc, out = g2_window_run
    r = bench("check", out, env={"COLUMNS": ""})
    rows = [ln for ln in r.stdout.splitlines() if ln.startswith("│ G2")]
    assert len(rows) == 5, r.stdout                      # one line per quantity: none wrapped
    assert max(len(ln) for ln in r.stdout.splitlines()) > 80
    assert "controller: fw 0x0100 (protocol 1.1, " in r.stdout


def test_check_json(g2_window_run):
    _, out = g2_window_run
    r = bench("check", out, "--json")
    assert r.returncode == 0, r.stderr
    doc = json.loads(r.stdout)
    assert doc["scenario"] == "gong_g2_500rpm" and doc["recording"] == str(out)
    assert doc["controller"].startswith("fw 0x0100")
    assert doc["integrity"]["ok"] is True and doc["integrity"]["cycles_done"] == 3000
    assert [c["quantity"] for c in doc["claims"]][:1] == ["G2.sf"]
    assert {c["verdict"] for c in doc["claims"]} == {"INVALID"} and doc["passed"] is False
    assert doc["metrics"]["t_end_s"] == pytest.approx(0.2999)


def test_claims_no_progress_and_only():
    r = bench("claims", "--no-progress", "--only", "g2")
    assert r.returncode == 0, r.stderr
    assert r.stdout.startswith("G2  ") and "\nG3  " not in r.stdout


def test_a_bundled_campaign_resolves_by_name_from_anywhere(tmp_path):
    from hil_bench.faults.campaign import load_campaign

    here = os.getcwd()
    os.chdir(tmp_path)
    try:
        camp = load_campaign("g2_protection")
    finally:
        os.chdir(here)
    assert camp.name == "g2_protection" and camp.path.is_file() and len(camp.cases) == 18
