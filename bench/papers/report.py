"""``bench claims --run``: run every claim's scenarios, measure every quantity, write a report.

    .venv/bin/bench claims --run [--only Y1,G2 [--beyond]] [--out reports/claims] [--jobs N]
                                 [--no-beyond]

Steps: plan the runs (hil_bench.claims.registry.CLAIMS, plus the studies beyond the papers,
bench/papers/beyond.py), run them against the C stub in parallel (on hil_bench.cluster's executor:
``--jobs`` local workers or ``--scheduler``; rich progress on the terminal), measure each
quantity on its recording (hil_bench.papers.claims.measure), compute the studies
(bench/papers/studies.py), draw the plots (bench/papers/report_plots.py) and write ``<out>/report.md``, ``<out>/report.html`` (self-contained:
the plots inlined as base64 PNG) and ``<out>/plots/*.png``. The recordings stay in
``<out>/recordings`` (``bench check`` works on each).
"""
from __future__ import annotations

import base64
import datetime as _dt
import html
import math
import json
import os
import platform
import time
import traceback
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from rich.console import Console
from rich.markup import escape

from hil_bench.claims.model import Claim, Quantity, Run
from hil_bench.claims.registry import CLAIMS
from hil_bench.record.recorder import SIDE_SUFFIXES

from .claim_metrics import (
    TELEM_EMF_LSB_V,
    TELEM_IQ_LSB_A,
    TELEM_OMEGA_LSB_RAD_S,
    TELEM_THETA_LSB_RAD,
    Context,
    speed_lsb_rpm,
)
from . import conditions
from .conditions import scenario_for
from .claims import OPERATING_POINT_DEF, derive, measure_with_resolution, relate

#: the claim of a run outside any claim (a condition's note names it)
_NO_CLAIM = Claim("-", "", "", ())


@dataclass
class RunOutcome:
    run: Run
    recording: Path
    ok: bool
    error: str = ""
    wall_s: float = 0.0
    cycles: int = 0
    reused: bool = False
    retried: str = ""       # the error of a first attempt the bench broke (run once more)


@dataclass
class Row:
    claim: str
    key: str
    what: str
    paper: str
    measured: str
    unit: str
    rule: str
    source: str
    verdict: str
    note: str = ""
    diagnostic: bool = False
    value: float = math.nan
    is_relation: bool = False
    comparator: bool = False      # a row of the bench's comparator: decides through relations only


@dataclass
class Report:
    out_dir: Path
    claims: list[Claim]
    rows: list[Row] = field(default_factory=list)
    outcomes: dict[str, RunOutcome] = field(default_factory=dict)
    studies: dict[str, dict] = field(default_factory=dict)
    study_errors: dict[str, str] = field(default_factory=dict)
    plots: dict[str, list[Path]] = field(default_factory=dict)
    beyond: dict[str, Any] = field(default_factory=dict)
    residual: dict[str, Any] = field(default_factory=dict)
    assumptions: dict[str, Any] = field(default_factory=dict)
    comparators: dict[str, Any] = field(default_factory=dict)
    bandwidth: dict[str, Any] = field(default_factory=dict)
    wall_s: float = 0.0
    jobs: int = 1
    command: str = ""       # the exact command that produced the report


def _write_aside(path: Path, text: str) -> Path:
    """Write ``text`` to a temporary name beside ``path`` and rename it into place: a reader
    sees the old file or the new one, never half of one."""
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    tmp.write_text(text)
    os.replace(tmp, path)
    return path


# -- running --------------------------------------------------------------------------------------

def _run_one(run: Run, out_path: str, link: str = "stub") -> tuple[bool, str, float, int]:
    """Worker (own process): one scenario against a fresh stub (or the controller on ``link``)."""
    from hil_bench.loop.runner import run_scenario
    try:
        scn = scenario_for(run)
        # another controller in lockstep: a link slower than the control rate only slows the
        # run down, the results are the same (bench run --allow-slow-link)
        res = run_scenario(scn, link_spec=link, out_path=Path(out_path), progress=False,
                           allow_slow_link=link != "stub")
        return res.ok, res.error or "", res.wall_s, res.cycles_done
    except Exception as exc:  # noqa: BLE001 - reported in the row, never a crash of the report
        return False, f"{type(exc).__name__}: {exc}\n{traceback.format_exc(limit=3)}", 0.0, 0


def default_jobs() -> int:
    return max(1, min(os.cpu_count() or 1, 4))


