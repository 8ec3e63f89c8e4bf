"""bench sweep (issue 17): the sweep file, the executor on a real Dask cluster with a worker
killed mid-sweep, the per-run time limit, resume by the scenario hash; what a sweep file and the
executor refuse (issue 28), plain ``dask worker`` processes and retried errors (issue 30).

The cluster tests start Dask's own ``dask scheduler`` and ``dask worker`` processes on
127.0.0.1, as Dask's documentation starts them (daemonic workers: no
DASK_DISTRIBUTED__WORKER__DAEMON). One runs a short SIL sweep, SIGKILLs a worker once the sweep
is under way, and checks the table: every run exactly once, none lost, a controller fault a
result row; then the same sweep with one more speed resumes: only the new runs run. The other
runs ``bench sweep --quick`` on such a cluster with an error injected on the workers' side (the
folder its recordings go to is a file), then again once it is fixed: the error rows run again.
The table's own tests (identity, damage, a full disk): tests/test_sweep_table.py.
"""
from __future__ import annotations

import math
import os
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from hil_bench.sweep import SweepError, load_sweep

VENV_BIN = Path(sys.executable).parent

SWEEP = """
[sweep]
name = "t_sweep"
base = "gong_g2_500rpm"
link = "sil"
time_limit_s = 60

[overrides]
"scenario.duration_s" = 0.3
"metrics.window_s" = [0.2, 0.3]
"reference.estimators" = []

[[axes]]
name = "observer"
key = "controller.estimator"
values = {observers}

[[axes]]
name = "speed_rpm"
key = "controller.speed_ref_rpm"
values = {speeds}

[[axes]]
name = "rs"
key = "plant.rs_ohm"
values = [0.9, 1.1]
relative = true

[collect]
metrics = ["pee_rms_rad", "speed_mean_rpm"]
"""


def write_sweep(tmp_path: Path, observers='["SMO_TANH", "HFI_SDFT"]',
                speeds="[300, 500, 700]", extra="") -> Path:
    p = tmp_path / "s.toml"
    p.write_text(SWEEP.format(observers=observers, speeds=speeds) + extra)
    return p


def test_grid_relative_axes_and_the_hash(tmp_path):
    sw = load_sweep(write_sweep(tmp_path))
    assert len(sw.points) == 2 * 3 * 2
    p = sw.points[0]
    assert p.inputs == {"observer": "SMO_TANH", "speed_rpm": 300, "rs": 0.9}
    assert "rs_ohm = 0.57447" in p.scenario_text          # 0.9 x gong2020's 0.6383 ohm
    # extending an axis moves the indices but not the hashes of the runs already there
    more = load_sweep(write_sweep(tmp_path, speeds="[300, 400, 500, 700]"))
    assert {q.scenario_hash for q in sw.points} < {q.scenario_hash for q in more.points}
    assert len({q.scenario_hash for q in more.points}) == len(more.points)


def test_seeded_samples(tmp_path):
    extra = '\n[sampling]\nmethod = "{m}"\nn = 8\nseed = 3\n'
    for m in ("lhs", "sobol"):
        text = SWEEP.format(observers='["SMO_TANH"]', speeds="[300, 700]").replace(
            'values = [300, 700]', 'range = [300, 700, 2]') + extra.format(m=m)
        (tmp_path / "x.toml").write_text(text)
        a, b = load_sweep(tmp_path / "x.toml"), load_sweep(tmp_path / "x.toml")
        speeds = [p.inputs["speed_rpm"] for p in a.points]
        assert len(a.points) == 8 and speeds == [p.inputs["speed_rpm"] for p in b.points]
        assert all(300 <= s <= 700 for s in speeds) and len(set(speeds)) == 8   # continuous


SPEED = '[[axes]]\nkey = "controller.speed_ref_rpm"\n'


