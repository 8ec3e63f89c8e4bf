"""Capture readers: a bench recording (MCAP), a CAN log (every format python-can reads), a raw
serial byte capture (``.serial.bin``), a scope/DAQ CSV export with a mapping file. Each returns a
:class:`~hil_bench.replay.capture.Capture` (docs/replay.md "Inputs").

Damage never stops a replay that has something intact: a truncated or corrupt capture adds a
line to ``Capture.problems`` naming the file and the position, and what could be read is
replayed. Only a capture with nothing replayable raises :class:`CaptureError`.
"""
from __future__ import annotations

import csv
import json
import math
import tomllib
from pathlib import Path

import numpy as np

from hil_bench.plant_rt.engine import REPLAY_CYCLE_DTYPE
from hil_bench.protocol.framing import Deframer
from hil_bench.protocol.messages import Param
from hil_bench.record import serial_capture as sc

from .capture import Anomalies, Capture, CaptureError, CycleAssembler, duty_raw_of, empty_telem

#: the first octets of every MCAP file (whatever its name: a .partial file the bench left)
MCAP_MAGIC = b"\x89MCAP0\r\n"
#: what python-can's LogReader reads (a trailing .gz is read compressed)
CAN_SUFFIXES = (".log", ".asc", ".blf", ".trc", ".csv", ".mf4")


def capture_kind(path: Path, mapping: Path | None) -> str:
    name = path.name.lower()
    if mapping is not None:
        return "csv"
    if name.endswith((".mcap", ".mcap.partial")):
        return "mcap"     # a recording, or what a recorder that died left (recorder.partial_path)
    try:
        with open(path, "rb") as f:
            head = f.read(max(len(sc.MAGIC), len(MCAP_MAGIC)))
    except OSError as exc:
        raise CaptureError(f"{path}: cannot open: {exc.strerror}") from None
    if head.startswith(sc.MAGIC):
        return "serial"
    if head.startswith(MCAP_MAGIC):
        return "mcap"
    base = name[:-3] if name.endswith(".gz") else name
    if base.endswith(CAN_SUFFIXES):
        if base.endswith(".csv") and not _is_can_csv(path):
            raise CaptureError(f"{path}: a CSV that is not a python-can CSV log (its header is not "
                               f"'timestamp,arbitration_id,...'): a scope/DAQ export needs "
                               f"--mapping FILE.toml (docs/replay.md)")
        return "can"
    raise CaptureError(f"{path}: unknown capture format: give a .mcap recording, a CAN log "
                       f"({', '.join(CAN_SUFFIXES)}, optionally .gz), a .serial.bin byte capture "
                       f"or a CSV with --mapping")


def _is_can_csv(path: Path) -> bool:
    from .canlog import _Source

    src = _Source(path, path.name.lower().endswith(".gz"))
    try:
        first = src.readline().decode("utf-8", errors="replace")
    finally:
        src.really_close()
    return first.strip().lower().startswith("timestamp,arbitration_id")


def read_capture(path: str | Path, *, ts_s: float | None = None,
                 mapping: str | Path | None = None, profile=None) -> Capture:
    path = Path(path)
    if not path.exists():
        raise CaptureError(f"{path}: no such file")
    kind = capture_kind(path, Path(mapping) if mapping else None)
    if kind == "mcap":
        return read_mcap(path)
    if kind == "serial":
        return read_serial(path, ts_s)
    if kind == "can":
        return read_can_log(path, ts_s)
    return read_csv(path, Path(mapping), profile=profile, ts_s=ts_s)


# -- frames (CAN and serial) --------------------------------------------------------------------

def _ts_from(asm: CycleAssembler, ts_s: float | None, path: Path) -> tuple[float, str]:
    if ts_s is not None:
        return float(ts_s), "--ts-us"
    if asm.hello is not None and asm.hello["period_us"] > 0:
        return asm.hello["period_us"] * 1e-6, "HELLO.period_us in the capture"
    raise CaptureError(f"{path}: the capture has no HELLO frame (it starts after the handshake), "
                       f"so its control period is unknown: give --ts-us")