def execute(runs: dict[str, Run], rec_dir: Path, jobs: int | None,
            console: Console | None = None, reuse: bool = False,
            scheduler: str | None = None, link: str = "stub") -> dict[str, RunOutcome]:
    """Run every scenario against the controller on ``link`` on the executor (hil_bench.cluster:
    a local Dask cluster of ``jobs`` workers, or ``scheduler``) with a progress bar; returns
    outcomes by run id."""

    rec_dir.mkdir(parents=True, exist_ok=True)
    outcomes: dict[str, RunOutcome] = {}
    todo = []
    for rid, run in runs.items():
        path = rec_dir / f"{rid}.mcap"
        if reuse and path.exists():
            outcomes[rid] = RunOutcome(run, path, True, reused=True)
        else:
            todo.append((rid, run, path))
    console = console or Console(stderr=True)
    from hil_bench.cluster import Executor, TaskFailure

    by_id = {rid: (run, path) for rid, run, path in todo}
    with Executor(scheduler, jobs, progress=True, console=console, label="claims") as ex:
        args = [(rid, (run, str(path.resolve()), link)) for rid, run, path in todo]
        for rid, res in ex.map(_run_one, args):
            run, path = by_id[rid]
            if isinstance(res, TaskFailure):    # a dead worker, every retry: the bench's failure
                ok, err, wall, cycles = False, f"worker failed: {res.error}", 0.0, 0
            else:
                ok, err, wall, cycles = res.value
            outcomes[rid] = RunOutcome(run, path, ok, err, wall, cycles)
            if not console.is_terminal:
                console.print(escape(f"  {rid}: {'ok' if ok else 'ended: ' + err.splitlines()[0]}"
                                     f" ({wall:.1f} s)"))
    # a run the bench broke (not the controller: a link that timed out on a loaded machine, a
    # dead stub) is run once more, alone; the report says so. A controller fault is a result.
    for rid, o in list(outcomes.items()):
        if o.ok or o.reused or "controller reported fault" in o.error:
            continue
        first = (o.error.splitlines() or ["no error text"])[0]
        console.print(escape(f"  {rid}: the bench broke the run ({first}): once more"))
        _keep_attempt(o.recording)
        ok, err, wall, cycles = _run_one(o.run, str(o.recording), link)
        outcomes[rid] = RunOutcome(o.run, o.recording, ok, err, wall, cycles, retried=first)
    return outcomes


#: <run>.mcap and the files a run writes beside it (bench/record/recorder.py: the serial and CAN captures)
_RUN_SIBLINGS = (".mcap",) + tuple(sfx for sfx, _ in SIDE_SUFFIXES)


def _keep_attempt(recording: Path) -> None:
    """Move a broken attempt's files (<run>.mcap, <run>.serial.bin, <run>.log) to
    <run>.attempt1.*: the recorder refuses to overwrite, and a record is never thrown away."""
    stem = recording.name[:-len(".mcap")] if recording.name.endswith(".mcap") else recording.stem
    for suffix in _RUN_SIBLINGS:
        f = recording.with_name(stem + suffix)
        if f.exists():
            f.rename(recording.with_name(f"{stem}.attempt1{suffix}"))


# -- measuring ------------------------------------------------------------------------------------

def _fmt(v: Any, unit: str = "") -> str:
    if isinstance(v, str):
        return v
    if v is None or not math.isfinite(v):
        return "n/a"
    a = abs(v)
    s = f"{v:.4g}" if (a >= 1e-3 or a == 0) else f"{v:.3e}"
    return f"{s} {unit}".strip()


def _context(path: Path):
    """(context, scenario) of a recording."""
    from hil_bench.record.recording import load_recording
    from hil_bench.scenario import scenario_of

    from .check import build_context
    rec = load_recording(path)
    scn = scenario_of(rec)
    return build_context(rec, scn), scn


class _Contexts:
    """Recordings are loaded once each; each is checked against the conditions of the run it
    was made for (hil_bench.papers.conditions: the estimator the controller reported, the plant,
    the compensation, the operating point and window): ``mismatch`` says why it is not."""

    def __init__(self, outcomes: dict[str, RunOutcome], claim: Claim | None = None):
        self.outcomes = outcomes
        self.claim = claim
        self.cache: dict[str, Context | Exception] = {}
        self.mismatch: dict[str, str] = {}

    def get(self, run_id: str) -> Context:
        if run_id not in self.cache:
            out = self.outcomes.get(run_id)
            try:
                if out is None:
                    raise FileNotFoundError(f"run {run_id} was not run")
                if not out.recording.exists():
                    raise FileNotFoundError(f"no recording for run {run_id}: {out.error}")
                ctx, scn = _context(out.recording)
                self.cache[run_id] = ctx
                failed = conditions.failed(out.run, ctx.rec, scn, self.claim)
                if failed:
                    self.mismatch[run_id] = conditions.Match(self.claim or _NO_CLAIM, out.run,
                                                             tuple(failed)).note()
            except Exception as exc:  # noqa: BLE001
                self.cache[run_id] = exc
        v = self.cache[run_id]
        if isinstance(v, Exception):
            raise v
        return v


