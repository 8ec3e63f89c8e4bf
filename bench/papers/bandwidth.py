"""Estimator-bandwidth sweeps (issue 16, point 5): every band a claim is judged by that depends on
a bandwidth the bench chose, measured again with that bandwidth scaled, in the claims report.

The papers' estimator gains are lost (Yuan's Table 1 is an image; Hou gives no PLL or tracking
gains), so the bench chose them: the SMOs' speed comes from a type-2 PLL on the observer's
angle (est_common.h: kp = 2 zeta wn, ki = wn^2; the controller's default wn = 150 rad/s,
zeta = 1), the sign and sigmoid SMOs low-pass their back EMF at wc (1000 / 2000 rad/s), HF
injection tracks the angle with a PI loop of bandwidth HFI_BW_RAD_S (300 rad/s in Hou's
scenarios). The report writes each run's values (report.estimator_settings); this study says how
the verdict moves with them. A sweep is (claim, bandwidth): the claim's own verdict runs again at
the scenario's own residual and set-up with that one bandwidth x ``SCALES`` of the value the run
chose (zeta kept), each point judged by the claim's own rules (report.judge_claim), and the claim
"holds for bandwidths in [a, b]": the contiguous stretch of the grid around the chosen value
(1 x) where every point holds (PASS, or COMPARED with every relation passing).

Which claims, which bandwidth, and why (``SWEEPS``):

* Y1 x PLL wn (both runs): Y1's bands are speed-estimation error bands (+-1.5 / +-3 rpm improved,
  +-4 / +-6 conventional), and both SMOs' speed is the PLL's; the noise of the angle (ADC, the
  observer's chattering, the dead-time ripple) reaches the speed through the PLL's bandwidth
  (the issue: even without dead time the 10 rpm error is 2.9 rpm at 150 rad/s).
* Y1 x SMO EMF cut-off wc (both runs): the sign SMO filters its switching function at 1000 rad/s
  (the improved one at 2000) against 4.2 rad/s electrical at 10 rpm: the filter decides how
  much chattering reaches the angle, so the speed band depends on it too. No claim judges an
  angle band on an SMO with this filter: the angle bands (G2-G4, G7 position-estimation error)
  are Gong's tanh SMO, which has no low-pass (Gong's point), and H3's is HF injection.
* Y8 x PLL wn: Table 4's error bands vs speed are Y1's improved-SMO speed band at five speeds.
* Y2 x PLL wn: the estimator response time (6.5 vs 4.1 ms) is a speed transient seen through
  the PLL; a type-2 loop's response scales with 1 / wn.
* H1 x HFI tracking bandwidth (the HFI run) and x PLL wn (the SMO run): H1 compares speed
  errors (HFI about +-1.5 / +-3 rpm, SMO +-4 / +-6) and is judged by the ranking HFI < SMO; each
  estimator's speed is its tracking loop's. The HFI speed also passes the scenario's 300 rad/s
  speed low-pass (SPEED_LPF_RAD_S), which stays as chosen.
* H2 x HFI tracking bandwidth and x PLL wn: the response time and speed drop after the load step
  are transients of the same loops.

A point's run is an ordinary claim run: the claim's scenario with CONFIG overrides
(``controller.params.PLL_KP`` / ``PLL_KI``, ``HFI_BW_RAD_S``, ``SMO_WC_RAD_S``) like
``bench run --set``, so its recording's CONFIG says what ran (report.estimator_settings), and the
1 x point sends the chosen value explicitly even where the scenario leaves it to the
controller's default. A run whose estimator does not have the bandwidth is the claim's own run.

``plan()`` lists the runs, ``evaluate(plan, rep, judge)`` measures them after the report ran
them; ``markdown`` / ``html_section`` write the section; plots go to
``<out>/plots/bandwidth_<claim>_<bandwidth>.png``; ``to_json`` is ``<out>/bandwidth.json``.
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from typing import Any, Callable

from hil_bench.claims.model import Claim, Run
from hil_bench.claims.registry import CLAIMS

from .claim_variants import Holds, Judge, base_runs, claim_on, derived_run

#: the grid, as multiples of the value each run chose
SCALES = (0.25, 0.5, 1.0, 2.0, 4.0)
#: ``bench claims --run --quick``
QUICK_SCALES = (0.5, 1.0, 2.0)
#: the controller's PLL when the scenario sends no PLL_KP / PLL_KI (firmware_stub/src/
#: controller.c estimator_init, est_pll_gains(150): kp = 2 wn, ki = wn^2; protocol/params.py)
PLL_DEFAULT_WN_RAD_S = 150.0
PLL_DEFAULT_ZETA = 1.0

_SMOS = ("SMO_SIGN", "SMO_SIGMOID", "SMO_TANH", "SMO_STA")


@dataclass(frozen=True)
class Bandwidth:
    """One estimator bandwidth: its CONFIG parameters, the estimators that have it, the value a
    run chose (from the CONFIG the host sends it) and the overrides that scale it."""
    name: str
    label: str                                  # "PLL wn"
    estimators: tuple[str, ...]
    chosen: Callable[[dict[str, float]], float]  # CONFIG -> rad/s
    overrides: Callable[[dict[str, float], float], tuple[tuple[str, float], ...]]  # (CONFIG, s)

    def applies(self, estimator: str) -> bool:
        return estimator in self.estimators


def _pll(controller: dict[str, float]) -> tuple[float, float]:
    """(wn rad/s, zeta) of the PLL a run's CONFIG sets: each gain not sent (or <= 0) is the
    controller's default, as estimator_init does."""
    kp = controller.get("PLL_KP", 0.0)
    ki = controller.get("PLL_KI", 0.0)
    if not ki > 0.0:
        ki = PLL_DEFAULT_WN_RAD_S ** 2
    if not kp > 0.0:
        kp = 2.0 * PLL_DEFAULT_ZETA * PLL_DEFAULT_WN_RAD_S
    wn = math.sqrt(ki)
    return wn, kp / (2.0 * wn)


