"""Checking the papers' claims (hil_bench.claims: the registry, its data and definitions) on
recordings: which quantities of a claim one recording measures (``applicable``), the verdict of
one quantity (``measure``: the metric of hil_bench.papers.claim_metrics, the run's state, the
operating point, the telemetry's resolution), of a relation (``relate``), of a derived row
(``derive``), what a controller trip says about the drive (``run_failure``, ``diagnose_fault``)
and the windows `bench check` keeps (``windows_needed``).

Verdicts: PASS, FAIL, COMPARED (value compared, no pass/fail), INVALID (the bench could not
measure: the run broke, the window is empty), NOT REPRODUCIBLE (reason given), NOT RESOLVED (a
relation whose difference is below the resolution of what it was measured from, e.g. one LSB of
the controller's telemetry), CALIBRATION (the plant was fitted to this number: the row is the
calibration's input, shown, no verdict), UNTESTED (a relation against a comparator the bench
reconstructed from a paper's citation, which did not hold its operating point: no verdict on the
paper), DEPENDS (a claim's verdict that changes over the plausible range of a number the paper
does not give: bench/papers/assumptions.py). A claim that does not reproduce is a result to show,
never something to tune away.
"""
from __future__ import annotations

import json
import math
from dataclasses import dataclass
from typing import Any, Callable

import numpy as np

from hil_bench.claims.model import Claim, Quantity, Relation
from hil_bench.claims.registry import CLAIMS
from hil_bench.record import channels as ch
from hil_bench.record.recording import Recording

from . import metrics
from .claim_metrics import (
    METRICS,
    Context,
    MetricAtLeast,
    MetricUnavailable,
    resolution,
)

VERDICTS = ("PASS", "FAIL", "COMPARED", "INVALID", "NOT REPRODUCIBLE", "NOT RESOLVED",
            "CALIBRATION", "UNTESTED", "DEPENDS")

#: operating-point check of a speed window (a bench definition, not a paper's rule)
OPERATING_POINT_DEF = ("bench definition: the window holds its operating point when the true mean "
                       "speed is within 10 % + 0.5 rpm of the reference")


@dataclass(frozen=True)
class QuantityResult:
    claim: Claim
    quantity: Quantity
    measured: float
    verdict: str
    note: str = ""
    setup: Any = None           # conditions.Match: the claim's run this recording is (or not)


@dataclass(frozen=True)
class RelationResult:
    claim: Claim
    relation: Relation
    measured: tuple[float, ...]
    verdict: str
    note: str = ""


def applicable(claim: Claim, rec, scn, estimator: bool = True):
    """The run of ``claim`` a recording is, by what ran (hil_bench.papers.conditions.match:
    the estimator the controller reported, the plant's set-up, the compensation, the operating
    point and window), with the quantities measured in it alone; None for a claim without
    runs. ``estimator`` False: a header read (the telemetry not yet streamed)."""
    from . import conditions
    m = conditions.match(claim, rec, scn, estimator)
    if m is None:
        return None, []
    return m, [conditions.window_of(q, m.run) for q in conditions.rows_on(claim, m.run)]


def steadiness_note(ctx: Context) -> str:
    """'' if the true speed is steady in the window (metrics.steadiness, a bench definition:
    metrics.STEADY_DEF), else why not, worded as an operating point not held: a figure of a
    steady state measured on a settling transient is not the paper's figure."""
    try:
        n = ctx.windowed(ch.PLANT_STATE, "speed_rpm")
    except MetricUnavailable as exc:
        return str(exc)
    s = metrics.steadiness(n)
    if s.steady:
        return ""
    return (f"the drive did not hold a steady speed in the window {ctx.window_s[0]:g}..."
            f"{ctx.window_s[1]:g} s: {s.text()} ({metrics.STEADY_DEF})")


def operating_point_note(ctx: Context, ref_rpm: float) -> str:
    """'' if the true speed held the operating point in the window, else why not. The drive
    holds it when its mean is within 10 % + 0.5 rpm of the reference (a validity condition of
    the measurement and a bench definition, not a tolerance on the claim)."""
    try:
        n = ctx.windowed(ch.PLANT_STATE, "speed_rpm")
    except MetricUnavailable as exc:
        return str(exc)
    mean = float(np.mean(n))
    if metrics.holds_speed(mean, ref_rpm):
        return ""
    return (f"the drive did not hold {ref_rpm:g} rpm: true speed {mean:.3g} rpm in the window "
            f"(range {float(np.min(n)):.3g}..{float(np.max(n)):.3g}; {OPERATING_POINT_DEF})")


