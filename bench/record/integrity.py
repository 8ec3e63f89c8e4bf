"""Run integrity: is a recording a complete, undamaged run over a clean link? (docs/protocol.md 6.9)

``check_integrity(rec, allow, requested_estimator)`` returns an :class:`Integrity`: the problems found,
each allowed by the scenario or not (``[link] allow = {crc_errors = 5}``: up to 5 allowed). An incomplete
or damaged run never passes: ``bench check --strict`` fails on any problem not allowed, and the claims
of such a run are INVALID (neither PASS nor FAIL), as are those of a run whose controller reported another
estimator than the one asked for, and those of a run that sent the plant's true angle to a sensorless
controller (docs/protocol.md 6.8): nothing on the wire can tell whether such a controller closed its loop
on its estimator or on the encoder angle it was given.

It reads only what ``hil_bench.record.recording.load_recording`` gives (metadata, topics as numpy columns, the
truncation note, ``unreadable_chunks`` once the reader counts them), never the MCAP itself:

* completeness: the ``run_result`` metadata record exists (it is written last: a bench that was killed
  leaves none; when reading stopped at damage before it, the problem says it was not read), ``cycles_done
  == cycles_planned``, no ``error``, not ``interrupted``; the file is not truncated, has no unreadable
  chunk and no record with an unknown opcode (``unknown_records``: damage, with its byte offsets); every cycle that ran has its row in ``/plant/state``;
* link integrity: the counters of ``LINK_COUNTERS`` (absent counters read as 0), each the larger of the
  last ``/link/stats`` row and the ``counters`` / ``rows_dropped`` of the ``run_result`` record: the stats
  rows go through the recorder's ring and can themselves be dropped, the run_result record cannot;
* the faults of the scenario (docs/faults.md): each must have acted and left a trace in every detection
  window, judged on the engine's own account in the ``run_result`` record (``faults``, and the counters
  ``faults_acted`` / ``faults_traced``), else on the ``/faults`` rows and the attached scenario;
* the side files: a ``X.serial.bin`` or ``X.log`` beside ``X.mcap`` that is not the one the run wrote
  (sidecars.py: its size and SHA-256 against the recording's ``sidecar<suffix>`` metadata);
* the estimator under test: ``estimator_mismatch`` on ``/link/stats`` (the host's per-cycle count) and the
  recount from ``/controller/telemetry.estimator`` against the run's requested estimator, whichever is
  larger; and the run metadata's ``encoder_angle_sent``: true with an estimator other than ENCODER is a
  problem of kind ``estimator`` that no scenario can allow.
"""
from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from typing import Mapping

import numpy as np

from hil_bench.protocol.messages import Estimator

from . import channels as ch

#: Link counters of /link/stats that are problems when non-zero (docs/protocol.md 6.5, 6.9), absent
#: counters reading as 0. In lockstep only lost and corrupt frames are link problems: a cycle the host
#: re-sent whose answers all came was late, which is timing (``TIMING_COUNTERS``).
LINK_COUNTERS: tuple[str, ...] = (
    "crc_errors", "cobs_errors", "length_errors", "overruns", "bytes_discarded", "seq_mismatch",
    "telem_missing", "unknown_ids",
    "duplicates", "lost_frames", "rows_dropped", "late_duty", "missed_duty", "estimator_mismatch",
    "bad_duties", "rt_overruns", "rx_malformed",
)
#: what each link problem is (the integrity section says which): a frame that failed its CRC or
#: framing is corrupt, one that never arrived is lost; the others are the controller's protocol,
#: real-time deadlines, or the bench's own recording
PROBLEM_CAUSE: dict[str, str] = {
    "crc_errors": "corrupt", "cobs_errors": "corrupt", "length_errors": "corrupt", "overruns": "corrupt",
    "bytes_discarded": "corrupt", "rx_malformed": "corrupt", "lost_frames": "lost",
    "seq_mismatch": "protocol", "telem_missing": "protocol", "unknown_ids": "protocol",
    "duplicates": "protocol", "bad_duties": "protocol", "estimator_mismatch": "protocol",
    "late_duty": "real time", "missed_duty": "real time", "rt_overruns": "real time",
    "rows_dropped": "recording",
}
#: lockstep timing (docs/protocol.md 6.5): re-sends, cycles answered late but whole, the answers to
#: re-sends. Recorded and reported, never a problem.
TIMING_COUNTERS: tuple[str, ...] = ("retries", "late_answers", "resend_answers")
#: what a scenario may allow: everything but an estimator mismatch, which invalidates the claims anyway
ALLOWABLE_COUNTERS: tuple[str, ...] = tuple(c for c in LINK_COUNTERS if c != "estimator_mismatch")