def _from_assembler(path: Path, kind: str, asm: CycleAssembler, an: Anomalies,
                    problems: list[str], ts_s: float | None, where_end: str) -> Capture:
    asm.finish(where_end)
    if not asm.cycles:
        raise CaptureError(f"{path}: no control cycle in the capture (no SENSE frame of the "
                           f"protocol)" + (f"; {'; '.join(problems)}" if problems else "")
                           + (f"; anomalies: {an.summary()}" if an.counts else ""))
    ts, ts_source = _ts_from(asm, ts_s, path)
    rows, telem, frames, text = asm.build(ts)
    cap = Capture(path=path, kind=kind, ts_s=ts, ts_source=ts_source, rows=rows, telem=telem,
                  frames=frames, frames_text=text, setup_frames=asm.setup, hello=asm.hello,
                  config=asm.config, commands=asm.commands, anomalies=an, problems=problems,
                  sessions=max(asm.sessions, 1))
    if cap.has_theta:
        cap.theta_source = "encoder (SENSE_AUX.theta_enc, THETA_ENC_VALID)"
    if asm.ignored_sessions_frames:
        cap.notes.append(f"{asm.ignored_sessions_frames} frames of later sessions not replayed")
    return cap


def read_can_log(path: Path, ts_s: float | None = None) -> Capture:
    """A CAN log through python-can's own reader for its format (never a parser of our own);
    damage is found, located and read past as ``bench/replay/canlog.py`` says."""
    from .canlog import read_log

    an = Anomalies()
    asm = CycleAssembler(an)
    state = {"t0": None}

    def on_message(msg, where_line: str) -> None:
        t = float(msg.timestamp)
        if state["t0"] is None:
            state["t0"] = t
        rel = t - state["t0"]
        where = f"{where_line} (t = {rel:.6f} s)"
        if msg.is_error_frame or msg.is_remote_frame or msg.is_extended_id:
            what = ("an error frame" if msg.is_error_frame else
                    "a remote frame" if msg.is_remote_frame else
                    f"a 29-bit id 0x{msg.arbitration_id:08X}")
            an.add("not_protocol", f"{where}: {what}", rel)
            return
        asm.feed(int(msg.arbitration_id), bytes(msg.data), rel, where)

    try:
        res = read_log(path, on_message)
    except ValueError as exc:
        raise CaptureError(f"{path}: {exc}") from None
    except OSError as exc:
        raise CaptureError(f"{path}: cannot read: {exc.strerror or exc}") from None
    for where, what in res.damaged:
        an.add("damaged", f"{where}: {what}")
    cap = _from_assembler(path, "can", asm, an, res.problems, ts_s,
                          f"end of the log (message {res.messages})")
    cap.notes.extend(res.notes)
    return cap


def read_serial(path: Path, ts_s: float | None = None) -> Capture:
    """A ``.serial.bin``: each direction through its own deframer (docs/protocol.md 2.4), the
    frames in record order. Framing errors are counted (``damaged``) with their byte offset."""
    an = Anomalies()
    problems: list[str] = []
    asm = CycleAssembler(an)
    deframers = {sc.TX: Deframer(), sc.RX: Deframer()}
    t0 = None
    last_offset = len(sc.MAGIC)
    end: list[str] = []
    try:
        records = list(sc.read_records(path, problems, end))
    except sc.SerialCaptureDamage as exc:
        raise CaptureError(str(exc)) from None
    for rec in records:
        if t0 is None:
            t0 = rec.t_ns
        t = (rec.t_ns - t0) * 1e-9
        d = deframers[rec.direction]
        before = sum(v for k, v in d.counters().items() if k not in ("frames_ok",
                                                                      "bytes_discarded"))
        frames = d.feed(rec.data)
        after = sum(v for k, v in d.counters().items() if k not in ("frames_ok",
                                                                     "bytes_discarded"))
        where = f"byte {rec.offset} ({'host -> controller' if rec.direction == sc.TX else 'controller -> host'}, t = {t:.6f} s)"
        if after > before:
            an.add("damaged", f"{where}: {after - before} damaged frame(s) (CRC, COBS, length or "
                              f"overrun; discarded up to the next 0x00)", t, n=after - before)
        for fid, payload in frames:
            asm.feed(fid, payload, t, where)
        last_offset = rec.offset
    for direction, d in deframers.items():
        c = d.counters()
        if d._pending:
            problems.append(f"{path}: the capture ends inside a frame "
                            f"({len(d._pending)} octets after the last 0x00, "
                            f"{'host -> controller' if direction == sc.TX else 'controller -> host'})")
        if c["bytes_discarded"]:
            an.counts["bytes_discarded"] += c["bytes_discarded"]
    t_last = (records[-1].t_ns - t0) * 1e-9 if records else math.nan
    cut = None
    if not end:
        cut = (f"{path}: no end record: the capture stops after the record at byte {last_offset} "
               f"(t = {t_last:.6f} s) without its writer closing it (a killed bench or recorder, "
               f"a full disk): what crossed the line after that is not in it")
    elif not end[0].startswith((sc.END_OF_RUN, "converted")):
        cut = f"{path}: the capture was closed before the end of the run: {end[0]}"
    if cut is not None:
        problems.append(cut)
        an.add("damaged", cut, t_last)
    return _from_assembler(path, "serial", asm, an, problems, ts_s,
                           f"end of file (record at byte {last_offset})")