#: metrics that re-run an observer from the start of the run (they need every row up to their
#: window's end)
NEEDS_HISTORY = frozenset({"chattering_a"})
#: rows kept before a window: a metric may look back (response time: 0.1 s before its event;
#: step responses: 0.05 s)
WINDOW_LEAD_S = 0.2


def windows_needed(scn, header=None) -> list[tuple[float, float]]:
    """The time windows the claims of a scenario (and the summary) read, each with its lead:
    what `bench check` keeps of a recording's per-cycle topics. ``header``: the recording's
    header (its metadata): the windows of the claim's run it is; without it, of every run."""
    from . import conditions
    out = [scn.metrics_window_s]
    for claim_id in scn.claims:
        claim = CLAIMS.get(claim_id)
        if claim is None:
            continue
        if header is not None:
            qs = applicable(claim, header, scn, estimator=False)[1]
        else:
            qs = [conditions.window_of(q, r) for r in claim.runs
                  for q in conditions.rows_on(claim, r)]
        for q in qs:
            w = q.window_s or scn.metrics_window_s
            out.append((0.0, w[1]) if q.metric in NEEDS_HISTORY else w)
            if q.at_speed_window_s is not None:
                out.append(q.at_speed_window_s)
    return [(max(0.0, w0 - WINDOW_LEAD_S), w1) for w0, w1 in out]


#: the last stretch before a trip that the fault diagnosis looks at
FAULT_LOOKBACK_S = 0.02


def diagnose_fault(fault: str, i_true_a: np.ndarray, i_read_a: np.ndarray,
                   full_scale_a: float | None, speed_rpm: float, speed_ref_rpm: float,
                   speed_hat_rpm: float, detail: int | None = None) -> str:
    """What a controller trip says about the drive, from the plant's record of the last
    FAULT_LOOKBACK_S before it: ``i_true_a`` / ``i_read_a`` the true and the sensed phase
    currents (any shape), ``full_scale_a`` the ADC's current full scale (None: exact sensing),
    the true, reference and estimated speeds at the trip, ``detail`` the FAULT_CTRL detail (for
    OVERCURRENT phase x 10^7 + the tripping reading in mA, docs/faults.md). '' for faults it has
    nothing to say on.

    A SENSOR_FAULT (the three readings do not sum to zero) while a true current is beyond the
    ADC's full scale is an over-current the sensors could not read: the clipped readings stop
    summing to zero. It is named as such, never left as a sensor fault."""
    i_peak = float(np.nanmax(np.abs(i_true_a))) if np.size(i_true_a) else math.nan
    i_read = float(np.nanmax(np.abs(i_read_a))) if np.size(i_read_a) else math.nan
    lost = (math.isfinite(speed_rpm) and abs(speed_rpm - speed_ref_rpm) >
            0.5 * abs(speed_ref_rpm) + 5.0)
    est_off = (math.isfinite(speed_hat_rpm) and math.isfinite(speed_rpm) and
               abs(speed_hat_rpm - speed_rpm) > 0.5 * abs(speed_rpm) + 5.0)
    where = (f"at the trip the true speed was {speed_rpm:.4g} rpm (reference {speed_ref_rpm:.4g}), "
             f"the estimate {speed_hat_rpm:.4g} rpm; phase current up to {i_peak:.3g} A"
             + (f" ({i_read:.3g} A read, ADC full scale {full_scale_a:g} A)" if full_scale_a
                else ""))
    state = ("the drive had lost its operating point" + (" and its estimate" if est_off else "")
             if lost else ("the estimate was off" if est_off else ""))
    clipped = bool(full_scale_a) and math.isfinite(i_peak) and i_peak >= full_scale_a
    if fault == "SENSOR_FAULT":
        if clipped:
            return ("not a sensor fault: an over-current beyond the ADC full scale; the clipped "
                    "readings no longer summed to zero"
                    + (f" ({state})" if state else "") + f"; {where}")
        return f"sensor plausibility trip with the currents inside the ADC range; {where}"
    if fault == "OVERCURRENT":
        trip = ""
        if detail is not None and 0 <= detail < 3 * 10**7:
            trip = (f"; phase {'abc'[detail // 10**7]} read {detail % 10**7 / 1e3:.3f} A at the "
                    "trip")
        return "over-current" + (f": {state}" if state else "") + f"; {where}{trip}"
    return ""