def _pll_overrides(controller: dict[str, float], s: float) -> tuple[tuple[str, float], ...]:
    wn, zeta = _pll(controller)
    return (("controller.params.PLL_KP", 2.0 * zeta * s * wn),
            ("controller.params.PLL_KI", (s * wn) ** 2))


def _param_default(name: str) -> float:
    from hil_bench.protocol.params import PARAMS
    return float(next(p.default for p in PARAMS if p.name == name))


def _single(param: str) -> tuple[Callable, Callable]:
    def chosen(controller: dict[str, float]) -> float:
        v = controller.get(param, 0.0)
        return v if v > 0.0 else _param_default(param)

    def overrides(controller: dict[str, float], s: float) -> tuple[tuple[str, float], ...]:
        return ((f"controller.params.{param}", s * chosen(controller)),)
    return chosen, overrides


def _hfi_chosen(controller: dict[str, float]) -> float:
    if controller.get("HFI_PI_KP", 0.0) > 0.0 or controller.get("HFI_PI_KI", 0.0) > 0.0:
        raise ValueError("the scenario sets HFI_PI_KP / HFI_PI_KI: HFI_BW_RAD_S does not set its "
                         "tracking loop, so it cannot be swept")
    return _single("HFI_BW_RAD_S")[0](controller)


PLL = Bandwidth("pll", "PLL wn", _SMOS, lambda c: _pll(c)[0], _pll_overrides)
HFI_BW = Bandwidth("hfi_bw", "HFI tracking bandwidth", ("HFI_SDFT",), _hfi_chosen,
                   _single("HFI_BW_RAD_S")[1])
SMO_WC = Bandwidth("smo_wc", "SMO EMF cut-off wc", ("SMO_SIGN", "SMO_SIGMOID"),
                   *_single("SMO_WC_RAD_S"))
BANDWIDTHS = {b.name: b for b in (PLL, HFI_BW, SMO_WC)}

