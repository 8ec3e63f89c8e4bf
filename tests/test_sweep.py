"""bench sweep (issue 17): the sweep file, the executor on a real Dask cluster with a worker
killed mid-sweep, the per-run time limit, resume by the scenario hash.

The cluster test starts Dask's own ``dask scheduler`` and two ``dask worker`` processes on
127.0.0.1, runs a short SIL sweep on them, SIGKILLs one worker once the sweep is under way, and
checks the table: every run exactly once, none lost, a controller fault a result row. Then the
same sweep with one more speed resumes: only the new runs run.
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


@pytest.mark.parametrize("bad,match", [
    ('[[axes]]\nkey = "plant.no_such"\nvalues = [1]\n', "t_sweep_00000"),
    ('[[axes]]\nname = "x"\nvalues = [1]\n', "give key"),
    ('[collect]\nmetrics = ["nope"]\n', "metrics: unknown 'nope'"),
    ('[sampling]\nmethod = "random"\n', "method = 'random'"),
])
def test_a_bad_sweep_file_is_named(tmp_path, bad, match):
    text = ("[sweep]\nname = \"t_sweep\"\nbase = \"gong_g2_500rpm\"\n" + bad)
    (tmp_path / "b.toml").write_text(text)
    with pytest.raises(SweepError, match=match):
        load_sweep(tmp_path / "b.toml")


def test_the_time_limit_ends_a_run(tmp_path):
    """A run still going at the limit is ended by the runner and says so (real time: it cannot
    finish early)."""
    import dataclasses

    from hil_bench.cluster.limits import time_limit
    from hil_bench.loop.runner import Runner
    from hil_bench.scenario import load_scenario

    scn = load_scenario("gong_g2_500rpm")
    # no mlockall: in a process this size it takes longer than the limit itself
    scn = dataclasses.replace(scn, duration_s=5.0, realtime=dataclasses.replace(
        scn.realtime, max_consecutive_misses=1_000_000, mlock=False))
    t0 = time.monotonic()
    with time_limit(1.5):
        result = Runner(scn, "sil", tmp_path / "t.mcap", progress=False, realtime=True).run()
    assert result.timed_out and "time limit of 1.5 s per run exceeded" in result.error
    assert 0 < result.cycles_done < 50_000 and time.monotonic() - t0 < 4.5


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


def test_a_killed_worker_loses_no_run_and_a_sweep_resumes(tmp_path):
    from distributed import Client

    from hil_bench.cluster import Executor
    from hil_bench.sweep.run import run_sweep

    port = _free_port()
    address = f"tcp://127.0.0.1:{port}"
    env = dict(os.environ, DASK_DISTRIBUTED__WORKER__DAEMON="False")
    procs = [_start([str(VENV_BIN / "dask"), "scheduler", "--host", "127.0.0.1", "--port",
                     str(port), "--no-dashboard"])]
    try:
        workers = [_start([str(VENV_BIN / "dask"), "worker", address, "--nthreads", "1",
                           "--nworkers", "1", "--no-dashboard", "--name", f"w{i}"], env=env)
                   for i in range(2)]
        procs += workers
        deadline = time.monotonic() + 60
        while True:
            try:
                with Client(address, timeout="2s") as c:
                    if len(c.scheduler_info()["workers"]) == 2:
                        break
            except OSError:
                pass
            assert time.monotonic() < deadline, "the Dask cluster did not come up"
            time.sleep(0.5)

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
