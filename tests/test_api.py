"""The Python API (docs/api.md): hil_bench.run / check / load_recording, the CLI's --set and
--version, the lazy top level, and what a missing C build says."""
from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import hil_bench
from hil_bench.record import channels as ch
from hil_bench.record.recording import load_recording as read_columns
from hil_bench.scenario import ScenarioError

REPO = Path(__file__).resolve().parents[1]
#: G2 cut to its start-up: the window (0.2..0.4 s) is the I-f ramp, not G2's window: the claim
#: does not apply to what ran (INVALID, never PASS or FAIL)
SHORT_STARTUP = {"scenario.duration_s": 0.4, "metrics.window_s": [0.2, 0.4]}


@pytest.fixture(scope="module")
def short_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("api") / "short.mcap"
    return hil_bench.run("gong_g2_500rpm", overrides=SHORT_STARTUP, out=out)


def test_run_returns_claims_integrity_metrics_and_the_recording(short_run):
    r = short_run
    assert r.recording.is_file() and r.scenario == "gong_g2_500rpm"
    assert r.run.cycles_done == r.run.cycles_planned == 4000 and r.run.error is None
    assert r.integrity.ok and r.integrity.problems == ()
    keys = [c.quantity for c in r.claims]
    assert keys == ["G2.sf", "G2.sf.telemetry", "G2.pee", "G2.thd", "G2.current"]
    # another window than G2's: the verdict follows what ran, not the scenario's name
    assert {c.verdict for c in r.claims} == {"INVALID"}
    assert not r.passed
    # the summary numbers are the window's
    assert r.metrics["pee_max_rad"] > 0.0
    assert r.metrics["t_end_s"] == pytest.approx(0.3999)
    with pytest.raises(KeyError, match="measured no 'G9.x'.*G2.pee"):
        r.measured("G9.x")


def test_the_overrides_are_what_ran_and_the_recording_says_so(short_run):
    rec = read_columns(short_run.recording, topics=[ch.PLANT_STATE])
    assert rec.topics[ch.PLANT_STATE]["t_s"][-1] == pytest.approx(0.3999)
    name, toml = rec.attachment_text("scenario/")
    assert "derived from" in toml and "'scenario.duration_s' = 0.4" not in toml
    assert "#   scenario.duration_s = 0.4" in toml and "duration_s = 0.4" in toml
    assert rec.run["hil_bench_version"] == hil_bench.__version__


def test_assert_claims_fails_with_the_paper_vs_measured_table(short_run):
    with pytest.raises(hil_bench.ClaimsNotReproduced) as info:
        short_run.assert_claims()
    text = str(info.value)
    assert text.startswith("claims not reproduced: G2.sf INVALID; G2.pee INVALID")
    assert str(short_run.recording) in text
    header = next(line for line in text.splitlines() if line.startswith("claim "))
    assert header.split() == ["claim", "quantity", "paper", "measured", "rule", "verdict"]
    assert "7.5 rpm" in text                                       # the paper's value
    assert "[1] not G2's set-up (run G2): window" in text          # the verdict's reason
    with pytest.raises(hil_bench.ClaimsNotReproduced, match=r"measures no claim \['Y1'\]"):
        short_run.assert_claims(only="Y1")


def test_check_of_the_recording_gives_the_same_verdicts(short_run):
    again = hil_bench.check(short_run.recording)
    assert again.run is None
    assert [(c.quantity, c.verdict) for c in again.claims] == \
        [(c.quantity, c.verdict) for c in short_run.claims]
    assert [c.measured for c in again.claims] == pytest.approx(
        [c.measured for c in short_run.claims], nan_ok=True)
    with pytest.raises(FileNotFoundError, match="no such recording"):
        hil_bench.check(short_run.recording.with_name("nothing.mcap"))


def test_load_recording_gives_dataframes_equal_to_the_recorded_columns(short_run):
    import pandas as pd

    data = hil_bench.load_recording(short_run.recording)
    cols = read_columns(short_run.recording)
    assert set(data.topics) == set(cols.topics)
    for topic, fields in cols.topics.items():
        frame = data[topic]
        assert isinstance(frame, pd.DataFrame)
        assert frame.index.name == "t_s"            # indexed by time; reset_index(): a column
        if topic == ch.LINK_FRAMES:                 # one row per frame (test_recording_tables.py)
            continue
        flat = frame.reset_index()
        assert list(flat.columns)[0] == "t_s"
        for name, values in fields.items():
            col = flat[name]                        # an enum's codes are its raw values
            got = (col.cat.codes if isinstance(col.dtype, pd.CategoricalDtype) else col).to_numpy()
            if values.dtype.kind == "f":
                np.testing.assert_array_equal(got, values)
            else:
                assert list(got) == list(values)
    assert data.run["scenario"] == "gong_g2_500rpm" and data.damage == ""
    assert "duration_s = 0.4" in data.scenario_toml
    only = hil_bench.load_recording(short_run.recording, channels=[ch.PLANT_STATE, "/reference/*"])
    assert only.topics == [ch.PLANT_STATE, "/reference/SMO_TANH"]
    with pytest.raises(KeyError, match="no channel '/nope'"):
        only["/nope"]


