"""What the bench writes is never an older run's, never one of its inputs, never a shared name
(issue 28 items 2 and 4, issue 26 item 5; bench/record/atomic.py, recorder.reserve_recording,
bench/record/sidecars.py).

* A ``--force`` run moves the previous recording and its side files aside before it starts: a
  run that fails leaves nothing at ``--out`` that reads as its result, and once the new
  recording is in place the old files are gone. The serial capture is written aside and renamed
  with the recording; the recording names its size, SHA-256 and run id, and ``bench check``
  calls another run's capture beside it an integrity problem.
* An output that is one of the command's inputs (the same path, a symbolic or a hard link) is
  refused with or without ``--force``, by every command that writes.
* Default names carry the time to the millisecond and the process id, and the name is taken by
  creating its partial file exclusively: two runs started together in one folder both record.
"""
from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from hil_bench.errors import OutputIsInput
from hil_bench.loop.runner import Runner, default_recording_path, run_scenario
from hil_bench.record.atomic import (
    partial_path,
    replaced_path,
    same_file,
    take_exclusive,
    write_text_aside,
)
from hil_bench.record.recorder import RecorderError, reserve_recording
from hil_bench.record.recording import load_recording
from tests.short_scenario import short_scenario, short_scenario_text

REPO = Path(__file__).resolve().parents[1]
EX = REPO / "examples" / "captures"
def scenario(duration=0.1, name="outputs"):
    return short_scenario(duration, name, source="outputs.toml")


def bench(*args, cwd=REPO, timeout=300):
    return subprocess.run([sys.executable, "-m", "hil_bench", *map(str, args)], cwd=cwd,
                          capture_output=True, text=True, timeout=timeout)


# -- 28.2: a failed --force run leaves no older file at --out ---------------------------------------

def test_a_forced_rerun_that_fails_leaves_no_older_recording_at_out(tmp_path):
    """The issue's case: X.mcap from a first run, a --force rerun whose recorder dies (killed
    mid-run). Before: the first run's X.mcap stayed, beside the new run's X.serial.bin, and
    `bench check --strict X.mcap` passed G2. Now nothing is at X.mcap or X.serial.bin: the old
    pair waits under .replaced names (the error says where), the new one under .partial names."""
    out = tmp_path / "x.mcap"
    first = run_scenario(scenario(0.1), out_path=out, progress=False)
    assert first.ok and out.exists() and out.with_suffix(".serial.bin").exists()
    old = out.read_bytes()
    runner = Runner(scenario(3600.0), out_path=out, progress=False, force=True)

    def kill():
        while getattr(runner, "engine", None) is None or runner.engine.cycles_done < 2000:
            time.sleep(0.002)
        os.kill(runner.rec.pid, signal.SIGKILL)

    th = threading.Thread(target=kill)
    th.start()
    result = runner.run()
    th.join()
    assert result.error is not None and "died (killed by signal 9)" in result.error
    assert not out.exists() and not out.with_suffix(".serial.bin").exists()
    assert f"the previous x.mcap is kept as {replaced_path(out)}" in result.error
    assert replaced_path(out).read_bytes() == old
    assert replaced_path(out.with_suffix(".serial.bin")).exists()
    checked = bench("check", "--strict", out)
    assert checked.returncode == 2 and "no such file" in checked.stderr
    # the dead run's partial file is kept, renamed x.abandoned.mcap by the next run of that
    # name (its writer holds no lock on it), and so is the first run's recording it was told of
    died = partial_path(out).read_bytes()
    again = run_scenario(scenario(0.1), out_path=out, progress=False, force=True)
    assert again.ok and out.exists() and replaced_path(out).read_bytes() == old
    assert (tmp_path / "x.abandoned.mcap").read_bytes() == died
    # a --force run that succeeds removes what it moved aside once its recording is in place
    newer = out.read_bytes()
    third = run_scenario(scenario(0.12), out_path=out, progress=False, force=True)
    assert third.ok and out.read_bytes() not in (old, newer)
    assert replaced_path(out).read_bytes() == old       # the first run's, not the second's
    assert not replaced_path(out.with_suffix(".serial.bin")).exists() or \
        replaced_path(out.with_suffix(".serial.bin")).stat().st_size > 0