@dataclass(frozen=True)
class Problem:
    kind: str            # "completeness", "link", "estimator", "fault", "operator", "script"
                         # or "sidecar"
    name: str            # run_result, cycles, error, interrupted, truncated, unreadable_chunks, damage, rows,
                         # encoder_angle_sent, never_acted / untraced / count (a fault), or a counter
    text: str
    value: float = 0.0
    allowed: int = 0     # the scenario's allowance (link counters only)

    @property
    def is_allowed(self) -> bool:
        return self.kind == "link" and self.value <= self.allowed


@dataclass
class Integrity:
    problems: list[Problem] = field(default_factory=list)
    counters: dict[str, int] = field(default_factory=dict)
    timing: dict[str, int] = field(default_factory=dict)   # TIMING_COUNTERS: statistics, not problems
    cycles_done: int | None = None
    cycles_planned: int | None = None
    estimator_mismatch: int = 0
    estimator_text: str = ""

    @property
    def unallowed(self) -> list[Problem]:
        return [p for p in self.problems if not p.is_allowed]

    @property
    def allowed(self) -> list[Problem]:
        return [p for p in self.problems if p.is_allowed]

    @property
    def ok(self) -> bool:
        """No problem the scenario does not allow, and the estimator under test closed the loop."""
        return not self.unallowed and self.estimator_mismatch == 0

    @property
    def encoder_angle_problem(self) -> Problem | None:
        return next((p for p in self.problems if p.kind == "estimator"), None)

    @property
    def invalid_note(self) -> str | None:
        """A few words for the claims table (the full reason is printed with the integrity)."""
        if self.encoder_angle_problem is not None:
            return "true angle sent to a sensorless controller: see integrity"
        if self.estimator_mismatch:
            return "estimator mismatch: see integrity"
        if any(p.kind == "operator" for p in self.problems):
            return "operator input during the run: see integrity"
        if any(p.kind == "script" for p in self.problems):
            return "script input during the run: see integrity"
        bad = self.unallowed
        return f"{bad[0].kind} problem: see integrity" if bad else None

    @property
    def invalid_reason(self) -> str | None:
        """Why the claims of this run are INVALID, or None."""
        enc = self.encoder_angle_problem
        if enc is not None:
            return enc.text
        if self.estimator_mismatch:
            return self.estimator_text
        bad = self.unallowed
        if bad:
            more = f" (+{len(bad) - 1} more)" if len(bad) > 1 else ""
            return bad[0].text + more
        return None


def _int(text: object) -> int | None:
    try:
        v = float(str(text))
    except ValueError:
        return None
    return int(v) if math.isfinite(v) else None


def _topic(rec, name: str) -> dict[str, np.ndarray] | None:
    try:
        return rec.topic(name)
    except Exception:  # noqa: BLE001 - RecordingError: the topic is not in the file
        return None



def run_result_counters(rec) -> dict:
    """The engine's final counters, from the run_result record's ``counters`` JSON ({} when the
    record, the field or its JSON is missing or not an object)."""
    result = rec.metadata.get("run_result") or {}
    try:
        final = json.loads(result.get("counters", "") or "{}")
    except ValueError:
        return {}
    return final if isinstance(final, dict) else {}


def _last_counters(rec) -> dict[str, int]:
    """Each counter: the largest of the /link/stats rows (cumulative: the largest is the last) and of
    the run_result record's ``counters`` and ``rows_dropped`` (the final values, written through the
    recorder's pipe: a stats row can be dropped by the ring it reports on, the record cannot)."""
    out = {c: 0 for c in LINK_COUNTERS + TIMING_COUNTERS}
    stats = _topic(rec, ch.LINK_STATS)
    for c in out:
        col = (stats or {}).get(c)
        if col is not None and len(col):
            values = np.asarray(col, dtype=float)
            finite = values[np.isfinite(values)]
            out[c] = int(finite.max()) if len(finite) else 0
    result = rec.metadata.get("run_result") or {}
    final = run_result_counters(rec)
    if "rows_dropped" in result:
        final = {**final, "rows_dropped": max(_int(result["rows_dropped"]) or 0,
                                              _int(final.get("rows_dropped", 0)) or 0)}
    for c in list(out):
        v = _int(final.get(c, 0))
        if v is not None and v > out[c]:
            out[c] = v
    return out