def test_bad_overrides_are_located_errors():
    with pytest.raises(ScenarioError, match="speed_ref_rpm"):
        hil_bench.run("gong_g2_500rpm", overrides={"controller.speed_ref_rpm": "fast"})
    with pytest.raises(TypeError, match="mapping of dotted keys"):
        hil_bench.run("gong_g2_500rpm", overrides=[("plant.t_delay_s", 0.0)])


def test_import_hil_bench_is_cheap_and_the_api_is_lazy():
    code = ("import sys, hil_bench; heavy = {'numpy', 'hil_bench.api', 'rich', 'cffi'} & "
            "set(sys.modules); f = hil_bench.run; print(sorted(heavy), f.__module__, "
            "hil_bench.__version__)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout.split()
    assert out[0] == "[]" and out[1] == "hil_bench.api"
    assert out[2] == hil_bench.__version__ != "unknown"


def _bench(*args: str, cwd: Path | None = None) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "hil_bench", *args], capture_output=True,
                          text=True, cwd=cwd, timeout=300)


def test_bench_version_says_what_and_where():
    r = _bench("--version")
    assert r.returncode == 0
    assert r.stdout.startswith(f"bench (hil-bench) {hil_bench.__version__} from checkout {REPO}")
    assert "C built" in r.stdout


def test_bench_run_set_overrides_by_dotted_key(tmp_path):
    out = tmp_path / "set.mcap"
    r = _bench("run", "gong_g2_500rpm", "--no-progress", "--out", str(out),
               "--set", "scenario.duration_s=0.3", "--set", "metrics.window_s=[0.1, 0.3]",
               "--set", "controller.estimator=SMO_SIGN")
    assert "ran 3000/3000 cycles" in r.stdout, r.stderr
    rec = read_columns(out, topics=[ch.CONTROLLER_TELEMETRY])
    assert json.loads(rec.run["reference_estimators"]) is not None
    assert rec.run["estimator"] == "SMO_SIGN"            # a bare word is a string
    bad = _bench("run", "gong_g2_500rpm", "--set", "duration_s")
    assert bad.returncode == 2 and "use KEY=VALUE" in bad.stderr
    unknown = _bench("run", "gong_g2_500rpm", "--set", "plant.no_such_key=1")
    assert unknown.returncode == 2 and "no_such_key" in unknown.stderr
    assert "Traceback" not in unknown.stderr


BLOCK_C = """
import sys
class Block:
    def find_spec(self, name, path=None, target=None):
        if name in ("hil_bench.plant_rt._plant_c", "hil_bench.firmware_stub._fw_c"):
            raise ModuleNotFoundError(f"No module named {name!r}", name=name)
sys.meta_path.insert(0, Block())
"""


def test_without_the_c_built_the_cli_and_the_api_say_what_to_run(tmp_path):
    """An editable install whose C is not built (make build's pip step alone): the message names
    `make build` in this checkout, not a traceback."""
    cli = subprocess.run([sys.executable, "-c", BLOCK_C + "from hil_bench.cli import main\n"
                          "raise SystemExit(main(['run', 'gong_g2_500rpm']))"],
                         capture_output=True, text=True, cwd=tmp_path, timeout=120)
    assert cli.returncode == 2, cli.stderr
    assert "Traceback" not in cli.stderr
    assert "compiled C is missing" in cli.stderr and "make build" in cli.stderr
    assert str(REPO) in cli.stderr.replace("\n", "")
    api = subprocess.run([sys.executable, "-c", BLOCK_C + "import hil_bench\n"
                          "try:\n    hil_bench.run('gong_g2_500rpm')\n"
                          "except ImportError as e:\n    print(type(e).__name__, e)"],
                         capture_output=True, text=True, cwd=tmp_path, timeout=120)
    assert api.stdout.startswith("NativeMissing hil_bench.plant_rt._plant_c, "
                                 "hil_bench.firmware_stub._fw_c not built")
    assert "make build" in api.stdout
    version = subprocess.run([sys.executable, "-c", BLOCK_C + "from hil_bench.cli import main\n"
                              "main(['--version'])"], capture_output=True, text=True, timeout=60)
    assert "C parts missing: hil_bench.plant_rt._plant_c" in version.stdout