# -- MCAP ---------------------------------------------------------------------------------------

def read_mcap(path: Path) -> Capture:
    from hil_bench.record import channels as ch
    from hil_bench.record.recording import RecordingError, load_recording

    try:
        rec = load_recording(path)
    except RecordingError as exc:
        raise CaptureError(str(exc)) from None
    problems = []
    if rec.truncated:
        problems.append(f"{path}: {rec.truncated}; the cycles before it are replayed")
    for d in rec.damage:
        problems.append(f"{path}: {d}; skipped")
    if ch.PLANT_SENSE not in rec.topics or not len(rec.topics[ch.PLANT_SENSE].get("t_s", [])):
        raise CaptureError(f"{path}: no /plant/sense rows in the recording (not a run of this "
                           f"bench, or nothing intact)" + (f"; {'; '.join(problems)}" if problems
                                                           else ""))
    run = rec.run
    try:
        ts = float(run["ts_s"])
        plant_params = json.loads(run["plant_params"])
    except (KeyError, ValueError) as exc:
        raise CaptureError(f"{path}: run metadata incomplete ({exc})") from None
    se = rec.topics[ch.PLANT_SENSE]
    te = rec.topics.get(ch.CONTROLLER_TELEMETRY, {})
    st = rec.topics.get(ch.PLANT_STATE, {})
    if "run_result" not in rec.metadata:
        problems.append(f"{path}: no run_result record: the bench did not finish this run (killed, "
                        f"or its recorder died): it ends where the file ends")
    t = np.asarray(se["t_s"], dtype=float)
    an = Anomalies()
    for p in problems:       # what the file itself lost counts with the capture's anomalies
        an.add("damaged", p, float(t[-1]) if len(t) else math.nan)
    # every topic aligned on /plant/sense by time (a truncated file may end mid-cycle)
    def aligned(cols: dict, n_keep: int) -> dict | None:
        if not cols or "t_s" not in cols:
            return None
        idx = np.searchsorted(cols["t_s"], t)
        ok = (idx < len(cols["t_s"]))
        ok[ok] &= cols["t_s"][idx[ok]] == t[ok]
        return {"idx": idx, "ok": ok}
    a_te = aligned(te, len(t))
    a_st = aligned(st, len(t))
    n = len(t)
    rows = np.zeros(n, dtype=REPLAY_CYCLE_DTYPE)
    rows["t_s"] = t
    rows["seq"] = se["seq"]
    rows["i_abc_a"] = np.stack([se["i_a_a"], se["i_b_a"], se["i_c_a"]], 1)
    rows["v_dc_v"] = se["v_dc_v"]
    telem = empty_telem(n)
    if a_st is not None:
        ok = a_st["ok"]
        rows["theta_rad"][ok] = st["theta_e_rad"][a_st["idx"][ok]]
        rows["has_theta"][ok] = 1
    if a_te is not None:
        ok = a_te["ok"]
        j = a_te["idx"][ok]
        d = np.stack([te["duty_a"][j], te["duty_b"][j], te["duty_c"][j]], 1)
        rows["duty_raw"][ok] = duty_raw_of(d)
        rows["has_duty"][ok] = 1
        has_t = np.isfinite(te["theta_hat_rad"][j])
        rows["theta_hat_rad"][ok] = te["theta_hat_rad"][j]
        rows["omega_hat_rad_s"][ok] = te["omega_hat_rad_s"][j]
        rows["has_telem"][np.flatnonzero(ok)[has_t]] = 1
        for key in telem:
            if key in te:
                telem[key][ok] = te[key][j]
        # what a replay into a controller compares beside the duties (/replay/controller)
        rows["state"][ok] = np.where(has_t, te["state"][j], -1)
        rows["estimator"][ok] = np.where(has_t, te["estimator"][j], -1)
        has_emf = np.isfinite(te["e_alpha_v"][j])
        rows["has_emf"][np.flatnonzero(ok)[has_emf]] = 1
        for key in ("e_alpha_v", "e_beta_v", "i_q_ref_a"):
            rows[key][ok] = te[key][j]
        missing = int((~ok).sum())
        if missing:
            an.add("drops", f"{missing} cycle(s) of /plant/sense have no /controller/telemetry row",
                   n=missing)
    # seq continuity of the recorded cycles
    dseq = (np.diff(rows["seq"].astype(np.int64)) & 0xFFFF)
    for i in np.flatnonzero(dseq != 1):
        if dseq[i] == 0:
            an.add("duplicates", f"/plant/sense row {i + 1}: seq {rows['seq'][i + 1]} again", t[i + 1])
        elif dseq[i] < 0x8000:
            an.add("gaps", f"/plant/sense row {i + 1}: seq jumps {rows['seq'][i]} -> "
                           f"{rows['seq'][i + 1]}", t[i + 1])
            an.counts["cycles_missing"] += int(dseq[i]) - 1
        else:
            an.add("out_of_order", f"/plant/sense row {i + 1}: seq goes backwards", t[i + 1])
    cap = Capture(path=path, kind="mcap", ts_s=ts, ts_source="run metadata ts_s", rows=rows,
                  telem=telem, anomalies=an, problems=problems, recording=rec)
    cap.theta_source = "plant truth (/plant/state theta_e_rad)" if a_st is not None else None
    if a_st is not None:
        cap.state = {k: np.where(a_st["ok"], v[np.minimum(a_st["idx"], len(v) - 1)], np.nan)
                     for k, v in st.items()}
    try:
        cap.config = {Param[k]: float(v) for k, v in json.loads(
            run.get("controller_params", "{}")).items()}
    except (KeyError, ValueError):
        cap.config = {}
    cap.plant_params = plant_params
    _frames_of_mcap(cap, rec)
    return cap


