"""A sweep's results table: ``DIR/results.parquet``, one row per run, and its journal.

* **Typed columns** (a notebook's ``pd.read_parquet`` gets them as they are): numbers as int64 or
  float64, ``integrity_ok`` as bool, the few-valued text (status, verdicts, end, link, worker,
  revision, a text axis) as categoricals (Arrow dictionaries), the rest as strings.
* **Its sweep's identity** in the file's metadata (``hil_bench.sweep``: the sweep id and the hash
  of each part: base scenario, overrides, axes, sampling, collect, link, record; spec.Sweep.identity)
  and in a ``sweep_id`` column. A table of another sweep is never resumed or merged: it is refused
  with the parts that differ (``--fresh`` sets it aside, or give another ``--out``). One change
  is resumed: a grid that grew (other axis values or samples) while every row already there is
  still one of its runs (same scenario hash: same derived scenario, profile and link).
* **The journal** ``DIR/results.journal.jsonl``: every row is appended (one write of one JSON
  line) as its run ends, so a sweep stopped by anything (a full disk, a kill, a power cut after
  the page cache reached the disk) keeps every row it had finished; the table is rewritten from
  table + journal (written aside, renamed into place) now and then and at the end, then the
  journal is emptied. A rerun reads both.
* **Reading is checked**: a table that is not Parquet (truncated, random bytes), not this bench's
  (no identity, a foreign schema), with columns of the wrong type, or a directory: one line that
  says what and what to do (TableError). Rows that repeat a scenario hash are reported and the
  last of each kept (a run's result is a function of its scenario: the rows are the same run
  twice, e.g. tables joined by hand, and the last is the latest).
"""
from __future__ import annotations

import errno
import json
import math
import os
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from hil_bench.installation import require_extra
from hil_bench.record.atomic import written_aside

from .spec import Sweep

RESULTS = "results.parquet"
#: what needs pyarrow here (its ExtraMissing message)
TABLE_FEATURE = "a sweep's results table"
JOURNAL = "results.journal.jsonl"
META_KEY = b"hil_bench.sweep"
FORMAT = 1
#: status of a row: the run's own outcome, or what kept it from having one
STATUSES = ("ok", "controller_fault", "ended", "timeout", "error")

INT_COLUMNS = ("index", "cycles_done", "cycles_planned", "seed", "decimate")
FLOAT_COLUMNS = ("cpu_s", "wall_s", "time_limit_s")
BOOL_COLUMNS = ("integrity_ok",)
CATEGORY_COLUMNS = ("sweep", "sweep_id", "status", "verdict", "end", "link", "worker",
                    "git_revision")
TEXT_COLUMNS = ("error", "integrity", "recording", "scenario_hash")
REQUIRED = ("index", "status", "scenario_hash", "sweep_id")


class TableError(ValueError):
    """A results table (or journal) that cannot be resumed: the message is one line, names the
    file, and says what to do."""


class TableWriteError(Exception):
    """The table or journal could not be written (a full disk, a read-only folder): the rows
    finished so far are in the table and journal; the message says which file and why."""

    def __init__(self, errno_: int | None, message: str):
        super().__init__(message)
        self.errno = errno_


def _aside_hint(out_dir: Path) -> str:
    return f"move it away, give another --out, or run with --fresh (which keeps it as {out_dir}/" \
           f"results.replaced-<time>.parquet and starts a new table)"


# -- types ------------------------------------------------------------------------------------


def column_type(sw: Sweep, name: str):
    """The Arrow type of a column (None: inferred)."""
    pa = require_extra(TABLE_FEATURE, "pyarrow")

    if name in INT_COLUMNS:
        return pa.int64()
    if name in FLOAT_COLUMNS or name in sw.metrics or name.endswith(".measured"):
        return pa.float64()
    if name in BOOL_COLUMNS:
        return pa.bool_()
    if name in CATEGORY_COLUMNS or name.endswith(".verdict"):
        return pa.dictionary(pa.int32(), pa.string())
    if name in TEXT_COLUMNS:
        return pa.string()
    if name.startswith("in."):
        ax = next((a for a in sw.axes if a.name == name[3:]), None)
        if ax is not None:
            return {"int": pa.int64(), "float": pa.float64(), "bool": pa.bool_(),
                    "text": pa.dictionary(pa.int32(), pa.string())}[ax.kind]
    return None