def _measure_quantity(q: Quantity, ctxs: _Contexts, studies: dict, study_errors: dict,
                      values: dict[str, float]) -> tuple[float, str, str, float]:
    """(value, verdict, note, resolution) of one quantity."""
    if q.metric == "derived":
        v = derive(q, values)
        if not math.isfinite(v):
            return v, "INVALID", "an input quantity has no value", 0.0
        return v, q.verdict(v), q.not_reproducible, 0.0
    if q.study:
        if q.study in study_errors:
            return math.nan, "INVALID", study_errors[q.study], 0.0
        v = float(studies[q.study][dict(q.params)["key"]])
        return v, q.verdict(v), q.not_reproducible, 0.0
    if q.aggregate:
        vals, notes = [], []
        for rid in q.runs:
            try:
                ctx = ctxs.get(rid)
            except Exception as exc:  # noqa: BLE001
                return math.nan, "INVALID", str(exc), 0.0
            if rid in ctxs.mismatch:
                return math.nan, "INVALID", ctxs.mismatch[rid], 0.0
            v, verdict, note, _res = measure_with_resolution(q, ctx)
            vals.append(v)
            if note:
                notes.append(f"{rid}: {note}")
        finite = [v for v in vals if math.isfinite(v)]
        if q.aggregate == "max_abs":
            right = [abs(v) for v in finite if abs(v) < 90.0]
            value = max(right) if right else math.nan
            note = f"per trial: {', '.join(_fmt(v) for v in vals)} deg"
            if not right:
                return value, "FAIL", "no trial with the right polarity; " + note, 0.0
        elif q.aggregate == "polarity_failures":
            value = float(sum(1 for v in vals if not (math.isfinite(v) and abs(v) < 90.0)))
            note = f"of {len(vals)} trials"
        else:
            raise ValueError(f"{q.key}: unknown aggregate {q.aggregate!r}")
        if notes:
            note += "; " + "; ".join(notes)
        return value, q.verdict(value), note, 0.0
    try:
        ctx = ctxs.get(q.runs[0])
    except Exception as exc:  # noqa: BLE001
        return math.nan, "INVALID", str(exc), 0.0
    if q.runs[0] in ctxs.mismatch:
        return math.nan, "INVALID", ctxs.mismatch[q.runs[0]], 0.0
    return measure_with_resolution(q, ctx)


def _source_cell(q: Quantity) -> str:
    """The rule's source, then what the measurement rests on that is the bench's own."""
    out = q.rule.source
    if q.definition:
        out += f" | {q.definition}"
    if q.at_speed_rpm is not None:
        out += " | operating point checked (bench definition, see above)"
    if q.calibration:
        out += " | CALIBRATION: the plant was fitted to this number"
    return out


def measure_claims(claims: list[Claim], outcomes: dict[str, RunOutcome], studies: dict,
                   study_errors: dict) -> list[Row]:
    rows: list[Row] = []
    for c in claims:
        ctxs = _Contexts(outcomes, c)       # one claim's recordings in memory at a time
        values: dict[str, float] = {}
        resolutions: dict[str, float] = {}
        qrows = []
        # derived quantities last: they read the others' values
        for q in sorted(c.quantities, key=lambda q: q.metric == "derived"):
            v, verdict, note, res = _measure_quantity(q, ctxs, studies, study_errors, values)
            values[q.key] = v
            resolutions[q.key] = res
            measured = _fmt(v, q.unit)
            if "lower bound" in note and math.isfinite(v):
                measured = ">= " + measured
            if not math.isfinite(v):
                measured = "no value: " + (_short_fault(note) if "ended early" in note
                                           else "not measurable (see note)")
            qrows.append((q, Row(c.id, q.key, q.what, _fmt(q.paper_value, q.unit if not
                                                            isinstance(q.paper_value, str) else ""),
                                 measured, q.unit,
                                 "no verdict" if q.calibration else q.rule.text(),
                                 _source_cell(q), verdict, note, q.diagnostic, v,
                                 comparator=bool(q.comparator))))
        order = {q.key: i for i, q in enumerate(c.quantities)}
        rows += [r for _, r in sorted(qrows, key=lambda x: order[x[0].key])]
        nr = frozenset(r.key for _, r in qrows if r.verdict == "NOT REPRODUCIBLE")
        off = frozenset(r.key for _, r in qrows if "did not hold" in r.note)
        untested = {r.key: "the comparator did not hold its operating point" for _, r in qrows
                    if r.verdict == "UNTESTED"}
        ended = {r.key: ("INVALID" if r.verdict == "INVALID" else "FAIL") for _, r in qrows
                 if "the run ended early" in r.note and r.verdict != "UNTESTED"}
        for rel in c.relations:
            vals, verdict, note = relate(rel, values, nr, off, resolutions, untested, ended)
            sym = {"<": " < ", ">": " > ", "=": " = "}[rel.op]
            rows.append(Row(c.id, rel.key, rel.what, rel.paper,
                            sym.join(_fmt(v) for v in vals), "",
                            {"<": "increasing as listed", ">": "decreasing as listed",
                             "=": f"|difference| < {rel.tol:g}"}[rel.op], rel.source, verdict,
                            note, rel.diagnostic, is_relation=True))
    return rows


def _short_fault(note: str) -> str:
    """'controller reported fault STARTUP_FAILED at seq 519 ...' -> 'controller fault
    STARTUP_FAILED at t = 0.0519 s'."""
    import re
    m = re.search(r"fault (\w+) at seq (\d+)", note)
    if m:
        cause = re.search(r"\[([^\];]+)", note)       # diagnose_fault's first clause
        return (f"the controller faulted ({m.group(1)}"
                + (f": {cause.group(1).strip()}" if cause else "") + f") at cycle {m.group(2)}")
    return "the run ended early"


def judge_claim(claim: Claim, outcomes: dict) -> tuple[str, list]:
    """One claim's verdict and rows on the runs' outcomes (no studies: the residual study's and
    the bandwidth sweeps' judge, bench/papers/claim_variants.py)."""
    rows = measure_claims([claim], outcomes, {}, {})
    return claim_verdict(rows), rows


