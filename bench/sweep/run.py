"""Running a sweep: every point on the executor (hil_bench.cluster), one Parquet row per run,
resumed by the scenario hash.

A row: the run's index and inputs (one column per axis), the metrics and claim quantities the
sweep collects, the status and verdict, the integrity, the end of the run and its error, cycles,
CPU and wall time (of the run on its worker, every process of it), the worker, the sampling
seed, the git revision and the hash of the run's full scenario (with its profile and link).
"""
from __future__ import annotations

import math
import os
import shutil
import tempfile
import time
from pathlib import Path
from typing import Any

from .spec import Point, Sweep

RESULTS = "results.parquet"
#: status of a row: the run's own outcome, or what kept it from having one
STATUSES = ("ok", "controller_fault", "ended", "timeout", "error")
WRITE_EVERY_S = 10.0
#: a run's recording keeps every cycle of the windows its metrics read, and every 20th outside
DECIMATE_OUTSIDE = 20


def run_point(text: str, name: str, link: str, record: str, keep_dir: str,
              metrics: list[str], claims: list[str]) -> dict[str, Any]:
    """One run on a worker: the scenario, its recording (temporary unless kept), what the sweep
    collects. A controller fault, a run that ended early or timed out: a row like any other."""
    from hil_bench.loop.links import LinkError
    from hil_bench.loop.runner import RunAborted, Runner
    from hil_bench.papers.check import check_recording
    from hil_bench.papers.claims import METRICS, MetricUnavailable, windows_needed
    from hil_bench.record.recorder import SIDE_SUFFIXES
    from hil_bench.scenario import check_against_profile, parse_scenario, tomlw

    scn = parse_scenario(text, Path(f"{name}.toml"))
    if scn.recording.decimate <= 1 and record != "decimated":
        # only the windows the metrics read are recorded in full: reading a whole recording
        # back costs ten times the run (bench check decodes every record in Python)
        text = tomlw.dumps(tomlw.set_dotted(scn.raw, "recording.decimate", DECIMATE_OUTSIDE))
        scn = parse_scenario(text, Path(f"{name}.toml"))
    check_against_profile(scn)
    row: dict[str, Any] = {"decimate": scn.recording.decimate}
    with tempfile.TemporaryDirectory(prefix="hil-sweep-") as tmp:
        out = Path(tmp) / f"{name}.mcap"
        try:
            result = Runner(scn, link, out, progress=False, force=True,
                            full_rate_s=tuple(windows_needed(scn))).run()
        except (RunAborted, LinkError, OSError, ValueError) as exc:
            return {"status": "error", "error": f"could not run: {exc}", "end": "SETUP"}
        row.update(end=result.end, error=result.error or "", cycles_done=result.cycles_done,
                   cycles_planned=result.cycles_planned)
        if result.timed_out:
            row["status"] = "timeout"
        elif result.end == "CONTROLLER_FAULT":
            row["status"] = "controller_fault"
        elif result.error:
            row["status"] = "ended"
        else:
            row["status"] = "ok"
        rec_path = Path(result.recording)
        verdict = ""
        if rec_path.exists() and result.cycles_done > 0:
            try:
                rep = check_recording(rec_path)
            except Exception as exc:  # noqa: BLE001 - a damaged recording: said in the row
                row["error"] = (row["error"] + "; " if row["error"] else "") + f"check: {exc}"
                rep = None
            if rep is not None:
                for m in metrics:
                    v = rep.summary.get(m)
                    if v is None and m in METRICS:
                        try:
                            v = METRICS[m][2](rep.context)
                        except (MetricUnavailable, ValueError, KeyError, IndexError):
                            v = math.nan
                    row[m] = float(v) if v is not None else math.nan
                for r in rep.results:
                    key = f"{r.claim.id}.{r.quantity.key}"
                    row[f"{key}.measured"] = float(r.measured)
                    row[f"{key}.verdict"] = r.verdict
                row["integrity_ok"] = bool(rep.integrity.ok) if rep.integrity else True
                row["integrity"] = ("; ".join(f"{p.kind} {p.name}" for p in rep.integrity.problems)
                                    if rep.integrity else "")
                if claims:
                    verdict = "PASS" if rep.all_pass else (
                        "INVALID" if not row["integrity_ok"] else "FAIL")
                else:
                    verdict = "INVALID" if not row["integrity_ok"] else ""
        row["verdict"] = verdict
        keep = record == "decimated" or (record == "failed" and (
            row["status"] != "ok" or verdict in ("FAIL", "INVALID")))
        row["recording"] = ""
        if keep and rec_path.exists():
            dest = Path(keep_dir) / rec_path.name
            dest.parent.mkdir(parents=True, exist_ok=True)
            for p in (rec_path, *(rec_path.with_suffix(sfx) for sfx, _ in SIDE_SUFFIXES)):
                if p.exists():
                    shutil.move(str(p), str(dest.parent / p.name))
            row["recording"] = str(dest)
    return row


