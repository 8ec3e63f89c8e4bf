"""Fault campaigns: a base scenario and a list (or grid) of faults, one run each, a table of what
the controller did with them, judged against the limits the campaign file states.

    bench campaign g2_protection (a bundled one by name, or a file) [--jobs N] [--scheduler ADDR]
                   [--out DIR] [--keep-all] [--no-progress]

A campaign file (TOML; docs/faults.md "Campaigns")::

    [campaign]
    name = "g2_protection"
    base = "gong_g2_500rpm"          # a bundled scenario, or a path relative to this file
    duration_s = 1.4                 # optional: the base's duration replaced
    link = "stub"                    # optional (--link overrides)

    [campaign.overrides]             # optional dotted keys set in the base (hil_bench.scenario.derive_scenario)
    "controller.params.IQ_MAX_A" = 8.0

    [recording]                      # every run: decimated, full rate around each fault
    decimate = 10

    [limits]                         # the verdict of every run (a run may override them)
    detected = true                  # every fault detected (a FAULT_CTRL, or evidence in the counters)
    detection_time_s = 0.05
    peak_current_a = 25.0
    duties_after_trip = 0

    [[runs]]                         # one run with the faults listed
    label = "open phase b"
    faults = [{kind = "open_phase", phase = "b", t_s = 1.2}]
    allow = {lost_frames = 2}        # link problems this run may show (its [link] allow)

    [[grid]]                         # one run per combination of the list-valued keys
    kind = "sensor_offset"
    phase = ["a", "b"]
    offset_a = [0.5, 2.0]
    t_s = 1.2

Every run is a scenario of its own (the base with the run's [[faults]], named
<campaign>@<case>); its recording is kept when the run does not PASS (and with --keep-all).
"""
from __future__ import annotations

import csv
import itertools
import math
import time
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from hil_bench.errors import BenchError
from hil_bench.scenario import ScenarioError, check_against_profile, parse_scenario, resolve_path
from hil_bench.scenario.scenario import NAME_PATTERN, parse_link_allow
from hil_bench.scenario.fields import Fields

LIMIT_KEYS = {"detected": bool, "detection_time_s": float, "peak_current_a": float,
              "peak_torque_nm": float, "duties_after_trip": int}


class CampaignError(BenchError, ValueError):
    """A campaign file that cannot be run; the message names the file, line and field."""


@dataclass(frozen=True)
class Case:
    """One run of a campaign."""

    name: str
    label: str
    faults: tuple[dict, ...]
    limits: dict[str, Any]
    allow: dict[str, int]


@dataclass
class Campaign:
    path: Path
    name: str
    description: str
    base_path: Path
    base_raw: dict
    link: str
    cases: list[Case]
    recording: dict
    limits: dict = field(default_factory=dict)


@dataclass
class CaseResult:
    case: Case
    recording: Path | None
    verdict: str                  # PASS / FAIL / INVALID
    reasons: list[str] = field(default_factory=list)
    outcomes: list = field(default_factory=list)  # hil_bench.record.fault_outcomes.FaultOutcome
    run_error: str = ""
    wall_s: float = 0.0


def _limits(f: Fields, defaults: dict[str, Any]) -> dict[str, Any]:
    out = dict(defaults)
    for key in list(f.table):
        if key not in LIMIT_KEYS:
            raise f.fail(key, f"unknown limit; known: {', '.join(LIMIT_KEYS)}")
        kind = LIMIT_KEYS[key]
        if kind is bool:
            out[key] = f.boolean(key, True)
        elif kind is int:
            out[key] = f.integer(key, 0, 0, 10**9)
        else:
            out[key] = f.number(key, min_value=0.0)
    return out



def _case_name(label: str, i: int) -> str:
    import re

    slug = re.sub(r"[^A-Za-z0-9_-]+", "_", label).strip("_")[:60]
    return f"{i:02d}_{slug}" if slug else f"{i:02d}"


#: the bundled campaigns (``bench campaign g2_protection`` by name, from a checkout or a wheel)
CAMPAIGN_DIR = Path(__file__).resolve().parents[1] / "campaigns"