def claim_verdict(rows: list[Row]) -> str:
    """A claim's summary over its non-diagnostic rows (a comparator's rows count only through
    the relations over them): FAIL if any fails, INVALID if any could not be measured, PASS if
    every pass/fail row passed (PARTLY if some rows had no verdict of their own: not
    reproducible, not resolved, untested), else NOT REPRODUCIBLE / UNTESTED / NOT RESOLVED /
    COMPARED."""
    vs = [r.verdict for r in rows if not r.diagnostic and not r.comparator
          and r.verdict != "CALIBRATION"]
    for v in ("FAIL", "INVALID"):
        if v in vs:
            return v
    if "PASS" in vs:
        return "PASS" if all(v in ("PASS", "COMPARED") for v in vs) else "PARTLY"
    for v in ("NOT REPRODUCIBLE", "UNTESTED", "NOT RESOLVED"):
        if v in vs:
            return v
    return "COMPARED"


def _css_class(verdict: str) -> str:
    return verdict.replace(" ", "_")


#: what the report says about the resolution of the controller's telemetry and the bench's own
#: definitions (the same text in report.md and report.html)
RESOLUTION_TEXT = (
    f"Telemetry resolution (docs/protocol.md): the controller reports its speed estimate in "
    f"steps of {TELEM_OMEGA_LSB_RAD_S:g} rad/s electrical ({speed_lsb_rpm(4):.3f} "
    f"rpm at p = 4, {speed_lsb_rpm(3):.3f} rpm at p = 3), its angle in "
    f"{TELEM_THETA_LSB_RAD:.3g} rad, its EMF in {TELEM_EMF_LSB_V:g} V and its i_q reference in "
    f"{TELEM_IQ_LSB_A * 1e3:g} mA. Where a host reference estimator ran on the same samples "
    f"(the same C, recorded in float64) the speed metrics are computed from it; otherwise from "
    f"the telemetry, and a relation whose difference is below one LSB is NOT RESOLVED (not "
    f"FAIL).")
DEFINITIONS_TEXT = (
    "Bench definitions (not the papers'; each row that rests on one says so in its source "
    "column): " + OPERATING_POINT_DEF + "; the estimator response time, the G8 settling band, "
    "the Y3 chattering index and the Y5 2 % tracking criterion.")


# -- what decides a claim ------------------------------------------------------------------------

#: the order in which a claim's verdict picks the row that decides it
_DECIDES = {"FAIL": ("FAIL",), "INVALID": ("INVALID",), "NOT REPRODUCIBLE": ("NOT REPRODUCIBLE",),
            "NOT RESOLVED": ("NOT RESOLVED",), "UNTESTED": ("UNTESTED",),
            "PARTLY": ("NOT REPRODUCIBLE", "UNTESTED", "NOT RESOLVED"),
            "PASS": ("PASS",), "COMPARED": ("COMPARED",)}


def _first_clause(text: str, limit: int = 220) -> str:
    text = " ".join(str(text).split())
    return text if len(text) <= limit else text[:limit].rsplit(" ", 1)[0] + " ..."


def claim_summary(c: Claim, rows: list[Row]) -> tuple[str, str, str, str]:
    """(verdict, the paper's number, the measured number, a one-line reason that names what
    decides it) of one claim: the row that decides the verdict (the first failing one for FAIL,
    the first passing relation or row for PASS, ...), and why - a bench limitation (NOT
    REPRODUCIBLE, INVALID), the drive's fault under the claim's set-up, a finding about the
    paper (FAIL against the paper's own rule), or a value the paper gives without a bound."""
    verdict = claim_verdict(rows)
    main = [r for r in rows if not r.diagnostic and not r.comparator and r.verdict != "CALIBRATION"]
    pick = None
    for want in _DECIDES.get(verdict, ()):
        # a relation states the claim's ranking: it decides before a single row where it holds
        cands = [r for r in main if r.verdict == want]
        if want == "PASS":
            cands = [r for r in cands if r.is_relation] + [r for r in cands if not r.is_relation]
        if cands:
            pick = cands[0]
            break
    if pick is None:
        return verdict, "", "", "no row of the paper's set-up"
    what = ("relation: " if pick.is_relation else "") + pick.what
    if pick.verdict == "NOT REPRODUCIBLE":
        reason = f"bench limitation ({what}): {_first_clause(pick.note)}"
    elif pick.verdict == "INVALID":
        reason = f"the bench could not measure {what}: {_first_clause(pick.note)}"
    elif pick.verdict == "NOT RESOLVED":
        reason = f"telemetry resolution ({what}): {_first_clause(pick.note)}"
    elif pick.verdict == "UNTESTED":
        reason = f"untested ({what}): {_first_clause(pick.note)}"
    elif pick.verdict == "FAIL" and "ended early" in pick.note:
        reason = (f"the drive faulted under the claim's set-up ({_first_clause(c.setup, 120)}): "
                  f"{_short_fault(pick.note)}")
    elif pick.verdict == "FAIL" and "did not hold" in pick.note:
        reason = f"the drive did not hold the operating point ({what}): {_first_clause(pick.note)}"
    elif pick.verdict == "FAIL":
        reason = (f"finding on the claim's set-up: {what} is {pick.measured} against the "
                  f"paper's {pick.paper} ({pick.rule}; {_first_clause(pick.source, 120)})")
    elif pick.verdict == "PASS":
        reason = (f"holds: {what} {pick.measured} against the paper's {pick.paper} ({pick.rule}; "
                  f"{_first_clause(pick.source, 120)})")
    else:
        reason = (f"reported value, no bound in the paper: {what} ({_first_clause(pick.source, 140)})"
                  + (f"; {_first_clause(pick.note, 120)}" if pick.note else ""))
    return verdict, pick.paper, pick.measured, reason


