"""Verdicts that name their assumption (issue 27, point 3), in the claims report.

Where a claim's verdict rests on a number its paper does not give (a dead time, a node
capacitance, the inverter compensation's residual, the current loop a THD was measured in), the
claim's own verdict runs again over the plausible range of that number, one number at a time
around the scenarios' value (an *axis*), each point judged by the claim's own rules
(report.judge_claim). The claim's verdict is then

* PASS or FAIL only if it is the same at every point of every axis ("across the range");
* **DEPENDS** otherwise, with the threshold per axis: "holds for dead time <= 1.0 us";
* its own verdict (COMPARED, NOT REPRODUCIBLE, UNTESTED, ...) where it has no pass/fail.

Each axis says what the paper gives ("Hou gives none"), where the scenarios' value comes from
("1.78 us: Yuan's fit") and where the range comes from. The report's summary table shows the
axes beside the verdict; ``to_json`` is ``<out>/assumptions.json``.

The residual axis reads the points of the residual study (residual.py: the same run ids, run
once); the other axes run their own copies of the claim's runs (``<prefix><value>.<run id>``).
``AXES`` lists the claims and their axes; ``plan()`` the runs, ``evaluate(plan, rep, judge)`` the
verdicts.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Callable

from hil_bench.claims.model import Claim, Run
from hil_bench.claims.registry import CLAIMS

from . import residual as rs
from .claim_variants import HOLDS, Judge, claim_on, derived_run


@dataclass(frozen=True)
class Axis:
    """One number a claim's verdict rests on that its paper does not give, over its plausible
    range."""

    name: str                            # "dead time"
    unit: str                            # "us"
    scale: float                         # SI -> unit
    default: float                       # the scenarios' value (SI)
    values: tuple[float, ...]            # the plausible range's grid (SI), with the default
    paper: str                           # what the paper gives: "Hou gives none"
    default_source: str                  # where the scenarios' value comes from
    range_source: str                    # where the range comes from
    variant: Callable[[Run, float], Run]  # the run at a value (the default: the run itself)
    origin: str = ""                     # the scenarios' value in a few words ("Yuan's fit")

    def fmt(self, v: float) -> str:
        return f"{v * self.scale:.3g} {self.unit}".strip()

    def fmt_range(self, lo: float, hi: float) -> str:
        return f"{lo * self.scale:.3g}-{hi * self.scale:.3g} {self.unit}".strip()

    def is_default(self, v: float) -> bool:
        return math.isclose(v, self.default, rel_tol=1e-9, abs_tol=1e-15)

    def run_at(self, run: Run, v: float) -> Run:
        return run if self.is_default(v) else self.variant(run, v)


# -- the axes --------------------------------------------------------------------------------------

def _profile(run: Run) -> str:
    from .conditions import scenario_for
    return scenario_for(run).profile


def _inverter_of(run: Run):
    from hil_bench.plant_rt.profile import load_profile
    return load_profile(_profile(run))


#: the dead time's plausible range: the IGBT inverters of the papers' class at 10 kHz
DEAD_TIMES_S = (0.5e-6, 1.0e-6, 1.78e-6, 2.5e-6, 3.0e-6)
DEAD_TIME_RANGE = (
    "0.5-3 us: the dead time of an IGBT leg is set from its drivers' and devices' worst-case "
    "delays, t_dead = 1.2 [(t_d,off,max - t_d,on,min) + (t_pdd,max - t_pdd,min)] (Infineon "
    "application note AN2007-04, 'How to calculate and minimize the dead time requirement for "
    "IGBTs properly'); for 600-1200 V modules at 10 kHz that gives about 0.5 us (fast devices, "
    "matched drivers) to 3 us (slow drivers, optocouplers). None of the papers' parts gives a "
    "figure the bench has: Gong names his modules (FP25R12KT3), Hou and Yuan no power stage")


def _dead_time_variant(run: Run, t_s: float) -> Run:
    """The run with the plant's dead time t_s and its node-capacitance band i_c = C V_dc / t_dt
    scaled with it (the same node capacitance); the drive's compensation follows the plant's
    values, at the scenario's residual (the runner sends INV_COMP_* from the plant)."""
    prof = _inverter_of(run)
    t0 = prof.dead_time_s
    band = prof.i_cap_band_a * t0 / t_s
    return derived_run(run, f"dt{t_s * 1e6:g}", (("plant.dead_time_s", t_s),
                                                  ("plant.i_cap_band_a", round(band, 6))),
                       f"dead time {t_s * 1e6:g} us (i_c {band:.3g} A)")


