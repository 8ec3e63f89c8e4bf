"""A recording's channels as pandas DataFrames, the shape a notebook expects
(``hil_bench.load_recording``, ``bench export``).

* Indexed by time: the index is the recorded ``t_s`` (plant time, seconds), named ``t_s``.
* Units in ``df.attrs["units"]``: ``{column: unit}`` for every column and the index, from the
  field names (``channels.field_unit``: ``i_a_a`` -> ``"A"``) and, for the decoded frames, from
  the DBC's signal units; ``""`` where there is none (counts, states, texts, duties).
  ``df.attrs`` also has ``"topic"`` and ``"description"``.
* Enumerations as pandas categoricals with their names, the names taken from the DBC's value
  tables (``hil_bench.protocol.messages``: ``State``, ``Estimator``, ``Fault``), never retyped:
  the telemetry's ``state`` and ``estimator`` (and the replay's), a ``fault_code`` column beside
  the controller's trips in ``/faults`` and ``/events``. The categories are the table's names in
  the order of their raw values, so for a table numbered 0..n-1 ``.cat.codes`` is the raw value;
  "missing" (-1: no TELEM that cycle) reads as NaN, and a value the table lacks (a drive sending
  estimator 9) as the category ``"9"``.
* ``/link/frames`` decoded with protocol/hil.dbc through cantools: one row per frame (the rows
  of a cycle share its ``t_s``), with ``seq`` (the cycle, -1 outside the cycles), ``direction``
  (``tx``: bench to controller, ``rx``: controller to bench), ``message`` (the DBC's name; NaN for
  a frame the DBC does not define or of the wrong length), ``id``, ``data`` (hex) and one column
  per signal of every message that occurs, named ``MESSAGE.signal`` (``DUTY.d_a``): physical
  values as cantools scales them, value tables as categoricals, integer signals as nullable
  integers, NaN / <NA> in the rows of other messages. A duty leg OFF (raw 65535) reads NaN.
  :func:`message_frame` gives one message's rows with plain signal names.

pandas is imported when a table is made (the "data" extra: ``installation.require_extra`` names it
when it is missing).
"""
from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING

import numpy as np

from hil_bench.installation import require_extra

from . import channels as chans

if TYPE_CHECKING:
    import pandas

#: the columns of the decoded /link/frames before its signals
FRAME_COLUMNS = ("seq", "direction", "message", "id", "data")


def _enum_tables() -> dict[str, Mapping[int, str]]:
    """Integer fields that carry a DBC value table: field name -> {raw value: name}."""
    from hil_bench.protocol.messages import Estimator, State

    state = {int(v): v.name for v in State}
    est = {int(v): v.name for v in Estimator}
    return {"state": state, "state_rec": state, "estimator": est, "estimator_rec": est}


def _fault_names() -> Mapping[int, str]:
    from hil_bench.protocol.messages import Fault

    return {int(v): v.name for v in Fault}


def categorical(raw, table: Mapping[int, str], missing: tuple[int, ...] = (-1,)):
    """Raw values as a pandas Categorical named by ``table`` (raw -> name): categories in raw
    order, then any value the table lacks as its decimal text; ``missing`` values and NaN read
    as NaN."""
    import pandas as pd

    raw = np.asarray(raw)
    if raw.dtype.kind == "f":
        ok = np.isfinite(raw)
        vals = np.where(ok, raw, missing[0] if missing else -1).astype(np.int64)
    elif raw.dtype.kind in "iu":
        ok = np.ones(len(raw), dtype=bool)
        vals = raw.astype(np.int64)
    else:
        raise TypeError(f"not integer values: dtype {raw.dtype}")
    ok &= ~np.isin(vals, np.asarray(missing, dtype=np.int64))
    keys = sorted(table)
    extra = sorted(set(np.unique(vals[ok]).tolist()) - set(keys))
    order = np.asarray(keys + extra, dtype=np.int64)
    cats = [table[k] for k in keys] + [str(v) for v in extra]
    codes = np.full(len(vals), -1, dtype=np.int64)
    if len(order):
        sorter = np.argsort(order)
        pos = sorter[np.searchsorted(order, vals[ok], sorter=sorter)]
        codes[ok] = pos
    return pd.Categorical.from_codes(codes, categories=cats)


def _index(t_s, n: int):
    import pandas as pd

    if t_s is None:
        return pd.RangeIndex(n)
    return pd.Index(np.asarray(t_s, dtype=np.float64), name="t_s")


