"""Running a sweep: every point on the executor (hil_bench.cluster), one Parquet row per run,
resumed by the scenario hash (the table, its journal and its identity: hil_bench.sweep.table).

A row: the run's index and inputs (one column per axis), the metrics and claim quantities the
sweep collects, the status and verdict, the integrity, the end of the run and its error, cycles,
CPU and wall time (of the run on its worker, every process of it), the worker, the sampling
seed, the git revision and the hash of the run's full scenario (with its profile and link).
"""
from __future__ import annotations

import errno
import math
import tempfile
import time
from pathlib import Path
from typing import Any

from rich.markup import escape

from .spec import Point, Sweep
from .table import (JOURNAL, RESULTS, STATUSES, Journal, Resumed, TableWriteError,  # noqa: F401
                    compact, resume)

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
            try:
                keep_recording(rec_path, dest, [rec_path.with_suffix(sfx)
                                                for sfx, _ in SIDE_SUFFIXES])
            except OSError as exc:
                # the row is not what the sweep promised (its recording): an error, run again
                # (the run's own end, if any, on the next line: the first says why it is an error)
                row["status"] = "error"
                row["error"] = (f"could not keep the recording in {dest.parent}: {exc.strerror}"
                                + (f"\nthe run: {row['error']}" if row["error"] else ""))
            else:
                row["recording"] = str(dest)
                # the run's own messages name where it recorded (a temporary folder, gone now)
                row["error"] = row["error"].replace(str(rec_path), str(dest))
    return row


def keep_recording(rec: Path, dest: Path, sides: list[Path]) -> None:
    """Move a recording and its side files into ``dest``'s folder, each whole or not at all (a
    copy across file systems is written aside: a full disk leaves no partial or empty file);
    the recording itself last, so a kept .mcap always has its side files."""
    from hil_bench.record.atomic import move_aside

    dest.parent.mkdir(parents=True, exist_ok=True)
    for p in [*sides, rec]:
        if p.exists():
            move_aside(p, dest.parent / p.name)


def _row_order(sw: Sweep, row: dict[str, Any]) -> dict[str, Any]:
    """A row's columns in the order a reader wants them: who, inputs, outcome, metrics, the rest."""
    first = ["sweep", "index", *(f"in.{a.name}" for a in sw.axes), "status", "verdict",
             *sw.metrics]
    out = {k: row[k] for k in first if k in row}
    out.update((k, v) for k, v in row.items() if k not in out)
    return out


def needs_run(sw: Sweep, row: dict | None, retry_errors: bool) -> bool:
    """Whether a point runs: not in the table yet; an ``error`` row (the bench's failure, not the
    run's result: a worker that could not run it) unless told not to retry; a ``timeout`` row
    whose limit was shorter than this sweep's."""
    if row is None:
        return True
    if row["status"] == "error":
        return retry_errors
    if row["status"] == "timeout":
        limit = row.get("time_limit_s")
        return limit is None or not math.isfinite(limit) or limit < sw.time_limit_s
    return False


class SweepStopped(RuntimeError):
    """The sweep could not go on (its table or journal cannot be written): one line that says
    what was kept and how to complete it."""