def _counts_lost_frames(rec) -> bool:
    """Was the recording made by an engine that tells lost frames from late answers (its /link/stats
    rows or run_result counters have ``lost_frames``)?"""
    stats = _topic(rec, ch.LINK_STATS)
    return (stats is not None and "lost_frames" in stats and len(stats["lost_frames"]) > 0) \
        or "lost_frames" in run_result_counters(rec)


#: why the claims of a run that sent the true angle to a sensorless controller are INVALID
ENCODER_SENT_TEXT = ("the plant's true angle was sent to a sensorless controller: its estimator cannot be "
                     "verified")


def _estimator_recount(rec, requested: str | None) -> tuple[int, str]:
    """Cycles whose TELEM.estimator differs from the requested estimator (missing telemetry excluded)."""
    if not requested:
        return 0, ""
    try:
        want = int(Estimator[requested])
    except KeyError:
        return 0, ""
    counted = getattr(rec, "estimator_counts", None)   # the whole run, counted while streaming
    if counted is None:
        telem = _topic(rec, ch.CONTROLLER_TELEMETRY)
        if not telem or "estimator" not in telem:
            return 0, ""
        est = np.asarray(telem["estimator"], dtype=float)
        est = est[np.isfinite(est)].astype(int)
        vals, cnts = np.unique(est, return_counts=True)
        counted = dict(zip(vals.tolist(), cnts.tolist()))
    wrong_counts = {int(v): int(c) for v, c in counted.items() if v >= 0 and v != want}
    n = sum(wrong_counts.values())
    if not n:
        return 0, ""
    values, counts = list(wrong_counts), list(wrong_counts.values())
    names = []
    for v, c in zip(values, counts):
        try:
            name = Estimator(int(v)).name
        except ValueError:
            name = str(int(v))
        names.append(f"{name} in {c} cycles")
    return n, (f"the controller reported estimator {', '.join(names)} while {requested} was asked for: the "
               f"loop was not closed by the estimator under test (docs/protocol.md 6.8)")


def _fault_rows(rec) -> list[tuple[int, str, str, str]]:
    """(index, kind, action, text) of every /faults row."""
    rows = _topic(rec, ch.FAULTS)
    if not rows or not len(rows.get("t_s", ())):
        return []
    return [(int(i), str(k), str(a), str(t)) for i, k, a, t in
            zip(rows["index"], rows["kind"], rows["action"], rows["text"])]


def _never_acted_why(f: dict, cycles_done: int | None, ts_s: float, refused: str) -> str:
    """Why a fault of the run's account (bench/loop/fault_events.account) never acted."""
    if f.get("refused"):
        return f"the plant refused it when it was due ({refused or 'no reason recorded'})"
    k_on = int(f.get("cycle_on", 0))
    if cycles_done is not None and cycles_done <= k_on:
        return (f"the run ended after {cycles_done} periods, before the fault's period {k_on} "
                f"(t = {k_on * ts_s:.6g} s)")
    if "frames" in f:
        matched, p = int(f.get("matched", 0)), float(f.get("probability", 1.0))
        if matched == 0:
            return f"0 {f['frames']} crossed the link {f.get('window', '')}"
        return (f"{matched} {f['frames']} met it {f.get('window', '')}, none drawn at probability "
                f"{p:g} (expected {p * matched:.2g} action(s))")
    return "the engine never applied it"