@pytest.mark.parametrize("bad,match", [
    ('[[axes]]\nkey = "plant.no_such"\nvalues = [1]\n', "t_sweep_00000"),
    ('[[axes]]\nname = "x"\nvalues = [1]\n', "give key"),
    ('[collect]\nmetrics = ["nope"]\n', "metrics: unknown 'nope'"),
    ('[sampling]\nmethod = "random"\n', "method = 'random'"),
    # issue 28: numbers that are not, counts nothing could run, fields nothing reads
    (SPEED + "values = [500, 1000]\nscale = nan\n", r"axes\[0\] \(controller.speed_ref_rpm\): "
                                                   r"scale = nan: must be a finite number"),
    (SPEED + "values = [500, nan]\n", "values: nan is not a finite number"),
    (SPEED + "range = [500, inf, 3]\n", "range stop = inf: must be a finite number"),
    (SPEED + 'values = [500]\nlog = "yes"\n', "log = 'yes': must be true or false"),
    (SPEED + "range = [100, 2000, 1e5]\n" + '[[axes]]\nkey = "plant.rs_ohm"\n'
     "range = [0.5, 1.0, 100000]\n",
     r"10,000,000,000 runs \(100,000 x 100,000 grid\) is more than the limit of 20,000 runs"),
    (SPEED + "range = [100, 2000, 3]\n[sampling]\nmethod = \"lhs\"\nn = 1e9\n",
     r"1,000,000,000 runs \(\[sampling\] n = 1,000,000,000\) is more than the limit of 20,000"),
    (SPEED + "range = [100, 2000, 3]\n[sampling]\nmethod = \"lhs\"\nn = 2.5\n",
     "n = 2.5: must be a whole number"),
    ('[sampling]\nmetod = "lhs"\n', "unknown field 'metod'"),
    (SPEED + "range = [100, 2000, 3]\n[sampling]\nmethod = \"lhs\"\nn = 4\nseed = -1\n",
     "seed = -1: must be >= 0"),
    ('[plots]\nx = "nope"\n', "x = 'nope': not an axis"),
])
def test_a_bad_sweep_file_is_named(tmp_path, bad, match):
    text = ("[sweep]\nname = \"t_sweep\"\nbase = \"gong_g2_500rpm\"\n" + bad)
    (tmp_path / "b.toml").write_text(text)
    with pytest.raises(SweepError, match=match):
        load_sweep(tmp_path / "b.toml")


@pytest.mark.parametrize("field,match", [
    ("time_limit_s = -1", "time_limit_s = -1: must be > 0"),
    ("time_limit_s = nan", "time_limit_s = nan: must be a finite number"),
    ('link = "stub:foo"', "link = 'stub:foo': unknown link; one of stub, sil"),
    ('link = "sil2"', "link = 'sil2': unknown link"),
    ('link = ""', "link = '': unknown link"),
    ('link = "serial:/dev/ttyUSB0@fast"', "bad baud rate 'fast'"),
    ("link = 3", "link = 3: must be a string"),
    ("time_limt_s = 60", "unknown field 'time_limt_s'"),
    ("max_runs = 4", r"12 runs \(2 x 3 x 2 grid\) is more than the limit of 4 runs"),
    ('name = "../x"', "name = '../x': letters, digits, _ . - only"),
    ("name = 1", "name = 1: must be a non-empty string"),
])
def test_a_bad_sweep_table_field_is_named(tmp_path, field, match):
    p = write_sweep(tmp_path)
    key = field.split(" ")[0]
    old = {"link": 'link = "sil"', "name": 'name = "t_sweep"'}.get(key, "time_limit_s = 60")
    p.write_text(p.read_text().replace(old, field, 1))
    with pytest.raises(SweepError, match=match) as exc:
        load_sweep(p)
    assert str(p) in str(exc.value) and "\n" not in str(exc.value)


def test_the_executor_refuses_bad_options_before_it_starts():
    from hil_bench.cluster import ClusterError, Executor
    from hil_bench.cluster.limits import time_limit

    for address in ("not a url", "tcp://host", "http://h:8786", "tcp://h:0", "tcp://a b:1"):
        with pytest.raises(ClusterError, match="not a Dask scheduler address"):
            Executor(address)
    for n in (0, -1, 1.5, True):
        with pytest.raises(ClusterError, match=">= 1"):
            Executor(None, n)
    for limit in (-1, 0, math.nan, math.inf):
        with pytest.raises(ValueError, match="finite number of seconds > 0"):
            with time_limit(limit):
                pass


def _start_a_child() -> int:
    """What a run does on its worker: a multiprocessing child (the recorder)."""
    import multiprocessing as mp

    p = mp.get_context("fork").Process(target=os._exit, args=(7,))
    p.start()
    p.join(30)
    return p.exitcode