def test_the_serial_capture_is_written_aside_and_renamed_with_the_recording(tmp_path):
    out = tmp_path / "aside.mcap"
    side = out.with_suffix(".serial.bin")
    runner = Runner(scenario(0.5), out_path=out, progress=False)
    seen = {}

    def look():
        while getattr(runner, "engine", None) is None or runner.engine.cycles_done < 1000:
            time.sleep(0.002)
        seen.update(side=side.exists(), side_partial=partial_path(side).exists())

    th = threading.Thread(target=look)
    th.start()
    result = runner.run()
    th.join()
    assert result.ok and seen == {"side": False, "side_partial": True}
    assert side.exists() and not partial_path(side).exists()
    meta = load_recording(out, topics=()).metadata
    assert meta["sidecar.serial.bin"]["file"] == side.name
    assert int(meta["sidecar.serial.bin"]["bytes"]) == side.stat().st_size
    assert meta["sidecar.serial.bin"]["run_id"] == meta["run"]["run_id"]
    from hil_bench.record.serial_capture import read_records

    end: list[str] = []
    list(read_records(side, [], end))
    assert end and end[0].endswith(f"(run {meta['run']['run_id']})")


def test_check_calls_another_runs_capture_beside_a_recording_a_problem(tmp_path):
    """X.mcap with the X.serial.bin of another run beside it (copied over, or left by a run
    that failed): an integrity problem of kind sidecar, so --strict exits 1."""
    a, b = tmp_path / "a.mcap", tmp_path / "b.mcap"
    assert run_scenario(scenario(0.1, "a"), out_path=a, progress=False).ok
    assert run_scenario(scenario(0.12, "b"), out_path=b, progress=False).ok
    ok = bench("check", "--strict", a, "--json")
    assert ok.returncode == 0, ok.stdout + ok.stderr
    shutil.copyfile(b.with_suffix(".serial.bin"), a.with_suffix(".serial.bin"))
    bad = bench("check", "--strict", a)
    assert bad.returncode == 1
    assert f"{a.with_suffix('.serial.bin')} is not this run's serial byte capture" in bad.stdout
    import hil_bench

    problems = hil_bench.check(a).integrity.problems
    assert any(p.startswith("sidecar: ") for p in problems)


def test_a_partial_file_being_written_is_never_taken_and_a_dead_ones_is_kept(tmp_path):
    """The partial file's writer holds a lock on it (the recorder process, for its whole life):
    a run of that name is refused, with or without --force, or takes the next free name when the
    name was a default one. A partial file no one holds is a dead writer's: kept as
    <stem>.abandoned.mcap, and the run goes on."""
    out = tmp_path / "busy.mcap"
    hold = take_exclusive(partial_path(out))      # as a recorder at work holds it
    partial_path(out).write_bytes(b"being written")
    try:
        for force in (False, True):
            with pytest.raises(RecorderError, match="is being written by another run"):
                run_scenario(scenario(), out_path=out, progress=False, force=force)
        taken = reserve_recording(out, pick_free=True)
        assert taken.path == tmp_path / "busy-1.mcap" and partial_path(taken.path).exists()
        taken.release()
        assert not partial_path(taken.path).exists()
    finally:
        os.close(hold)
    assert partial_path(out).read_bytes() == b"being written"
    result = run_scenario(scenario(), out_path=out, progress=False)   # its writer is gone now
    assert result.ok and out.exists() and not partial_path(out).exists()
    assert (tmp_path / "busy.abandoned.mcap").read_bytes() == b"being written"


# -- 26.5: unique default names --------------------------------------------------------------------

def test_default_names_have_milliseconds_and_the_process_id():
    name = default_recording_path(scenario()).name
    stem = name.removesuffix(".mcap")
    _, date, clock, ms, pid = stem.rsplit("-", 4)
    assert len(date) == 8 and len(clock) == 6 and len(ms) == 3 and pid == str(os.getpid())


