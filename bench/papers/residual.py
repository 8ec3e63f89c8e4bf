"""The inverter-compensation residual study (issue 16, item 2), in the claims report.

For each claim whose verdict the inverter's error decides (Y1, Y2, Y8, H1, H2, H3), the claim's
own runs again with the drive's feed-forward (firmware_stub/src/inv_comp.h) at a residual r =
the fraction of the plant's dead time and device drops its estimate leaves
(``controller.inverter_comp.residual``, docs/inverter_comp.md): r = 0 exact parameters, r = 1
no compensation at all. Each claim's non-diagnostic quantities and relations are measured with
the claim's own rules at each r, and the claim "holds up to N %" where N is the largest r of the
grid below which every point holds (PASS, or COMPARED with every relation passing). One
refinement round runs the midpoint of the first interval where the verdict flips.

``plan()`` lists the runs, ``evaluate(plan, rep)`` measures them after the report ran them (it
may ask for a refinement: ``refine_runs``), ``markdown`` / ``html_section`` write the section;
plots go to ``<out>/plots/residual_<claim>.png``. The figure the claims' scenarios run at (the
residual a real feed-forward leaves) is ``REALISTIC``; where it comes from: docs/inverter_comp.md.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

from hil_bench.claims.model import Claim, Run
from hil_bench.claims.registry import CLAIMS

from .claim_variants import Holds, Judge, base_runs, claim_on, derived_run

#: the claims the inverter's error decides: every claim the papers measured on hardware that
#: runs with the drive's compensation (Yuan IV.B-C, Hou 4, Gong's experiments; docs/claims.md "One
#: inverter policy"). Y4 and Y7 are the compensation's own subject (their runs have none).
RESIDUAL_CLAIMS = ("Y1", "Y2", "Y3", "Y8", "H1", "H2", "H3", "G5", "G6", "G7", "G8")
#: the coarse grid (fractions of the plant's dead time and drops)
RESIDUALS = (0.0, 0.01, 0.02, 0.03, 0.05, 0.10, 0.20, 0.50, 1.00)
#: the residual the claims' scenarios run at: docs/inverter_comp.md, "What residual a real drive has"
REALISTIC = 0.05
KEY = "controller.inverter_comp.residual"


def tag(r: float) -> str:
    """A residual in a run id: 0.05 -> 'r5', 0.015 -> 'r1.5' (percent)."""
    return f"r{100.0 * r:g}"


def _base_runs(c: Claim) -> list[Run]:
    return base_runs(c)


def variant(run: Run, r: float) -> Run:
    return derived_run(run, tag(r), ((KEY, r),), f"compensation residual {100 * r:g} %")


def claim_at(c: Claim, r: float) -> Claim:
    """The claim measured on its residual-r runs: its non-diagnostic quantities and relations."""
    return claim_on(c, lambda run: variant(run, r))


@dataclass
class Plan:
    claims: tuple[str, ...]
    residuals: dict[str, list[float]] = field(default_factory=dict)   # claim -> residuals run
    runs: list[Run] = field(default_factory=list)


def plan(claims: list[str] | None = None, residuals: tuple[float, ...] = RESIDUALS) -> Plan:
    ids = tuple(c for c in (claims or RESIDUAL_CLAIMS) if c in RESIDUAL_CLAIMS)
    pl = Plan(ids)
    seen: set[str] = set()
    for cid in ids:
        pl.residuals[cid] = list(residuals)
        for r in residuals:
            for run in claim_at(CLAIMS[cid], r).runs:   # a run two claims share (G6, G7): once
                if run.id not in seen:
                    seen.add(run.id)
                    pl.runs.append(run)
    return pl


@dataclass
class Point(Holds):
    residual: float
    verdict: str                     # the claim's verdict at this residual (report.claim_verdict)
    rows: list                       # report.Row of the claim's non-diagnostic rows


def holds_up_to(points: list[Point]) -> float | None:
    """The largest residual below which every point holds (None: fails at the smallest)."""
    best = None
    for p in sorted(points, key=lambda p: p.residual):
        if not p.holds:
            break
        best = p.residual
    return best


def first_flip(points: list[Point]) -> tuple[float, float] | None:
    """(holds, fails) residuals of the first flip of the sorted points, if any."""
    pts = sorted(points, key=lambda p: p.residual)
    for a, b in zip(pts, pts[1:]):
        if a.holds and not b.holds:
            return a.residual, b.residual
    return None


def measure(pl: Plan, rep, judge: Judge) -> dict[str, list[Point]]:
    out: dict[str, list[Point]] = {}
    for cid in pl.claims:
        pts = []
        for r in sorted(set(pl.residuals[cid])):
            verdict, rows = judge(claim_at(CLAIMS[cid], r), rep.outcomes)
            pts.append(Point(r, verdict, rows))
        out[cid] = pts
    return out


def refine_runs(pl: Plan, points: dict[str, list[Point]]) -> list[Run]:
    """One refinement round: the midpoint of each claim's first flip (added to the plan)."""
    runs: list[Run] = []
    for cid, pts in points.items():
        flip = first_flip(pts)
        if flip is None:
            continue
        mid = round(0.5 * (flip[0] + flip[1]), 4)
        if mid in pl.residuals[cid]:
            continue
        pl.residuals[cid].append(mid)
        have = {r.id for r in pl.runs}
        new = [r for r in claim_at(CLAIMS[cid], mid).runs if r.id not in have]
        pl.runs += new
        runs += new
    return runs