def resolve_campaign(name_or_path: str | Path) -> Path:
    """A bare name that is not a file resolves to a bundled campaign (``bench/campaigns/``)."""
    p = Path(name_or_path)
    if not p.exists() and p.suffix != ".toml" and len(p.parts) == 1:
        return CAMPAIGN_DIR / f"{name_or_path}.toml"
    return p


def load_campaign(path: str | Path) -> Campaign:
    """Load and check a campaign file, or a bundled campaign by name (every run's scenario is
    built and validated here, before anything runs). Raises CampaignError naming file, line and
    field."""
    asked = path
    path = resolve_campaign(path)
    where = str(path)
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        from hil_bench.errors import did_you_mean

        names = sorted(p.stem for p in CAMPAIGN_DIR.glob("*.toml"))
        what = (f"{asked}: no bundled campaign of that name and no such file"
                if path.parent == CAMPAIGN_DIR and Path(asked) != path else
                f"{where}: no such campaign file")
        raise CampaignError(f"{what}{did_you_mean(Path(str(asked)).stem, names)} (bundled: "
                            f"{', '.join(names) or 'none'})") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise CampaignError(f"{where}: cannot read a TOML text file: {exc}") from None
    try:
        raw = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise CampaignError(f"{where}: not valid TOML: {exc}") from None
    try:
        return _campaign(path, where, raw, text)
    except ScenarioError as exc:
        raise CampaignError(str(exc)) from None


def _campaign(path: Path, where: str, raw: dict, text: str) -> Campaign:
    from hil_bench.scenario import tomlw

    top = Fields(where, raw, "", text)
    c = top.table_of("campaign")
    name = c.string("name", path.stem)
    if not NAME_PATTERN.match(name) or "@" in name:
        raise c.fail("name", f"{name!r} must be letters, digits, '_', '-' or '.', not starting with "
                             f"'.' or '-': it names the report folder "
                             f"(reports/campaigns/<name>) and every run's scenario and recording "
                             f"(<name>@<run>)")
    description = c.string("description", "")
    base_name = c.string("base")
    base_path = resolve_path(base_name)
    if not base_path.exists():
        rel = (path.parent / base_name)
        if rel.exists():
            base_path = rel
        else:
            raise c.fail("base", f"{base_name!r}: neither a bundled scenario nor a file next to "
                                 f"the campaign")
    try:
        base_raw = tomllib.loads(base_path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError) as exc:
        raise c.fail("base", f"{base_path}: cannot read it: {exc}") from None
    if base_raw.get("faults"):
        raise c.fail("base", f"{base_path} has [[faults]] of its own: a campaign's base is a "
                             f"healthy run")
    if "duration_s" in c.table:
        d = c.number("duration_s", positive=True)
        base_raw = tomlw.set_dotted(base_raw, "scenario.duration_s", d)
        w = base_raw.get("metrics", {}).get("window_s")
        if isinstance(w, list) and len(w) == 2 and w[1] > d:
            # the base's metrics window ends after the shortened run: its last part, kept
            base_raw = tomlw.set_dotted(base_raw, "metrics.window_s",
                                        [min(float(w[0]), 0.5 * d), d])
    ov = c.table_of("overrides")
    for key in list(ov.table):
        ov.used.add(key)
        try:
            base_raw = tomlw.set_dotted(base_raw, key, ov.table[key])
        except ValueError as exc:
            raise ov.fail(key, str(exc)) from None
    link = c.string("link", "stub")
    c.reject_unknown()
    top.used.add("recording")
    recording = raw.get("recording", {})
    if not isinstance(recording, dict):
        raise top.fail("recording", "must be a table")
    limits = _limits(top.table_of("limits"), {"detected": True})

    cases: list[Case] = []
    top.used.add("runs")
    for i, item in enumerate(raw.get("runs", [])):
        f = Fields(where, item, f"runs[{i}]", text)
        label = f.string("label", "")
        f.used.add("faults")
        faults = item.get("faults")
        if not isinstance(faults, list) or not faults or not all(isinstance(x, dict) for x in faults):
            raise f.fail("faults", "must be a non-empty list of fault tables "
                                   "({kind = ..., t_s = ..., ...})")
        run_limits = _limits(f.table_of("limits"), limits)
        allow = parse_link_allow(f.table_of("allow"))
        f.reject_unknown()
        cases.append(Case(_case_name(label or faults[0].get("kind", ""), len(cases)), label,
                          tuple(faults), run_limits, allow))
    top.used.add("grid")
    for i, item in enumerate(raw.get("grid", [])):
        f = Fields(where, item, f"grid[{i}]", text)
        run_limits = _limits(f.table_of("limits"), limits)
        allow = parse_link_allow(f.table_of("allow"))
        axes = {k: (v if isinstance(v, list) else [v]) for k, v in item.items()
                if k not in ("limits", "allow")}
        for k in axes:
            f.used.add(k)
        if "kind" not in axes:
            raise f.fail("kind", "missing (required)")
        keys = list(axes)
        for combo in itertools.product(*(axes[k] for k in keys)):
            fault = dict(zip(keys, combo))
            label = " ".join([str(fault["kind"])] + [f"{k}={v}" for k, v in fault.items()
                                                        if k not in ("kind", "t_s")])
            cases.append(Case(_case_name(label, len(cases)), label, (fault,), run_limits, allow))
        f.reject_unknown()
    if not cases:
        raise top.fail("runs", "a campaign needs at least one [[runs]] or [[grid]] entry")
    longest = max(cases, key=lambda case: len(case.name))
    if not NAME_PATTERN.match(f"{name}@{longest.name}"):
        raise c.fail("name", f"{name!r}: with its run {longest.name!r} the scenario name "
                             f"{name}@{longest.name} is longer than 100 characters")
    top.reject_unknown()
    camp = Campaign(path, name, description, base_path, base_raw, link, cases, recording, limits)
    for case in cases:   # every run's scenario is valid before anything runs
        scenario_for(camp, case)
    return camp