def summary_row(rep: "Report", c: Claim, rows: list[Row]) -> tuple[str, str, str, str, str]:
    """(verdict, the assumption it rests on, paper, measured, what decides it) of the summary
    table: the verdict across the claim's assumptions where the report ran them
    (bench/papers/assumptions.py: DEPENDS with the threshold where the verdict moves over the
    plausible range of a number the paper does not give), else the claim's own; a comparator
    study's finding joins the reason of a claim whose relations it left untested."""
    from .assumptions import summary as assumption_summary
    v, paper, measured, reason = claim_summary(c, rows)
    across, assumption = assumption_summary(rep.assumptions, c.id)
    if across is not None and across != v:
        reason = (f"{across} across its assumptions (at the scenarios' values: {v}); " + reason)
        v = across
    if rep.comparators and any(r.verdict == "UNTESTED" for r in rows if not r.diagnostic):
        from .comparators import finding
        f = finding(rep.comparators, c.id)
        if f:
            reason += f"; comparator study: {f}"
    return v, assumption, paper, measured, reason


#: the estimator settings a report states per run (CONFIG as recorded), with their meaning
_SETTINGS = (("PLL_KP", "PLL kp", "1/s"), ("PLL_KI", "PLL ki", "1/s^2"),
             ("SPEED_LPF_RAD_S", "speed LPF", "rad/s"), ("SMO_K_V", "SMO k", "V"),
             ("SMO_K_MIN_V", "SMO k floor", "V"), ("SMO_WC_RAD_S", "SMO EMF LPF cut-off", "rad/s"),
             ("SMO_M_PER_A", "tanh m", "1/A"), ("SMO_SIGMOID_A_PER_A", "sigmoid a", "1/A"),
             ("SMO_STA_K1_V", "STA k1", "V"), ("SMO_STA_K2_V_S", "STA k2", "V/s"),
             ("HFI_BW_RAD_S", "HFI tracking bandwidth", "rad/s"), ("HFI_U_V", "HFI injection", "V"),
             ("HFI_F_HZ", "HFI frequency", "Hz"), ("DELAY_COMP_ENABLE", "delay pre-compensation", ""))


def estimator_settings(recording: Path) -> str:
    """The estimator's chosen bandwidths and gains of one run, from its recording's CONFIG (what
    the controller was sent) and the estimator it ran: the PLL as a type-2 loop (kp = 2 zeta
    wn, ki = wn^2: est_common.h), every filter cut-off and gain the estimator has."""
    from hil_bench.record.recording import read_header
    try:
        run = read_header(recording).run
        params = json.loads(run.get("controller_params", "{}"))
        comp = json.loads(run.get("inverter_comp", "{}") or "{}")
    except Exception:  # noqa: BLE001 - no settings is said, never a crash of the report
        return ""
    est = run.get("estimator", "?")
    parts = []
    kp, ki = params.get("PLL_KP"), params.get("PLL_KI")
    for name, label, unit in _SETTINGS:
        v = params.get(name)
        if v is None or name in ("PLL_KP", "PLL_KI"):
            continue
        if name == "SPEED_LPF_RAD_S" and v <= 0:
            parts.append("speed LPF off")
            continue
        parts.append(f"{label} {v:.4g} {unit}".strip())
    if kp and ki and ki > 0:
        wn = math.sqrt(ki)
        parts.insert(0, f"PLL bandwidth wn {wn:.4g} rad/s, zeta {kp / (2 * wn):.3g} (kp {kp:.4g} "
                        f"1/s, ki {ki:.4g} 1/s^2)")
    if params.get("LOOP_ANGLE") is not None:
        parts.append("the loop turns with the " + ("PLL's angle" if params["LOOP_ANGLE"] >= 1
                                                    else "observer's EMF angle") + " (LOOP_ANGLE)")
    if comp.get("on"):
        r = comp.get("residual")
        parts.append("inverter compensation on" + (f", residual {100 * r:g} %" if r is not None
                                                   else ""))
    parts.append("settings not listed are the controller's own defaults (not sent, so not "
                 "recorded)")
    return f"{est}: " + "; ".join(parts)


def command_of(out_dir: Path, only: list[str] | None, jobs: int | None, beyond: bool,
               reuse: bool, beyond_quick: bool, scheduler: str | None, residual: bool,
               bandwidth: bool = True) -> str:
    """The command line that runs this report (when it was not started from one)."""
    import shlex
    argv = ["claims", "--run", "--out", str(out_dir)]
    if only:
        argv += ["--only", ",".join(only)]
    if jobs:
        argv += ["--jobs", str(jobs)]
    if only and beyond:
        argv.append("--beyond")
    elif not beyond:
        argv.append("--no-beyond")
    if beyond_quick:
        argv.append("--quick")
    if reuse:
        argv.append("--reuse")
    if scheduler:
        argv += ["--scheduler", scheduler]
    if not residual:
        argv.append("--no-residual")
    if not bandwidth:
        argv.append("--no-bandwidth")
    return ".venv/bin/bench " + shlex.join(argv)


# -- writing --------------------------------------------------------------------------------------

