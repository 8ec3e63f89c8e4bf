"""Messages that said something else than what happened (issue 19, item 7): a run the bench's own
faults ended is not "nothing at all (the controller is silent)"; an answer that came late is named
late; HELLO_ACKs with the wrong session are not "no HELLO_ACK"; a valid MCAP file of someone else is
not "a damaged recording"; `bench replay` takes the `.partial` file the bench points to; the serial
capture of a killed run says it was cut; rich markup does not eat `[[faults]]` in error texts."""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from hil_bench.cli import main as cli_main
from hil_bench.loop.host_session import HostSession, ProtocolViolation
from hil_bench.loop.runner import run_scenario
from hil_bench.protocol.messages import MESSAGES, Mode
from hil_bench.record.recorder import partial_path
from hil_bench.record.recording import NotABenchRecording, load_recording
from hil_bench.replay.readers import read_capture
from hil_bench.record import channels as ch
from hil_bench.scenario import check_against_profile, parse_scenario

from tests.test_faults_engine import BASE
from tests.test_host_session import ScriptedLink, hello_ack

REPO = Path(__file__).resolve().parents[1]

#: a scenario description rich would take for markup, were it not escaped
DESCRIPTION = 'description = "[bold]not markup[/bold] [[faults]]"'


def text(faults: str = "", duration: float = 0.3) -> str:
    return BASE.format(duration=duration, faults=faults, events="", estimator="SMO_TANH",
                       controller="", scenario=DESCRIPTION)


def scenario(faults: str = "", duration: float = 0.3):
    scn = parse_scenario(text(faults, duration), Path("truthful.toml"))
    check_against_profile(scn)
    return scn


# ---- what ended a lockstep run -------------------------------------------------------------------

@pytest.mark.parametrize("fault,said", [
    # a stall longer than the patience: nothing crosses, the run ends naming the bench's own fault
    ('kind = "stall"\nstall_periods = 30000', "the bench's own stall faults[0] let"),
    # every DUTY of the cycle dropped (the cycle never advances past the fault's window)
    ('kind = "drop"\ndirection = "from_controller"\nmessage = "DUTY"\nuntil_s = 0.25',
     "the bench's own drop fault faults[0] dropped 5 frame(s) of this cycle"),
])
def test_a_run_the_bench_itself_ended_says_so(tmp_path, fault, said):
    """The host's patience (1 s here: what is tested is the message at its end) runs out on a cycle
    whose frames the bench's own fault kept from crossing: the message says so, not "silent"."""
    result = run_scenario(scenario(f"[[faults]]\nt_s = 0.2\n{fault}\n[link]\npatience_s = 1.0"),
                          out_path=tmp_path / "x.mcap", progress=False)
    assert result.end == "NO_DUTY" and result.cycles_done == 2000, result.error
    assert said in result.error and "nothing at all" not in result.error, result.error


def test_an_answer_merely_late_is_waited_for_and_counted_late(tmp_path):
    """The DUTY of cycle 2000 held 0.3 s by the bench's own delay fault: late is not lost
    (docs/protocol.md 6.5). The run goes on to its end, the cycle counts as late (its re-sends all
    answered), the /timing row shows the delay, and the fault's trace names the late answer."""
    out = tmp_path / "late.mcap"
    result = run_scenario(scenario('[[faults]]\nt_s = 0.2\nkind = "delay"\ndirection = '
                                   '"from_controller"\nmessage = "DUTY"\ndelay_s = 0.3\ncount = 1'),
                          out_path=out, progress=False)
    assert result.ok, result.error
    stats = result.link_stats
    # cycle 2000 is late; a busy host may make others late too (timing, never a problem)
    assert stats["late_answers"] >= 1 and stats["lost_frames"] == 0 and stats["retries"] >= 2, stats
    rec = load_recording(out)
    timing = rec.topic(ch.TIMING)
    (row,) = np.flatnonzero(timing["seq"] == 2000)
    assert timing["retries"][row] >= 2 and timing["rtt_us"][row] >= 0.3e6
    if stats["late_answers"] == 1:
        assert list(timing["seq"][timing["retries"] > 0]) == [2000]
    traces = [t for a, t in zip(rec.topic(ch.FAULTS)["action"], rec.topic(ch.FAULTS)["text"])
              if a == "trace"]
    assert traces and "late_answers +" in traces[0], traces


# ---- the handshake ---------------------------------------------------------------------------------

def test_hello_acks_with_the_wrong_session_are_named():
    def wrong_echo(fid, payload):
        if fid == MESSAGES["HELLO"].frame_id:
            return [hello_ack((MESSAGES["HELLO"].unpack(payload)["session"] + 1) & 0xFFFF)]
        return []

    s = HostSession(ScriptedLink(wrong_echo))
    with pytest.raises(ProtocolViolation, match=r"answers, but no HELLO_ACK within 0\.3 s echoed "
                                                r"our session 0x[0-9A-F]{4}: \d+ HELLO_ACK came "
                                                r"with session 0x[0-9A-F]{4}") as info:
        s.handshake(period_s=1e-4, estimator=1, flags=0, mode=Mode.LOCKSTEP, timeout_s=0.3)
    assert "no controller answering" not in str(info.value)