def scenario_for(camp: Campaign, case: Case):
    """The scenario of one run: the base with the run's faults, recording and allowances."""
    from hil_bench.scenario import tomlw

    doc = tomlw.set_dotted(camp.base_raw, "scenario.name", f"{camp.name}@{case.name}")
    doc = tomlw.set_dotted(doc, "scenario.description",
                           f"campaign {camp.name}: {case.label or case.name}")
    doc = tomlw.set_dotted(doc, "scenario.claims", [])
    doc["faults"] = [dict(f) for f in case.faults]
    if camp.recording:
        doc["recording"] = dict(camp.recording)
    if case.allow:
        doc = tomlw.set_dotted(doc, "link.allow", dict(case.allow))
    text = (f"# campaign {camp.path}: run {case.name}, base {camp.base_path}\n" + tomlw.dumps(doc))
    try:
        scn = parse_scenario(text, camp.path.with_name(f"{camp.name}@{case.name}.toml"))
        check_against_profile(scn)
    except ScenarioError as exc:
        raise CampaignError(f"{camp.path}: run {case.name} ({case.label}): {exc}") from None
    return scn


# ---- running ------------------------------------------------------------------------------------


def judge(case: Case, outcomes: list, run_error: str, end: str,
          never_acted: list[str] | None = None) -> tuple[str, list[str]]:
    """PASS / FAIL against the case's limits; INVALID when the bench, not the controller, ended
    the run, or a fault never acted (``never_acted``: the integrity check's words, naming the
    fault and why) or left no trace."""
    reasons: list[str] = []
    if run_error and "controller reported fault" not in run_error and end not in (
            "NO_DUTY", "WATCHDOG", "CONTROLLER_FAULT", "BAD_DUTIES"):
        return "INVALID", [f"the run ended for another reason than the controller: {run_error}"]
    if never_acted:
        return "INVALID", list(never_acted)
    if len(outcomes) < len(case.faults):
        return "INVALID", [f"{len(case.faults) - len(outcomes)} fault(s) have no /faults record"]
    for o in outcomes:
        if o.t_on_s is None:
            return "INVALID", [f"fault {o.index} ({o.kind}) never acted: " + "; ".join(o.notes)]
        if o.untraced and o.trip_s is None:
            if case.limits.get("detected", True):
                reasons.append(f"{o.kind}: not detected ({o.evidence})")
            continue
        lim = case.limits
        if lim.get("detected", True) and not o.detected:
            reasons.append(f"{o.kind}: not detected")
        if "detection_time_s" in lim and o.detection_s is not None and \
                o.detection_s > lim["detection_time_s"]:
            reasons.append(f"{o.kind}: detected after {o.detection_s * 1e3:.1f} ms > "
                           f"{lim['detection_time_s'] * 1e3:g} ms")
        if "peak_current_a" in lim and math.isfinite(o.peak_current_a) and \
                o.peak_current_a > lim["peak_current_a"]:
            reasons.append(f"{o.kind}: peak |i| {o.peak_current_a:.2f} A > {lim['peak_current_a']:g} A")
        if "peak_torque_nm" in lim and math.isfinite(o.peak_torque_nm) and \
                o.peak_torque_nm > lim["peak_torque_nm"]:
            reasons.append(f"{o.kind}: peak |T_e| {o.peak_torque_nm:.2f} N m > "
                           f"{lim['peak_torque_nm']:g} N m")
        if "duties_after_trip" in lim and o.duties_after_trip > lim["duties_after_trip"]:
            reasons.append(f"{o.kind}: {o.duties_after_trip} duties after the trip were not all "
                           f"legs off (limit {lim['duties_after_trip']})")
    return ("FAIL" if reasons else "PASS"), reasons