def fault_problems(rec, scenario_faults=None, cycles_done: int | None = None) -> list[Problem]:
    """Every fault of the run must have acted and left a trace in each of its detection windows
    (docs/faults.md): checked against the engine's own account in the run_result record
    (``faults``, with its ``faults_acted`` / ``faults_traced`` counters), or, where that record is
    missing (a killed run, an older recording), against the /faults rows and ``scenario_faults``
    (the scenario's FaultSpecs). A problem names the fault and why."""
    out: list[Problem] = []
    rows = _fault_rows(rec)
    result = rec.metadata.get("run_result") or {}
    try:
        account = json.loads(result.get("faults", "") or "null")
    except ValueError:
        account = None
    try:
        ts_s = float(rec.run.get("ts_s", "nan"))
    except (TypeError, ValueError):
        ts_s = math.nan
    if isinstance(account, list):
        for f in account:
            if not isinstance(f, dict) or "index" not in f:
                continue
            i = int(f["index"])
            name = f"faults[{i}] ({f.get('what', f.get('kind', '?'))})"
            if int(f.get("acted_cycle", -1)) < 0:
                refused = next((t for idx, _, a, t in rows if idx == i and a == "refused"), "")
                why = _never_acted_why(f, cycles_done, ts_s, refused)
                out.append(Problem("fault", "never_acted",
                                   f"{name} never acted: {why}; the run did not test it"))
            elif int(f.get("untraced_windows", 0)) > 0:
                text = next((t for idx, _, a, t in rows if idx == i and a == "trace"
                             and t.startswith("no trace")), "no counter moved in its detection window")
                out.append(Problem("fault", "untraced",
                                   f"{name} acted but left no trace: {text}; what the run tested is "
                                   f"unknown"))
        counters = run_result_counters(rec)
        acted, traced = counters.get("faults_acted"), counters.get("faults_traced")
        n = len(account)
        short = [c for c in (acted, traced) if c is not None and int(c) < n]
        if not out and short:
            out.append(Problem("fault", "count", f"the engine counted {acted} of the run's {n} faults "
                                                 f"acting and {traced} with a trace"))
        return out
    # no account: the /faults rows (and the scenario, for the faults that left none)
    acted_idx = {i for i, _, a, _ in rows if a not in ("trace", "refused", "off")}
    for i, kind, a, text in rows:
        if a == "trace" and text.startswith("no trace"):
            out.append(Problem("fault", "untraced", f"faults[{i}] ({kind}) acted but left no trace: "
                                                    f"{text}; what the run tested is unknown"))
    for fs in scenario_faults or ():
        if fs.index not in acted_idx:
            out.append(Problem("fault", "never_acted",
                               f"faults[{fs.index}] ({fs.describe()}) never acted: no /faults row "
                               f"says it did (the run ended before it, or its rows were lost); the "
                               f"run did not test it"))
    return out


