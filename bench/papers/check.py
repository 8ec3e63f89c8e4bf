"""``bench check RECORDING``: recompute the metrics and the paper claims from the file alone.

The scenario (attached to the recording), the plant parameters and the run metadata come out of
the MCAP itself, so a recording checks the same on any machine.

Beside the claims the report carries the run's integrity (``bench/record/integrity.py``, docs/protocol.md 6.9):
an incomplete or damaged run, or one over a link with errors the scenario does not allow, never passes
(``all_pass`` is false, ``--strict`` exits 1) and its claims are INVALID, as are those of a run whose
controller reported another estimator than the one asked for.
"""
from __future__ import annotations

import dataclasses
import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from rich.console import Console
from rich.markup import escape
from rich.table import Table

from hil_bench.claims.registry import CLAIMS
from hil_bench.record import channels as ch
from hil_bench.record.integrity import Integrity, check_integrity
from hil_bench.record.recording import Recording, RecordingError, load_recording
from hil_bench.scenario import RPM_PER_RAD_S, Scenario, scenario_of, speed_ref_at

from . import metrics
from .claim_metrics import Context
from .claims import QuantityResult, evaluate


@dataclass
class CheckReport:
    recording: Recording
    scenario: Scenario
    context: Context
    summary: dict[str, float] = field(default_factory=dict)
    results: list[QuantityResult] = field(default_factory=list)
    integrity: Integrity | None = None
    faults: list = field(default_factory=list)     # hil_bench.record.fault_outcomes.FaultOutcome per [[faults]]

    @property
    def all_pass(self) -> bool:
        """No quantity failed (PASS or COMPARED everywhere, diagnostics -- not the paper's setup --
        aside) and the run is complete, undamaged, over a clean (or allowed) link."""
        intact = self.integrity is None or self.integrity.ok
        return intact and all(r.verdict in ("PASS", "COMPARED") for r in self.results
                              if not r.quantity.diagnostic)


def build_context(rec: Recording, scn: Scenario) -> Context:
    run = rec.run
    try:
        plant = json.loads(run["plant_params"])
        ts_s = float(run["ts_s"])
        pole_pairs = int(plant["pole_pairs"])
    except (KeyError, ValueError) as exc:
        raise RecordingError(f"{rec.path}: run metadata incomplete ({exc})") from None
    window = scn.metrics_window_s
    ref_rpm = speed_ref_at(scn, window[0]) * RPM_PER_RAD_S
    return Context(rec, window, ref_rpm, pole_pairs, ts_s,
                   speed_ref_at=lambda t: speed_ref_at(scn, t) * RPM_PER_RAD_S)


def summarise(ctx: Context) -> dict[str, float]:
    """Headline numbers of the window, whatever the claims."""
    out: dict[str, float] = {}
    state = ctx.rec.topics.get(ch.PLANT_STATE, {})
    telem = ctx.rec.topics.get(ch.CONTROLLER_TELEMETRY, {})
    if state:
        out["cycles_recorded"] = float(len(state["t_s"]))
        out["t_end_s"] = float(state["t_s"][-1]) if len(state["t_s"]) else 0.0
    try:
        n = ctx.windowed(ch.PLANT_STATE, "speed_rpm")
        out["speed_mean_rpm"] = float(n.mean())
        out["speed_band_true_rpm"] = metrics.speed_band_rpm(n, ctx.speed_ref_rpm)
        out["iq_mean_a"] = float(ctx.windowed(ch.PLANT_STATE, "i_q_a").mean())
    except Exception:  # noqa: BLE001 - a summary never fails the check
        pass
    if telem:
        try:
            nh = ctx.windowed(ch.CONTROLLER_TELEMETRY, "speed_hat_rpm")
            out["speed_hat_mean_rpm"] = float(nh.mean())
            out["speed_band_hat_rpm"] = metrics.speed_band_rpm(nh, ctx.speed_ref_rpm)
            err = metrics.angle_error(ctx.windowed(ch.CONTROLLER_TELEMETRY, "theta_hat_rad"),
                                      ctx.windowed(ch.PLANT_STATE, "theta_e_rad"))
            out["pee_max_rad"] = err.max_abs_rad
            out["pee_mean_rad"] = err.mean_rad
            out["pee_rms_rad"] = err.rms_rad
        except Exception:  # noqa: BLE001
            pass
    for topic in sorted(t for t in ctx.rec.topics if t.startswith(ch.REFERENCE_PREFIX)):
        name = topic[len(ch.REFERENCE_PREFIX):]
        rctx = ctx.with_source("reference:" + name)
        try:
            err = metrics.angle_error(*rctx.estimate_and_truth("theta_hat_rad", "theta_e_rad"))
            out[f"ref_{name}_pee_max_rad"] = err.max_abs_rad
            out[f"ref_{name}_pee_rms_rad"] = err.rms_rad
            out[f"ref_{name}_speed_band_rpm"] = metrics.speed_band_rpm(
                ctx.windowed(topic, "speed_hat_rpm"), ctx.speed_ref_rpm)
        except Exception:  # noqa: BLE001
            pass
    return out