def dead_time_axis(paper: str, default_source: str) -> Axis:
    return Axis("dead time", "us", 1e6, 1.78e-6, DEAD_TIMES_S, paper, default_source,
                DEAD_TIME_RANGE, _dead_time_variant, "Yuan's fit")


#: the node capacitance (both devices' output capacitance, snubber, cable) of a leg
NODE_CAP_SCALES = (1 / 3, 1.0, 3.0)
NODE_CAP_RANGE = (
    "0.3-2.7 nF (x 1/3 .. 3 of the profile's 0.9 nF): the output capacitance of 600-1200 V IGBT "
    "modules of 10-50 A is of the order of 0.1-0.5 nF per device, with the cable's and a "
    "snubber's on top; no paper gives its inverter's")


def _node_cap_variant(run: Run, scale: float) -> Run:
    prof = _inverter_of(run)
    band = prof.i_cap_band_a * scale
    return derived_run(run, f"cn{scale:.3g}", (("plant.i_cap_band_a", round(band, 6)),),
                       f"node capacitance x {scale:.3g} (i_c {band:.3g} A)")


def node_cap_axis(paper: str) -> Axis:
    return Axis("node capacitance", "nF", 0.9, 1.0, NODE_CAP_SCALES, paper,
                "0.9 nF: plant_rt/profiles (C_node ~0.9 nF: both devices' C_oss, snubber, cable)",
                NODE_CAP_RANGE, _node_cap_variant, "the profiles' estimate")


#: the residual's plausible range: no figure could be sourced (docs/inverter_comp.md)
RESIDUALS = (0.0, 0.01, 0.02, 0.03, 0.05, 0.10)
RESIDUAL_RANGE = (
    "0-10 %: no sourced figure for what a commissioned feed-forward leaves (docs/inverter_comp.md, "
    "'What residual a real drive has'); 0 is exact compensation, 10 % twice the scenarios' 5 %. "
    "The residual study reports 0-100 %")


def residual_axis(paper: str) -> Axis:
    return Axis("compensation residual", "%", 100.0, rs.REALISTIC, RESIDUALS, paper,
                "5 %: the scenarios' [controller.inverter_comp] residual (an assumption)",
                RESIDUAL_RANGE, rs.variant, "an assumption")


_YUAN_RES = "Yuan describes no dead-time compensation"
_HOU_RES = "Hou describes no dead-time compensation"
_GONG_RES = "Gong describes no dead-time compensation"
_HOU_DT = "Hou gives no dead time (no power stage is named)"
_HOU_DT_SRC = ("1.78 us: Yuan's fit (plant_rt/profiles/yuan2020.toml), taken for Hou's drive "
               "(plant_rt/profiles/hou2021.toml)")
_GONG_DT = "Gong gives no dead time (he names his FP25R12KT3 modules)"
_GONG_DT_SRC = "1.78 us: Yuan's fit, taken for Gong's drive (plant_rt/profiles/gong2020.toml)"