def _array(values: list, typ):
    import pyarrow as pa

    if typ is None:
        return pa.array(values)
    if pa.types.is_dictionary(typ):
        return pa.array([None if v is None else str(v) for v in values],
                        pa.string()).dictionary_encode()
    if pa.types.is_floating(typ):
        return pa.array([None if v is None else float(v) for v in values], typ)
    if pa.types.is_integer(typ):
        return pa.array([None if v is None or (isinstance(v, float) and not math.isfinite(v))
                         else int(v) for v in values], typ)
    return pa.array(values, typ)


def to_arrow(sw: Sweep, rows: list[dict]):
    """The rows as a typed Arrow table with the sweep's identity in its metadata."""
    pa = require_extra(TABLE_FEATURE, "pyarrow")

    columns: dict[str, None] = {}
    for r in rows:
        for k in r:
            columns.setdefault(k, None)
    arrays = [_array([r.get(k) for r in rows], column_type(sw, k)) for k in columns]
    table = pa.Table.from_arrays(arrays, names=list(columns))
    meta = {"format": FORMAT, "sweep": sw.name, "file": str(sw.path), "sweep_id": sw.sweep_id,
            "identity": sw.identity(), "runs": len(sw.points), "quick": sw.quick}
    return table.replace_schema_metadata({META_KEY: json.dumps(meta).encode()})


def write_table(sw: Sweep, rows: list[dict], path: Path) -> None:
    """The table, written aside and renamed into place (a failed write leaves the old table)."""
    pq = require_extra(TABLE_FEATURE, "pyarrow.parquet")

    with written_aside(path) as tmp:
        pq.write_table(to_arrow(sw, rows), tmp)


# -- reading ----------------------------------------------------------------------------------


def _kind_ok(typ, want: str) -> bool:
    import pyarrow as pa

    if pa.types.is_dictionary(typ):
        typ = typ.value_type
    if pa.types.is_null(typ):
        return True
    return {"int": pa.types.is_integer(typ),
            "number": pa.types.is_integer(typ) or pa.types.is_floating(typ),
            "bool": pa.types.is_boolean(typ),
            "text": pa.types.is_string(typ) or pa.types.is_large_string(typ)}[want]


def _expected_kind(sw: Sweep, name: str) -> str | None:
    import pyarrow as pa

    typ = column_type(sw, name)
    if typ is None:
        return None
    if pa.types.is_dictionary(typ) or pa.types.is_string(typ):
        return "text"
    if pa.types.is_boolean(typ):
        return "bool"
    if pa.types.is_integer(typ) and name in ("index", "seed"):
        return "int"
    return "number"


def read_table(sw: Sweep, path: Path) -> tuple[dict | None, list[dict]]:
    """(the identity in its metadata, its rows) of a results table; TableError when it is not a
    table this bench can resume."""
    pa = require_extra(TABLE_FEATURE, "pyarrow")
    import pyarrow.parquet as pq

    hint = _aside_hint(path.parent)
    if path.is_dir():
        raise TableError(f"{path}: is a directory, not a results table; {hint}")
    if not path.is_file():
        raise TableError(f"{path}: is not a regular file; {hint}")
    try:
        table = pq.ParquetFile(path).read()
    except (pa.ArrowException, OSError, ValueError, EOFError, IndexError) as exc:
        why = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise TableError(f"{path}: not a readable Parquet table (truncated or damaged: {why}); "
                         f"{hint}") from None
    raw = (table.schema.metadata or {}).get(META_KEY)
    meta = None
    if raw is not None:
        try:
            meta = json.loads(raw)
            if not isinstance(meta, dict) or not isinstance(meta.get("identity"), dict):
                raise ValueError("no identity")
        except ValueError:
            raise TableError(f"{path}: its sweep identity (metadata {META_KEY.decode()}) is "
                             f"damaged; {hint}") from None
    if table.num_rows == 0 and meta is None:
        return None, []
    names = table.column_names
    missing = [c for c in REQUIRED if c not in names]
    if missing:
        raise TableError(f"{path}: no column {missing[0]!r}: not a sweep table of this bench "
                         f"({len(names)} columns: {', '.join(names[:6])}"
                         f"{', ...' if len(names) > 6 else ''}); {hint}")
    for name, typ in zip(names, table.schema.types):
        want = _expected_kind(sw, name) if name not in REQUIRED else (
            "int" if name == "index" else "text")
        if want and not _kind_ok(typ, want):
            raise TableError(f"{path}: column {name!r} holds {typ}, not {want}: not a table this "
                             f"bench wrote, or edited since; {hint}")
    rows = table.to_pylist()
    for i, r in enumerate(rows):
        if r["status"] not in STATUSES or not r["scenario_hash"] or not r["sweep_id"]:
            raise TableError(f"{path}: row {i}: status {r['status']!r}, scenario_hash "
                             f"{r['scenario_hash']!r}, sweep_id {r['sweep_id']!r}: not a row "
                             f"this bench wrote; {hint}")
    return meta, rows