def _read_table(path: Path):
    import pyarrow.parquet as pq

    return pq.read_table(path).to_pylist() if path.exists() else []


def _write_table(rows: list[dict], path: Path) -> None:
    """Atomically (a crash leaves the previous table, never half of one)."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    columns: dict[str, None] = {}
    for r in rows:
        for k in r:
            columns.setdefault(k, None)
    table = pa.Table.from_pylist([{k: r.get(k) for k in columns} for r in rows])
    tmp = path.with_suffix(".parquet.tmp")
    pq.write_table(table, tmp)
    os.replace(tmp, path)


def run_sweep(sw: Sweep, out_dir: Path, executor, console=None) -> tuple[list[dict], dict]:
    """Run the points whose hash is not in out_dir/results.parquet yet; write the table as the
    runs end (every WRITE_EVERY_S and at the end). Returns (every row, what this call did)."""
    from hil_bench.loop.runner import git_revision

    out_dir.mkdir(parents=True, exist_ok=True)
    table_path = out_dir / RESULTS
    rows = _read_table(table_path)
    have = {r["scenario_hash"] for r in rows}
    todo = [p for p in sw.points if p.scenario_hash not in have]
    # the same scenario twice in one sweep (e.g. a relative axis at 1.0 twice) runs once
    unique: dict[str, Point] = {}
    for p in todo:
        unique.setdefault(p.scenario_hash, p)
    rev = git_revision()
    keep_dir = str((out_dir / "recordings").resolve())
    by_hash = {h: p for h, p in unique.items()}
    t0 = time.monotonic()
    last_write = time.monotonic()
    args = [(p.scenario_hash, (p.scenario_text, f"{sw.name}_{p.scenario_hash}", sw.link, sw.record,
                               keep_dir, sw.metrics, sw.claims))
            for p in unique.values()]
    from hil_bench.cluster import TaskFailure

    n_new = 0
    for h, res in executor.map(run_point, args, time_limit_s=sw.time_limit_s,
                               describe=lambda h: ", ".join(f"{k}={_fmt(v)}" for k, v in
                                                            by_hash[h].inputs.items())):
        p = by_hash[h]
        row: dict[str, Any] = {"sweep": sw.name, "index": p.index}
        row.update({f"in.{k}": v for k, v in p.inputs.items()})
        if isinstance(res, TaskFailure):
            row.update(status="error", error=res.error, end="BENCH", worker=res.worker,
                       cpu_s=math.nan, wall_s=math.nan)
        else:
            row.update(res.value)
            row.update(worker=res.worker, cpu_s=res.cpu_s, wall_s=res.wall_s)
        row.update(seed=sw.seed if sw.method != "grid" else 0, git_revision=rev,
                   scenario_hash=h, link=sw.link)
        rows.append(row)
        n_new += 1
        if time.monotonic() - last_write > WRITE_EVERY_S:
            _write_table(rows, table_path)
            last_write = time.monotonic()
    if rows:
        _write_table(rows, table_path)
    return rows, {"ran": n_new, "skipped": len(sw.points) - len(todo),
                  "wall_s": time.monotonic() - t0}


def _fmt(v) -> str:
    return f"{v:g}" if isinstance(v, float) else str(v)


def describe(rows: list[dict]) -> str:
    from collections import Counter

    c = Counter(r.get("status", "?") for r in rows)
    return ", ".join(f"{n} {s}" for s, n in c.most_common())


__all__ = ["RESULTS", "STATUSES", "run_point", "run_sweep", "describe"]