#: per claim, the numbers its verdict rests on that its paper does not give
AXES: dict[str, tuple[Axis, ...]] = {
    "Y1": (residual_axis(_YUAN_RES),),
    "Y2": (residual_axis(_YUAN_RES),),
    "Y8": (residual_axis(_YUAN_RES),),
    "H1": (residual_axis(_HOU_RES), dead_time_axis(_HOU_DT, _HOU_DT_SRC)),
    "H2": (residual_axis(_HOU_RES),),
    "H3": (dead_time_axis(_HOU_DT, _HOU_DT_SRC), node_cap_axis("Hou gives none"),
           residual_axis(_HOU_RES)),
    "G6": (residual_axis(_GONG_RES), dead_time_axis(_GONG_DT, _GONG_DT_SRC)),
    "G7": (residual_axis(_GONG_RES), dead_time_axis(_GONG_DT, _GONG_DT_SRC)),
    "G8": (residual_axis(_GONG_RES), dead_time_axis(_GONG_DT, _GONG_DT_SRC)),
}


# -- plan, measure, judge ------------------------------------------------------------------------

def claim_at(c: Claim, axis: Axis, v: float) -> Claim:
    """The claim's non-diagnostic rows and relations on its runs at value v of the axis."""
    return claim_on(c, lambda run: axis.run_at(run, v))


@dataclass
class Plan:
    claims: tuple[str, ...]
    runs: list[Run] = field(default_factory=list)


def plan(claims: list[str] | None = None) -> Plan:
    ids = tuple(c for c in (claims or AXES) if c in AXES)
    pl = Plan(ids)
    seen: set[str] = set()
    for cid in ids:
        for axis in AXES[cid]:
            for v in axis.values:
                for run in claim_at(CLAIMS[cid], axis, v).runs:
                    if run.id not in seen:
                        seen.add(run.id)
                        pl.runs.append(run)
    return pl


@dataclass
class Point:
    value: float
    verdict: str
    rows: list

    @property
    def holds(self) -> bool:
        return self.verdict in HOLDS


@dataclass
class AxisResult:
    axis: Axis
    points: list[Point]

    def verdicts(self) -> set[str]:
        return {p.verdict for p in self.points}

    def threshold(self) -> str:
        """Where the claim holds on this axis: 'holds for dead time <= 1 us', 'holds nowhere',
        'holds everywhere', or the holding values listed; points that give no pass/fail (a run
        the bench could not measure, an untested comparator) are named as such, never counted
        as holding or as failing."""
        pts = sorted(self.points, key=lambda p: p.value)
        a = self.axis
        span = a.fmt_range(pts[0].value, pts[-1].value)
        if all(vote(p.verdict) is None for p in pts):
            return (f"no pass/fail at any {a.name} of {span} ("
                    + ", ".join(dict.fromkeys(p.verdict for p in pts)) + ")")
        silent = [p for p in pts if vote(p.verdict) is None]
        note = ("; no pass/fail at " + ", ".join(f"{a.fmt(p.value)} ({p.verdict})"
                                                  for p in silent)) if silent else ""
        voting = [p for p in pts if vote(p.verdict) is not None]
        held = [p for p in voting if p.holds]
        measured = " measured" if silent else ""
        if not held:
            return f"holds at no {a.name}{measured} of {span}{note}"
        if len(held) == len(voting):
            return f"holds at every {a.name}{measured} of {span}{note}"
        idx = [voting.index(p) for p in held]
        contiguous = idx == list(range(idx[0], idx[-1] + 1))
        if contiguous and idx[0] == 0:
            return (f"holds for {a.name} <= {a.fmt(held[-1].value)} (fails from "
                    f"{a.fmt(voting[idx[-1] + 1].value)}){note}")
        if contiguous and idx[-1] == len(voting) - 1:
            return (f"holds for {a.name} >= {a.fmt(held[0].value)} (fails at "
                    f"{a.fmt(voting[idx[0] - 1].value)} and below){note}")
        return f"holds at {a.name} " + ", ".join(a.fmt(p.value) for p in held) + f" only{note}"

    def text(self) -> str:
        a = self.axis
        return (f"{a.name}: {self.threshold()}; {a.paper}; the scenarios' "
                f"{a.default_source}; plausible {a.range_source.split(':')[0]}")

    def short(self) -> str:
        """The summary table's line: the threshold, what the paper gives, the bench's value."""
        a = self.axis
        return (f"{a.name}: {self.threshold()} ({a.paper}; the scenarios' {a.fmt(a.default)} is "
                f"{a.origin})")