def _fault_context(rec: Recording, fault: str, detail: int | None = None,
                   speed_ref_at: Callable[[float], float] | None = None) -> str:
    """diagnose_fault on a recording (the last FAULT_LOOKBACK_S of /plant/state, /plant/sense,
    /controller/telemetry); '' if the recording lacks them. ``speed_ref_at``: the scenario's speed
    reference (rpm) at a time (Context.speed_ref_at); without it the reference reads NaN."""
    try:
        st, se = rec.topics[ch.PLANT_STATE], rec.topics[ch.PLANT_SENSE]
        t = np.asarray(st["t_s"], float)
        if not t.size:
            return ""
        m = t >= t[-1] - FAULT_LOOKBACK_S
        ts_ = np.asarray(se["t_s"], float)
        ms = ts_ >= ts_[-1] - FAULT_LOOKBACK_S if ts_.size else np.zeros(0, bool)
        phases = ("i_a_a", "i_b_a", "i_c_a")
        i_true = np.stack([np.asarray(st[f], float)[m] for f in phases])
        i_read = np.stack([np.asarray(se[f], float)[ms] for f in phases])
        pp = json.loads(rec.run.get("plant_params", "{}"))
        fs = float(pp["adc_full_scale_a"]) if pp.get("adc_model") else None
        n = float(np.asarray(st["speed_rpm"], float)[-1])
        n_hat = math.nan
        if ch.CONTROLLER_TELEMETRY in rec.topics:
            nh = np.asarray(rec.topics[ch.CONTROLLER_TELEMETRY]["speed_hat_rpm"], float)
            n_hat = float(nh[-1]) if nh.size else math.nan
        ref = speed_ref_at(float(t[-1])) if speed_ref_at is not None else math.nan
    except (KeyError, ValueError, IndexError):
        return ""
    return diagnose_fault(fault, i_true, i_read, fs, n, ref, n_hat, detail)


def run_failure(rec: Recording,
                speed_ref_at: Callable[[float], float] | None = None) -> tuple[str, str]:
    """('', '') for a complete run; ('FAIL', why) when the controller under test faulted (the
    method's own failure, with what the plant shows about it: diagnose_fault, given the
    scenario's ``speed_ref_at``); ('INVALID', why) when the bench broke (link, stub, interrupt)."""
    import re
    result = rec.metadata.get("run_result", {})
    err = str(result.get("error", ""))
    if not err:
        return "", ""
    if "controller reported fault" in err:
        tail = err.split("controller reported", 1)[1]
        m = re.search(r"fault (\w+)", tail)
        d = re.search(r"detail (-?\d+)", tail)
        cause = (_fault_context(rec, m.group(1), int(d.group(1)) if d else None,
                                speed_ref_at) if m else "")
        return "FAIL", f"the run ended early: {err}" + (f" [{cause}]" if cause else "")
    return "INVALID", f"the run ended early: {err}"


def comparator_note(q: Quantity, why: str) -> str:
    """Why a comparator's row is UNTESTED: the bench's reconstruction did not hold the point."""
    return (f"untested: the bench's comparator did not hold its operating point ({q.comparator}); "
            + why)


def _off_point(q: Quantity, qctx: Context) -> str:
    """Why the run was not at the quantity's operating point ('' if it was): its speed (the
    row's at_speed_rpm), then a steady window (needs_steady)."""
    why_op = ""
    if q.at_speed_rpm is not None:
        octx = qctx.with_window(q.at_speed_window_s) if q.at_speed_window_s else qctx
        why_op = operating_point_note(octx, q.at_speed_rpm)
    if not why_op and q.needs_steady:
        why_op = steadiness_note(qctx)
    return why_op


def measure(q: Quantity, ctx: Context) -> tuple[float, str, str]:
    """(value, verdict, note) of one quantity on one recording's context."""
    return measure_with_resolution(q, ctx)[:3]