def check_integrity(rec, allow: Mapping[str, int] | None = None,
                    requested_estimator: str | None = None, scenario_faults=None) -> Integrity:
    """The integrity problems of a recording (see the module docstring). ``scenario_faults``: the
    scenario's [[faults]] (FaultSpec), for recordings without the engine's account of them."""
    allow = dict(allow or {})
    out = Integrity()
    add = out.problems.append

    # -- completeness ---------------------------------------------------------------------------------
    result = rec.metadata.get("run_result")
    planned_meta = _int(rec.metadata.get("run", {}).get("cycles_planned", ""))
    if result is None:
        if rec.truncated:
            add(Problem("completeness", "run_result",
                        f"run_result record not read (damage before it: {rec.truncated}); whether the bench "
                        f"finished the run is unknown (`bench recover` copies every intact chunk after the "
                        f"damage)"))
        else:
            add(Problem("completeness", "run_result",
                        "no run_result record: the bench did not finish the run (killed or crashed before "
                        "the end)"))
        out.cycles_planned = planned_meta
    else:
        done, planned = _int(result.get("cycles_done", "")), _int(result.get("cycles_planned", ""))
        out.cycles_done, out.cycles_planned = done, planned if planned is not None else planned_meta
        if done is None or out.cycles_planned is None or done < out.cycles_planned:
            add(Problem("completeness", "cycles", f"ran {done}/{out.cycles_planned} planned cycles",
                        float(done or 0)))
        if result.get("error"):
            add(Problem("completeness", "error", f"the run ended with an error: {result['error']}"))
        if str(result.get("interrupted", "")).lower() in ("true", "1"):
            add(Problem("completeness", "interrupted", "the run was interrupted"))
    if rec.truncated:
        add(Problem("completeness", "truncated", f"the recording is truncated ({rec.truncated})"))
    unreadable = int(getattr(rec, "unreadable_chunks", 0) or 0)
    if unreadable:
        add(Problem("completeness", "unreadable_chunks", f"{unreadable} unreadable chunk(s) in the recording",
                    float(unreadable)))
    unknown = list(getattr(rec, "unknown_records", None) or [])
    if unknown:
        where = ", ".join(f"byte {off} (opcode 0x{op:02X}, {n} octets)" for off, op, n in unknown[:5])
        add(Problem("completeness", "damage",
                    f"{len(unknown)} damaged record(s) skipped (unknown opcode) at {where}"
                    + (f" and {len(unknown) - 5} more" if len(unknown) > 5 else ""), float(len(unknown))))
    bad_lengths = [d for d in (getattr(rec, "damage", None) or []) if d.startswith("record at byte ")]
    if bad_lengths:
        add(Problem("completeness", "damage",
                    f"{len(bad_lengths)} record(s) with a damaged length field: {bad_lengths[0]}"
                    + (f" (+{len(bad_lengths) - 1} more)" if len(bad_lengths) > 1 else ""),
                    float(len(bad_lengths))))
    counts = getattr(rec, "counts", None) or {}
    if ch.PLANT_STATE in counts:
        rows = int(counts[ch.PLANT_STATE])       # messages in the file, kept or not
    else:
        state = _topic(rec, ch.PLANT_STATE)
        rows = len(state["t_s"]) if state and "t_s" in state else 0
    # a decimated recording ([recording] decimate, docs/faults.md) has fewer rows than cycles by
    # design: the engine counts the rows it wrote (run_result counters state_rows)
    expected = out.cycles_done
    if result is not None:
        written = run_result_counters(rec).get("state_rows")
        if written is not None and expected is not None and int(written) < expected:
            expected = int(written)
    if expected is not None and rows < expected:
        what = ("cycles have no row" if expected == out.cycles_done else
                "rows the engine wrote (a decimated recording) are missing")
        add(Problem("completeness", "rows", f"{expected - rows} of {expected} {what} in "
                                            f"{ch.PLANT_STATE}", float(expected - rows)))

    # -- link -------------------------------------------------------------------------------------------
    counted = _last_counters(rec)
    out.counters = {c: counted[c] for c in LINK_COUNTERS}
    out.timing = {c: counted[c] for c in TIMING_COUNTERS}
    if not _counts_lost_frames(rec) and out.timing["retries"]:
        # a recording of a bench before "late is not lost" (no lost_frames counter): its retries are
        # all that tells of a lost frame, so they stay a problem as they were then
        out.counters["retries"] = out.timing["retries"]
    for name, value in out.counters.items():
        if value and name != "estimator_mismatch":
            limit = int(allow.get(name, 0))
            cause = PROBLEM_CAUSE.get(name, "link")
            text = (f"{name} = {value} ({cause})" + (f" (scenario allows {limit})" if limit else "")
                    if name != "retries" else
                    f"retries = {value} (a recording made before lost and late answers were told apart: "
                    f"a re-send may be a lost frame)")
            add(Problem("link", name, text, float(value), limit))

    # -- faults: every fault of the scenario acted and left a trace (docs/faults.md) ------------------
    out.problems += fault_problems(rec, scenario_faults, out.cycles_done)

    # -- operator inputs (bench run --live, docs/foxglove.md) and a script's (hil_bench.Session,
    # docs/api.md): a run a viewer or a script steered is not the scenario's run, whatever its file
    # says: no claim of it can PASS ------------------------------------------------------------------------
    events = _topic(rec, ch.EVENTS)
    if events and "kind" in events:
        for kind, who in (("operator", "operator input(s) during the run (bench run --live)"),
                          ("script", "script input(s) during the run (hil_bench.Session)")):
            steered = [str(t) for k, t in zip(events["kind"], events.get("text", ())) if k == kind]
            if steered:
                add(Problem(kind, f"{kind}_input", f"{len(steered)} {who}: {steered[0]}"
                            + (f" (+{len(steered) - 1} more)" if len(steered) > 1 else ""),
                            float(len(steered))))

    # -- the files beside it: this run's, or another's (sidecars.py) --------------------------------------
    path = getattr(rec, "path", None)
    if path is not None:
        from .sidecars import sidecar_problems

        for suffix, text in sidecar_problems(path, rec.metadata):
            add(Problem("sidecar", suffix, text))

    # -- the estimator under test -------------------------------------------------------------------------
    sent = str(rec.run.get("encoder_angle_sent", "")).lower() in ("true", "1")
    if sent and requested_estimator and requested_estimator.upper() != "ENCODER":
        add(Problem("estimator", "encoder_angle_sent",
                    f"{ENCODER_SENT_TEXT} ({requested_estimator} asked for, with [controller] "
                    f"send_encoder_angle = true: SENSE_AUX.theta_enc carried the true angle every cycle; "
                    f"docs/protocol.md 6.8)"))
    recount, text = _estimator_recount(rec, requested_estimator)
    engine = out.counters.get("estimator_mismatch", 0)
    out.estimator_mismatch = max(recount, engine)
    if out.estimator_mismatch:
        out.estimator_text = text or (f"estimator_mismatch = {engine}: the controller reported another "
                                      f"estimator than {requested_estimator} (docs/protocol.md 6.8)")
    return out