def _frames_of_mcap(cap: Capture, rec) -> None:
    """The recorded frames (/link/frames) assembled into cycles, matched to the rows by seq."""
    from hil_bench.record import channels as ch

    fr = rec.topics.get(ch.LINK_FRAMES)
    if not fr or not len(fr.get("t_s", [])):
        cap.notes.append("no /link/frames in the recording: replay into a controller is not "
                         "possible from it")
        return
    scratch = Anomalies()
    asm = CycleAssembler(scratch)
    for i in range(len(fr["t_s"])):
        t = float(fr["t_s"][i])
        for text, _dir in ((fr["tx"][i], "tx"), (fr["rx"][i], "rx")):
            for tok in str(text).split():
                if "#" not in tok or tok == "...":
                    continue
                fid, _, hexdata = tok.partition("#")
                try:
                    asm.feed(int(fid, 16), bytes.fromhex(hexdata), t, f"/link/frames row {i}")
                except ValueError:
                    scratch.add("damaged", f"/link/frames row {i}: unreadable frame {tok!r}", t)
    asm.finish("end of /link/frames")
    cap.setup_frames = asm.setup
    cap.hello = asm.hello
    cap.commands = asm.commands
    if asm.config:
        cap.config = {**cap.config, **asm.config}
    if not asm.cycles:
        return
    rows_f, _telem, frames, text = asm.build(cap.ts_s)
    # match by time: cycle k of the frames is at k Ts, the recorded rows carry t_k = k Ts
    idx = np.searchsorted(rows_f["t_s"], cap.rows["t_s"])
    ok = idx < len(rows_f)
    ok[ok] &= rows_f["t_s"][idx[ok]] == cap.rows["t_s"][ok]
    cap.rows["first_frame"][ok] = rows_f["first_frame"][idx[ok]]
    cap.rows["n_frames"][ok] = rows_f["n_frames"][idx[ok]]
    cap.frames = frames
    up = [""] * cap.n
    down = [""] * cap.n
    for r, j in zip(np.flatnonzero(ok), idx[ok]):
        up[r] = text[0][j]
        down[r] = text[1][j]
    cap.frames_text = (up, down)
    # what the frames say about the capture (retries, late frames) is part of its anomalies
    for kind in ("duplicates", "out_of_order", "unknown_ids", "wrong_length", "damaged"):
        if scratch.counts.get(kind):
            for k2, t2, text2 in scratch.details:
                if k2 == kind:
                    cap.anomalies.details.append((k2, t2, text2))
            cap.anomalies.counts[kind] += scratch.counts[kind]
    missing = int((~ok).sum())
    if missing:
        cap.notes.append(f"{missing} recorded cycle(s) have no frames in /link/frames")