def _empty_columns(topic: str) -> dict[str, np.ndarray]:
    """A channel with no message: its fields with no row, typed as the schema says."""
    kind = chans.kind_of_topic(topic)
    if kind is None:
        return {}
    lay = chans.LAYOUTS[kind]
    types = {"F64": np.float64, "CNT": np.int64, "U32": np.int64, "I32": np.int64, "STR": object}
    return {n: np.empty(0, dtype=types[t]) for t, n in lay.fields}


def channel_frame(topic: str, cols: Mapping[str, np.ndarray]) -> pandas.DataFrame:
    """One channel's columns (as ``record.recording.load_recording`` keeps them) as a DataFrame
    indexed by ``t_s``, units in ``attrs``, enums as categoricals; ``/link/frames`` decoded."""
    pd = require_extra("reading a recording into DataFrames", "pandas")
    if not cols:
        cols = _empty_columns(topic)
    if topic == chans.LINK_FRAMES and "tx" in cols and "rx" in cols:
        return link_frames(cols)
    n = max((len(v) for v in cols.values()), default=0)
    cols = {k: v for k, v in cols.items() if len(v) == n}
    tables = _enum_tables()
    kind = chans.kind_of_topic(topic)
    data: dict[str, object] = {}
    for name, values in cols.items():
        if name == "t_s":
            continue
        if name in tables and kind in ("TELEMETRY", "REPLAY_CONTROLLER") \
                and np.asarray(values).dtype.kind in "iuf":
            data[name] = categorical(values, tables[name])
        else:
            data[name] = values
    if kind in ("FAULT", "EVENT") and "value" in cols:
        # the controller's trips carry FAULT_CTRL's code as their value
        if kind == "FAULT":
            trip = np.asarray(cols.get("action", np.empty(n, object)), dtype=object) == "trip"
        else:
            trip = np.asarray(cols.get("kind", np.empty(n, object)), dtype=object) \
                == "controller_fault"
        code = np.where(trip, np.asarray(cols["value"], dtype=np.float64), np.nan)
        data["fault_code"] = categorical(code, _fault_names())
    df = pd.DataFrame(data, index=_index(cols.get("t_s"), n), copy=False)
    df.attrs["topic"] = topic
    if kind is not None:
        df.attrs["description"] = chans.DESCRIPTIONS[kind]
    df.attrs["units"] = {**({"t_s": "s"} if df.index.name == "t_s" else {}),
                         **{c: chans.field_unit(c) for c in df.columns}}
    return df


# ---- /link/frames ----------------------------------------------------------------------------


def _signal_columns():
    """Per DBC message (by frame id): (message, [(column, signal, kind, extra)]) where kind is
    ``cat`` (a value table: extra = {raw: name}), ``int`` (an integer signal), ``off`` (a
    float signal with a named sentinel: extra = the sentinel's physical value) or ``float``."""
    from hil_bench.protocol import dbc

    sentinels = {(s.message, sig): s.raw for s in dbc.sentinels() for sig in s.signals}
    out = {}
    for msg in dbc.database().messages:
        cols = []
        for sig in msg.signals:
            column = f"{msg.name}.{sig.name}"
            if (msg.name, sig.name) in sentinels:
                off = sig.conversion.raw_to_scaled(sentinels[msg.name, sig.name],
                                                   decode_choices=False)
                cols.append((column, sig, "off", off))
            elif sig.choices:
                cols.append((column, sig, "cat", {int(k): str(v) for k, v in sig.choices.items()}))
            elif not sig.is_float and sig.scale == 1 and sig.offset == 0:
                cols.append((column, sig, "int", None))
            else:
                cols.append((column, sig, "float", None))
        out[msg.frame_id] = (msg, cols)
    return out


