"""The comparators: do the bench's reconstructions of the methods the papers compare against
hold their operating points (issue 27, point 4), in the claims report.

Yuan's "conventional SMO" (eq. 4-10: the sign SMO, its EMF low-passed, the angle compensated
by atan(w/wc)) and Hou's "improved SMO method mentioned in [8]" (Liang et al.: a second-order,
super-twisting SMO) come with no gains. The claims run the bench's reading of them (the runs a
claim marks ``comparator``); where such a run does not hold its operating point, the rows on it
and every relation over them are UNTESTED, not FAIL (hil_bench.papers.claims). This study says
whether any setting the papers or their citations support holds the operating points, first on
an ideal inverter (the dead time and drops off), then under the claim's own set-up:

* the sign SMO: the switching gain by Yuan's own stability condition, eq. 5 (k > |E|: the
  adaptive k = 1.5 |w^| psi_f floored at 1.5 x the 10 rpm EMF, the claims' setting), and the
  library's 5 V floor (not Yuan's);
* the super-twisting SMO: the gains by the algorithm's convergence condition (Levant; Moreno and
  Osorio 2012) from the speed estimate (the claims' setting), and the same condition fixed at
  the claim's 50 rpm (a constant-gain STA, as [8]'s title suggests).

Each point is the comparator's rows measured on its run with the setting and the plant (an
ordinary claim run: scenario + overrides, so its recording says what ran). ``plan()`` lists the
runs, ``evaluate(plan, rep)`` judges them, ``markdown`` / ``html_section`` / ``to_json`` report.
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Any, Callable

from hil_bench.claims.model import Claim, Run
from hil_bench.claims.registry import CLAIMS

from .claim_variants import derived_run

#: the plants a comparator runs on: the ideal inverter first, then the claim's own set-up
PLANTS = (("ideal inverter", (("plant.inverter_nonlinear", False),)),
          ("the claim's set-up", ()))


def _sta_fixed(profile: str, rpm: float, margin: float = 2.0) -> tuple:
    """The STA's gains by its convergence condition at a fixed speed (est_smo_sta.h): delta =
    w_e^2 psi_f / Ls, k2 = 2 m Ls delta, k1 = m Ls sqrt(12 delta)."""
    from hil_bench.plant_rt.profile import load_profile
    p = load_profile(profile)
    w_e = rpm / 60.0 * 2.0 * math.pi * p.pole_pairs
    delta = w_e ** 2 * p.psi_f_wb / p.lq_h
    k2 = 2.0 * margin * p.lq_h * delta
    k1 = margin * p.lq_h * math.sqrt(12.0 * delta)
    return (("controller.params.SMO_STA_K1_V", round(k1, 4)),
            ("controller.params.SMO_STA_K2_V_S", round(k2, 3)))


@dataclass(frozen=True)
class Setting:
    name: str
    label: str                       # what it is and where it comes from
    overrides: tuple                 # () for the claims' own setting


def settings_for(estimator: str, profile: str) -> tuple[Setting, ...]:
    if estimator == "SMO_SIGN":
        return (Setting("eq5", "k by Yuan's eq. 5 (k > |E|: floor 1.5 x the 10 rpm EMF), the "
                               "claims' setting", ()),
                Setting("k5v", "k floored at the library's 5 V (not Yuan's)",
                        (("controller.params.SMO_K_MIN_V", 5.0),)))
    if estimator == "SMO_STA":
        return (Setting("adaptive", "gains by the STA's convergence condition at the speed "
                                    "estimate (Moreno & Osorio 2012), the claims' setting", ()),
                Setting("fixed50", "gains by the same condition fixed at 50 rpm (margin 2): a "
                                   "constant-gain STA", _sta_fixed(profile, 50.0)))
    return ()


@dataclass
class Plan:
    claims: tuple[str, ...]
    points: list[tuple[str, Run, Setting, str, Run]] = field(default_factory=list)
    runs: list[Run] = field(default_factory=list)


def comparator_runs(c: Claim) -> list[Run]:
    """The claim's comparator runs that decide (non-diagnostic rows on them)."""
    want: list[str] = []
    for q in c.quantities:
        if q.comparator and not q.diagnostic:
            for rid in q.runs:
                if rid not in want:
                    want.append(rid)
    return [c.run(r) for r in want]


def plan(claims: list[str] | None = None) -> Plan:
    from .conditions import expected, scenario_for
    ids = tuple(c for c in (claims or CLAIMS) if c in CLAIMS and comparator_runs(CLAIMS[c]))
    pl = Plan(ids)
    seen: set[str] = set()
    for cid in ids:
        for run in comparator_runs(CLAIMS[cid]):
            for st in settings_for(expected(run).estimator, scenario_for(run).profile):
                for plant, ov in PLANTS:
                    if not st.overrides and not ov:
                        var = run                       # the claim's own run
                    else:
                        tag = f"cmp.{st.name}" + (".ideal" if ov else "")
                        var = derived_run(run, tag, st.overrides + ov,
                                          f"comparator {st.label}; {plant}")
                    pl.points.append((cid, run, st, plant, var))
                    if var.id not in seen and var is not run:
                        seen.add(var.id)
                        pl.runs.append(var)
    return pl


