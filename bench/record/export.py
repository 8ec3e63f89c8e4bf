"""``bench export REC --format parquet|csv [--channels T,...] --out DIR_OR_FILE [--force]``: a
recording's channels as tables for tools that do not read MCAP.

Each channel becomes one table, exactly as ``hil_bench.load_recording`` gives it
(bench/record/tables.py): ``t_s`` (s) first, one column per field, enumerations by name,
``/link/frames`` decoded by the DBC into one row per frame. ``--out`` is a folder (created if
missing) with one file per channel, named after the topic (``/plant/state`` ->
``plant_state.parquet``, ``/reference/SMO_TANH`` -> ``reference_SMO_TANH.parquet``), or, when a
single channel is chosen, a file ending in the format's suffix.

* **Parquet**: each column's unit in its field metadata (``unit``), and the schema metadata
  ``hil_bench`` (JSON: topic, units, the recording, its damage, the run's metadata); pandas reads
  the index, the categoricals and ``df.attrs`` back (``pandas.read_parquet``). Needs pyarrow.
* **CSV**: a plain table (header row, then rows; enumerations by name, an empty cell where a
  value is missing), with a sidecar ``<file>.json`` beside it: topic, units, the categories of
  each enumeration, the recording and its damage. No comment lines, so every CSV reader reads it.

Every file is written under a temporary name in its folder and all are renamed into place once
every one is complete: a failed export leaves no half file and no older file replaced. An
existing output is refused unless ``force``; an output that is the recording itself, always.

A damaged recording (bench/record/recording.py: cut short, unreadable chunks) is exported up to
what is readable; :attr:`Exported.damage` says what was not (the CLI prints it and exits 1). A
file with nothing readable is refused (:class:`ExportError`).
"""
from __future__ import annotations

import json
import os
import secrets
from dataclasses import dataclass, field
from pathlib import Path

from hil_bench.installation import require_extra

from . import channels as chans
from .recording import RecordingError, load_recording, read_header
from .tables import channel_frame

FORMATS = {"parquet": ".parquet", "csv": ".csv"}


class ExportError(ValueError):
    """The export cannot be made (bad arguments, unreadable input, an output in the way)."""


@dataclass
class Exported:
    source: Path
    fmt: str
    #: (topic, file written, rows)
    files: list[tuple[str, Path, int]] = field(default_factory=list)
    #: what of the recording could not be read ("" if nothing)
    damage: str = ""


def file_stem(topic: str) -> str:
    """The file name of a channel: ``/plant/state`` -> ``plant_state``."""
    return topic.strip("/").replace("/", "_") or "channel"


def _select(available: list[str], wanted: list[str] | None, source: Path) -> list[str]:
    if not wanted:
        return sorted(available)
    out: list[str] = []
    for w in wanted:
        if w == f"{chans.REFERENCE_PREFIX}*":
            refs = [t for t in available if t.startswith(chans.REFERENCE_PREFIX)]
            if not refs:
                raise ExportError(f"{source}: --channels {w}: the recording has no reference "
                                  f"estimator channel")
            out += [t for t in sorted(refs) if t not in out]
            continue
        if w not in available:
            import difflib

            near = difflib.get_close_matches(w if w.startswith("/") else "/" + w, available, n=1)
            hint = f"; did you mean {near[0]}?" if near else ""
            raise ExportError(f"{source}: --channels: no channel {w!r} in the recording (it has: "
                              f"{', '.join(sorted(available)) or 'none'}){hint}")
        if w not in out:
            out.append(w)
    return out


def _targets(out: Path, fmt: str, topics: list[str]) -> dict[str, list[Path]]:
    """topic -> [table file, sidecar files...]."""
    ext = FORMATS[fmt]
    other = {s for f, s in FORMATS.items() if f != fmt}
    if out.suffix.lower() in other:
        raise ExportError(f"--out {out}: a {out.suffix} file name, but the format is {fmt} "
                          f"(give --format {out.suffix.lstrip('.').lower()} or a {ext} name)")
    if out.suffix.lower() == ext and not out.is_dir():
        if len(topics) != 1:
            raise ExportError(f"--out {out}: a file name, but {len(topics)} channels are chosen "
                              f"(one file per channel): give a folder, or one channel with "
                              f"--channels")
        files = {topics[0]: out}
    else:
        if out.exists() and not out.is_dir():
            raise ExportError(f"--out {out}: exists and is not a folder")
        files = {t: out / (file_stem(t) + ext) for t in topics}
    return {t: [p] + ([p.with_name(p.name + ".json")] if fmt == "csv" else [])
            for t, p in files.items()}