#: per-cycle topics: `bench check` keeps only the rows in the claims' windows
WINDOWED_TOPICS = (ch.PLANT_STATE, ch.PLANT_SENSE, ch.CONTROLLER_TELEMETRY, ch.LINK_FRAMES,
                   "/reference/*")

#: the fields `bench check` keeps of each per-cycle topic: those the summary, the claims' metrics
#: (bench/papers/claim_metrics.py, bench/papers/metrics.py) and the estimator replay (bench/papers/estimator_trace.py) read.
#: Every other field, and the topics not named here (/timing, /replay/*), is never decoded:
#: memory per second of window is what these columns take (float64: the metrics see the values
#: exactly as recorded). tests/test_integrity.py holds this list against the field names those
#: modules use, so a metric that reads a new field cannot silently see it missing.
CHECK_FIELDS: dict[str, tuple[str, ...]] = {
    ch.PLANT_STATE: ("t_s", "speed_rpm", "i_q_a", "theta_e_rad", "omega_e_rad_s", "i_a_a",
                     "i_alpha_a", "i_beta_a"),
    ch.PLANT_SENSE: ("t_s", "seq", "i_a_a", "i_b_a", "i_c_a", "v_dc_v"),
    ch.CONTROLLER_TELEMETRY: ("t_s", "theta_hat_rad", "speed_hat_rpm", "e_alpha_v", "e_beta_v",
                              "duty_a", "duty_b", "duty_c", "i_q_ref_a"),
    "/reference/*": ("t_s", "theta_hat_rad", "speed_hat_rpm", "e_alpha_v", "e_beta_v"),
    ch.LINK_FRAMES: ("t_s", "seq", "tx"),   # read only with dual sampling: the SENSE_DUAL frames
}
#: what a run with [[faults]] reads besides: the plant's peaks and the controller's state after
#: its trip (bench/record/fault_outcomes.py)
FAULT_FIELDS: dict[str, tuple[str, ...]] = {
    ch.PLANT_STATE: ("i_b_a", "i_c_a", "torque_e_nm"),
    ch.CONTROLLER_TELEMETRY: ("state",),
}
#: small topics read whole (a row per 0.1 s, or per event)
WHOLE_TOPICS = (ch.LINK_STATS, ch.EVENTS, ch.FAULTS)