def measure_with_resolution(q: Quantity, ctx: Context) -> tuple[float, str, str, float]:
    """(value, verdict, note, resolution) of one quantity on one recording's context; the
    resolution is what ``resolution`` gives for the metric's source (0: exact)."""
    kind, why = run_failure(ctx.rec, ctx.speed_ref_at)
    unit, _definition, fn = METRICS[q.metric]
    qctx = ctx.with_source(q.source)
    if q.window_s is not None:
        qctx = qctx.with_window(q.window_s)
    at_least = ""
    try:
        value = float(fn(qctx, **dict(q.params)))
    except MetricAtLeast as exc:
        value, at_least = exc.value, str(exc)
    except MetricUnavailable as exc:
        if kind == "FAIL" and q.comparator:
            return math.nan, "UNTESTED", comparator_note(q, why), 0.0
        if kind:
            return math.nan, kind, why, 0.0
        return math.nan, "INVALID", str(exc), 0.0
    except (ValueError, KeyError) as exc:
        # a rotor that stalled or turned back has no spectrum to fit: the operating point's
        # failure (the drive's), said before the metric's; a controller fault is the method's
        if kind == "FAIL":
            if q.comparator:
                return math.nan, "UNTESTED", comparator_note(q, why), 0.0
            return math.nan, "FAIL", f"{why}; cannot compute: {exc}", 0.0
        if not kind:
            why_op = _off_point(q, qctx) or (operating_point_note(qctx, qctx.speed_ref_rpm)
                                             if qctx.speed_ref_rpm else "")
            if why_op:
                if q.comparator:
                    return math.nan, "UNTESTED", comparator_note(q, why_op), 0.0
                return (math.nan, "FAIL" if q.rule.kind != "compared" else "COMPARED",
                        f"{why_op}; cannot compute: {exc}", 0.0)
        return math.nan, "INVALID", f"cannot compute: {exc}", 0.0
    res = resolution(q.metric, qctx)
    if kind == "INVALID":
        return value, kind, why, res
    if at_least:
        why = (why + "; " if why else "") + at_least
    if res > 0 and math.isfinite(value) and abs(value) < 3.0 * res and q.metric != \
            "response_time_ms":
        why = (why + "; " if why else "") + (f"near the telemetry resolution ({res:.3g} {unit} "
                                             "per LSB)")
    if q.calibration:
        return value, "CALIBRATION", q.calibration + ("; " + why if why else ""), res
    if kind == "FAIL" and not math.isfinite(value):
        if q.comparator:
            return value, "UNTESTED", comparator_note(q, why), res
        return value, "FAIL", why, res        # the drive faulted before the window
    if q.not_reproducible:
        return value, "NOT REPRODUCIBLE", q.not_reproducible, res
    why_op = _off_point(q, qctx)
    if why_op:
        if q.comparator:
            return value, "UNTESTED", comparator_note(q, why_op + ("; " + why if why else "")), res
        return (value, "FAIL" if q.rule.kind != "compared" else "COMPARED",
                why_op + ("; " + why if why else ""), res)
    if kind == "FAIL":
        if q.comparator:
            return value, "UNTESTED", comparator_note(q, why), res
        return value, "FAIL" if q.rule.kind != "compared" else "COMPARED", why, res
    if at_least and q.rule.kind == "at_most":
        return value, "FAIL", why, res        # already beyond its bound
    return value, q.rule.verdict(value), why, res


def evaluate(claim: Claim, ctx: Context, scn=None) -> list[QuantityResult]:
    """The quantities of ``claim`` measurable in this one recording (``bench check``): those of
    the claim's run the recording is, by what ran (``applicable``); if it meets no run's
    conditions, the nearest run's quantities, each INVALID saying which condition failed and
    what ran instead. ``scn`` None: every quantity of the claim on this context (no
    conditions)."""
    m = None
    if scn is None:
        quantities = list(claim.quantities)
    else:
        m, quantities = applicable(claim, ctx.rec, scn)
    out = []
    for q in quantities:
        if q.study or q.aggregate or q.metric == "derived":
            continue
        if m is not None and not m.ok:
            out.append(QuantityResult(claim, q, math.nan, "INVALID", m.short(), m))
            continue
        value, verdict, note = measure(q, ctx)
        out.append(QuantityResult(claim, q, value, verdict, note, m))
    return out