#: the verdicts a claim can only have as its own, whatever the axes say
_NO_PASS_FAIL = ("COMPARED", "NOT REPRODUCIBLE", "UNTESTED", "NOT RESOLVED", "INVALID")


def vote(verdict: str) -> bool | None:
    """A point's vote: it holds (PASS, COMPARED, PARTLY), it fails (FAIL), or it has no
    pass/fail to give (INVALID: the bench could not measure; NOT REPRODUCIBLE, NOT RESOLVED,
    UNTESTED)."""
    if verdict in HOLDS:
        return True
    return False if verdict == "FAIL" else None


def verdict_across(own: str, results: list[AxisResult]) -> str:
    """A claim's verdict over its axes (its own verdict is the default point's):

    * no axis, or its own run INVALID: its own verdict;
    * a point that FAILs is never hidden: FAIL when no point holds, DEPENDS when some do or when
      its own verdict has no pass/fail (NOT REPRODUCIBLE, UNTESTED, NOT RESOLVED: it fails at
      some values of the assumption and cannot be judged at the paper's);
    * every point that gives a pass/fail holds: its own verdict only if every point gave one;
      a point the bench could not measure (INVALID) makes it INVALID (the range was not
      measured; the threshold names the point), a point with no pass/fail of its own
      (UNTESTED, NOT RESOLVED, NOT REPRODUCIBLE) makes a PASS a PARTLY."""
    if not results or own == "INVALID":
        return own
    points = [p for r in results for p in r.points]
    votes = [vote(p.verdict) for p in points]
    if False in votes:
        return "DEPENDS" if True in votes or own in _NO_PASS_FAIL else "FAIL"
    if own in _NO_PASS_FAIL:
        return own
    if any(p.verdict == "INVALID" for p in points):
        return "INVALID"
    if None in votes and own == "PASS":
        return "PARTLY"
    return own


def evaluate(pl: Plan, rep, judge: Judge, claim_verdict: Callable[[list], str]) -> dict[str, Any]:
    """Per claim: its axes' points (the default point is the claim's own verdict from the
    report's rows, by the report's ``claim_verdict``), its verdict across them and the text the
    summary shows. The report hands its own judge and verdict (as to the residual study), so
    this module does not import the report that imports it."""
    out: dict[str, Any] = {"claims": {}}
    for cid in pl.claims:
        own_rows = [r for r in rep.rows if r.claim == cid]
        own = claim_verdict(own_rows)
        results = []
        for axis in AXES[cid]:
            pts = []
            for v in axis.values:
                if axis.is_default(v):          # the default: the claim's own verdict
                    pts.append(Point(v, own, [r for r in own_rows if not r.diagnostic]))
                    continue
                verdict, rows = judge(claim_at(CLAIMS[cid], axis, v), rep.outcomes)
                pts.append(Point(v, verdict, rows))
            results.append(AxisResult(axis, pts))
        out["claims"][cid] = {"own": own, "verdict": verdict_across(own, results),
                              "axes": results}
    return out


def summary(assump: dict[str, Any], cid: str) -> tuple[str | None, str]:
    """(the verdict across the claim's axes or None, the text the summary table shows)."""
    c = (assump or {}).get("claims", {}).get(cid)
    if c is None:
        return None, NO_AXIS.get(cid, "")
    return c["verdict"], "; ".join(r.short() for r in c["axes"])