def _task_on_a_daemon(q) -> None:
    import multiprocessing as mp

    from hil_bench.cluster import call

    r = call(_start_a_child, (), None)
    q.put((getattr(r, "value", None), getattr(r, "error", None), mp.current_process().daemon))


def test_a_task_on_a_daemonic_worker_process_may_start_a_child():
    """Dask starts its workers as daemonic processes; multiprocessing forbids those children.
    A task lifts the flag while it runs, and puts it back."""
    import multiprocessing as mp

    ctx = mp.get_context("fork")
    q = ctx.Queue()
    worker = ctx.Process(target=_task_on_a_daemon, args=(q,), daemon=True)
    worker.start()
    value, error, daemon_after = q.get(timeout=60)
    worker.join(30)
    assert error is None and value == 7
    assert daemon_after is True


def test_the_time_limit_ends_a_run(tmp_path):
    """A run still going at the limit is ended by the runner and says so. The run is paced at real
    time in lockstep (--pace 1: 5 s of plant time take at least 5 s of wall time, so it cannot
    finish before the 1.5 s limit), not a real-time run: a loaded host may end a real-time run
    on its own (a period more than 100 periods late), which is not what this tests."""
    import dataclasses

    from hil_bench.cluster.limits import time_limit
    from hil_bench.loop.runner import Runner
    from hil_bench.scenario import load_scenario

    scn = dataclasses.replace(load_scenario("gong_g2_500rpm"), duration_s=5.0)
    with time_limit(1.5):
        result = Runner(scn, "sil", tmp_path / "t.mcap", progress=False, pace=1.0).run()
    assert result.timed_out and "time limit of 1.5 s per run exceeded" in result.error
    assert 0 < result.cycles_done < 50_000


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _start(args: list[str], env=None) -> subprocess.Popen:
    return subprocess.Popen(args, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                            start_new_session=True, env=env)


def _stop(proc: subprocess.Popen) -> None:
    if proc.poll() is None:
        os.killpg(proc.pid, signal.SIGTERM)
        try:
            proc.wait(10)
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait(5)


def _plain_env() -> dict:
    """The environment a lab's `dask worker` has: nothing of Dask's set."""
    return {k: v for k, v in os.environ.items() if not k.startswith("DASK_")}


def _scheduler() -> tuple[str, list[subprocess.Popen]]:
    port = _free_port()
    proc = _start([str(VENV_BIN / "dask"), "scheduler", "--host", "127.0.0.1", "--port",
                   str(port), "--no-dashboard"], env=_plain_env())
    return f"tcp://127.0.0.1:{port}", [proc]


def _worker(address: str, name: str) -> subprocess.Popen:
    return _start([str(VENV_BIN / "dask"), "worker", address, "--nthreads", "1", "--nworkers",
                   "1", "--no-dashboard", "--name", name], env=_plain_env())


def _wait_for_workers(address: str, n: int) -> None:
    """Until n workers have joined; skipped with the reason if the cluster never comes up (this
    waits on processes starting, not on a run: no result depends on it)."""
    from distributed import Client

    deadline = time.monotonic() + 90
    while True:
        try:
            with Client(address, timeout="2s") as c:
                if len(c.scheduler_info()["workers"]) == n:
                    return
        except OSError:
            pass
        if time.monotonic() > deadline:
            pytest.skip(f"the Dask scheduler and {n} worker(s) did not come up on {address} "
                        f"within 90 s")
        time.sleep(0.5)


