"""The sweep's table (issue 28 items 3, 6, 7; issue 30 items 3, 4): its identity, resuming and
refusing, damaged tables, duplicated rows, a full disk, retried errors, typed columns, the CLI's
error summary, the heat maps' numbers and order, folders two sweeps cannot share.

The runs themselves are made up by a FakeExecutor (what run_point returns, from the point's
inputs): these tests are about the table, and take a second; tests/test_sweep.py and
tests/test_sweep_cluster.py run real sweeps.
"""
from __future__ import annotations

import errno
import json
import os
import subprocess
from pathlib import Path

import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from hil_bench.cli import main as bench_main
from hil_bench.cluster import TaskFailure, TaskResult
from hil_bench.sweep import load_sweep
from hil_bench.sweep.run import SweepStopped, error_summary, run_sweep
from hil_bench.sweep.table import JOURNAL, RESULTS, TableError, resume

SWEEP = """
[sweep]
name = "t_table"
base = "gong_g2_500rpm"
link = "sil"
time_limit_s = 60

[overrides]
"scenario.duration_s" = {duration}
"metrics.window_s" = [0.2, 0.3]
"reference.estimators" = []

[[axes]]
name = "observer"
key = "controller.estimator"
values = ["SMO_TANH", "SMO_SIGN"]

[[axes]]
name = "speed_rpm"
key = "controller.speed_ref_rpm"
values = {speeds}

[collect]
metrics = ["pee_rms_rad", "speed_mean_rpm"]

[plots]
x = "speed_rpm"
y = "observer"
"""


def sweep_file(tmp_path: Path, speeds="[1500, 50, 500]", duration=0.3, name="s.toml") -> Path:
    p = tmp_path / name
    p.write_text(SWEEP.format(speeds=speeds, duration=duration))
    return p


class FakeExecutor:
    """Runs nothing: each point's row is what run_point would return, made up from its inputs;
    ``fail``: the indices (in submission order) that come back as the bench's failure."""

    where = "fake executor"

    def __init__(self, fail=(), error="OSError: [Errno 28] No space left on device: '/x/12'"):
        self.fail = set(fail)
        self.error = error
        self.submitted: list[str] = []

    def map(self, fn, items, *, time_limit_s=None, describe=None):
        for i, (key, args) in enumerate(items):
            self.submitted.append(key)
            if i in self.fail:
                yield key, TaskFailure(f"{self.error}\nTraceback ...", "w1")
                continue
            text = args[0]
            speed = float(text.split("speed_rpm = ")[1].split(",")[0].split("\n")[0])
            yield key, TaskResult({"decimate": 20, "end": "END", "error": "", "cycles_done": 3000,
                                   "cycles_planned": 3000, "status": "ok",
                                   "pee_rms_rad": speed / 1e4, "speed_mean_rpm": speed,
                                   "integrity_ok": True, "integrity": "", "verdict": "",
                                   "recording": ""}, "w1", 0.5, 0.6)


def run(sw, out, **kw):
    return run_sweep(sw, out, kw.pop("executor", None) or FakeExecutor(), **kw)


def cli(*args, capsys) -> tuple[int, str, str]:
    rc = bench_main(["sweep", *map(str, args)])
    got = capsys.readouterr()
    return rc, got.out, got.err


# -- identity (28.3) ------------------------------------------------------------------------------


def test_the_table_carries_the_sweep_identity_and_another_sweep_is_refused(tmp_path):
    sw = load_sweep(sweep_file(tmp_path))
    out = tmp_path / "out"
    rows, did = run(sw, out)
    assert did["ran"] == 6 and len(rows) == 6
    table = pq.read_table(out / RESULTS)
    meta = json.loads(table.schema.metadata[b"hil_bench.sweep"])
    assert meta["sweep_id"] == sw.sweep_id and set(meta["identity"]) >= {
        "base scenario", "overrides", "axes", "sampling", "collect", "link"}
    assert set(table.column("sweep_id").to_pylist()) == {sw.sweep_id}
    # the same sweep: resumed, nothing runs
    rows, did = run(load_sweep(sweep_file(tmp_path)), out)
    assert did["ran"] == 0 and did["skipped"] == 6 and len(rows) == 6
    # the overrides edited (every point's scenario differs): refused, the table untouched
    before = (out / RESULTS).read_bytes()
    edited = load_sweep(sweep_file(tmp_path, duration=0.35, name="s2.toml"))
    with pytest.raises(TableError, match=r"another sweep .*its overrides differ .*--fresh"):
        run(edited, out)
    assert (out / RESULTS).read_bytes() == before
    # --fresh: the old table kept aside, the new sweep's alone in results.parquet
    rows, did = run(edited, out, fresh=True)
    assert did["ran"] == 6 and {r["sweep_id"] for r in rows} == {edited.sweep_id}
    aside = list(out.glob("results.replaced-*.parquet"))
    assert len(aside) == 1 and aside[0].read_bytes() == before
    assert len(pq.read_table(out / RESULTS)) == 6