#: what the summary says of a claim without an axis
NO_AXIS = {
    "G1": "none: Gong's simulation gives every number (Table I, m, k by eq. 17)",
    "G2": "none: Gong's simulation gives every number",
    "G3": "none: Gong's simulation gives every number",
    "G4": "none: Gong's simulation gives every number (the speed loop's overshoot is the bench's)",
    "Y3": "none the verdict moves with: the same samples replayed through both observers",
    "G5": "the current-sampling chain (an anti-alias filter, the sample instants against the "
          "carrier): Gong gives none and the bench models none, so the row is NOT REPRODUCIBLE "
          "(the residual study shows the compensation does not move it)",
    "Y4": "the current loop (Yuan's Table 1 is lost): the calibration loop decides, the "
          "controller's own 500 Hz loop is shown beside (.stubloop rows)",
    "Y5": "none: the paper's own M = 24, k = 5",
    "Y6": "none: the paper's recursions",
    "Y7": "none: the paper's own extractors on the Y4 current",
}


def to_json(assump: dict[str, Any]) -> dict:
    out = {}
    for cid, c in assump.get("claims", {}).items():
        out[cid] = {"own": c["own"], "verdict": c["verdict"], "axes": [
            {"name": r.axis.name, "unit": r.axis.unit, "paper": r.axis.paper,
             "default": r.axis.default * r.axis.scale, "default_source": r.axis.default_source,
             "range_source": r.axis.range_source, "threshold": r.threshold(),
             "points": [{"value": p.value * r.axis.scale, "verdict": p.verdict,
                         "rows": [{"key": x.key, "measured": _finite(x.value),
                                   "verdict": x.verdict} for x in p.rows]}
                        for p in r.points]} for r in c["axes"]]}
    return out


def _finite(x: float) -> float | None:
    return x if isinstance(x, float) and math.isfinite(x) else None


def markdown(rep) -> list[str]:
    a = rep.assumptions
    L = ["## Verdicts across their assumptions", "",
         "Each claim whose verdict rests on a number its paper does not give, run again over the "
         "plausible range of that number (one at a time, the others at the scenarios' values), "
         "judged by its own rules. PASS / FAIL only where every point agrees; DEPENDS with the "
         "threshold otherwise.", ""]
    for cid, c in a.get("claims", {}).items():
        L.append(f"### {cid}: {c['verdict']} (at the scenarios' values: {c['own']})")
        L.append("")
        for r in c["axes"]:
            L.append(f"* {r.text()}. Range: {r.axis.range_source}.")
            L.append("")
            L.append("  | " + r.axis.name + " | " + " | ".join(r.axis.fmt(p.value)
                                                              for p in r.points) + " |")
            L.append("  |---|" + "---|" * len(r.points))
            L.append("  | verdict | " + " | ".join(p.verdict for p in r.points) + " |")
            L.append("")
    return L


def html_section(rep, img) -> list[str]:
    import html as h
    a = rep.assumptions
    H = ["<h2 id='assumptions'>Verdicts across their assumptions</h2>",
         "<p>Each claim whose verdict rests on a number its paper does not give, run again over "
         "the plausible range of that number, judged by its own rules: PASS / FAIL only where "
         "every point agrees, DEPENDS with the threshold otherwise.</p>"]
    for cid, c in a.get("claims", {}).items():
        H.append(f"<h3>{h.escape(cid)}: {h.escape(c['verdict'])} (at the scenarios' values: "
                 f"{h.escape(c['own'])})</h3><ul>")
        for r in c["axes"]:
            H.append(f"<li>{h.escape(r.text())}. Range: {h.escape(r.axis.range_source)}."
                     "<table><tr><th>" + h.escape(r.axis.name) + "</th>"
                     + "".join(f"<th>{h.escape(r.axis.fmt(p.value))}</th>" for p in r.points)
                     + "</tr><tr><td>verdict</td>"
                     + "".join(f"<td class='{h.escape(p.verdict.replace(' ', '_'))}'>"
                               f"{h.escape(p.verdict)}</td>" for p in r.points)
                     + "</tr></table></li>")
        H.append("</ul>")
    return H