def test_a_killed_worker_loses_no_run_and_a_sweep_resumes(tmp_path):
    from hil_bench.cluster import Executor
    from hil_bench.sweep.run import run_sweep

    address, procs = _scheduler()
    try:
        workers = [_worker(address, f"w{i}") for i in range(2)]
        procs += workers
        _wait_for_workers(address, 2)

        sw = load_sweep(write_sweep(tmp_path))
        out = tmp_path / "out"
        rows_box: dict = {}
        with Executor(address, progress=False, label="t") as ex:
            seen = []
            real_map = ex.map

            def watching_map(*a, **kw):
                for item in real_map(*a, **kw):
                    seen.append(item)
                    yield item
            ex.map = watching_map
            th = threading.Thread(target=lambda: rows_box.update(
                result=run_sweep(sw, out, ex)), daemon=True)
            th.start()
            while len(seen) < 2 and th.is_alive():
                time.sleep(0.05)
            os.killpg(workers[0].pid, signal.SIGKILL)   # mid-sweep: its running run is lost
            th.join(240)
            assert not th.is_alive(), "the sweep did not finish after a worker was killed"
        rows, did = rows_box["result"]
        assert did["ran"] == len(sw.points) == 12
        hashes = [r["scenario_hash"] for r in rows]
        assert sorted(hashes) == sorted(p.scenario_hash for p in sw.points)   # each once
        assert not [r for r in rows if r["status"] == "error"], rows
        # HFI on this surface-PM motor is refused at its configuration: a result, not retried
        hfi = [r for r in rows if r["in.observer"] == "HFI_SDFT"]
        assert hfi and all(r["status"] == "controller_fault" for r in hfi)
        ok = [r for r in rows if r["in.observer"] == "SMO_TANH"]
        assert all(r["status"] == "ok" and math.isfinite(r["pee_rms_rad"]) for r in ok), ok

        import pyarrow.parquet as pq

        table = pq.read_table(out / "results.parquet").to_pylist()
        assert len(table) == 12 and {r["scenario_hash"] for r in table} == set(hashes)
        for col in ("in.speed_rpm", "cpu_s", "wall_s", "git_revision", "seed", "worker",
                    "integrity_ok", "end", "cycles_done"):
            assert col in table[0], col

        # one more speed: only its runs run, on the surviving worker
        more = load_sweep(write_sweep(tmp_path, speeds="[300, 500, 600, 700]"))
        with Executor(address, progress=False, label="t2") as ex:
            rows2, did2 = run_sweep(more, out, ex)
        assert did2["ran"] == 4 and did2["skipped"] == 12 and len(rows2) == 16
        assert len({r["scenario_hash"] for r in rows2}) == 16
    finally:
        for p in reversed(procs):
            _stop(p)


QUICK = """
[sweep]
name = "t_quick"
base = "gong_g2_500rpm"
link = "sil"
record = "decimated"           # every run keeps its recording: the error injected below

[overrides]
"scenario.duration_s" = 0.3
"metrics.window_s" = [0.2, 0.3]
"reference.estimators" = []

[[axes]]
name = "observer"
key = "controller.estimator"
values = ["SMO_TANH", "SMO_SIGN", "SMO_SIGMOID"]

[[axes]]
name = "speed_rpm"
key = "controller.speed_ref_rpm"
values = [50, 500, 1500, 3000]

[collect]
metrics = ["pee_rms_rad"]

[quick]
axes = {observer = ["SMO_TANH", "SMO_SIGN"], speed_rpm = [500, 1500]}
"""


def test_a_quick_sweep_on_plain_dask_workers_completes_and_a_rerun_retries_its_errors(tmp_path):
    import pyarrow.parquet as pq

    sweep = tmp_path / "q.toml"
    sweep.write_text(QUICK)
    out = tmp_path / "out"
    out.mkdir()
    (out / "recordings").write_text("not a folder")      # the workers cannot keep a recording
    address, procs = _scheduler()
    try:
        procs.append(_worker(address, "plain"))
        _wait_for_workers(address, 1)
        cmd = [str(VENV_BIN / "bench"), "sweep", str(sweep), "--quick", "--scheduler", address,
               "--out", str(out), "--no-plots", "--no-progress"]
        first = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
        assert first.returncode == 1, first.stderr
        # the summary says what the errors were, not only how many
        assert "4 rows: 4 error" in first.stdout
        assert "4 errors like run 0 (observer=SMO_TANH, speed_rpm=500): could not keep the " \
               "recording in" in first.stdout, first.stdout
        assert "the error rows run again with" in first.stdout
        (out / "recordings").unlink()                     # fixed
        second = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
        assert second.returncode == 0, second.stdout + second.stderr
        assert "4 runs in" in second.stdout and "(4 of them rows that were errors)" in second.stdout
    finally:
        for p in reversed(procs):
            _stop(p)
    rows = pq.read_table(out / "results.parquet").to_pylist()
    assert len(rows) == 4 and len({r["scenario_hash"] for r in rows}) == 4
    assert all(r["status"] == "ok" and math.isfinite(r["pee_rms_rad"]) for r in rows), rows
    assert all(Path(r["recording"]).stat().st_size > 0 for r in rows)
    assert {r["worker"] for r in rows} != {""}