def test_a_grid_that_grew_runs_only_its_new_points_a_shrunk_one_is_refused(tmp_path):
    out = tmp_path / "out"
    run(load_sweep(sweep_file(tmp_path)), out)
    more = load_sweep(sweep_file(tmp_path, speeds="[1500, 50, 500, 700]"))
    ex = FakeExecutor()
    rows, did = run(more, out, executor=ex)
    assert did["ran"] == 2 and did["skipped"] == 6 and len(rows) == 8
    assert [r["index"] for r in rows] == list(range(8))            # this sweep's numbering
    assert json.loads(pq.read_table(out / RESULTS).schema.metadata[b"hil_bench.sweep"])[
        "sweep_id"] == more.sweep_id
    fewer = load_sweep(sweep_file(tmp_path, speeds="[1500, 50]"))
    with pytest.raises(TableError, match="axes differ"):
        run(fewer, out)


def test_a_table_with_foreign_rows_or_without_identity_is_refused(tmp_path):
    sw = load_sweep(sweep_file(tmp_path))
    other = load_sweep(sweep_file(tmp_path, duration=0.4, name="o.toml"))
    a, b = tmp_path / "a", tmp_path / "b"
    run(sw, a)
    run(other, b)
    # rows of another sweep joined into this one's table (its metadata kept)
    ta, tb = pq.read_table(a / RESULTS), pq.read_table(b / RESULTS)
    joined = pa.concat_tables([ta, tb.cast(ta.schema)])
    pq.write_table(joined, a / RESULTS)
    with pytest.raises(TableError, match=r"6 of its 12 rows are of another sweep \(sweep id "):
        run(sw, a)
    # the same rows with the sweep id faked: still foreign hashes
    ids = pa.array([sw.sweep_id] * len(joined)).dictionary_encode()
    faked = joined.set_column(joined.column_names.index("sweep_id"), "sweep_id", ids)
    pq.write_table(faked, a / RESULTS)
    with pytest.raises(TableError, match="6 of its 12 rows are no run of this sweep"):
        run(sw, a)
    # a table without an identity (another program's, or an older bench's)
    pq.write_table(ta.replace_schema_metadata({}), a / RESULTS)
    with pytest.raises(TableError, match="without a sweep identity"):
        run(sw, a)


# -- damaged tables, duplicated rows (28.7) -------------------------------------------------------