def read_journal(path: Path) -> tuple[list[dict], int]:
    """(the rows a journal holds, how many lines were unreadable and skipped: their runs run
    again). An unfinished last line (a write cut short) is one of those."""
    if not path.exists():
        return [], 0
    if not path.is_file():
        raise TableError(f"{path}: the sweep's journal is not a regular file; move it away")
    rows, bad = [], 0
    with path.open("rb") as f:
        for line in f:
            try:
                if not line.endswith(b"\n"):
                    raise ValueError("unfinished")
                r = json.loads(line)
                if not (isinstance(r, dict) and isinstance(r.get("scenario_hash"), str)
                        and r.get("status") in STATUSES and isinstance(r.get("sweep_id"), str)):
                    raise ValueError("not a row")
            except ValueError:
                bad += 1
                continue
            rows.append(r)
    return rows, bad


# -- resuming ---------------------------------------------------------------------------------


@dataclass
class Resumed:
    """The rows of this sweep already done (one per scenario hash), and what was made of the
    files found (each a line for the user)."""
    rows: list[dict] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    #: the table on disk is not these rows (a journal to fold in, duplicates, a grown grid)
    dirty: bool = False


def set_aside(out_dir: Path) -> list[str]:
    """--fresh: the table and journal there are renamed (never deleted) out of the way."""
    stamp = time.strftime("%Y%m%d-%H%M%S")
    notes = []
    for name, new in ((RESULTS, f"results.replaced-{stamp}.parquet"),
                      (JOURNAL, f"results.journal.replaced-{stamp}.jsonl")):
        p = out_dir / name
        if p.exists() or p.is_symlink():
            dest = out_dir / new
            k = 2
            while dest.exists():
                dest = out_dir / new.replace(stamp, f"{stamp}-{k}")
                k += 1
            os.rename(p, dest)
            notes.append(f"--fresh: the previous {name} is kept as {dest}")
    return notes


def _foreign(sw: Sweep, path: Path, meta: dict | None, n_rows: int) -> TableError:
    hint = f"give another --out, or run with --fresh (which keeps it as " \
           f"{path.parent}/results.replaced-<time>.parquet and starts this sweep's table)"
    if meta is None:
        return TableError(f"{path}: {n_rows} rows without a sweep identity (another program's "
                          f"table, or one from before sweeps carried theirs); not resumed, "
                          f"never merged: {hint}")
    mine = sw.identity()
    theirs = meta.get("identity", {})
    differ = [k for k in mine if theirs.get(k) != mine[k]]
    return TableError(f"{path}: holds another sweep ({meta.get('sweep', '?')} from "
                      f"{meta.get('file', '?')}, {n_rows} rows): its "
                      f"{', '.join(differ) or 'identity'} differ from {sw.path}'s; not resumed, "
                      f"never merged: {hint}")