def test_two_runs_started_together_in_one_folder_both_record(tmp_path):
    """The issue's test: two `bench run gong_g2_500rpm` started together in one folder. Before:
    both picked recordings/gong_g2_500rpm-<second>.mcap and one (or both) exited 2."""
    args = [sys.executable, "-m", "hil_bench", "run", "gong_g2_500rpm", "--no-progress",
            "--set", "scenario.duration_s=0.3", "--set", "metrics.window_s=[0.2, 0.3]"]
    time.sleep(1.05 - time.time() % 1.0)    # just after a second starts: the same second's name
    procs = [subprocess.Popen(args, cwd=tmp_path, stdout=subprocess.PIPE,
                              stderr=subprocess.PIPE, text=True) for _ in range(2)]
    outs = [p.communicate(timeout=600) for p in procs]
    assert [p.returncode for p in procs] == [0, 0], outs
    made = sorted((tmp_path / "recordings").glob("gong_g2_500rpm-*.mcap"))
    assert len(made) == 2
    for f in made:
        assert load_recording(f, topics=()).metadata["run_result"]["cycles_done"] == "3000"
    assert not list((tmp_path / "recordings").glob(".*"))   # no partial or replaced file left


# -- 28.4: no command writes over one of its inputs -------------------------------------------------

def _links(tmp_path: Path, target: Path) -> dict[str, Path]:
    """The same file by its own path, a symbolic link and a hard link (in tmp_path)."""
    sym, hard = tmp_path / f"sym_{target.name}", tmp_path / f"hard_{target.name}"
    sym.symlink_to(target)
    os.link(target, hard)
    return {"path": target, "symlink": sym, "hard link": hard}


@pytest.mark.parametrize("force", [False, True])
def test_replay_refuses_its_own_capture_as_out(tmp_path, force):
    cap = tmp_path / "cap.mcap"
    shutil.copyfile(EX / "example.mcap", cap)
    before = cap.read_bytes()
    for how, out in _links(tmp_path, cap).items():
        r = bench("replay", cap, "--out", out, *(["--force"] if force else []))
        assert r.returncode == 2, (how, r.stdout, r.stderr)
        assert "is the command's own capture" in r.stderr and "Traceback" not in r.stderr
        assert cap.read_bytes() == before, how


@pytest.mark.parametrize("force", [False, True])
def test_run_refuses_its_scenario_file_as_out(tmp_path, force):
    scn = tmp_path / "s.toml"
    scn.write_text(short_scenario_text(0.1, "s"))
    text = scn.read_text()
    for how, out in _links(tmp_path, scn).items():
        r = bench("run", scn, "--out", out, "--no-progress", *(["--force"] if force else []))
        assert r.returncode == 2 and "is the command's own scenario file" in r.stderr, (how, r.stderr)
        assert scn.read_text() == text
    # ... and through the API: the same error type
    import hil_bench

    with pytest.raises(OutputIsInput):
        hil_bench.run(scn, out=tmp_path / "hard_s.toml", force=True)


@pytest.mark.parametrize("force", [False, True])
def test_recover_refuses_its_input_by_any_link(tmp_path, force):
    src = tmp_path / "d.mcap"
    shutil.copyfile(EX / "example.mcap", src)
    before = src.read_bytes()
    for how, out in _links(tmp_path, src).items():
        r = bench("recover", src, "-o", out, *(["--force"] if force else []))
        assert r.returncode == 2 and "is the damaged file itself" in r.stderr, (how, r.stderr)
        assert src.read_bytes() == before


@pytest.mark.parametrize("force", [False, True])
def test_layout_refuses_its_scenario_file(tmp_path, force):
    scn = tmp_path / "l.toml"
    scn.write_text(short_scenario_text(0.1, "l"))
    text = scn.read_text()
    for how, out in _links(tmp_path, scn).items():
        r = bench("layout", scn, "-o", out, *(["--force"] if force else []))
        assert r.returncode == 2 and "is the command's own scenario file" in r.stderr, (how, r.stderr)
        assert scn.read_text() == text
    ok = bench("layout", scn, "-o", tmp_path / "layout.json")
    assert ok.returncode == 0 and (tmp_path / "layout.json").read_text().startswith("{")


