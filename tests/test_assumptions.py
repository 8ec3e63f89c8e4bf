"""Verdicts that name their assumption (bench/papers/assumptions.py) and the comparator study
(bench/papers/comparators.py): which claims run over which numbers, the runs each point adds, the
verdict across the range (PASS / FAIL only where every point agrees, else DEPENDS with the
threshold), and the comparator settings the papers support. The runs themselves are in `bench
claims --run` (docs/claims.md, "Verdicts that name their assumption", "The comparators")."""
from __future__ import annotations

import math

import pytest

from hil_bench.claims.registry import CLAIMS
from hil_bench.papers import assumptions as asm
from hil_bench.papers import comparators as cmp
from hil_bench.papers import residual as rs
from hil_bench.papers.claim_variants import base_runs


def test_the_axes_name_what_the_paper_does_not_give():
    assert [a.name for a in asm.AXES["H3"]] == ["dead time", "node capacitance",
                                                "compensation residual"]
    for cid, axes in asm.AXES.items():
        for a in axes:
            assert any(math.isclose(v, a.default) for v in a.values), (cid, a.name)
            assert a.paper and a.default_source and a.range_source, (cid, a.name)
    dt = asm.AXES["H3"][0]
    assert "Hou gives no dead time" in dt.paper and "Yuan's fit" in dt.default_source
    assert (min(dt.values), max(dt.values)) == (0.5e-6, 3.0e-6)
    # no axis where the paper gives every number, or the verdict has no pass/fail to move
    for cid in ("G1", "G2", "G3", "G4", "G5", "Y5", "Y6"):
        assert cid not in asm.AXES and asm.NO_AXIS[cid]


def test_a_dead_time_point_scales_the_commutation_band_and_keeps_the_rest():
    from hil_bench.plant_rt.profile import load_profile
    run = CLAIMS["H3"].run("H3.pure.0deg.sw")
    v = asm.AXES["H3"][0].run_at(run, 1.0e-6)
    ov = dict(v.overrides)
    prof = load_profile("hou2021")
    assert ov["plant.dead_time_s"] == 1.0e-6
    assert ov["plant.i_cap_band_a"] == pytest.approx(prof.i_cap_band_a * 1.78, rel=1e-4)
    assert v.overrides[:len(run.overrides)] == run.overrides and v.id == "dt1.H3.pure.0deg.sw"
    assert asm.AXES["H3"][0].run_at(run, 1.78e-6) is run          # the default: the claim's own
    # the residual axis reads the residual study's runs (same ids: run once)
    r = asm.AXES["H3"][2].run_at(run, 0.0)
    assert r.id == rs.variant(run, 0.0).id


def test_the_plan_adds_each_point_once_on_the_deciding_runs():
    pl = asm.plan(["H3", "G7"])
    ids = [r.id for r in pl.runs]
    assert len(ids) == len(set(ids))
    h3 = {r.id for r in base_runs(CLAIMS["H3"])}
    assert h3 == {f"H3.pure.{a}deg.sw" for a in (0, 45, 90, 135, 180)}
    assert "dt0.5.H3.pure.90deg.sw" in ids and "cn3.H3.pure.90deg.sw" in ids
    assert "dt0.5.G67.2000.on.sw" in ids


def _result(values_verdicts, axis=None):
    axis = axis or asm.AXES["H3"][0]
    return asm.AxisResult(axis, [asm.Point(v, verdict, []) for v, verdict in values_verdicts])


def test_pass_or_fail_only_across_the_range_else_depends_with_the_threshold():
    us = 1e-6
    held = _result([(0.5 * us, "PASS"), (1.0 * us, "PASS"), (1.78 * us, "FAIL"),
                    (2.5 * us, "FAIL"), (3.0 * us, "FAIL")])
    assert asm.verdict_across("FAIL", [held]) == "DEPENDS"
    assert held.threshold() == "holds for dead time <= 1 us (fails from 1.78 us)"
    assert "Hou gives no dead time" in held.text()
    fails = _result([(v * us, "FAIL") for v in (0.5, 1.0, 1.78, 2.5, 3.0)])
    assert asm.verdict_across("FAIL", [fails]) == "FAIL"
    assert fails.threshold() == "holds at no dead time of 0.5-3 us"
    assert fails.short() == ("dead time: holds at no dead time of 0.5-3 us (Hou gives no dead time "
                             "(no power stage is named); the scenarios' 1.78 us is Yuan's fit)")
    passes = _result([(v * us, "PASS") for v in (0.5, 1.0, 1.78, 2.5, 3.0)])
    assert asm.verdict_across("PASS", [passes, fails]) == "DEPENDS"
    assert asm.verdict_across("PASS", [passes]) == "PASS"
    middle = _result([(0.5 * us, "FAIL"), (1.0 * us, "PASS"), (1.78 * us, "PASS"),
                      (3.0 * us, "FAIL")])
    assert middle.threshold() == "holds at dead time 1 us, 1.78 us only"
    # a broken point does not vote, and is named; it never lets a PASS stand for the range
    broken = _result([(0.5 * us, "INVALID"), (1.78 * us, "FAIL")])
    assert asm.verdict_across("FAIL", [broken]) == "FAIL"
    assert broken.threshold() == ("holds at no dead time measured of 0.5-1.78 us; no pass/fail "
                                  "at 0.5 us (INVALID)")
    lone = _result([(0.5 * us, "INVALID"), (1.0 * us, "INVALID"), (1.78 * us, "PASS"),
                    (2.5 * us, "INVALID"), (3.0 * us, "INVALID")])
    assert asm.verdict_across("PASS", [lone]) == "INVALID"    # review: was PASS on one point
    assert lone.threshold().startswith("holds at every dead time measured of 0.5-3 us; no "
                                       "pass/fail at 0.5 us (INVALID), 1 us (INVALID)")
    top = _result([(0.5 * us, "PASS"), (1.0 * us, "PASS"), (1.78 * us, "PASS"),
                   (2.5 * us, "FAIL"), (3.0 * us, "INVALID")])
    assert asm.verdict_across("PASS", [top]) == "DEPENDS"
    assert top.threshold() == ("holds for dead time <= 1.78 us (fails from 2.5 us); no pass/fail "
                               "at 3 us (INVALID)")
    untested = _result([(0.5 * us, "UNTESTED"), (1.78 * us, "PASS")])
    assert asm.verdict_across("PASS", [untested]) == "PARTLY"
    # a claim without pass / fail of its own: a failing point is not hidden behind it
    assert asm.verdict_across("UNTESTED", [fails]) == "DEPENDS"
    assert asm.verdict_across("NOT REPRODUCIBLE", [passes]) == "NOT REPRODUCIBLE"
    assert asm.verdict_across("INVALID", [passes]) == "INVALID"