def _settings_lines(outcomes: list) -> list[tuple[str, str]]:
    """(run ids, settings) of a claim's runs, runs with the same settings together."""
    by_text: dict[str, list[str]] = {}
    for o in outcomes:
        if o.recording.exists():
            text = estimator_settings(o.recording)
            if text:
                by_text.setdefault(text, []).append(o.run.id)
    return [(", ".join(ids), text) for text, ids in by_text.items()]


def _md_cell(s: str) -> str:
    return str(s).replace("|", "\\|").replace("\n", " ")


def write_markdown(rep: Report) -> Path:
    L = ["# Paper claims reproduced on the bench", ""]
    L += [f"Generated {_dt.datetime.now().isoformat(timespec='seconds')} on {platform.node()} "
          f"({os.cpu_count()} cores, {rep.jobs} parallel runs), wall time {rep.wall_s:.0f} s. "
          f"Command: `{rep.command}`.", ""]
    L += ["Verdicts: **PASS** / **FAIL** against a rule from the paper; **COMPARED**: the paper "
          "gives a value without a bound or a stated resolution, so the value is compared, no "
          "pass/fail; **NOT REPRODUCIBLE**: the reason is given; **INVALID**: the bench could "
          "not measure; **NOT RESOLVED**: a relation whose difference is below the resolution of "
          "what it was measured from; **CALIBRATION**: the plant was fitted to this number, so "
          "the row is the fit's input (no verdict); **UNTESTED**: a relation against the bench's "
          "reconstruction of a method the paper only cites (a comparator), which did not hold its "
          "operating point; **DEPENDS**: the verdict changes over the plausible range of a number "
          "the paper does not give (the assumption column names it and the threshold). Rows "
          "marked *diagnostic* are not the paper's setup (e.g. dead time off, to locate a "
          "failure) and do not count for the claim.", ""]
    L += [RESOLUTION_TEXT, "", DEFINITIONS_TEXT, ""]
    L += ["| claim | verdict | the assumption it rests on | paper | measured | what decides it "
          "| claim |", "|---|---|---|---|---|---|---|"]
    by_claim = {c.id: [r for r in rep.rows if r.claim == c.id] for c in rep.claims}
    for c in rep.claims:
        v, assumption, paper, measured, reason = summary_row(rep, c, by_claim[c.id])
        L.append(f"| [{c.id}](#{c.id.lower()}) | {v} | {_md_cell(assumption)} | {_md_cell(paper)} "
                 f"| {_md_cell(measured)} | {_md_cell(reason)} | {_md_cell(c.text)} |")
    L.append("")
    for c in rep.claims:
        L += [f"## {c.id}", "", f"**{c.paper}.** {c.text}", ""]
        if c.plant:
            L += [f"Plant and compensation that decide: {c.plant}.", ""]
        if c.setup:
            L += [f"Setup: {c.setup}.", ""]
        if c.notes:
            L += [f"Notes: {c.notes}", ""]
        L += ["| quantity | paper | measured | rule | rule's source | verdict | note |",
              "|---|---|---|---|---|---|---|"]
        for r in by_claim[c.id]:
            what = ("*" + r.what + "*") if r.diagnostic else r.what
            if r.is_relation:
                what = "relation: " + what
            L.append(f"| {_md_cell(what)} | {_md_cell(r.paper)} | {_md_cell(r.measured)} | "
                     f"{_md_cell(r.rule)} | {_md_cell(r.source)} | **{r.verdict}** | "
                     f"{_md_cell(r.note)} |")
        L.append("")
        runs = [rep.outcomes[r.id] for r in c.runs if r.id in rep.outcomes]
        settings = _settings_lines(runs)
        if settings:
            L.append("Estimator settings (each run's CONFIG as recorded): " + "; ".join(
                f"{ids}: {text}" for ids, text in settings))
            L.append("")
        if runs:
            L.append("Runs: " + "; ".join(
                f"`{o.run.id}` ({o.run.name}{': ' + o.run.label if o.run.label else ''}) "
                f"{'ok' if o.ok else 'ended early: ' + o.error.splitlines()[0] if o.error else ''}"
                f"{', reused' if o.reused else f', {o.wall_s:.1f} s'}"
                f"{f' (second attempt; the first ended: {o.retried})' if o.retried else ''}"
                for o in runs))
            L.append("")
        for p in rep.plots.get(c.id, []):
            L += [f"![{c.id}]({p.relative_to(rep.out_dir)})", ""]
    if rep.assumptions:
        from .assumptions import markdown as assumptions_md
        L += assumptions_md(rep)
    if rep.comparators:
        from .comparators import markdown as comparators_md
        L += comparators_md(rep)
    if rep.residual:
        from .residual import markdown as residual_md
        L += residual_md(rep)
    if rep.bandwidth:
        from .bandwidth import markdown as bandwidth_md
        L += bandwidth_md(rep)
    if rep.beyond:
        from .beyond import markdown as beyond_md
        L += beyond_md(rep)
    path = rep.out_dir / "report.md"
    _write_aside(path, "\n".join(L) + "\n")
    return path