def test_campaign_sweep_and_claims_refuse_an_input_as_their_report_folder(tmp_path):
    camp = tmp_path / "c.toml"
    shutil.copyfile(REPO / "bench" / "campaigns" / "g2_protection.toml", camp)
    camp_text = camp.read_text()
    r = bench("campaign", camp, "--out", camp, "--no-progress")
    assert r.returncode == 2 and "is the command's own campaign file" in r.stderr, r.stderr
    assert camp.read_text() == camp_text
    sweep = tmp_path / "w.toml"
    shutil.copyfile(REPO / "bench" / "sweeps" / "observers_speed_load.toml", sweep)
    r = bench("sweep", sweep, "--out", sweep, "--no-progress", "--quick")
    assert r.returncode == 2 and "is the command's own sweep file" in r.stderr, r.stderr
    registry = REPO / "bench" / "claims" / "gong2020.toml"
    before = registry.read_bytes()
    r = bench("claims", "--run", "--only", "G2", "--out", registry, "--no-progress")
    assert r.returncode == 2 and "is the command's own claims registry file" in r.stderr, r.stderr
    assert registry.read_bytes() == before


def test_helpers_see_the_same_file_through_links(tmp_path):
    f = tmp_path / "f.txt"
    write_text_aside(f, "one")
    links = _links(tmp_path, f)
    assert all(same_file(f, p) for p in links.values())
    assert not same_file(f, tmp_path / "other.txt")
    with pytest.raises(FileExistsError):
        write_text_aside(f, "two", replace=False)
    assert f.read_text() == "one" and not list(tmp_path.glob(".f.txt.*"))


# -- 26.5: a claims run or a campaign beside another one in the same folder -----------------------

HOLD_LOCK = ("import sys, time; from pathlib import Path; from hil_bench.sweep.folder import "
             "FolderLock\nFolderLock(Path(sys.argv[1]), sys.argv[2]).__enter__()\n"
             "print('held', flush=True); time.sleep(600)\n")


def _hold(folder: Path, command: str) -> subprocess.Popen:
    """Another process holding ``folder``'s writer lock, as a running claims run or campaign."""
    folder.mkdir(parents=True, exist_ok=True)
    p = subprocess.Popen([sys.executable, "-c", HOLD_LOCK, str(folder), command],
                         stdout=subprocess.PIPE, text=True)
    assert p.stdout.readline().strip() == "held"
    return p


def test_claim_folder_takes_the_default_or_one_beside_it(tmp_path):
    from hil_bench.sweep.folder import FolderBusy, claim_folder

    default = tmp_path / "reports" / "claims"
    folder, lock, note = claim_folder(None, default, "bench claims")
    with lock:
        assert folder == default and note == ""
        beside, lock2, note2 = claim_folder(None, default, "bench claims")   # held: one beside
        with lock2:
            assert beside != default and beside.parent == default.parent
            assert beside.name.startswith("claims-") and beside.name.endswith(f"-{os.getpid()}")
            assert f"{default} is being written by another bench claims" in note2
            assert str(beside) in note2
        with pytest.raises(FolderBusy, match="another bench claims is writing this folder"):
            claim_folder(default, default, "bench claims")     # --out given: refused
    assert claim_folder(None, default, "bench claims")[0] == default    # released: free again


def test_a_claims_run_beside_a_running_one_writes_its_own_folder(tmp_path):
    """Two `bench claims --run` in one folder: the second writes reports/claims-<time>-<pid>
    (before: both wrote reports/claims, their recordings under the same names)."""
    holder = _hold(tmp_path / "reports" / "claims", "bench claims")
    try:
        r = subprocess.run([sys.executable, "-m", "hil_bench", "claims", "--run", "--only", "G2",
                            "--no-progress"], cwd=tmp_path, capture_output=True, text=True,
                           timeout=600)
        assert r.returncode == 0, r.stderr
        assert "reports/claims is being written by another bench claims" in r.stderr
        made = [p for p in (tmp_path / "reports").iterdir() if p.name.startswith("claims-")]
        assert len(made) == 1 and (made[0] / "report.md").exists()
        assert (made[0] / "recordings" / "G2.mcap").exists()
        assert not (tmp_path / "reports" / "claims" / "report.md").exists()
        # with --out naming the held folder: refused in one line, nothing run
        r = subprocess.run([sys.executable, "-m", "hil_bench", "claims", "--run", "--only", "G2",
                            "--out", "reports/claims", "--no-progress"], cwd=tmp_path,
                           capture_output=True, text=True, timeout=600)
        assert r.returncode == 2 and "another bench claims is writing this folder" in r.stderr
        assert "Traceback" not in r.stderr
    finally:
        holder.kill()
        holder.wait()