def link_frames(cols: Mapping[str, np.ndarray]) -> pandas.DataFrame:
    """``/link/frames`` rows (t_s, seq, tx, rx: candump-style ``ID#DATA`` texts) decoded into one
    row per frame (module docstring)."""
    pd = require_extra("reading a recording into DataFrames", "pandas")
    by_id = _signal_columns()
    t_s, seqs = cols["t_s"], cols.get("seq")
    f_t, f_seq, f_dir, f_id, f_data, f_msg = [], [], [], [], [], []
    #: frame id -> (rows, {signal: values}): the decoded values by signal, not a dict per frame
    per_msg: dict[int, tuple[list[int], dict[str, list]]] = {}
    elided = 0
    for i in range(len(t_s)):
        for direction, text in (("tx", cols["tx"][i]), ("rx", cols["rx"][i])):
            for tok in str(text).split():
                if tok == "...":                    # the cycle had more frames than its text holds
                    elided += 1
                    continue
                fid_text, _, hexdata = tok.partition("#")
                try:
                    fid = int(fid_text, 16)
                    data = bytes.fromhex(hexdata)
                except ValueError:
                    fid, data = -1, None
                row = len(f_t)
                f_t.append(t_s[i])
                f_seq.append(-1 if seqs is None else seqs[i])
                f_dir.append(direction)
                f_id.append(fid)
                f_data.append(hexdata.upper() if data is not None else tok)
                entry = by_id.get(fid) if data is not None else None
                if entry is None or len(data) != entry[0].length:
                    f_msg.append(None)
                    continue
                msg = entry[0]
                f_msg.append(msg.name)
                if fid not in per_msg:
                    per_msg[fid] = ([], {sig.name: [] for sig in msg.signals})
                rows, values = per_msg[fid]
                rows.append(row)
                decoded = msg.decode(data, decode_choices=False)
                for name, column in values.items():
                    # a multiplexed message (CONFIG: one signal per parameter) has only the
                    # signals of its multiplexer value in a frame: the others are missing there
                    column.append(decoded.get(name))
    n = len(f_t)
    names = [m.name for _, (m, _) in sorted(by_id.items())]
    data = {"seq": np.asarray(f_seq, dtype=np.int64),
            "direction": pd.Categorical(f_dir, categories=["tx", "rx"]),
            "message": pd.Categorical(f_msg, categories=names),
            "id": np.asarray(f_id, dtype=np.int64),
            "data": np.asarray(f_data, dtype=object)}
    units = {"t_s": "s", **{c: "" for c in data}}
    for fid in sorted(per_msg):
        rows, values = per_msg[fid]
        at = np.asarray(rows, dtype=np.int64)
        for column, sig, kind, extra in by_id[fid][1]:
            listed = values.pop(sig.name)
            present = np.asarray([v is not None for v in listed], dtype=bool)
            got = np.asarray([v for v in listed if v is not None])
            at_sig = at[present]
            if kind == "cat":
                raw = np.full(n, np.nan)
                raw[at_sig] = got
                data[column] = categorical(raw, extra, missing=())
            elif kind == "int":
                vals, mask = np.zeros(n, dtype=np.int64), np.ones(n, dtype=bool)
                vals[at_sig], mask[at_sig] = got.astype(np.int64), False
                data[column] = pd.arrays.IntegerArray(vals, mask)
            else:
                full = np.full(n, np.nan)
                vals = got.astype(np.float64)
                if kind == "off":
                    vals[vals == extra] = np.nan
                full[at_sig] = vals
                data[column] = full
            units[column] = sig.unit or ""
    df = pd.DataFrame(data, index=_index(np.asarray(f_t, dtype=np.float64), n), copy=False)
    df.attrs["topic"] = chans.LINK_FRAMES
    df.attrs["description"] = ("Every frame of the run decoded with protocol/hil.dbc: one row per "
                               "frame, tx = bench to controller, rx = controller to bench")
    df.attrs["units"] = units
    if elided:
        df.attrs["elided"] = (f"{elided} cycle(s) had more frames than the recording's text "
                              f"holds ('...'): those frames were not recorded")
    return df


def message_frame(frames: pandas.DataFrame, message: str) -> pandas.DataFrame:
    """One message's rows of a decoded ``/link/frames`` table, indexed by ``t_s``: ``cycle``
    (the recording's seq of the row: -1 outside the cycles), ``direction``, then the message's
    signals by their plain names (``message_frame(frames, "DUTY").d_a``; ``seq`` is then the
    message's own seq signal, as on the wire), units in ``attrs``."""
    prefix = f"{message}."
    if "message" not in frames.columns:
        raise KeyError("not a decoded /link/frames table (no 'message' column)")
    present = [str(m) for m in frames["message"].dropna().unique()]
    if message not in present:
        import difflib

        near = difflib.get_close_matches(message, present, n=1)
        hint = f"; did you mean {near[0]!r}?" if near else ""
        raise KeyError(f"no {message!r} frame in the recording (it has: "
                       f"{', '.join(sorted(present)) or 'none'}){hint}")
    signals = [c for c in frames.columns if c.startswith(prefix)]
    out = frames.loc[frames["message"] == message, ["seq", "direction", *signals]]
    out = out.rename(columns={"seq": "cycle", **{c: c[len(prefix):] for c in signals}})
    units = frames.attrs.get("units", {})
    out.attrs = {"topic": chans.LINK_FRAMES, "message": message,
                 "units": {"t_s": "s", "cycle": "", "direction": "",
                           **{c[len(prefix):]: units.get(c, "") for c in signals}}}
    return out


__all__ = ["require", "categorical", "channel_frame", "link_frames", "message_frame"]