_CSS = """
body { font-family: sans-serif; max-width: 1400px; margin: 1em auto; padding: 0 1em; }
table { border-collapse: collapse; margin: 0.5em 0 1em; font-size: 0.9em; }
td, th { border: 1px solid #bbb; padding: 3px 6px; vertical-align: top; }
th { background: #eee; }
.PASS { background: #c8f0c8; } .FAIL { background: #f6c4c4; } .COMPARED { background: #e8e8f8; }
.INVALID { background: #f6e0a8; } .NOT_REPRODUCIBLE { background: #ead8f0; }
.PARTLY { background: #f0f0b0; } .NOT_RESOLVED { background: #dde8ee; }
.CALIBRATION { background: #eeeeee; } .UNTESTED { background: #e4e4d4; }
.DEPENDS { background: #f8dcb0; }
tr.diag td { color: #666; font-style: italic; }
img { max-width: 100%; border: 1px solid #ccc; margin: 0.5em 0; }
code { background: #f4f4f4; }
"""


def _img(path: Path) -> str:
    data = base64.b64encode(path.read_bytes()).decode()
    return f'<img alt="{html.escape(path.stem)}" src="data:image/png;base64,{data}">'


def write_html(rep: Report) -> Path:
    e = html.escape
    H = [f"<!doctype html><html><head><meta charset='utf-8'><title>Paper claims</title>"
         f"<style>{_CSS}</style></head><body>", "<h1>Paper claims reproduced on the bench</h1>"]
    H.append(f"<p>Generated {e(_dt.datetime.now().isoformat(timespec='seconds'))} on "
             f"{e(platform.node())}, wall time {rep.wall_s:.0f} s, {rep.jobs} parallel runs. "
             f"Command: <code>{e(rep.command)}</code>.</p>")
    H.append("<p>Verdicts: PASS / FAIL against a rule from the paper; COMPARED: value compared, "
             "no pass/fail (the paper gives no bound and no resolution); NOT REPRODUCIBLE (reason "
             "given); INVALID: the bench could not measure; NOT RESOLVED: a relation whose "
             "difference is below the resolution of what it was measured from; CALIBRATION: the "
             "plant was fitted to this number (no verdict); UNTESTED: a relation against the "
             "bench's reconstruction of a method the paper only cites, which did not hold its "
             "operating point; DEPENDS: the verdict changes over the plausible range of a number "
             "the paper does not give (the assumption column names it and the threshold). "
             "<i>Diagnostic</i> rows are not the paper's setup and do not count.</p>")
    H.append(f"<p>{e(RESOLUTION_TEXT)}</p><p>{e(DEFINITIONS_TEXT)}</p>")
    by_claim = {c.id: [r for r in rep.rows if r.claim == c.id] for c in rep.claims}
    H.append("<table><tr><th>claim</th><th>verdict</th><th>the assumption it rests on</th>"
             "<th>paper</th><th>measured</th><th>what decides it</th><th>claim</th></tr>")
    for c in rep.claims:
        v, assumption, paper, measured, reason = summary_row(rep, c, by_claim[c.id])
        H.append(f"<tr><td><a href='#{c.id}'>{c.id}</a></td><td class='{_css_class(v)}'>{v}</td>"
                 f"<td>{e(assumption)}</td><td>{e(paper)}</td><td>{e(measured)}</td>"
                 f"<td>{e(reason)}</td><td>{e(c.text)}</td></tr>")
    H.append("</table>")
    for c in rep.claims:
        H.append(f"<h2 id='{c.id}'>{c.id}</h2><p><b>{e(c.paper)}.</b> {e(c.text)}</p>")
        if c.plant:
            H.append(f"<p>Plant and compensation that decide: {e(c.plant)}.</p>")
        if c.setup:
            H.append(f"<p>Setup: {e(c.setup)}.</p>")
        if c.notes:
            H.append(f"<p>Notes: {e(c.notes)}</p>")
        H.append("<table><tr><th>quantity</th><th>paper</th><th>measured</th><th>rule</th>"
                 "<th>rule's source</th><th>verdict</th><th>note</th></tr>")
        for r in by_claim[c.id]:
            what = ("relation: " if r.is_relation else "") + r.what
            H.append(f"<tr class='{'diag' if r.diagnostic else ''}'><td>{e(what)}</td>"
                     f"<td>{e(r.paper)}</td><td>{e(r.measured)}</td><td>{e(r.rule)}</td>"
                     f"<td>{e(r.source)}</td><td class='{_css_class(r.verdict)}'>{e(r.verdict)}"
                     f"</td><td>{e(r.note)}</td></tr>")
        H.append("</table>")
        settings = _settings_lines([rep.outcomes[r.id] for r in c.runs if r.id in rep.outcomes])
        if settings:
            H.append("<p>Estimator settings (each run's CONFIG as recorded):</p><ul>" + "".join(
                f"<li><code>{e(ids)}</code>: {e(text)}</li>" for ids, text in settings) + "</ul>")
        for p in rep.plots.get(c.id, []):
            H.append(_img(p))
    if rep.assumptions:
        from .assumptions import html_section as assumptions_html
        H += assumptions_html(rep, _img)
    if rep.comparators:
        from .comparators import html_section as comparators_html
        H += comparators_html(rep, _img)
    if rep.residual:
        from .residual import html_section as residual_html
        H += residual_html(rep, _img)
    if rep.bandwidth:
        from .bandwidth import html_section as bandwidth_html
        H += bandwidth_html(rep, _img)
    if rep.beyond:
        from .beyond import html_section
        H += html_section(rep, _img)
    H.append("</body></html>")
    path = rep.out_dir / "report.html"
    _write_aside(path, "\n".join(H))
    return path


# -- the whole thing -----------------------------------------------------------------------------