def evaluate(pl: Plan, rep, judge: Judge) -> dict[str, Any]:
    points = measure(pl, rep, judge)
    from .report_plots import plot_residual
    plots = [plot_residual(rep, cid, pts, holds_up_to(pts), REALISTIC) for cid, pts in points.items()]
    return {"plan": pl, "points": points, "plots": [p for p in plots if p is not None]}


def _pct(r: float | None) -> str:
    return "none (fails at 0 %)" if r is None else f"{100 * r:g} %"


def _table(out: dict) -> tuple[list[str], list[list[str]]]:
    grid = sorted({r for pts in out["points"].values() for p in pts for r in [p.residual]})
    head = ["claim", "holds up to"] + [f"{100 * r:g} %" for r in grid]
    rows = []
    for cid, pts in out["points"].items():
        by_r = {p.residual: p.verdict for p in pts}
        rows.append([cid, _pct(holds_up_to(pts))] + [by_r.get(r, "") for r in grid])
    return head, rows


def summary(out: dict) -> dict[str, float | None]:
    return {cid: holds_up_to(pts) for cid, pts in out["points"].items()}


INTRO = ("Each claim's runs again with the drive's dead-time and drop feed-forward at a residual r "
         "(its estimate = (1 - r) x the plant's dead time and drops; 0 % exact, 100 % no "
         "compensation), measured with the claim's own rules; 'holds up to' is the largest r below "
         "which every point holds. The claims' scenarios run at {real:g} % (docs/inverter_comp.md: "
         "where the figure comes from); the uncompensated runs are the 100 % column.")


def markdown(rep) -> list[str]:
    out = rep.residual
    head, rows = _table(out)
    L = ["## Inverter-compensation residual", "", INTRO.format(real=100 * REALISTIC), "",
         "| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    L += ["| " + " | ".join(r) + " |" for r in rows]
    L.append("")
    for p in out["plots"]:
        L += [f"![{p.stem}]({p.relative_to(rep.out_dir)})", ""]
    return L


def html_section(rep, img) -> list[str]:
    import html as h
    out = rep.residual
    head, rows = _table(out)
    H = ["<h2 id='residual'>Inverter-compensation residual</h2>",
         f"<p>{h.escape(INTRO.format(real=100 * REALISTIC))}</p><table><tr>"
         + "".join(f"<th>{h.escape(c)}</th>" for c in head) + "</tr>"]
    for r in rows:
        H.append("<tr>" + "".join(f"<td class='{h.escape(c.replace(' ', '_'))}'>{h.escape(c)}</td>"
                                  for c in r) + "</tr>")
    H.append("</table>")
    for p in out["plots"]:
        H.append(img(p))
    return H


def to_json(out: dict) -> dict:
    """The study as plain data (reports/claims/residual.json)."""
    return {cid: {"holds_up_to": holds_up_to(pts),
                  "points": [{"residual": p.residual, "verdict": p.verdict,
                              "rows": [{"key": r.key, "measured": r.value, "verdict": r.verdict,
                                        "note": r.note} for r in p.rows]} for p in pts]}
            for cid, pts in out["points"].items()}


def _finite(x: float) -> float | None:
    return x if isinstance(x, float) and math.isfinite(x) else None