@dataclass
class Point:
    claim: str
    run: str
    setting: Setting
    plant: str
    holds: bool
    rows: list                      # report.Row of the comparator's rows on the variant


def _claim_of(c: Claim, run: Run, var: Run) -> Claim:
    qs = tuple(dataclasses.replace(q, run=var.id) for q in c.quantities
               if q.comparator and not q.diagnostic and q.runs == (run.id,))
    return dataclasses.replace(c, quantities=qs, relations=(), runs=(var,))


def _measured(row) -> bool:
    """A comparator's row holds its point: it has a value and a verdict of its own (not
    UNTESTED: it lost the point; not INVALID: the bench broke, the wrong estimator ran, or there
    is no value)."""
    return row.verdict in ("PASS", "FAIL", "COMPARED") and math.isfinite(row.value)


def evaluate(pl: Plan, rep, measure_claims: Callable[..., list]) -> dict[str, Any]:
    """Each point's comparator rows, measured by the report's ``measure_claims`` (handed in, so
    this module does not import the report that imports it)."""
    pts = []
    for cid, run, st, plant, var in pl.points:
        rows = measure_claims([_claim_of(CLAIMS[cid], run, var)], rep.outcomes, {}, {})
        holds = bool(rows) and all(_measured(r) for r in rows)
        pts.append(Point(cid, run.id, st, plant, holds, rows))
    return {"points": pts}


def finding(comp: dict[str, Any], cid: str) -> str:
    """One line per claim: which sourced setting holds where, or that none does."""
    pts = [p for p in comp.get("points", []) if p.claim == cid]
    if not pts:
        return ""
    ideal = [p for p in pts if p.plant == PLANTS[0][0] and p.holds]
    own = [p for p in pts if p.plant == PLANTS[1][0] and p.holds]
    if own:
        return ("the comparator holds its operating points under the claim's set-up with "
                + ", ".join(sorted({p.setting.label for p in own})))
    if ideal:
        return ("the comparator holds its operating points on the ideal inverter ("
                + "; ".join(sorted({p.setting.label for p in ideal}))
                + ") but not under the claim's set-up with any sourced setting: the relations "
                  "over it are untested")
    return ("no sourced setting holds the comparator's operating points, even on the ideal "
            "inverter: the relations over it are untested")


def _cell(p: Point) -> str:
    vals = ", ".join(f"{r.measured}" + ("" if r.verdict != "UNTESTED" else " (off its point)")
                     for r in p.rows)
    return ("holds: " if p.holds else "does not hold: ") + vals


def markdown(rep) -> list[str]:
    comp = rep.comparators
    L = ["## The comparators", "",
         "The bench's reconstructions of the methods the papers compare against (Yuan's "
         "conventional sign SMO, Hou's super-twisting SMO of his ref. [8]), with the settings the "
         "papers or their citations support, on an ideal inverter and under the claim's set-up. "
         "Where the claim's comparator does not hold its operating point, the relations over it "
         "are UNTESTED.", ""]
    for cid in dict.fromkeys(p.claim for p in comp.get("points", [])):
        L += [f"**{cid}**: {finding(comp, cid)}.", "",
              "| run | setting | plant | comparator rows |", "|---|---|---|---|"]
        for p in comp["points"]:
            if p.claim == cid:
                L.append(f"| {p.run} | {p.setting.label} | {p.plant} | {_cell(p)} |")
        L.append("")
    return L


def html_section(rep, img) -> list[str]:
    import html as h
    comp = rep.comparators
    H = ["<h2 id='comparators'>The comparators</h2>",
         "<p>The bench's reconstructions of the methods the papers compare against, with the "
         "settings the papers or their citations support, on an ideal inverter and under the "
         "claim's set-up. Where the claim's comparator does not hold its operating point, the "
         "relations over it are UNTESTED.</p>"]
    for cid in dict.fromkeys(p.claim for p in comp.get("points", [])):
        H.append(f"<p><b>{h.escape(cid)}</b>: {h.escape(finding(comp, cid))}.</p><table><tr>"
                 "<th>run</th><th>setting</th><th>plant</th><th>comparator rows</th></tr>")
        for p in comp["points"]:
            if p.claim == cid:
                H.append(f"<tr><td>{h.escape(p.run)}</td><td>{h.escape(p.setting.label)}</td>"
                         f"<td>{h.escape(p.plant)}</td><td>{h.escape(_cell(p))}</td></tr>")
        H.append("</table>")
    return H


def to_json(comp: dict[str, Any]) -> dict:
    out: dict = {}
    for p in comp.get("points", []):
        out.setdefault(p.claim, {"finding": finding(comp, p.claim), "points": []})
        out[p.claim]["points"].append({
            "run": p.run, "setting": p.setting.name, "setting_label": p.setting.label,
            "plant": p.plant, "holds": p.holds,
            "rows": [{"key": r.key, "measured": r.value if math.isfinite(r.value) else None,
                      "verdict": r.verdict, "note": r.note} for r in p.rows]})
    return out