#: (claim, bandwidth): the bands that depend on a chosen bandwidth (module docstring: why each)
SWEEPS: tuple[tuple[str, str], ...] = (
    ("Y1", "pll"), ("Y1", "smo_wc"), ("Y8", "pll"), ("Y2", "pll"),
    ("H1", "hfi_bw"), ("H1", "pll"), ("H2", "hfi_bw"), ("H2", "pll"))


def _setup(run: Run):
    from .conditions import expected
    return expected(run)


def chosen(run: Run, bw: Bandwidth) -> float | None:
    """The value of ``bw`` a claim run chose (rad/s), None when its estimator has none."""
    setup = _setup(run)
    return bw.chosen(setup.controller) if bw.applies(setup.estimator) else None


def tag(bw: Bandwidth, s: float, residual: float | None = None) -> str:
    """A point in a run id: 'bw.pllx0.25' (at the scenario's residual), 'bw.pllx0.25.r0' (at 0 %)."""
    return f"bw.{bw.name}x{s:g}" + ("" if residual is None else f".r{100 * residual:g}")


def variant(run: Run, bw: Bandwidth, s: float, residual: float | None = None) -> Run:
    """``run`` with ``bw`` at s x its chosen value (the run itself when its estimator has no
    such bandwidth), at the scenario's compensation residual or at ``residual``."""
    from .residual import KEY
    setup = _setup(run)
    extra_ov = () if residual is None else ((KEY, residual),)
    res_label = "" if residual is None else f", compensation residual {100 * residual:g} %"
    if not bw.applies(setup.estimator):
        if residual is None:
            return run
        return derived_run(run, f"r{100 * residual:g}", extra_ov,
                           f"compensation residual {100 * residual:g} %")
    value = bw.chosen(setup.controller)
    extra = ""
    if bw is PLL:
        extra = f", zeta {_pll(setup.controller)[1]:.3g}"
    return derived_run(run, tag(bw, s, residual), bw.overrides(setup.controller, s) + extra_ov,
                       f"{bw.label} {s * value:g} rad/s ({s:g} x the chosen {value:g}{extra})"
                       + res_label)


def claim_at(c: Claim, bw: Bandwidth, s: float, residual: float | None = None) -> Claim:
    """The claim measured on its runs with ``bw`` at s x: its non-diagnostic rows."""
    return claim_on(c, lambda run: variant(run, bw, s, residual))


@dataclass
class Sweep:
    claim: str
    bandwidth: str
    scales: list[float]
    chosen: dict[str, float]          # run id -> the value it chose, rad/s (the runs swept)
    residual: float | None = None     # None: the scenarios' residual

    @property
    def bw(self) -> Bandwidth:
        return BANDWIDTHS[self.bandwidth]

    @property
    def key(self) -> str:
        return f"{self.claim}.{self.bandwidth}" + ("" if self.residual is None else
                                                   f".r{100 * self.residual:g}")

    @property
    def at(self) -> str:
        return ("at the scenarios' residual" if self.residual is None else
                f"at {100 * self.residual:g} % residual")


@dataclass
class Plan:
    sweeps: list[Sweep] = field(default_factory=list)
    runs: list[Run] = field(default_factory=list)


#: the residuals every sweep runs at: the scenarios' own, and exact compensation (at 5 % every Y
#: point stalled: issue 27, 6)
SWEEP_RESIDUALS: tuple[float | None, ...] = (None, 0.0)


def plan(claims: list[str] | None = None, scales: tuple[float, ...] = SCALES,
         sweeps: tuple[tuple[str, str], ...] = SWEEPS,
         residuals: tuple[float | None, ...] = SWEEP_RESIDUALS) -> Plan:
    """The sweeps of ``claims`` (default: every claim of ``SWEEPS``), at each of ``residuals``
    (None: the scenarios' residual), and the runs they add (the runs a sweep leaves as they are
    are the claim's own, run by the report anyway)."""
    pl = Plan()
    seen: set[str] = set()
    for cid, name in sweeps:
        if claims is not None and cid not in claims:
            continue
        bw = BANDWIDTHS[name]
        c = CLAIMS[cid]
        swept = {run.id: chosen(run, bw) for run in base_runs(c)}
        swept = {k: v for k, v in swept.items() if v is not None}
        if not swept:
            raise ValueError(f"{cid}: no run of its verdict has the {bw.label}")
        own = {r.id for r in c.runs}
        for res in residuals:
            pl.sweeps.append(Sweep(cid, name, sorted(set(scales)), swept, res))
            for s in scales:
                for run in claim_at(c, bw, s, res).runs:
                    if run.id not in own and run.id not in seen:
                        seen.add(run.id)
                        pl.runs.append(run)
    return pl