def resume(sw: Sweep, out_dir: Path, *, fresh: bool = False) -> Resumed:
    """Read what out_dir holds for this sweep (TableError when it holds another sweep's or a
    damaged table). Rows are re-stamped with this sweep's index, inputs and id."""
    res = Resumed()
    if fresh:
        res.notes += set_aside(out_dir)
    table_path, journal_path = out_dir / RESULTS, out_dir / JOURNAL
    meta, rows = (read_table(sw, table_path) if (table_path.exists() or table_path.is_symlink())
                  else (None, []))
    jrows, bad = read_journal(journal_path)
    if bad:
        res.notes.append(f"{journal_path}: {bad} unreadable line(s) skipped (a write cut short): "
                         f"their runs run again")
    by_hash = {}
    for p in sw.points:
        by_hash.setdefault(p.scenario_hash, p)
    # the table: one identity, every row one of this sweep's runs
    never = (f"not resumed, never merged: give another --out, or run with --fresh (which keeps "
             f"it as {out_dir}/results.replaced-<time>.parquet and starts this sweep's table)")
    if rows or meta is not None:
        if meta is None:
            raise _foreign(sw, table_path, None, len(rows))
        table_id = meta.get("sweep_id")
        strays = [r for r in rows if r["sweep_id"] != table_id]
        if strays:
            raise TableError(f"{table_path}: {len(strays)} of its {len(rows)} rows are of another "
                             f"sweep (sweep id {strays[0]['sweep_id']}) than the table's "
                             f"({table_id}): {never}")
        foreign = [r for r in rows if r["scenario_hash"] not in by_hash]
        if table_id != sw.sweep_id:
            differ = {k for k, v in sw.identity().items() if meta["identity"].get(k) != v}
            if not differ <= {"axes", "sampling"} or foreign:
                raise _foreign(sw, table_path, meta, len(rows))
            res.notes.append(f"{table_path}: its sweep had other {' and '.join(sorted(differ))}; "
                             f"all {len(rows)} of its rows are runs of this one: kept, the new "
                             f"runs run")
        elif foreign:
            raise TableError(f"{table_path}: {len(foreign)} of its {len(rows)} rows are no run of "
                             f"this sweep (scenario hash {foreign[0]['scenario_hash']} and "
                             f"others): {never}")
    # the journal: rows of this very sweep only
    jforeign = [r for r in jrows if r["sweep_id"] != sw.sweep_id or r["scenario_hash"] not in by_hash]
    if jforeign:
        if {r["sweep_id"] for r in jforeign} <= {meta.get("sweep_id") if meta else None} and \
                all(r["scenario_hash"] in by_hash for r in jforeign):
            pass           # a grown grid's journal: the same runs
        else:
            raise TableError(f"{journal_path}: {len(jforeign)} rows of another sweep (sweep id "
                             f"{jforeign[0]['sweep_id']}): {never}")
    # one row per run: the table's duplicates reported; the journal's rows are later than the
    # table's (a retried error, or a table rewritten before the journal was emptied)
    merged: dict[str, dict] = {}
    dups = 0
    for r in rows:
        if r["scenario_hash"] in merged:
            dups += 1
        merged[r["scenario_hash"]] = r
    if dups:
        res.notes.append(f"{table_path}: {dups} row(s) repeat the scenario hash of another row "
                         f"(the same run twice: tables joined by hand?); the last of each kept, "
                         f"{len(merged)} rows left")
    for r in jrows:
        merged[r["scenario_hash"]] = r
    for h, r in merged.items():
        p = by_hash[h]
        r.update({"sweep": sw.name, "sweep_id": sw.sweep_id, "index": p.index})
        r.update({f"in.{k}": v for k, v in p.inputs.items()})
    res.rows = sorted(merged.values(), key=lambda r: r["index"])
    res.dirty = bool(jrows or dups or (meta is not None and meta.get("sweep_id") != sw.sweep_id))
    return res


# -- writing ----------------------------------------------------------------------------------


class Journal:
    """Rows appended as runs end: one ``os.write`` of one line each; a write that fails (a full
    disk) is cut back, so the journal holds whole lines only."""

    def __init__(self, path: Path):
        self.path = path
        try:
            self.fd = os.open(path, os.O_WRONLY | os.O_APPEND | os.O_CREAT | os.O_CLOEXEC, 0o644)
        except OSError as exc:
            raise TableWriteError(exc.errno, f"cannot write {path}: {exc.strerror}") from None

    def append(self, row: dict[str, Any]) -> None:
        line = (json.dumps(row, default=str) + "\n").encode()
        size = os.fstat(self.fd).st_size
        try:
            n = os.write(self.fd, line)
            if n != len(line):
                raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        except OSError as exc:
            try:
                os.ftruncate(self.fd, size)
            except OSError:
                pass
            raise TableWriteError(exc.errno, f"cannot write {self.path}: {exc.strerror}") from None

    def clear(self) -> None:
        """Empty it (its rows are in the table now)."""
        os.ftruncate(self.fd, 0)

    def close(self) -> None:
        if self.fd >= 0:
            os.close(self.fd)
            self.fd = -1
            try:
                if self.path.stat().st_size == 0:
                    self.path.unlink()
            except OSError:
                pass


def compact(sw: Sweep, rows: list[dict], out_dir: Path, journal: Journal | None) -> None:
    """The table rewritten with every row (aside, then renamed), then the journal emptied; a
    failure (TableWriteError) leaves the old table and the whole journal."""
    path = out_dir / RESULTS
    try:
        write_table(sw, rows, path)
        if journal is not None:
            journal.clear()
    except OSError as exc:
        raise TableWriteError(exc.errno, f"cannot write {path}: {exc.strerror}") from None


__all__ = ["RESULTS", "JOURNAL", "STATUSES", "TableError", "TableWriteError", "Journal",
           "Resumed", "resume", "compact", "read_table", "read_journal", "write_table",
           "to_arrow", "column_type"]