# -- scope / DAQ CSV ----------------------------------------------------------------------------

UNITS = {"s": 1.0, "ms": 1e-3, "us": 1e-6, "ns": 1e-9,
         "A": 1.0, "mA": 1e-3, "kA": 1e3,
         "V": 1.0, "mV": 1e-3, "kV": 1e3,
         "rad": 1.0, "deg": math.pi / 180.0,
         "1": 1.0, "%": 1e-2}
_KIND_UNITS = {"time": ("s", "ms", "us", "ns"), "current": ("A", "mA", "kA"),
               "voltage": ("V", "mV", "kV"), "angle": ("rad", "deg"), "duty": ("1", "%")}
SIGNALS = {"i_a": "current", "i_b": "current", "i_c": "current", "v_dc": "voltage",
           "duty_a": "duty", "duty_b": "duty", "duty_c": "duty",
           "v_a": "voltage", "v_b": "voltage", "v_c": "voltage", "theta": "angle"}


class MappingError(CaptureError):
    pass


def load_mapping(path: Path) -> dict:
    """The mapping TOML (docs/replay.md "CSV mapping"), validated; errors name file and key."""
    try:
        doc = tomllib.loads(Path(path).read_text())
    except FileNotFoundError:
        raise MappingError(f"{path}: no such mapping file") from None
    except tomllib.TOMLDecodeError as exc:
        raise MappingError(f"{path}: not valid TOML: {exc}") from None
    where = str(path)
    for top in doc:
        if top not in ("csv", "time", "signals", "control"):
            raise MappingError(f"{where}: {top}: unknown table (csv, time, signals, control)")
    out = {"csv": dict(doc.get("csv", {})), "control": dict(doc.get("control", {})),
           "signals": {}}
    t = doc.get("time")
    if not isinstance(t, dict) or "column" not in t:
        raise MappingError(f"{where}: time: needs column = \"...\" and unit = \"s\"|\"ms\"|...")
    out["time"] = _signal_spec(where, "time", t, "time")
    sig = doc.get("signals", {})
    for name, spec in sig.items():
        if name not in SIGNALS:
            raise MappingError(f"{where}: signals.{name}: unknown signal; known: "
                               f"{', '.join(SIGNALS)}")
        out["signals"][name] = _signal_spec(where, f"signals.{name}", spec, SIGNALS[name])
    s = out["signals"]
    currents = [k for k in ("i_a", "i_b", "i_c") if k in s]
    if len(currents) < 2:
        raise MappingError(f"{where}: signals: needs at least two phase currents (i_a, i_b, i_c)")
    if "v_dc" not in s:
        raise MappingError(f"{where}: signals.v_dc: missing (a column, or value = <volts>)")
    duties = [k for k in ("duty_a", "duty_b", "duty_c") if k in s]
    volts = [k for k in ("v_a", "v_b", "v_c") if k in s]
    if duties and volts:
        raise MappingError(f"{where}: signals: give the duties or the phase voltages, not both")
    if duties and len(duties) != 3 or volts and len(volts) != 3:
        raise MappingError(f"{where}: signals: the three duties (duty_a, duty_b, duty_c) or the "
                           f"three phase voltages (v_a, v_b, v_c)")
    if not duties and not volts:
        raise MappingError(f"{where}: signals: no duties or phase voltages: the estimators need "
                           f"the voltage the inverter applied")
    th = s.get("theta")
    if th is not None and th.get("frame", "electrical") not in ("electrical", "mechanical"):
        raise MappingError(f"{where}: signals.theta.frame: 'electrical' or 'mechanical'")
    return out