@dataclass
class Point(Holds):
    scale: float
    verdict: str                     # the claim's verdict at this scale (report.claim_verdict)
    rows: list                       # report.Row of the claim's non-diagnostic rows
    recorded: dict[str, float | None] = field(default_factory=dict)  # swept run -> its CONFIG's


def recorded_value(recording, bw: Bandwidth) -> float | None:
    """The bandwidth a recording's CONFIG says ran (rad/s; a gain not sent is the controller's
    default, as for the plan); None without a readable recording."""
    import json
    from hil_bench.record.recording import read_header
    try:
        params = json.loads(read_header(recording).run.get("controller_params", "{}"))
    except Exception:  # noqa: BLE001 - said in the table ("not recorded"), never a crash
        return None
    return bw.chosen({k: float(v) for k, v in params.items()})


def holds_range(points: list[Point]) -> tuple[float, float] | None:
    """(lowest, highest) scale of the contiguous stretch of holding points around the chosen
    value (scale 1); None when the claim does not hold at the chosen value (or 1 x is not on
    the grid)."""
    pts = sorted(points, key=lambda p: p.scale)
    i = next((k for k, p in enumerate(pts) if math.isclose(p.scale, 1.0)), None)
    if i is None or not pts[i].holds:
        return None
    lo = hi = i
    while lo > 0 and pts[lo - 1].holds:
        lo -= 1
    while hi + 1 < len(pts) and pts[hi + 1].holds:
        hi += 1
    return pts[lo].scale, pts[hi].scale


def measure(pl: Plan, rep, judge: Judge) -> dict[str, list[Point]]:
    out: dict[str, list[Point]] = {}
    for sw in pl.sweeps:
        pts = []
        for s in sw.scales:
            c = claim_at(CLAIMS[sw.claim], sw.bw, s, sw.residual)
            verdict, rows = judge(c, rep.outcomes)
            rec = {}
            t = tag(sw.bw, s, sw.residual)
            for run in c.runs:
                if run.id.startswith(t + "."):
                    o = rep.outcomes.get(run.id)
                    base = run.id[len(t) + 1:]
                    rec[base] = recorded_value(o.recording, sw.bw) if o else None
            pts.append(Point(s, verdict, rows, rec))
        out[sw.key] = pts
    return out


def evaluate(pl: Plan, rep, judge: Judge) -> dict[str, Any]:
    points = measure(pl, rep, judge)
    from .report_plots import plot_bandwidth
    plots = []
    for sw in pl.sweeps:
        pts = points[sw.key]
        rng = holds_range(pts)
        p = plot_bandwidth(rep, _plot_name(sw),
                           f"{sw.claim} vs {sw.bw.label} {sw.at}: " + (
                               "does not hold at the chosen value" if rng is None else
                               f"holds for {rng[0]:g} .. {rng[1]:g} x the chosen"),
                           f"{sw.bw.label} / the chosen value ({_chosen_text(sw)})", pts)
        if p is not None:
            plots.append(p)
    return {"plan": pl, "points": points, "plots": plots}


# -- writing --------------------------------------------------------------------------------------

def _plot_name(sw: Sweep) -> str:
    return f"bandwidth_{sw.key.replace('.', '_')}"


def _chosen_text(sw: Sweep) -> str:
    vals = sorted(set(sw.chosen.values()))
    if len(vals) == 1:
        return f"{vals[0]:g} rad/s"
    return ", ".join(f"{rid} {v:g} rad/s" for rid, v in sw.chosen.items())