def relate(rel: Relation, values: dict[str, float], not_reproducible: frozenset = frozenset(),
           off_point: frozenset = frozenset(),
           resolutions: dict[str, float] | None = None,
           untested: dict[str, str] | None = None,
           ended: dict[str, str] | None = None) -> tuple[tuple[float, ...], str, str]:
    """Check a relation on the measured values; a relation over a quantity that is NOT
    REPRODUCIBLE is not reproducible either. An ordering ("<", ">") between two values whose
    difference is below the resolution of either (``resolutions``: one LSB of what they were
    measured from) is NOT RESOLVED, unless another pair of the chain is resolved and wrong
    (FAIL). A relation over a row of the paper's method that did not hold its operating point
    FAILs; over a comparator's row that did not (``untested``: key -> why) it is UNTESTED: the
    bench's reconstruction of a method the paper only cites is not the paper's claim. A relation
    over a row whose run ended early (``ended``: key -> "FAIL" when the controller faulted,
    "INVALID" when the bench broke) is FAIL or INVALID whatever its values: a run cut short
    never makes a relation hold."""
    resolutions = resolutions or {}
    untested = untested or {}
    ended = ended or {}
    vals = tuple(float(k[1:]) if k.startswith("#") else values.get(k, math.nan) for k in rel.keys)
    broke = [k for k in rel.keys if ended.get(k) == "INVALID"]
    if broke:
        return vals, "INVALID", f"{', '.join(broke)}: the run ended early (the bench)"
    nr = [k for k in rel.keys if k in not_reproducible]
    if nr:
        return vals, "NOT REPRODUCIBLE", f"{', '.join(nr)} not reproducible on this bench"
    cut = [k for k in rel.keys if ended.get(k) == "FAIL" and k not in untested]
    if cut:
        return vals, "FAIL", (f"{', '.join(cut)}: the run ended early (the controller faulted), "
                              "so the comparison does not hold either")
    off = [k for k in rel.keys if k in off_point and k not in untested]
    if off:
        return vals, "FAIL", (f"{', '.join(off)}: the drive did not hold the operating point, so "
                              "the comparison does not hold either")
    unt = [k for k in rel.keys if k in untested]
    if unt:
        return vals, "UNTESTED", "; ".join(f"{k}: {untested[k]}" for k in unt)
    if not all(math.isfinite(v) for v in vals):
        missing = [k for k, v in zip(rel.keys, vals) if not math.isfinite(v)]
        return vals, "FAIL", f"no measured value for {', '.join(missing)}"
    if rel.op == "=":
        ok = all(abs(a - b) < rel.tol for a, b in zip(vals, vals[1:]))
        return vals, "PASS" if ok else "FAIL", ""
    if rel.compared:            # the paper reports both values: the ordering shown, no verdict
        ok = all((a < b) if rel.op == "<" else (a > b) for a, b in zip(vals, vals[1:]))
        res = max((resolutions.get(k, 0.0) for k in rel.keys), default=0.0)
        small = res > 0 and all(abs(a - b) < res for a, b in zip(vals, vals[1:]))
        return vals, "COMPARED", (f"the paper's ordering ({rel.paper}) "
                                  + ("holds here" if ok else "is not seen here")
                                  + (f"; the difference is below the resolution {_g(res)}"
                                     if small else ""))
    if rel.op not in ("<", ">"):
        raise ValueError(f"{rel.key}: unknown relation {rel.op!r}")
    wrong, unresolved = [], []
    for (ka, a), (kb, b) in zip(zip(rel.keys, vals), zip(rel.keys[1:], vals[1:])):
        res = max(resolutions.get(ka, 0.0), resolutions.get(kb, 0.0))
        if abs(a - b) < res * (1.0 - 1e-9):
            unresolved.append(f"|{_g(a)} - {_g(b)}| = {_g(abs(a - b))} is below the resolution "
                              f"{_g(res)} (one LSB of the controller's telemetry)")
        elif not (a < b if rel.op == "<" else a > b):
            wrong.append((ka, kb))
    if wrong:
        return vals, "FAIL", ""
    if unresolved:
        return vals, "NOT RESOLVED", "; ".join(unresolved)
    if rel.min_fall:
        falls = [abs(a - b) / abs(b if rel.op == "<" else a) for a, b in zip(vals, vals[1:])]
        short = min(falls)
        note = (f"falls by {100 * short:.1f} %, the paper's size to reach {100 * rel.min_fall:.1f} % "
                f"({rel.min_fall_source})")
        return vals, "PASS" if short >= rel.min_fall else "FAIL", note
    return vals, "PASS", ""


def _g(v: float) -> str:
    return f"{v:.4g}"


def derive(q: Quantity, values: dict[str, float]) -> float:
    """A quantity computed from two others (metric "derived"): op "diff" a - b, "pct" the
    percent change from b to a, "ratio" a / b."""
    p = dict(q.params)
    a, b = values.get(p["a"], math.nan), values.get(p["b"], math.nan)
    if p["op"] == "diff":
        return a - b
    if p["op"] == "pct":
        return metrics.percent_change(b, a)
    if p["op"] == "ratio":
        return a / b if b else math.nan
    raise ValueError(f"{q.key}: unknown derivation {p['op']!r}")