def _run_case(camp: Campaign, case_index: int, out_dir: str, link: str) -> dict:
    """One run (here or in a worker process): returns what the table needs."""
    from hil_bench.loop.runner import Runner
    from hil_bench.papers.check import read_for_check
    from hil_bench.record.fault_outcomes import outcomes as fault_outcomes
    from hil_bench.record.integrity import fault_problems

    case = camp.cases[case_index]
    scn = scenario_for(camp, case)
    out = Path(out_dir) / f"{case.name}.mcap"
    t0 = time.monotonic()
    try:
        # replaces the case's recording of an earlier campaign; a name another run of it is
        # writing now (its .partial) becomes the next free one (recorder.reserve_recording)
        runner = Runner(scn, link_spec=link, out_path=out, progress=False, force=True)
        runner.pick_free_name = True
        result = runner.run()
    except (BenchError, ValueError, OSError) as exc:
        return {"error": f"could not run: {exc}", "end": "SETUP", "recording": None,
                "wall_s": time.monotonic() - t0}
    rec_path = result.recording if Path(result.recording).exists() else None
    rec = read_for_check(rec_path) if rec_path else None
    outcomes = fault_outcomes(rec) if rec is not None else []
    never = [p.text for p in fault_problems(rec, scn.faults, result.cycles_done)
             if p.name == "never_acted"] if rec is not None else []
    return {"error": result.error or "", "end": result.end, "recording": str(rec_path or ""),
            "wall_s": time.monotonic() - t0, "outcomes": outcomes, "never_acted": never}


def run_campaign(camp: Campaign, out_dir: Path, *, jobs: int | None = None,
                 link: str | None = None, keep_all: bool = False, console=None,
                 scheduler: str | None = None, progress: bool = True) -> list[CaseResult]:
    """Run every case on the executor (hil_bench.cluster: a local Dask cluster of ``jobs``
    workers, or ``scheduler``); keep the recordings of the runs that did not PASS."""
    from rich.console import Console
    from rich.markup import escape

    from hil_bench.cluster import Executor, TaskFailure
    from hil_bench.record.recorder import SIDE_SUFFIXES

    console = console or Console(stderr=True)
    rec_dir = out_dir / "recordings"
    rec_dir.mkdir(parents=True, exist_ok=True)
    results: dict[int, CaseResult] = {}
    with Executor(scheduler, jobs, progress=progress, console=console, label=camp.name) as ex:

        def finished():
            """(case index, result) as the runs end, on whichever worker."""
            args = [(str(i), (camp, i, str(rec_dir.resolve()), link or camp.link))
                    for i in range(len(camp.cases))]
            for key, res in ex.map(_run_case, args,
                                   describe=lambda k: camp.cases[int(k)].name):
                if isinstance(res, TaskFailure):   # the bench's failure, said
                    yield int(key), {"error": res.error.splitlines()[0], "end": "BENCH",
                                     "recording": None, "wall_s": 0.0}
                else:
                    yield int(key), res.value

        for i, r in finished():
            case = camp.cases[i]
            outs = r.get("outcomes", [])
            if r["end"] in ("SETUP", "BENCH"):
                verdict, reasons = "INVALID", [r["error"]]
            else:
                verdict, reasons = judge(case, outs, r["error"], r["end"], r.get("never_acted"))
            rec = Path(r["recording"]) if r.get("recording") else None
            if rec is not None and verdict == "PASS" and not keep_all:
                for p in (rec, *(rec.with_suffix(sfx) for sfx, _ in SIDE_SUFFIXES)):
                    p.unlink(missing_ok=True)
                rec = None
            results[i] = CaseResult(case, rec, verdict, reasons, outs, r["error"], r["wall_s"])
            if not console.is_terminal:
                console.print(escape(f"  {case.name}: {verdict}" +
                                     (f" ({reasons[0]})" if reasons else "")))
    if not any(rec_dir.iterdir()):
        rec_dir.rmdir()
    return [results[i] for i in sorted(results)]