def test_the_comparators_run_the_settings_the_papers_support():
    pl = cmp.plan(["Y1", "H1", "G2"])
    assert pl.claims == ("Y1", "H1")                  # G2 has no comparator
    by = {(c, st.name, plant): var.id for c, _run, st, plant, var in pl.points}
    assert by[("Y1", "eq5", "the claim's set-up")] == "Y1.conventional.sw"   # the claims' own
    assert by[("Y1", "eq5", "ideal inverter")] == "cmp.eq5.ideal.Y1.conventional.sw"
    assert by[("Y1", "k5v", "the claim's set-up")] == "cmp.k5v.Y1.conventional.sw"
    assert by[("H1", "fixed50", "ideal inverter")] == "cmp.fixed50.ideal.H1.smo.sw"
    run = next(r for r in pl.runs if r.id == "cmp.fixed50.ideal.H1.smo.sw")
    ov = dict(run.overrides)
    assert ov["plant.inverter_nonlinear"] is False
    # the STA's convergence condition at 50 rpm, margin 2 (est_smo_sta.h): k2 = 4 w^2 psi_f
    w = 50 / 60 * 2 * math.pi * 3
    assert ov["controller.params.SMO_STA_K2_V_S"] == pytest.approx(4 * w * w * 0.303, rel=1e-3)
    # Yuan's conventional SMO runs with his eq. 5 gain floor in the claims themselves
    from hil_bench.papers.conditions import expected
    assert expected(CLAIMS["Y1"].run("Y1.conventional")).controller["SMO_K_MIN_V"] == \
        pytest.approx(0.48)


def test_a_comparator_finding_says_where_it_holds():
    from hil_bench.papers.report import Row
    st = cmp.Setting("eq5", "k by eq. 5", ())
    row = Row("Y1", "k", "w", "1", "1 rpm", "rpm", "", "", "UNTESTED")
    pts = [cmp.Point("Y1", "r", st, cmp.PLANTS[0][0], True, []),
           cmp.Point("Y1", "r", st, cmp.PLANTS[1][0], False, [row])]
    f = cmp.finding({"points": pts}, "Y1")
    assert f.startswith("the comparator holds its operating points on the ideal inverter")
    assert "untested" in f
    none = cmp.finding({"points": [cmp.Point("Y1", "r", st, cmp.PLANTS[0][0], False, [row])]},
                       "Y1")
    assert none.startswith("no sourced setting holds")


def test_a_partly_claim_holds_and_a_point_without_pass_fail_does_not_vote():
    """G6 is PARTLY (its lags pass, its i_q relations are NOT RESOLVED): it holds at a point; a
    point whose verdict has no pass/fail (NOT RESOLVED, UNTESTED, INVALID) does not vote."""
    us = 1e-6
    partly = _result([(v * us, "PARTLY") for v in (0.5, 1.0, 1.78, 2.5, 3.0)])
    assert asm.verdict_across("PARTLY", [partly]) == "PARTLY"
    mixed = _result([(0.5 * us, "PARTLY"), (1.78 * us, "PARTLY"), (3.0 * us, "FAIL")])
    assert asm.verdict_across("PARTLY", [mixed]) == "DEPENDS"
    quiet = _result([(0.5 * us, "UNTESTED"), (1.78 * us, "FAIL"), (3.0 * us, "NOT RESOLVED")])
    assert asm.verdict_across("FAIL", [quiet]) == "FAIL"


def test_an_axis_without_pass_or_fail_says_so():
    nr = _result([(v * 1e-6, "NOT REPRODUCIBLE") for v in (0.5, 1.78, 3.0)])
    assert nr.threshold() == "no pass/fail at any dead time of 0.5-3 us (NOT REPRODUCIBLE)"


def test_a_comparator_point_with_invalid_rows_does_not_hold():
    """Review of issue 27: the study counted a broken run (INVALID rows, no value) as a point
    where the comparator holds, and the summary said so."""
    from hil_bench.papers.report import Row
    bad = Row("Y1", "k", "w", "1", "no value", "rpm", "", "", "INVALID", "run ended early: link lost")
    good = Row("Y1", "k", "w", "1", "2 rpm", "rpm", "", "", "PASS", "", value=2.0)
    assert not cmp._measured(bad)
    assert cmp._measured(good)
    assert not cmp._measured(Row("Y1", "k", "w", "1", "x", "rpm", "", "", "UNTESTED", "",
                                 value=2.0))