def test_a_run_that_records_nothing_raises_run_failed(monkeypatch, tmp_path):
    monkeypatch.setenv("HIL_STUB", "/bin/false")        # exits at once: no handshake, no cycle
    with pytest.raises(hil_bench.RunFailed, match=r"no cycle ran \(.*peer closed the link") as info:
        hil_bench.run("gong_g2_500rpm", out=tmp_path / "x.mcap")
    assert str(tmp_path / "x.mcap") in str(info.value)  # the attempt's recording is kept


@pytest.mark.parametrize("call, error, words", [
    (lambda: hil_bench.run(None), "ArgumentError", "scenario: a bundled scenario's name"),
    (lambda: hil_bench.run(123), "ArgumentError", "got 123 (int)"),
    (lambda: hil_bench.run(""), "ArgumentError", "got ''"),
    (lambda: hil_bench.run("gong_g2_500rpm", link=None), "ArgumentError", "link: a link spec"),
    (lambda: hil_bench.run("gong_g2_500rpm", link=""), "LinkError", "link is empty"),
    (lambda: hil_bench.run("gong_g2_500rpm", link="stub:foo"), "LinkError", "did you mean 'stub'"),
    (lambda: hil_bench.run("gong_g2_500rpm", overrides={1: 2}), "ArgumentError",
     "the key 1 is not a dotted scenario key"),
    (lambda: hil_bench.run("gong_g2_500rpm", overrides={"plant.t_delay_s": object()}),
     "ArgumentError", "a scenario value is a bool, number, string or a list"),
    (lambda: hil_bench.run("gong_g2_500rpm", out=3), "ArgumentError", "out: a file path"),
    (lambda: hil_bench.run("gong_g2_500rpm", force="yes"), "ArgumentError", "force: True or False"),
    (lambda: hil_bench.run("gong_g2_500rpm", cpu="0"), "ArgumentError", "cpu: a CPU number"),
    (lambda: hil_bench.run("gong_g2_500rmp"), "ScenarioError", "did you mean 'gong_g2_500rpm'"),
    (lambda: hil_bench.check(None), "ArgumentError", "check(path): a file path"),
    (lambda: hil_bench.check("no/such.mcap"), "NoSuchFile", "no such recording"),
    (lambda: hil_bench.load_recording(None), "ArgumentError", "load_recording(path): a file path"),
    (lambda: hil_bench.signals.settles(None, 1.0, within_s=1.0, band=0.1), "ArgumentError",
     "signals.settles: give a pandas Series indexed by time"),
])
def test_every_bad_argument_is_the_benchs_own_error(call, error, words):
    """Before: hil_bench.run(None) was a bare TypeError from inside pathlib, run(123) an
    AttributeError, overrides={1: 2} an AttributeError from the TOML writer, check(None) a
    TypeError: every one is now a BenchError of the documented kind, with its words."""
    with pytest.raises(hil_bench.BenchError) as info:
        call()
    assert type(info.value).__name__ == error and words in str(info.value), str(info.value)
    if error == "ArgumentError":            # still catchable as what it always was
        assert isinstance(info.value, TypeError) and isinstance(info.value, ValueError)


def test_load_recording_refuses_a_channel_the_file_does_not_have(short_run):
    """Before: channels=["/nope"] returned no frame and no word."""
    with pytest.raises(hil_bench.ArgumentError, match=r"no channel '/nope'.*has: /controller/"):
        hil_bench.load_recording(short_run.recording, channels=["/nope"])
    with pytest.raises(hil_bench.ArgumentError, match="did you mean '/plant/state'"):
        hil_bench.load_recording(short_run.recording, channels=["/plant/stat"])
    assert hil_bench.load_recording(short_run.recording, channels="/plant/state").topics == \
        [ch.PLANT_STATE]


def test_the_result_names_the_controller_that_answered(short_run):
    """From its HELLO_ACK as recorded, not the link spec: the bundled stub is fw 0x0100."""
    assert short_run.controller.startswith("fw 0x0100 (protocol 1.1, estimators 0x")
    assert "hil_stub " in short_run.controller and short_run.run.link == "stub"
    assert hil_bench.check(short_run.recording).controller == short_run.controller
    assert f"controller: {short_run.controller}" in short_run.summary()