def run_sweep(sw: Sweep, out_dir: Path, executor, console=None, *, retry_errors: bool = True,
              fresh: bool = False, resumed: Resumed | None = None) -> tuple[list[dict], dict]:
    """Run the points out_dir's table does not hold yet (and, with ``retry_errors``, those whose
    row is an ``error``); every row goes to the journal as its run ends and the table is
    rewritten now and then and at the end (hil_bench.sweep.table). Returns (every row, what this
    call did). TableError: out_dir holds another sweep or a damaged table; SweepStopped: the
    table could not be written (every row finished is kept). ``resumed``: what
    hil_bench.sweep.table.resume read from out_dir already (else it is read here)."""
    from contextlib import closing

    from hil_bench.cluster import TaskFailure
    from hil_bench.loop.runner import git_revision

    try:
        out_dir.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise SweepStopped(f"cannot create the sweep folder {out_dir}: {exc.strerror}") from None
    if resumed is None:
        resumed = resume(sw, out_dir, fresh=fresh)
    if console is not None:
        for note in resumed.notes:
            console.print(escape(note))
    rows_by_hash: dict[str, dict] = {r["scenario_hash"]: r for r in resumed.rows}
    # the same scenario twice in one sweep (e.g. a relative axis at 1.0 twice) runs once
    unique: dict[str, Point] = {}
    for p in sw.points:
        unique.setdefault(p.scenario_hash, p)
    todo = {h: p for h, p in unique.items() if needs_run(sw, rows_by_hash.get(h), retry_errors)}
    retried = sum(1 for h in todo if h in rows_by_hash)
    rev = git_revision()
    keep_dir = str((out_dir / "recordings").resolve())
    t0 = time.monotonic()
    args = [(h, (p.scenario_text, f"{sw.name}_{h}", sw.link, sw.record, keep_dir, sw.metrics,
                 sw.claims)) for h, p in todo.items()]

    def ordered() -> list[dict]:
        return sorted(rows_by_hash.values(), key=lambda r: r["index"])

    n_new = 0
    journal = None
    try:
        journal = Journal(out_dir / JOURNAL)
        if resumed.dirty:
            compact(sw, ordered(), out_dir, journal)     # the journal's rows into the table
        next_write, write_every = time.monotonic() + WRITE_EVERY_S, WRITE_EVERY_S
        with closing(executor.map(run_point, args, time_limit_s=sw.time_limit_s,
                                  describe=lambda h: ", ".join(f"{k}={_fmt(v)}" for k, v in
                                                               todo[h].inputs.items()))) as done:
            for h, res in done:
                p = todo[h]
                row: dict[str, Any] = {"sweep": sw.name, "index": p.index}
                row.update({f"in.{k}": v for k, v in p.inputs.items()})
                if isinstance(res, TaskFailure):
                    row.update(status="error", error=res.error, end="BENCH", worker=res.worker,
                               cycles_done=0, cpu_s=math.nan, wall_s=math.nan)
                else:
                    row.update(res.value)
                    row.update(worker=res.worker, cpu_s=res.cpu_s, wall_s=res.wall_s)
                row.setdefault("integrity_ok", False)     # no recording was checked
                row.update(seed=sw.seed if sw.method != "grid" else 0, git_revision=rev,
                           scenario_hash=h, link=sw.link, time_limit_s=sw.time_limit_s,
                           sweep_id=sw.sweep_id)
                row = _row_order(sw, row)
                journal.append(row)
                rows_by_hash[h] = row
                n_new += 1
                if time.monotonic() >= next_write:
                    # rewriting the table costs more as it grows: at most ~5 % of the sweep's time
                    c0 = time.monotonic()
                    compact(sw, ordered(), out_dir, journal)
                    write_every = max(WRITE_EVERY_S, 20 * (time.monotonic() - c0))
                    next_write = time.monotonic() + write_every
        if rows_by_hash:
            compact(sw, ordered(), out_dir, journal)
    except TableWriteError as exc:
        kept = sum(1 for r in rows_by_hash.values() if r["status"] != "error")
        fix = "free space" if exc.errno in (errno.ENOSPC, errno.EDQUOT) else "fix that"
        raise SweepStopped(
            f"{exc}; the sweep stopped after {n_new} of {len(todo)} runs: the {kept} rows "
            f"finished are kept in {out_dir / RESULTS} and {out_dir / JOURNAL}; {fix} and "
            f"run it again with --out {out_dir} to complete it") from None
    finally:
        if journal is not None:
            journal.close()
    return ordered(), {"ran": n_new, "retried": retried,
                       "skipped": len(sw.points) - len(todo), "wall_s": time.monotonic() - t0}


def _fmt(v) -> str:
    return f"{v:g}" if isinstance(v, float) else str(v)


def describe(rows: list[dict]) -> str:
    from collections import Counter

    c = Counter(r.get("status", "?") for r in rows)
    return ", ".join(f"{n} {s}" for s, n in c.most_common())


def error_summary(sw: Sweep, rows: list[dict], most: int = 3) -> list[str]:
    """What the ``error`` rows were: per kind of message (its first line, numbers aside: a pid
    or a pty differs from run to run), how many share it and the first one with its run's
    inputs; the ``most`` commonest, then how many other kinds."""
    import re
    from collections import Counter

    firsts: dict[str, tuple[str, dict]] = {}
    counts: Counter = Counter()
    for r in rows:
        if r.get("status") != "error":
            continue
        msg = (str(r.get("error") or "").strip().splitlines() or ["(no message)"])[0]
        kind = re.sub(r"\d+", "#", msg)
        counts[kind] += 1
        firsts.setdefault(kind, (msg, r))
    lines = []
    for kind, n in counts.most_common(most):
        msg, r = firsts[kind]
        ins = ", ".join(f"{a.name}={_fmt(r.get(f'in.{a.name}'))}" for a in sw.axes)
        lines.append(f"{n} error{'s' if n > 1 else ''} like run {r['index']}"
                     f"{' (' + ins + ')' if ins else ''}: {msg}")
    if len(counts) > most:
        lines.append(f"... and {len(counts) - most} other kinds of error (the table's error "
                     f"column)")
    return lines


__all__ = ["RESULTS", "STATUSES", "SweepStopped", "run_point", "run_sweep", "describe",
           "error_summary", "needs_run"]