def holds_text(sw: Sweep, points: list[Point]) -> str:
    """'holds for PLL wn in [75, 300] rad/s' (per run where the runs chose different values)."""
    rng = holds_range(points)
    if rng is None:
        held = [p.scale for p in sorted(points, key=lambda p: p.scale) if p.holds]
        return ("does not hold at the chosen value" + (
            f" (holds at {', '.join(f'{s:g} x' for s in held)})" if held else
            " nor anywhere on the grid"))
    lo, hi = rng
    grid = sorted(p.scale for p in points)
    edge = []
    if lo == grid[0]:
        edge.append("the grid's lowest")
    if hi == grid[-1]:
        edge.append("the grid's highest")
    vals = sorted(set(sw.chosen.values()))
    if len(vals) == 1:
        where = f"[{lo * vals[0]:g}, {hi * vals[0]:g}] rad/s"
    else:
        where = "; ".join(f"{rid} [{lo * v:g}, {hi * v:g}]" for rid, v in sw.chosen.items()) + \
                " rad/s"
    return (f"holds for {sw.bw.label} in {where} ({lo:g} .. {hi:g} x the chosen)"
            + (f"; {' and '.join(edge)} point holds too, the range may be wider" if edge else ""))


def _cell(row) -> str:
    """A row at one point: the measured figure and verdict, and why a figure is not the paper's
    operating point (the drive did not hold it: the true speed) or there is none (the fault and
    when)."""
    note = str(row.note)
    if not math.isfinite(row.value) and "ended early" in note:
        m = re.search(r"at cycle (\d+) \(t = ([0-9.]+) s\)", note)
        f = re.search(r"fault (\w+) at seq", note)
        return (f"no value: {f.group(1) if f else 'the run ended'}"
                + (f" at t = {float(m.group(2)):.3g} s" if m else "") + f" {row.verdict}")
    m = re.search(r"did not hold (\S+ rpm): true speed (\S+ rpm)", note)
    if m:
        return f"{row.measured} {row.verdict} (not at {m.group(1)}: true speed {m.group(2)})"
    return f"{row.measured} {row.verdict}"


def _recorded_cell(p: Point) -> str:
    """The value each swept run's recording says ran: 'wn 37.5 rad/s' (per run if they differ)."""
    vals = set(p.recorded.values())
    fmt = lambda v: "not recorded" if v is None else f"{v:.4g} rad/s"  # noqa: E731
    if len(vals) == 1:
        return fmt(vals.pop())
    return ", ".join(f"{rid} {fmt(v)}" for rid, v in p.recorded.items())


def table(sw: Sweep, points: list[Point]) -> tuple[list[str], list[list[str]]]:
    """Rows: the claim's verdict, then each non-diagnostic quantity and relation (measured
    figure and verdict); columns: the bandwidth's points."""
    pts = sorted(points, key=lambda p: p.scale)
    vals = sorted(set(sw.chosen.values()))
    head = [f"{sw.bw.label} (x chosen)"] + [
        (f"{p.scale * vals[0]:g} rad/s ({p.scale:g} x)" if len(vals) == 1 else f"{p.scale:g} x")
        for p in pts]
    rows = [["claim verdict"] + [p.verdict for p in pts],
            ["as recorded (CONFIG)"] + [_recorded_cell(p) for p in pts]]
    keys: list[tuple[str, str]] = []
    for p in pts:
        for r in p.rows:
            if (r.key, r.what) not in keys:
                keys.append((r.key, r.what))
    for key, what in keys:
        cells = []
        for p in pts:
            row = next((r for r in p.rows if r.key == key), None)
            cells.append(_cell(row) if row is not None else "")
        rows.append([("relation: " if any(r.is_relation for p in pts for r in p.rows
                                          if r.key == key) else "") + what] + cells)
    return head, rows


def summary(out: dict) -> dict[str, str]:
    return {sw.key: holds_text(sw, out["points"][sw.key]) for sw in out["plan"].sweeps}


