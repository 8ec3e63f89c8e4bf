"""The last tracebacks (issue 19, item 5): a campaign `name` with a '/' (a ValueError from pathlib),
two Ctrl-C 50 ms apart (a KeyboardInterrupt inside the post-run check, the recording possibly not
finalised), and 64 link faults that passed validation and failed after the controller had started
(tests/test_fault_validity.py: refused at load now, naming the engine's limit)."""
from __future__ import annotations

import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from mcap.reader import make_reader

from hil_bench.cli import main as cli_main
from hil_bench.faults.campaign import CampaignError, load_campaign
from hil_bench.record import channels as ch
from hil_bench.record.recorder import partial_path
from hil_bench.record.recording import load_recording
from tests.short_scenario import short_scenario_text

REPO = Path(__file__).resolve().parents[1]
CAMPAIGN = (REPO / "bench" / "campaigns" / "g2_protection.toml").read_text()


@pytest.mark.parametrize("name", ["a/b", "../up", ".hidden", "x y", "a@b", "n" * 99])
def test_a_campaign_name_that_cannot_name_its_files_is_refused(tmp_path, capsys, name):
    p = tmp_path / "camp.toml"
    p.write_text(CAMPAIGN.replace('name = "g2_protection"', f'name = "{name}"'))
    with pytest.raises(CampaignError, match=r"camp\.toml:\d+: campaign\.name: "):
        load_campaign(p)
    assert cli_main(["campaign", str(p), "--out", str(tmp_path / "r")]) == 2
    err = capsys.readouterr().err
    assert "campaign.name" in err and "Traceback" not in err
    assert not (tmp_path / "r").exists()


@pytest.mark.parametrize("gaps_s", [(0.05,), (0.05, 0.3), (0.0, 0.0, 0.05, 0.1)],
                         ids=["twice-50ms", "three", "four"])
def test_repeated_ctrl_c_finalises_the_recording_and_exits_cleanly(tmp_path, gaps_s):
    out = tmp_path / "interrupted.mcap"
    scn = tmp_path / "long.toml"
    scn.write_text(short_scenario_text(600.0))   # the run cannot end by itself
    proc = subprocess.Popen([sys.executable, "-m", "hil_bench", "run", str(scn), "--out", str(out),
                             "--no-progress"], cwd=REPO, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    deadline = time.monotonic() + 60
    part = partial_path(out)
    while time.monotonic() < deadline and (not part.exists() or part.stat().st_size < 300_000):
        time.sleep(0.05)
    assert proc.poll() is None, f"the run ended before the Ctrl-C: {proc.communicate()}"
    proc.send_signal(signal.SIGINT)
    for gap in gaps_s:
        time.sleep(gap)
        if proc.poll() is None:
            proc.send_signal(signal.SIGINT)
    stdout, stderr = proc.communicate(timeout=60)
    # 130, or ended by SIGINT itself: CPython exits that way on purpose when a KeyboardInterrupt
    # ran through its machinery (bpo-1054041), so the calling shell sees an interrupt; a shell
    # reports both as 130. Seen about 1 run in 20 with presses during the check after the run.
    assert proc.returncode in (130, -signal.SIGINT), (stdout, stderr)
    assert "Traceback" not in stderr and "Traceback" not in stdout, stderr
    assert "interrupted" in stderr
    rec = load_recording(out)
    assert rec.truncated is None                  # finalised: summary and footer written
    assert rec.metadata["run_result"]["interrupted"] in ("true", "True")
    assert len(rec.topic(ch.PLANT_STATE)["t_s"]) > 100
    with open(out, "rb") as f:
        assert make_reader(f, validate_crcs=True).get_summary() is not None