# ---- recordings that are not damaged -----------------------------------------------------------------

def _third_party_mcap(path: Path) -> None:
    from mcap.writer import Writer

    with open(path, "wb") as f:
        w = Writer(f)
        w.start(profile="", library="someone else")
        sid = w.register_schema(name="pose", encoding="jsonschema", data=b"{}")
        cid = w.register_channel(topic="/robot/pose", message_encoding="json", schema_id=sid)
        for i in range(10):
            w.add_message(channel_id=cid, log_time=i, publish_time=i, data=b'{"x": 1}')
        w.finish()


def test_a_valid_mcap_of_someone_else_is_not_called_damaged(tmp_path, capsys):
    p = tmp_path / "[other].mcap"
    _third_party_mcap(p)
    assert cli_main(["check", str(p)]) == 2
    err = capsys.readouterr().err
    assert "not a recording of this bench" in err and "/robot/pose" in err
    assert "bench recover" not in err and "damaged" not in err
    assert "[other].mcap" in err.replace("\n", "")          # not eaten as markup
    with pytest.raises(NotABenchRecording):
        from hil_bench.papers.check import check_recording
        check_recording(p)
    text = tmp_path / "notes.mcap"
    text.write_text("not an mcap file at all\n")
    assert cli_main(["check", str(text)]) == 2
    err = capsys.readouterr().err.replace("\n", "")   # rich wraps a long path
    assert "not an MCAP file" in err and "bench recover" not in err


@pytest.fixture(scope="module")
def bench_run(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("run") / "run.mcap"
    result = run_scenario(scenario(), out_path=out, progress=False)
    assert result.ok, result.error
    return out


def test_a_damaged_bench_recording_still_gets_the_recover_hint(bench_run, tmp_path, capsys):
    bad = tmp_path / "bad.mcap"
    data = bytearray(bench_run.read_bytes())
    data[8:4000] = bytes(3992)
    bad.write_bytes(bytes(data))
    assert cli_main(["check", str(bad)]) == 2
    assert "bench recover" in capsys.readouterr().err


def test_bench_replay_reads_the_partial_file_the_bench_points_to(bench_run, tmp_path, capsys):
    part = partial_path(tmp_path / "cut.mcap")
    data = bench_run.read_bytes()
    part.write_bytes(data[: len(data) * 6 // 10])
    assert read_capture(part).kind == "mcap"
    assert cli_main(["replay", str(part), "--estimators", "SMO_TANH",
                     "--out", str(tmp_path / "r.mcap")]) == 0
    captured = capsys.readouterr()
    assert "replayed" in captured.out and "damaged capture" in captured.err
    assert "no run_result record" in captured.err


def test_the_serial_capture_of_a_killed_run_says_it_was_cut(bench_run, tmp_path):
    side = bench_run.with_suffix(".serial.bin")
    cap = read_capture(side)                            # a complete run: closed by the bench
    assert not cap.problems and not cap.anomalies.counts.get("damaged")
    cut = tmp_path / "cut.serial.bin"                   # its writer killed: no end record
    data = side.read_bytes()
    cut.write_bytes(data[: data.rfind(b"end of the run") - 13])
    cap = read_capture(cut)
    assert any("no end record" in p for p in cap.problems)
    assert cap.anomalies.summary() != "none"
    # the bench killed mid-run (its recorder goes on and closes the capture): said so too
    out = tmp_path / "killed.mcap"
    scn = tmp_path / "long.toml"
    scn.write_text(text(duration=60.0))
    proc = subprocess.Popen([sys.executable, "-m", "hil_bench", "run", str(scn), "--no-progress",
                             "--out", str(out)], cwd=REPO, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and (not partial_path(out).exists() or
                                           partial_path(out).stat().st_size < 300_000):
        time.sleep(0.05)
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    side = out.with_suffix(".serial.bin")   # renamed into place with the recording, once closed
    while time.monotonic() < deadline and not (side.exists() and out.exists()):
        time.sleep(0.1)
    cap = read_capture(side)
    assert any("closed before the end of the run" in p and "went away" in p for p in cap.problems)
    assert cap.anomalies.summary() != "none"


# ---- rich markup -------------------------------------------------------------------------------------

def test_error_texts_keep_their_brackets(tmp_path, capsys, bench_run):
    bad = tmp_path / "bad.toml"
    bad.write_text("faults = 3\n" + text())
    assert cli_main(["run", str(bad), "--no-progress", "--out", str(tmp_path / "x.mcap")]) == 2
    assert "([[faults]])" in capsys.readouterr().err
    camp = tmp_path / "camp.toml"
    camp.write_text('[campaign]\nname = "c"\nbase = "gong_g2_500rpm"\n')
    assert cli_main(["campaign", str(camp), "--out", str(tmp_path / "r")]) == 2
    assert "[[runs]] or [[grid]]" in capsys.readouterr().err.replace("\n", " ")
    assert cli_main(["check", str(bench_run)]) == 0
    assert "[bold]not markup[/bold] [[faults]]" in capsys.readouterr().out
    missing = tmp_path / "[red]gone[/red].mcap"
    assert cli_main(["check", str(missing)]) == 2
    assert "[red]gone[/red].mcap: no such file" in capsys.readouterr().err.replace("\n", "")