def _sense_dual_only(cols: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """/link/frames reduced to what ``claim_metrics.dual_samples`` reads: the SENSE_DUAL frames of tx."""
    from hil_bench.protocol.messages import MESSAGES

    prefix = f"{MESSAGES['SENSE_DUAL'].frame_id:03X}#"
    tx = cols.get("tx")
    if tx is not None:
        cols = dict(cols)
        cols["tx"] = np.array([" ".join(i for i in str(x).split() if i.startswith(prefix))
                               for x in tx], dtype=object)
    return cols


def read_for_check(path: str | Path) -> Recording:
    """The recording as `bench check` needs it, in bounded memory: the header first (metadata,
    the attached scenario), then one streaming pass keeping, of the per-cycle topics, only the
    fields in ``CHECK_FIELDS`` and only the rows inside the windows the scenario's claims read,
    and counting the estimator the controller reported over the whole run."""
    from collections import Counter

    from hil_bench.record.recording import read_header

    from .claims import windows_needed

    header = read_header(path)
    scn = scenario_of(header)
    windows = windows_needed(scn, header)
    # a fault's outcome reads the plant from the fault on (its peaks) to the end of the run
    windows += [(max(0.0, fs.t_s - scn.recording.pre_trigger_s), scn.duration_s)
                for fs in scn.faults]
    estimators: Counter = Counter()

    def count_estimators(cols) -> None:
        est = cols.get("estimator")
        if est is not None and len(est):
            values, counts = np.unique(np.asarray(est), return_counts=True)
            estimators.update({int(v): int(c) for v, c in zip(values, counts)})

    try:
        dual = bool(json.loads(header.run.get("plant_params", "{}")).get("dual_sampling"))
    except (ValueError, AttributeError):
        dual = True   # unknown: read the frames (the metric says what is missing)
    topics = [t for t in WINDOWED_TOPICS if dual or t != ch.LINK_FRAMES] + list(WHOLE_TOPICS)
    fields = dict(CHECK_FIELDS)
    if scn.faults:
        for topic, extra in FAULT_FIELDS.items():
            fields[topic] = fields[topic] + extra
    rec = load_recording(path, topics=topics, fields=fields,
                         windows={t: windows for t in WINDOWED_TOPICS},
                         reduce={ch.CONTROLLER_TELEMETRY: (count_estimators, ("estimator",))},
                         transform={ch.LINK_FRAMES: _sense_dual_only})
    rec.estimator_counts = dict(estimators)
    # the metadata of a finalised file's summary section (read_header): a record after damage
    # that stopped the streaming pass (the run_result, written last) is still found there
    for name, data in header.metadata.items():
        rec.metadata.setdefault(name, data)
    return rec


def check_recording(path: str | Path) -> CheckReport:
    rec = read_for_check(path)
    scn = scenario_of(rec)
    ctx = build_context(rec, scn)
    report = CheckReport(rec, scn, ctx, summarise(ctx))
    for claim_id in scn.claims:
        claim = CLAIMS.get(claim_id)
        if claim is None:
            raise RecordingError(f"{rec.path}: scenario names unknown claim {claim_id!r}")
        report.results.extend(evaluate(claim, ctx, scn))
    report.integrity = check_integrity(rec, scn.link.allow, rec.run.get("estimator"),
                                       scenario_faults=scn.faults)
    from hil_bench.record.fault_outcomes import FaultOutcome, outcomes

    report.faults = outcomes(rec)
    listed = {o.index for o in report.faults}
    for fs in scn.faults:   # a fault that left no /faults row at all: never acted (integrity says why)
        if fs.index not in listed:
            why = next((p.text.split(" never acted: ", 1)[-1] for p in report.integrity.problems
                        if p.name == "never_acted" and p.text.startswith(f"faults[{fs.index}] ")),
                       "no /faults row")
            report.faults.append(FaultOutcome(fs.index, fs.kind, fs.target, None, notes=[why]))
    report.faults.sort(key=lambda o: o.index)
    note = report.integrity.invalid_note
    if note:
        report.results = [dataclasses.replace(r, verdict="INVALID", note=note) for r in report.results]
    return report


def timing_of(rec: Recording) -> dict[str, float]:
    """The run's timing from the last /link/stats row (the engine's percentiles over the whole
    run): cycle time, and in real time the period start error and the deadline misses."""
    stats = rec.topics.get(ch.LINK_STATS, {})
    if not stats or not len(stats.get("t_s", ())):
        return {}
    last = {k: float(v[-1]) for k, v in stats.items() if len(v)}
    out = {k: last[k] for k in ("cycle_wall_p50_us", "cycle_wall_p99_us", "cycle_wall_max_us")
           if k in last}
    if rec.run.get("mode") != "realtime":
        # late is not lost (docs/protocol.md 6.5): cycles answered after a re-send, as timing
        for k in ("retries", "late_answers", "lost_frames"):
            if k in last:
                out[k] = last[k]
        timing = rec.topics.get(ch.TIMING, {})
        if len(timing.get("retries", ())) and len(timing.get("rtt_us", ())):
            import numpy as np

            resent = np.asarray(timing["retries"], dtype=float) > 0
            if resent.any():
                out["late_max_us"] = float(np.nanmax(np.asarray(timing["rtt_us"], dtype=float)[resent]))
    if rec.run.get("mode") == "realtime":
        for k in ("jitter_p50_us", "jitter_p99_us", "jitter_p999_us", "jitter_max_us",
                  "missed_duty", "late_duty", "rt_overruns", "cycles"):
            if k in last:
                out[k] = last[k]
    return out


def print_timing(rec: Recording, console: Console) -> None:
    t = timing_of(rec)
    if not t:
        return
    if "jitter_p99_us" in t:
        cycles = max(t.get("cycles", 0.0), 1.0)
        console.print(f"real time: period start error p50 {t['jitter_p50_us']:.1f} us, p99 "
                      f"{t['jitter_p99_us']:.1f} us, p99.9 {t['jitter_p999_us']:.1f} us, max "
                      f"{t['jitter_max_us']:.1f} us; SENSE->DUTY p50 {t['cycle_wall_p50_us']:.1f} us,"
                      f" p99 {t['cycle_wall_p99_us']:.1f} us; {t.get('missed_duty', 0):.0f} missed "
                      f"(rate {t.get('missed_duty', 0) / cycles:.2e}), {t.get('late_duty', 0):.0f} "
                      f"late, {t.get('rt_overruns', 0):.0f} overruns")
    elif "cycle_wall_p50_us" in t:
        late = ""
        if t.get("retries", 0) > 0:
            slowest = (f", the slowest answered {t['late_max_us'] * 1e-3:.3g} ms after its SENSE"
                       if "late_max_us" in t else "")
            late = (f"; {t.get('late_answers', 0):.0f} cycle(s) answered late but whole after "
                    f"{t['retries']:.0f} re-send(s) (timing, not a link problem{slowest})")
        console.print(f"cycle time (lockstep, wall clock): p50 {t['cycle_wall_p50_us']:.1f} us, "
                      f"p99 {t['cycle_wall_p99_us']:.1f} us, max {t['cycle_wall_max_us']:.1f} us"
                      + late)


def print_integrity(integrity: Integrity | None, console: Console) -> None:
    """One line when the run is intact, else one line per problem (allowed ones marked)."""
    if integrity is None:
        return
    done = "?" if integrity.cycles_done is None else integrity.cycles_done
    planned = "?" if integrity.cycles_planned is None else integrity.cycles_planned
    cycles = f"{done}/{planned} cycles"
    if not integrity.problems and not integrity.estimator_mismatch:
        console.print(f"integrity: [green]complete[/green] ({cycles}), link clean")
        return
    state = "[green]ok[/green]" if integrity.ok else "[red]NOT OK[/red]"
    console.print(f"integrity: {state} ({cycles})")
    for p in integrity.problems:
        tag = ("[dim]allowed[/dim]" if p.is_allowed else
               "[red]INVALID[/red]" if p.kind == "estimator" else "[red]problem[/red]")
        console.print(f"  {tag} {p.kind}: {escape(p.text)}")
    if integrity.estimator_mismatch:
        console.print(f"  [red]INVALID[/red] estimator: {escape(integrity.estimator_text)}")


def print_faults(faults: list, console: Console) -> None:
    """One line per fault of the run: detected?, how fast, by what, the plant's peaks from the
    fault on, and the controller's reaction after its trip."""
    if not faults:
        return
    console.print("faults:")
    for o in faults:
        head = escape(f"  #{o.index} {o.kind} ({o.target})")
        if o.t_on_s is None:
            console.print(f"{head}: [yellow]never acted[/yellow]" +
                          escape(f" ({'; '.join(o.notes)})" if o.notes else ""))
            continue
        if o.detected:
            what = (f"[green]detected[/green] after {o.detection_s * 1e3:.1f} ms by "
                    f"{escape(o.detected_by)}")
        else:
            what = f"[red]NOT detected[/red] ({escape(o.evidence or 'no trace row')})"
        react = ""
        if o.trip_s is not None:
            react = escape(f"; after the trip: {o.duties_after_trip} DUTY frame(s) not all legs "
                           f"off, state {o.state_after or '?'}")
        console.print(f"{head} at {o.t_on_s:.4f} s: {what}; peak |i| {fmt_value(o.peak_current_a, 'A')}, "
                      f"|T_e| {fmt_value(o.peak_torque_nm, 'N m')}{react}")


def fmt_value(v: float, unit: str = "") -> str:
    if not math.isfinite(v):
        return "n/a"
    s = f"{v:.4g}"
    return f"{s} {unit}".strip()


def print_report(report: CheckReport, console: Console | None = None) -> None:
    console = console or Console()
    rec, scn, ctx = report.recording, report.scenario, report.context
    run = rec.run
    console.print(f"[bold]{escape(scn.name)}[/bold] — {escape(scn.description)}")
    from hil_bench.record.controller_id import describe as controller_text

    console.print(escape(f"recording {rec.path}  ({rec.messages} messages, git "
                         f"{run.get('git_revision', '?')}, controller: "
                         f"{controller_text(rec.metadata)}, estimator {run.get('estimator', '?')})"))
    result = rec.metadata.get("run_result", {})
    if result.get("error"):
        console.print(f"[red]run ended early:[/red] {escape(result['error'])}")
    if rec.damaged:
        console.print(f"[yellow]recording damaged:[/yellow] " +
                      escape(f"read {rec.messages} messages; {rec.damage_text()}. `bench recover "
                             f"{rec.path} -o FIXED.mcap` copies every intact chunk, also those "
                             f"after the damage."))
    print_integrity(report.integrity, console)
    print_faults(report.faults, console)
    print_timing(rec, console)
    w0, w1 = ctx.window_s
    console.print(f"window {w0:g}..{w1:g} s, speed reference {ctx.speed_ref_rpm:g} rpm")
    s = report.summary
    if s:
        console.print("  ".join(f"{k}={fmt_value(v)}" for k, v in s.items()))
    for cid in scn.claims:         # a claim asked for that no single recording measures
        if cid in CLAIMS and not any(r.claim.id == cid for r in report.results):
            console.print(escape(f"{cid}: no quantity of this claim is measured on one "
                                 f"recording (studies, several runs): `bench claims --run "
                                 f"--only {cid}`"))
    if not report.results:
        return
    table = Table(title="paper claims: paper value vs measured", show_lines=False)
    for col in ("claim", "quantity", "paper", "measured", "rule", "verdict"):
        table.add_column(col)
    from .claim_metrics import METRICS

    for r in report.results:
        unit = METRICS[r.quantity.metric][0]
        colour = {"PASS": "green", "COMPARED": "blue", "NOT REPRODUCIBLE": "magenta",
                  "INVALID": "yellow"}.get(r.verdict, "red")
        paper = r.quantity.paper_value
        table.add_row(escape(r.claim.id), escape(r.quantity.what or r.quantity.metric),
                      escape(paper if isinstance(paper, str) else fmt_value(paper, unit)),
                      fmt_value(r.measured, unit), escape(r.quantity.rule_text()),
                      f"[{colour}]{r.verdict}[/{colour}]" + escape(f" ({r.note})" if r.note else ""))
    console.print(table)
    shown = set()
    for r in report.results:       # the set-up a claim's rows are INVALID for, once per claim
        m = r.setup
        if m is None or m.ok or r.claim.id in shown:
            continue
        shown.add(r.claim.id)
        console.print(f"[yellow]{escape(r.claim.id)}: INVALID, not the set-up the claim is "
                      f"about[/yellow] " + escape(f"(the nearest of its runs: {m.run.id}, "
                                                  f"scenario {m.run.name}):"))
        for f in m.failed:
            console.print("  " + escape(f.text()))
    for cid in dict.fromkeys(r.claim.id for r in report.results):
        notes = CLAIMS[cid].notes
        if notes:
            console.print(f"[dim]{escape(f'{cid}: {notes}')}[/dim]")