# ---- the table ------------------------------------------------------------------------------------


def rows(results: list[CaseResult]) -> list[dict[str, str]]:
    """One row per fault of every run."""
    out = []
    for r in results:
        faults = r.outcomes or [None]
        for o in faults:
            out.append({
                "run": r.case.name,
                "fault": (o.kind if o else (r.case.faults[0].get("kind", "?"))),
                "detected": ("yes" if o and o.detected else "no") if o else "-",
                "detection_ms": (f"{o.detection_s * 1e3:.1f}" if o and o.detection_s is not None
                                 else "-"),
                "by": (o.detected_by or o.evidence) if o else "",
                "peak_current_a": f"{o.peak_current_a:.2f}" if o and math.isfinite(o.peak_current_a)
                                  else "-",
                "peak_torque_nm": f"{o.peak_torque_nm:.2f}" if o and math.isfinite(o.peak_torque_nm)
                                  else "-",
                "duties_after_trip": (str(o.duties_after_trip) if o and o.trip_s is not None else "-"),
                "verdict": r.verdict,
                "why": "; ".join(r.reasons),
                "recording": str(r.recording or ""),
            })
    return out


def write_report(camp: Campaign, results: list[CaseResult], out_dir: Path, wall_s: float) -> Path:
    """results.md and results.csv in out_dir; returns the markdown's path."""
    from hil_bench.record.atomic import write_aside, write_text_aside

    table = rows(results)
    out_dir.mkdir(parents=True, exist_ok=True)
    with write_aside(out_dir / "results.csv", newline="") as fh:   # renamed into place when whole
        w = csv.DictWriter(fh, fieldnames=list(table[0]) if table else ["run"])
        w.writeheader()
        w.writerows(table)
    counts = {v: sum(1 for r in results if r.verdict == v) for v in ("PASS", "FAIL", "INVALID")}
    lines = [f"# Campaign {camp.name}", "",
             camp.description, "",
             f"Base scenario `{camp.base_path}`, link `{camp.link}`, {len(results)} runs in "
             f"{wall_s:.0f} s: {counts['PASS']} PASS, {counts['FAIL']} FAIL, "
             f"{counts['INVALID']} INVALID. Recordings of the runs that did not pass: "
             f"`recordings/`.", "",
             "| run | fault | detected | after [ms] | by | peak abs(i) [A] | peak abs(T_e) [N m] | "
             "duties after trip | verdict | why |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for row in table:
        cells = [row[k].replace("|", "/") for k in ("run", "fault", "detected", "detection_ms", "by",
                                                     "peak_current_a", "peak_torque_nm",
                                                     "duties_after_trip", "verdict", "why")]
        lines.append("| " + " | ".join(cells) + " |")
    lines += ["", "Limits (the campaign file's `[limits]`): " +
              ", ".join(f"`{k} = {v}`" for k, v in camp.limits.items()) + "."]
    special = [r for r in results if r.case.limits != camp.limits]
    if special:
        lines.append("Runs with limits of their own: " + "; ".join(
            f"{r.case.name}: " + ", ".join(f"`{k} = {v}`" for k, v in r.case.limits.items()
                                           if camp.limits.get(k) != v) for r in special) + ".")
    md = out_dir / "results.md"
    write_text_aside(md, "\n".join(lines) + "\n")
    return md

