"""The inverter-compensation residual study (bench/papers/residual.py): its runs, the claims it
measures on them, 'holds up to', the refinement at a flip and the plot (no runs here: the study
itself runs in `bench claims --run`)."""
from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

from hil_bench.papers import residual as rs
from hil_bench.claims.registry import CLAIMS
from hil_bench.papers.report import Row


def test_plan_runs_every_claim_at_every_residual():
    pl = rs.plan()
    assert pl.claims == rs.RESIDUAL_CLAIMS
    ids = [r.id for r in pl.runs]
    assert len(ids) == len(set(ids))
    for cid in rs.RESIDUAL_CLAIMS:
        base = rs._base_runs(CLAIMS[cid])
        assert base, cid
        for r in rs.RESIDUALS:
            for run in base:
                v = rs.variant(run, r)
                assert v.id in ids and v.overrides[-1] == (rs.KEY, r) and v.scenario == run.scenario
    assert rs.REALISTIC in rs.RESIDUALS and 0.0 in rs.RESIDUALS and 1.0 in rs.RESIDUALS


def test_claim_at_keeps_the_verdicts_rows_on_the_residual_runs():
    c = rs.claim_at(CLAIMS["Y1"], 0.03)
    assert c.quantities and all(not q.diagnostic for q in c.quantities)
    run_ids = {r.id for r in c.runs}
    for q in c.quantities:
        assert set(q.runs) <= run_ids and all(x.startswith("r3.") for x in q.runs)
    keys = {q.key for q in c.quantities}
    assert c.relations and all(set(rel.keys) <= keys for rel in c.relations)
    h3 = rs.claim_at(CLAIMS["H3"], 0.1)
    assert {q.aggregate for q in h3.quantities} == {"max_abs", "polarity_failures"}
    assert all(len(q.runs) == 5 for q in h3.quantities)        # the five angles, HF-only test


def _pts(verdicts):
    return [rs.Point(r, v, []) for r, v in verdicts]


def test_holds_up_to_and_the_flip():
    pts = _pts([(0.0, "PASS"), (0.01, "PASS"), (0.02, "COMPARED"), (0.03, "FAIL"), (0.05, "PASS")])
    assert rs.holds_up_to(pts) == 0.02                      # not beyond the first failure
    assert rs.first_flip(pts) == (0.02, 0.03)
    assert rs.holds_up_to(_pts([(0.0, "FAIL"), (0.01, "PASS")])) is None
    assert rs.first_flip(_pts([(0.0, "PASS"), (1.0, "PASS")])) is None
    assert rs.holds_up_to(_pts([(0.0, "INVALID")])) is None


def test_refinement_runs_the_midpoint_once():
    pl = rs.plan(["H3"], residuals=(0.0, 0.1))
    n0 = len(pl.runs)
    pts = {"H3": _pts([(0.0, "PASS"), (0.1, "FAIL")])}
    extra = rs.refine_runs(pl, pts)
    assert len(extra) == 5 and all(r.id.startswith("r5.") for r in extra)
    assert 0.05 in pl.residuals["H3"] and len(pl.runs) == n0 + 5
    assert rs.refine_runs(pl, pts) == []                    # already there


def test_plot_draws_the_curve(tmp_path: Path):
    from hil_bench.papers.report_plots import plot_residual
    (tmp_path / "plots").mkdir()
    rep = SimpleNamespace(out_dir=tmp_path)
    pts = [rs.Point(r, "PASS" if r < 0.05 else "FAIL",
                    [Row("Y1", "Y1.improved.10", "w", "1.5", "", "rpm", "", "", "PASS",
                         value=1.0 + 30 * r)]) for r in rs.RESIDUALS]
    path = plot_residual(rep, "Y1", pts, rs.holds_up_to(pts), rs.REALISTIC)
    assert path.exists() and path.stat().st_size > 10_000