INTRO = ("The papers' estimator gains are lost, so the bench chose them (each run's values are in "
         "its claim's 'Estimator settings'). Each sweep runs the claim's own runs again, at their "
         "own residual and set-up, with one bandwidth at a multiple of the value each run chose "
         "(the PLL's damping kept), sent as CONFIG like `bench run --set`, and judges every point "
         "with the claim's own rules; 'holds for' is the contiguous stretch of the grid around "
         "the chosen value (1 x) where the claim holds (PASS, or COMPARED with its relations "
         "passing). Runs whose estimator has no such bandwidth are the claim's own runs. Why "
         "each claim and bandwidth: bench/papers/bandwidth.py.")


def _sweep_title(sw: Sweep) -> str:
    return f"{sw.claim} vs {sw.bw.label} {sw.at} (chosen: {_chosen_text(sw)})"


def markdown(rep) -> list[str]:
    out = rep.bandwidth
    L = ["## Estimator-bandwidth sweeps", "", INTRO, ""]
    plots = {p.stem: p for p in out["plots"]}
    for sw in out["plan"].sweeps:
        pts = out["points"][sw.key]
        head, rows = table(sw, pts)
        L += [f"### {_sweep_title(sw)}", "", f"{sw.claim} {holds_text(sw, pts)}.", "",
              "| " + " | ".join(_md(c) for c in head) + " |", "|" + "---|" * len(head)]
        L += ["| " + " | ".join(_md(c) for c in r) + " |" for r in rows]
        L.append("")
        p = plots.get(_plot_name(sw))
        if p is not None:
            L += [f"![{p.stem}]({p.relative_to(rep.out_dir)})", ""]
    return L


def _md(s: str) -> str:
    return str(s).replace("|", "\\|").replace("\n", " ")


def html_section(rep, img) -> list[str]:
    import html as h
    out = rep.bandwidth
    plots = {p.stem: p for p in out["plots"]}
    H = ["<h2 id='bandwidth'>Estimator-bandwidth sweeps</h2>", f"<p>{h.escape(INTRO)}</p>"]
    for sw in out["plan"].sweeps:
        pts = out["points"][sw.key]
        head, rows = table(sw, pts)
        H.append(f"<h3>{h.escape(_sweep_title(sw))}</h3><p>{h.escape(sw.claim)} "
                 f"{h.escape(holds_text(sw, pts))}.</p><table><tr>"
                 + "".join(f"<th>{h.escape(c)}</th>" for c in head) + "</tr>")
        for r in rows:
            H.append("<tr>" + "".join(
                f"<td class='{h.escape(_verdict_class(c))}'>{h.escape(c)}</td>" for c in r)
                + "</tr>")
        H.append("</table>")
        p = plots.get(_plot_name(sw))
        if p is not None:
            H.append(img(p))
    return H


_VERDICTS = ("NOT REPRODUCIBLE", "NOT RESOLVED", "COMPARED", "INVALID", "PARTLY", "PASS", "FAIL",
             "UNTESTED", "DEPENDS")


def _verdict_class(cell: str) -> str:
    """The CSS class of a cell: the verdict it states (after the figure, before a reason)."""
    head = cell.split(" (not at ")[0]
    return next((v.replace(" ", "_") for v in _VERDICTS if head.endswith(v)), "")


def to_json(out: dict) -> dict:
    """The sweeps as plain data (reports/claims/bandwidth.json)."""
    res = {}
    for sw in out["plan"].sweeps:
        pts = out["points"][sw.key]
        rng = holds_range(pts)
        res[sw.key] = {
            "claim": sw.claim, "bandwidth": sw.bandwidth, "label": sw.bw.label,
            "residual": sw.residual,
            "chosen_rad_s": sw.chosen, "holds_scales": list(rng) if rng else None,
            "holds": holds_text(sw, pts),
            "points": [{"scale": p.scale, "verdict": p.verdict, "recorded_rad_s": p.recorded,
                        "rows": [{"key": r.key, "measured": _finite(r.value),
                                  "verdict": r.verdict, "note": r.note} for r in p.rows]}
                       for p in sorted(pts, key=lambda p: p.scale)]}
    return res


def _finite(x: float) -> float | None:
    return x if isinstance(x, float) and math.isfinite(x) else None