def _signal_spec(where: str, key: str, spec, kind: str) -> dict:
    if not isinstance(spec, dict):
        raise MappingError(f"{where}: {key}: must be a table {{ column = \"...\", unit = \"...\" }}")
    allowed = {"column", "unit", "value", "scale", "offset", "frame", "reference"}
    for k in spec:
        if k not in allowed:
            raise MappingError(f"{where}: {key}.{k}: unknown key ({', '.join(sorted(allowed))})")
    if "column" not in spec and "value" not in spec:
        raise MappingError(f"{where}: {key}: needs column = \"<header name>\" (or value = <number>)")
    unit = spec.get("unit", _KIND_UNITS[kind][0])
    if unit not in _KIND_UNITS[kind]:
        raise MappingError(f"{where}: {key}.unit: {unit!r} is not a {kind} unit "
                           f"({', '.join(_KIND_UNITS[kind])})")
    out = dict(spec)
    out["unit"] = unit
    out["factor"] = UNITS[unit] * float(spec.get("scale", 1.0))
    out["where"] = f"{where}: {key}"
    return out


def read_csv(path: Path, mapping_path: Path, *, profile=None, ts_s: float | None = None) -> Capture:
    """A scope/DAQ export, resampled onto the control period (docs/replay.md "Resampling")."""
    from hil_bench.installation import require_extra

    from .resample import DAQ_FEATURE, resample_capture

    # SciPy resamples the export: said before the file is read
    require_extra(DAQ_FEATURE, "scipy.signal", "scipy.interpolate", "scipy.integrate")
    m = load_mapping(mapping_path)
    delim = m["csv"].get("delimiter", ",")
    skip = int(m["csv"].get("skip_rows", 0))
    an = Anomalies()
    problems: list[str] = []
    try:
        raw = path.read_bytes()
    except OSError as exc:
        raise CaptureError(f"{path}: cannot read: {exc.strerror}") from None
    if raw and not raw.endswith(b"\n"):
        # the file ends inside its last line: a cut export; its last field may be a prefix of
        # the number that was there (12.34 of 12.3456), so the line is left out, never read half
        cut = raw.rfind(b"\n") + 1
        n_last = raw.count(b"\n") + 1
        problems.append(f"{path}: file ends inside line {n_last} (byte {cut}): truncated; that "
                        f"line is left out")
        an.add("damaged", f"line {n_last} (byte {cut}): the file ends inside it; left out")
        raw = raw[:cut]
    lines = raw.decode("utf-8", errors="replace").splitlines()
    if len(lines) <= skip:
        raise CaptureError(f"{path}: line {skip + 1}: no header line")
    header = next(csv.reader([lines[skip]], delimiter=delim))
    header = [h.strip() for h in header]
    col_of = {h: i for i, h in enumerate(header)}
    specs = {"time": m["time"], **m["signals"]}
    for key, spec in specs.items():
        if "column" in spec and spec["column"] not in col_of:
            raise MappingError(f"{spec['where']}.column: column {spec['column']!r} is not in "
                               f"{path} (line {skip + 1} has: {', '.join(header)})")
    used = {k: col_of[s["column"]] for k, s in specs.items() if "column" in s}
    data = {k: [] for k in used}
    line_no = []
    for ln, row in enumerate(csv.reader(lines[skip + 1:], delimiter=delim), start=skip + 2):
        if not row or all(not c.strip() for c in row):
            continue
        if len(row) < len(header):
            problems.append(f"{path}: line {ln}: {len(row)} of {len(header)} columns "
                            f"(truncated); left out")
            an.add("damaged", f"line {ln}: truncated row", math.nan)
            continue
        try:
            vals = {k: float(row[i]) for k, i in used.items()}
        except ValueError:
            bad = next(k for k, i in used.items() if not _is_float(row[i]))
            an.add("drops", f"line {ln}: {specs[bad]['column']} = {row[used[bad]]!r} is not a "
                            f"number; sample left out", math.nan)
            continue
        for k, v in vals.items():
            data[k].append(v)
        line_no.append(ln)
    if len(line_no) < 2:
        raise CaptureError(f"{path}: fewer than two readable samples"
                           + (f"; {'; '.join(problems)}" if problems else ""))
    arrays = {k: np.asarray(v) * specs[k]["factor"] + float(specs[k].get("offset", 0.0))
              * specs[k]["factor"] for k, v in data.items()}
    for k, s in specs.items():
        if "column" not in s:
            arrays[k] = np.full(len(line_no), float(s["value"]) * s["factor"])
    return resample_capture(path, m, arrays, np.asarray(line_no), an, problems, profile, ts_s)


def _is_float(s: str) -> bool:
    try:
        float(s)
        return True
    except ValueError:
        return False