def run_report(out_dir: Path, only: list[str] | None = None, jobs: int | None = None,
               beyond: bool | None = None, reuse: bool = False, console: Console | None = None,
               beyond_quick: bool = False, scheduler: str | None = None,
               residual: bool = True, command: str | None = None,
               bandwidth: bool = True) -> Report:
    """``command``: the command line that started it (the report's "Command:"; default: the
    equivalent of the arguments given). ``bandwidth``: the estimator-bandwidth sweeps
    (bench/papers/bandwidth.py; ``beyond_quick``: on the coarse grid). ``beyond``: the studies
    beyond the papers (default: only when no claim is picked by ``only``; they are no claim's
    runs)."""
    t0 = time.monotonic()
    if beyond is None:
        beyond = not only
    console = console or Console(stderr=True)
    out_dir = Path(out_dir)
    (out_dir / "plots").mkdir(parents=True, exist_ok=True)
    ids = [c for c in CLAIMS] if not only else only
    unknown = [c for c in ids if c not in CLAIMS]
    if unknown:
        raise ValueError(f"unknown claim(s) {', '.join(unknown)}; known: {', '.join(CLAIMS)}")
    claims = [CLAIMS[c] for c in ids]
    runs: dict[str, Run] = {}
    for c in claims:
        for r in c.runs:
            runs.setdefault(r.id, r)
    beyond_plan = None
    if beyond:
        from . import beyond as by
        beyond_plan = by.plan(quick=beyond_quick)
        for r in beyond_plan.runs:
            runs.setdefault(r.id, r)
    residual_plan = None
    if residual:
        from . import residual as rs
        residual_plan = rs.plan(ids)
        for r in residual_plan.runs:
            runs.setdefault(r.id, r)
    assumptions_plan = None
    if residual:          # the assumptions' axes share the residual study's switch and runs
        from . import assumptions as asm
        assumptions_plan = asm.plan(ids)
        for r in assumptions_plan.runs:
            runs.setdefault(r.id, r)
    comparators_plan = None
    if residual:
        from . import comparators as cmp
        comparators_plan = cmp.plan(ids)
        for r in comparators_plan.runs:
            runs.setdefault(r.id, r)
    bandwidth_plan = None
    if bandwidth:
        from . import bandwidth as bw
        bandwidth_plan = bw.plan(ids, bw.QUICK_SCALES if beyond_quick else bw.SCALES)
        for r in bandwidth_plan.runs:
            runs.setdefault(r.id, r)
    jobs = jobs or default_jobs()
    rep = Report(out_dir, claims, jobs=jobs,
                 command=command or command_of(out_dir, only, jobs, beyond, reuse, beyond_quick,
                                               scheduler, residual, bandwidth))
    console.print(escape(f"{len(runs)} runs ({jobs} in parallel) for claims {', '.join(ids)}"
                         + (" and the studies beyond the papers" if beyond else "")))
    rep.outcomes = execute(runs, out_dir / "recordings", jobs, console, reuse=reuse,
                           scheduler=scheduler)
    from .studies import STUDIES
    for c in claims:
        for s in c.studies:
            if s in rep.studies or s in rep.study_errors:
                continue
            try:
                rep.studies[s] = STUDIES[s]()
            except Exception as exc:  # noqa: BLE001
                rep.study_errors[s] = f"{type(exc).__name__}: {exc}"
    rep.rows = measure_claims(claims, rep.outcomes, rep.studies, rep.study_errors)
    from .report_plots import plot_claims
    rep.plots = plot_claims(rep)
    if residual_plan is not None and residual_plan.claims:
        from . import residual as rs
        t_res = time.monotonic()
        extra = rs.refine_runs(residual_plan, rs.measure(residual_plan, rep, judge_claim))
        if extra:
            console.print(f"residual study: {len(extra)} runs at the flips")
            rep.outcomes.update(execute({r.id: r for r in extra}, out_dir / "recordings", jobs,
                                        console, reuse=reuse, scheduler=scheduler))
        rep.residual = rs.evaluate(residual_plan, rep, judge_claim)
        _write_aside(out_dir / "residual.json", json.dumps(rs.to_json(rep.residual), indent=1))
        rep.residual["refine_s"] = time.monotonic() - t_res
    if assumptions_plan is not None and assumptions_plan.claims:
        from . import assumptions as asm
        rep.assumptions = asm.evaluate(assumptions_plan, rep, judge_claim, claim_verdict)
        _write_aside(out_dir / "assumptions.json", json.dumps(asm.to_json(rep.assumptions), indent=1))
    if comparators_plan is not None and comparators_plan.points:
        from . import comparators as cmp
        rep.comparators = cmp.evaluate(comparators_plan, rep, measure_claims)
        _write_aside(out_dir / "comparators.json", json.dumps(cmp.to_json(rep.comparators), indent=1))
    if bandwidth_plan is not None and bandwidth_plan.sweeps:
        from . import bandwidth as bw
        rep.bandwidth = bw.evaluate(bandwidth_plan, rep, judge_claim)
        _write_aside(out_dir / "bandwidth.json", json.dumps(bw.to_json(rep.bandwidth), indent=1))
    if beyond_plan is not None:
        from . import beyond as by
        rep.beyond = by.evaluate(beyond_plan, rep)
    rep.wall_s = time.monotonic() - t0
    write_markdown(rep)
    write_html(rep)
    return rep