def _damage(kind: str, path: Path, good: bytes) -> None:
    if kind == "truncated":
        path.write_bytes(good[: len(good) // 2])
    elif kind == "random":
        path.write_bytes(os.urandom(len(good)))
    elif kind == "empty":
        path.write_bytes(b"")
    elif kind == "flipped":
        b = bytearray(good)
        for i in range(len(b) // 3, len(b) // 3 + 64):
            b[i] ^= 0x5A
        path.write_bytes(bytes(b))
    elif kind == "foreign schema":
        pq.write_table(pa.table({"x": [1, 2], "y": ["a", "b"]}), path)
    elif kind == "string dtypes":
        t = pq.read_table(path)
        i = t.column_names.index("cpu_s")
        t = t.set_column(i, "cpu_s", pa.array([str(v) for v in t.column("cpu_s").to_pylist()]))
        pq.write_table(t, path)
    elif kind == "a directory":
        path.unlink()
        path.mkdir()
        (path / "part-0.parquet").write_bytes(good)


@pytest.mark.parametrize("kind,match", [
    ("truncated", "not a readable Parquet table"),
    ("random", "not a readable Parquet table"),
    ("empty", "not a readable Parquet table"),
    ("flipped", "not a readable Parquet table|column|identity|row"),
    ("foreign schema", "no column 'index'"),
    ("string dtypes", "column 'cpu_s' holds string, not number"),
    ("a directory", "is a directory"),
])
def test_a_damaged_table_is_one_line_and_left_as_it_is(tmp_path, capsys, kind, match):
    path = sweep_file(tmp_path)
    out = tmp_path / "out"
    run(load_sweep(path), out)
    good = (out / RESULTS).read_bytes()
    _damage(kind, out / RESULTS, good)
    listing = lambda: sorted(p.name for p in out.rglob("*") if p.name != ".sweep.lock")  # noqa: E731
    before = listing()
    rc, stdout, err = cli(path, "--out", out, "--no-progress", capsys=capsys)
    assert rc == 2 and "Traceback" not in err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ") and str(out / RESULTS) in lines[0]
    assert __import__("re").search(match, lines[0]), lines[0]
    assert "--fresh" in lines[0]
    assert listing() == before                                        # nothing moved or written


def test_fresh_sets_a_damaged_table_aside(tmp_path):
    sw = load_sweep(sweep_file(tmp_path))
    out = tmp_path / "out"
    out.mkdir()
    (out / RESULTS).write_bytes(b"junk")
    rows, did = run(sw, out, fresh=True)
    assert did["ran"] == 6
    assert [p.read_bytes() for p in out.glob("results.replaced-*.parquet")] == [b"junk"]


def test_duplicated_rows_are_reported_and_the_last_of_each_kept(tmp_path):
    sw = load_sweep(sweep_file(tmp_path))
    out = tmp_path / "out"
    run(sw, out)
    t = pq.read_table(out / RESULTS)
    doubled = pa.concat_tables([t, t.slice(0, 2)])       # two rows again (a join by hand)
    pq.write_table(doubled, out / RESULTS)
    res = resume(sw, out)
    assert len(res.rows) == 6
    assert any("2 row(s) repeat the scenario hash" in n and "the last of each kept" in n
               for n in res.notes), res.notes
    rows, did = run(sw, out)
    assert did["ran"] == 0 and len(pq.read_table(out / RESULTS)) == 6   # written back unique


def test_unreadable_journal_lines_are_skipped_and_said_their_runs_run_again(tmp_path):
    sw = load_sweep(sweep_file(tmp_path))
    out = tmp_path / "out"
    run(sw, out, executor=FakeExecutor(fail={0, 1, 2, 3, 4, 5}))
    good = pq.read_table(out / RESULTS).to_pylist()
    # rows 0 and 1 done since, in the journal; then garbage, and a line cut short
    lines = [json.dumps({**r, "status": "ok", "error": ""}) for r in good[:2]]
    (out / JOURNAL).write_text(lines[0] + "\n{not json\n" + lines[1] + "\n" + lines[1][:40])
    res = resume(sw, out)
    assert [r["status"] for r in res.rows] == ["ok", "ok"] + ["error"] * 4
    assert any("2 unreadable line(s) skipped" in n for n in res.notes), res.notes
    ex = FakeExecutor()
    rows, did = run(sw, out, executor=ex)
    assert did["ran"] == 4 and all(r["status"] == "ok" for r in rows)


# -- a full disk (28.6) -------------------------------------------------------------------------


def test_a_failed_write_stops_the_sweep_keeps_every_finished_row_and_a_rerun_completes(
        tmp_path, monkeypatch):
    from hil_bench.sweep import table

    sw = load_sweep(sweep_file(tmp_path))
    out = tmp_path / "out"
    real_write = os.write
    calls = {"n": 0}

    def write(fd, data):
        if fd != journal_fd["fd"]:
            return real_write(fd, data)
        calls["n"] += 1
        if calls["n"] == 4:                     # the 4th row: half of it fits, then the disk is full
            real_write(fd, data[: len(data) // 2])
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        return real_write(fd, data)

    journal_fd = {"fd": -1}
    real_init = table.Journal.__init__

    def init(self, path):
        real_init(self, path)
        journal_fd["fd"] = self.fd

    monkeypatch.setattr(table.Journal, "__init__", init)
    monkeypatch.setattr(table.os, "write", write)
    ex = FakeExecutor()
    with pytest.raises(SweepStopped, match=r"No space left on device; the sweep stopped after 3 "
                                           r"of 6 runs.* --out .*out to complete it"):
        run(sw, out, executor=ex)
    monkeypatch.undo()
    # the three rows finished are in the journal, whole (the half line was cut back)
    lines = (out / JOURNAL).read_bytes().splitlines(keepends=True)
    assert len(lines) == 3 and all(json.loads(x)["status"] == "ok" for x in lines)
    assert not (out / RESULTS).exists()
    rows, did = run(sw, out)
    assert did["ran"] == 3 and did["skipped"] == 3 and len(rows) == 6
    assert len({r["scenario_hash"] for r in rows}) == 6
    assert not (out / JOURNAL).exists() and len(pq.read_table(out / RESULTS)) == 6


def test_a_table_that_cannot_be_rewritten_keeps_the_old_table_and_the_journal(
        tmp_path, monkeypatch):
    sw = load_sweep(sweep_file(tmp_path))
    out = tmp_path / "out"
    run(load_sweep(sweep_file(tmp_path, speeds="[1500]")), out)
    before = pq.read_table(out / RESULTS).column("scenario_hash").to_pylist()

    real = pq.write_table
    calls = []

    def full(table_, where, **kw):
        calls.append(where)
        if len(calls) == 1:                   # the resumed table rewritten before the runs
            return real(table_, where, **kw)
        Path(where).write_bytes(b"PAR1")      # a start, then the disk is full
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(pq, "write_table", full)
    with pytest.raises(SweepStopped, match="No space left on device"):
        run(sw, out)
    monkeypatch.undo()
    assert pq.read_table(out / RESULTS).column("scenario_hash").to_pylist() == before   # whole
    assert not [p for p in out.iterdir() if p.name.endswith(".tmp")]
    assert len((out / JOURNAL).read_bytes().splitlines()) == 4       # the 4 new rows
    rows, did = run(sw, out)
    assert did["ran"] == 0 and len(rows) == 6 and len(pq.read_table(out / RESULTS)) == 6


@pytest.fixture
def tiny_disk(tmp_path):
    """A 512 kB tmpfs (needs root and mount rights; skipped with the reason otherwise)."""
    mnt = tmp_path / "disk"
    mnt.mkdir()
    try:
        r = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=512k", "tmpfs", str(mnt)],
                           capture_output=True, text=True, timeout=20)
    except (OSError, subprocess.TimeoutExpired) as exc:
        pytest.skip(f"cannot mount a tmpfs for a real full disk: {exc}")
    if r.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs for a real full disk: {r.stderr.strip()}")
    try:
        yield mnt
    finally:
        subprocess.run(["umount", "-l", str(mnt)], capture_output=True, timeout=20)


def _fill(disk: Path, leave: int) -> Path:
    filler = disk / "filler"
    st = os.statvfs(disk)
    free = st.f_bavail * st.f_frsize
    with filler.open("wb") as f:
        f.write(b"\0" * max(0, free - leave))
    return filler


def test_a_really_full_disk_keeps_the_rows_and_leaves_no_partial_file(tmp_path, tiny_disk):
    from hil_bench.sweep.run import keep_recording

    sw = load_sweep(sweep_file(tmp_path, speeds=str(list(range(100, 2100, 100)))))   # 40 runs
    out = tiny_disk / "out"
    out.mkdir()
    filler = _fill(tiny_disk, 8 * 1024)
    with pytest.raises(SweepStopped, match="No space left on device") as exc:
        run(sw, out)
    assert "\n" not in str(exc.value) and "--out" in str(exc.value)
    kept = [json.loads(x) for x in (out / JOURNAL).read_bytes().splitlines()]
    assert 0 < len(kept) < 40 and (out / JOURNAL).read_bytes().endswith(b"\n")
    files = [p for p in out.rglob("*") if p.is_file() and p.name != ".sweep.lock"]
    assert all(p.stat().st_size > 0 for p in files), files
    assert not [p for p in files if p.name.endswith(".tmp")]
    # a recording kept into the full disk: whole or absent, never 0 bytes or partial
    rec = tmp_path / "r.mcap"
    rec.write_bytes(os.urandom(200_000))
    (tmp_path / "r.serial.bin").write_bytes(os.urandom(100))
    with pytest.raises(OSError) as full:
        keep_recording(rec, out / "recordings" / "r.mcap", [tmp_path / "r.serial.bin"])
    assert full.value.errno == errno.ENOSPC
    assert not (out / "recordings" / "r.mcap").exists() and rec.exists()
    assert not [p for p in (out / "recordings").iterdir() if p.name.endswith(".tmp")]
    # space again: the rerun completes the sweep, every run once
    filler.unlink()
    rows, did = run(sw, out)
    assert did["ran"] == 40 - len(kept) and len(rows) == 40
    assert len({r["scenario_hash"] for r in rows}) == 40 and not (out / JOURNAL).exists()


# -- retried errors, the summary (30.4) -----------------------------------------------------------


def test_error_rows_are_retried_on_a_rerun_unless_told_not_to(tmp_path):
    sw = load_sweep(sweep_file(tmp_path))
    out = tmp_path / "out"
    rows, _ = run(sw, out, executor=FakeExecutor(fail={0, 2, 3}))
    assert sum(r["status"] == "error" for r in rows) == 3
    lines = error_summary(sw, rows)
    first = next(r for r in rows if r["status"] == "error")
    assert len(lines) == 1 and lines[0].startswith(f"3 errors like run {first['index']} (observer=")
    assert lines[0].endswith(": OSError: [Errno 28] No space left on device: '/x/12'")
    rows, did = run(sw, out, retry_errors=False)
    assert did["ran"] == 0 and sum(r["status"] == "error" for r in rows) == 3
    ex = FakeExecutor()
    rows, did = run(sw, out, executor=ex)
    assert did["ran"] == 3 and did["retried"] == 3 and len(ex.submitted) == 3
    assert all(r["status"] == "ok" for r in rows) and len(rows) == 6


def test_a_timeout_runs_again_only_under_a_longer_limit(tmp_path):
    from hil_bench.sweep.run import needs_run

    sw = load_sweep(sweep_file(tmp_path))
    row = {"status": "timeout", "time_limit_s": 60.0}
    assert not needs_run(sw, row, True)
    sw.time_limit_s = 120.0
    assert needs_run(sw, row, True)
    assert not needs_run(sw, {"status": "controller_fault"}, True)
    assert needs_run(sw, {"status": "error"}, True) and not needs_run(sw, {"status": "error"}, False)


def test_the_error_summary_groups_messages_that_differ_only_in_numbers(tmp_path):
    sw = load_sweep(sweep_file(tmp_path))
    rows = [{"status": "error", "index": i, "in.observer": "SMO_TANH", "in.speed_rpm": 50,
             "error": f"could not run: slcan /dev/pts/{i} (pid {100 + i})\ntraceback"}
            for i in range(5)] + [{"status": "error", "index": 9, "error": "KilledWorker: x"},
                                  {"status": "ok", "index": 10}]
    lines = error_summary(sw, rows)
    assert lines[0] == ("5 errors like run 0 (observer=SMO_TANH, speed_rpm=50): could not run: "
                        "slcan /dev/pts/0 (pid 100)")
    assert lines[1].startswith("1 error like run 9") and lines[1].endswith("KilledWorker: x")


# -- dtypes (30.3) --------------------------------------------------------------------------------


def test_the_table_has_proper_dtypes(tmp_path):
    import pandas as pd

    sw = load_sweep(sweep_file(tmp_path))
    out = tmp_path / "out"
    run(sw, out, executor=FakeExecutor(fail={1}))
    df = pd.read_parquet(out / RESULTS)
    assert df["integrity_ok"].dtype == bool
    assert not df.loc[df["status"] == "error", "integrity_ok"].any()
    for col in ("status", "verdict", "end", "link", "worker", "in.observer", "sweep_id"):
        assert isinstance(df[col].dtype, pd.CategoricalDtype), col
    assert df["in.speed_rpm"].dtype == "int64" and df["index"].dtype == "int64"
    for col in ("cpu_s", "wall_s", "pee_rms_rad", "speed_mean_rpm", "time_limit_s"):
        assert df[col].dtype == "float64", col
    assert df["cycles_done"].dtype == "int64"


# -- plots (30.4) ---------------------------------------------------------------------------------


def test_heat_maps_print_each_cell_and_sort_numeric_axes_as_numbers(tmp_path, monkeypatch):
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib.figure import Figure

    from hil_bench.sweep.plots import axis_order, plot_sweep

    sw = load_sweep(sweep_file(tmp_path))                 # speeds given as 1500, 50, 500
    out = tmp_path / "out"
    rows, _ = run(sw, out, executor=FakeExecutor(fail={4}))
    assert axis_order(sw, "speed_rpm", [1500, 50, 500, 50]) == [50, 500, 1500]
    assert axis_order(sw, "observer", ["SMO_SIGN", "SMO_TANH"]) == ["SMO_TANH", "SMO_SIGN"]
    seen = {}
    real = Figure.savefig

    def savefig(self, fname, *a, **kw):
        seen.setdefault("texts", [t.get_text() for ax in self.axes for t in ax.texts])
        seen.setdefault("xticks", [t.get_text() for t in self.axes[0].get_xticklabels()])
        return real(self, fname, *a, **kw)

    monkeypatch.setattr(Figure, "savefig", savefig)
    paths = plot_sweep(sw, rows, out)
    assert paths and all(p.stat().st_size > 0 for p in paths)
    assert seen["xticks"] == ["50", "500", "1500"]
    # pee_rms_rad of the made-up runs is speed / 1e4; the failed run's cell says "error"
    texts = seen["texts"]
    assert {"0.005", "0.05", "0.15"} <= set(texts) and "error" in texts, texts
    assert "1500, 50" not in (out / "report.html").read_text()
    assert not [p for p in out.rglob("*.tmp")]


# -- folders (26.5) -------------------------------------------------------------------------------


def test_default_folders_never_collide_and_a_folder_has_one_writer(tmp_path):
    from hil_bench.sweep.folder import FolderBusy, FolderLock, new_out_dir

    made = [new_out_dir(tmp_path / "reports", "obs") for _ in range(20)]
    assert len(set(made)) == 20 and all(p.is_dir() for p in made)
    assert made[0].name.startswith("obs-") and made[0].name.split("-")[-1] == str(os.getpid())
    with FolderLock(made[0]):
        # another process (a second bench sweep) is refused while this one writes
        code = ("import sys; from pathlib import Path; from hil_bench.sweep.folder import "
                "FolderLock, FolderBusy\ntry:\n    FolderLock(Path(sys.argv[1])).__enter__()\n"
                "except FolderBusy as e:\n    print(e); sys.exit(3)\n")
        r = subprocess.run([os.sys.executable, "-c", code, str(made[0])], capture_output=True,
                           text=True, timeout=60)
        assert r.returncode == 3 and "another bench sweep is writing this folder" in r.stdout
        assert f"pid {os.getpid()}" in r.stdout
    with FolderLock(made[0]):          # released: free again
        pass
    assert FolderBusy


def test_the_cli_refuses_bad_options_in_one_line(tmp_path, capsys):
    path = sweep_file(tmp_path)
    for args, match in ([("--scheduler", "not a url"), "not a Dask scheduler address"],
                        [("--scheduler", "tcp://host"), "not a Dask scheduler address"]):
        rc, out, err = cli(path, "--out", tmp_path / "o", *args, capsys=capsys)
        assert rc == 2 and len(err.strip().splitlines()) == 1 and match in err, err
    for args in (("--workers", "0"), ("--workers", "-2"), ("--time-limit-s", "-1"),
                 ("--time-limit-s", "nan")):
        with pytest.raises(SystemExit) as e:
            bench_main(["sweep", str(path), "--out", str(tmp_path / "o"), *args])
        assert e.value.code == 2
        assert f"argument {args[0]}" in capsys.readouterr().err