def _same_file(a: Path, b: Path) -> bool:
    try:
        return a.exists() and os.path.samefile(a, b)
    except OSError:
        return False


def export(source: str | Path, out: str | Path, fmt: str = "parquet",
           channels: list[str] | None = None, force: bool = False) -> Exported:
    """Write the channels of ``source`` (all, or those ``channels`` names; ``/reference/*``: every
    reference estimator) as ``fmt`` tables into ``out`` (module docstring)."""
    source, out = Path(source), Path(out)
    if fmt not in FORMATS:
        raise ExportError(f"--format {fmt!r}: one of {', '.join(FORMATS)}")
    require_extra(f"bench export --format {fmt}", "pandas",
                  *(("pyarrow",) if fmt == "parquet" else ()))
    if not source.exists():
        raise ExportError(f"{source}: no such recording")
    if source.is_dir():
        raise ExportError(f"{source}: is a folder, not a recording")
    if _same_file(out, source):
        raise ExportError(f"--out {out}: is the recording itself; refusing to write over the "
                          f"input")
    try:
        header = read_header(source)
    except RecordingError as exc:
        raise ExportError(_unreadable(exc, source)) from None
    topics = _select(sorted(header.counts), channels, source)
    if not topics:
        raise ExportError(f"{source}: no channel to export")
    targets = _targets(out, fmt, topics)
    for paths in targets.values():
        for p in paths:
            if _same_file(p, source):
                raise ExportError(f"--out {out}: {p} is the recording itself; refusing to write "
                                  f"over the input")
            if p.is_dir():
                raise ExportError(f"--out {out}: {p} is a folder")
    existing = [str(p) for paths in targets.values() for p in paths if p.exists()]
    if existing and not force:
        raise ExportError(f"--out {out}: {', '.join(existing[:3])}"
                          + (f" and {len(existing) - 3} more" if len(existing) > 3 else "")
                          + " exist; refusing to overwrite (--force replaces them)")
    try:
        rec = load_recording(source, topics=topics)
    except RecordingError as exc:
        raise ExportError(_unreadable(exc, source)) from None
    done = Exported(source, fmt, damage=rec.damage_text())
    folder = {paths[0].parent for paths in targets.values()}
    for d in folder:
        try:
            d.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise ExportError(f"--out {out}: cannot create {d}: {exc.strerror}") from None
    written: list[tuple[Path, Path]] = []     # (temporary, final)
    try:
        for topic in topics:
            cols = rec.topics.get(topic)
            if cols is None:       # counted but not decodable (a foreign encoding)
                continue
            df = channel_frame(topic, cols)
            meta = {"topic": topic, "recording": str(source), "units": df.attrs.get("units", {}),
                    "description": df.attrs.get("description", ""), "damage": done.damage}
            table_path, *side = targets[topic]
            tmp = _temp_beside(table_path)
            written.append((tmp, table_path))
            if fmt == "parquet":
                _write_parquet(df, tmp, {**meta, "run": rec.run})
            else:
                df.to_csv(tmp, index=True)
                cats = {c: [str(x) for x in df[c].cat.categories] for c in df.columns
                        if str(df[c].dtype) == "category"}
                tmp_side = _temp_beside(side[0])
                written.append((tmp_side, side[0]))
                tmp_side.write_text(json.dumps({**meta, "categories": cats}, indent=1) + "\n")
            done.files.append((topic, table_path, len(df)))
            del df
        for tmp, final in written:
            os.replace(tmp, final)
    except BaseException:
        for tmp, _final in written:
            tmp.unlink(missing_ok=True)
        raise
    return done


def _unreadable(exc: RecordingError, source: Path) -> str:
    hint = (f" (a damaged recording: `bench recover {source} -o FIXED.mcap` copies every intact "
            f"chunk)") if exc.damaged else ""
    return f"{exc}{hint}: nothing exported"


def _temp_beside(path: Path) -> Path:
    """A name in the same folder that nothing else uses (the file is created by its writer, so it
    gets the usual permissions)."""
    return path.with_name(f".{path.name}.{os.getpid()}.{secrets.token_hex(4)}.tmp")


def _write_parquet(df, path: Path, meta: dict) -> None:
    import pyarrow as pa
    import pyarrow.parquet as pq

    table = pa.Table.from_pandas(df, preserve_index=True)
    units = meta["units"]
    fields = [f.with_metadata({"unit": units.get(f.name, "")}) for f in table.schema]
    schema = pa.schema(fields, metadata={**(table.schema.metadata or {}),
                                         b"hil_bench": json.dumps(meta).encode()})
    pq.write_table(table.cast(schema), path)


__all__ = ["ExportError", "Exported", "FORMATS", "export", "file_stem"]
