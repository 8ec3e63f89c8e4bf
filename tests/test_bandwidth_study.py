"""The estimator-bandwidth sweeps (bench/papers/bandwidth.py): which claims and bandwidths, the
value each run chose, the runs at each scale and the CONFIG they send (one 20 ms real run), the
'holds for' logic, the report section and the CLI hook. The sweeps themselves run in
`bench claims --run` (docs/claims.md, "Bandwidth sweeps")."""
from __future__ import annotations

import json
import math
import re
from pathlib import Path
from types import SimpleNamespace

import pytest

from hil_bench.claims.registry import CLAIMS
from hil_bench.papers import bandwidth as bw
from hil_bench.papers.claim_variants import base_runs
from hil_bench.papers.report import Row


def test_the_sweeps_cover_the_speed_and_transient_bands():
    assert ("Y1", "pll") in bw.SWEEPS and ("H1", "hfi_bw") in bw.SWEEPS
    assert ("Y1", "smo_wc") in bw.SWEEPS
    assert 1.0 in bw.SCALES and 1.0 in bw.QUICK_SCALES
    assert min(bw.SCALES) <= 0.25 and max(bw.SCALES) >= 4.0


def test_the_chosen_values_are_what_each_run_sends_or_the_controllers_default():
    y1 = {r.id: r for r in CLAIMS["Y1"].runs}
    # the improved SMO: the host sends the reference estimator's PLL (kp 300, ki 22500)
    assert bw.chosen(y1["Y1.improved"], bw.PLL) == pytest.approx(150.0)
    # the sign SMO: nothing sent, the controller's default
    assert bw.chosen(y1["Y1.conventional"], bw.PLL) == pytest.approx(bw.PLL_DEFAULT_WN_RAD_S)
    assert bw.chosen(y1["Y1.conventional"], bw.SMO_WC) == pytest.approx(1000.0)
    assert bw.chosen(y1["Y1.conventional"], bw.HFI_BW) is None          # not an HFI run
    h1 = {r.id: r for r in CLAIMS["H1"].runs}
    assert bw.chosen(h1["H1.hfi"], bw.HFI_BW) == pytest.approx(300.0)   # hou_h1_hfi.toml
    assert bw.chosen(h1["H1.hfi"], bw.PLL) is None


def test_the_pll_default_is_the_c_estimators():
    """PLL_DEFAULT_WN_RAD_S / _ZETA are what the C's default config gives (est_pll_gains)."""
    from hil_bench.firmware_stub.est_smo import SmoSign
    cfg = SmoSign(0.6, 2e-3, 0.08, 1e-4).config
    wn = math.sqrt(cfg["pll_ki"])
    assert wn == pytest.approx(bw.PLL_DEFAULT_WN_RAD_S, rel=1e-6)
    assert cfg["pll_kp"] / (2 * wn) == pytest.approx(bw.PLL_DEFAULT_ZETA, rel=1e-6)


def test_pll_keeps_zeta_and_sends_both_gains():
    wn, zeta = bw._pll({"PLL_KP": 2 * 0.7 * 200.0, "PLL_KI": 200.0 ** 2})
    assert (wn, zeta) == pytest.approx((200.0, 0.7))
    o = dict(bw._pll_overrides({"PLL_KP": 280.0, "PLL_KI": 40000.0}, 0.5))
    assert o["controller.params.PLL_KI"] == pytest.approx(100.0 ** 2)
    assert o["controller.params.PLL_KP"] == pytest.approx(2 * 0.7 * 100.0)


def test_plan_runs_each_swept_run_at_each_scale():
    """Every sweep at the scenarios' residual and at 0 % (issue 27, 6: at 5 % every Y point
    stalled), on the runs that decide (the switching plant's twins)."""
    pl = bw.plan(["Y1", "H1"])
    assert {(s.claim, s.bandwidth, s.residual) for s in pl.sweeps} == {
        (c, b, r) for c, b in (("Y1", "pll"), ("Y1", "smo_wc"), ("H1", "hfi_bw"), ("H1", "pll"))
        for r in (None, 0.0)}
    ids = [r.id for r in pl.runs]
    assert len(ids) == len(set(ids))
    n = len(bw.SCALES)
    # Y1: both runs swept by both bandwidths at both residuals; H1: one run per bandwidth (the
    # other is its own at the scenarios' residual, its 0 % copy at 0 %: one run each)
    assert len(ids) == 2 * 2 * n * 2 + 2 * (2 * n + 1)
    own = {r.id for c in ("Y1", "H1") for r in CLAIMS[c].runs}
    assert not own & set(ids)
    hfi = [r for r in pl.runs if r.id.startswith("bw.hfi_bwx")]
    assert hfi and all(r.id.endswith(".H1.hfi.sw") for r in hfi)
    for r in hfi:
        s = _scale_of(r.id)
        ov = dict(r.overrides)
        assert ov["controller.params.HFI_BW_RAD_S"] == pytest.approx(300.0 * s)
        assert ov.get("controller.inverter_comp.residual", 0.05) == (0.0 if ".r0." in r.id
                                                                     else 0.05)
    quick = bw.plan(["Y1"], bw.QUICK_SCALES, residuals=(None,))
    assert len(quick.runs) == 2 * 2 * len(bw.QUICK_SCALES)
    assert bw.plan(["G2"]).sweeps == []


def test_claim_at_reads_the_variants_and_keeps_the_unswept_run():
    c = bw.claim_at(CLAIMS["H1"], bw.HFI_BW, 2.0)
    runs = {q.key: q.runs for q in c.quantities}
    assert runs["H1.hfi.10.sw"] == ("bw.hfi_bwx2.H1.hfi.sw",)
    assert runs["H1.smo.10.sw"] == ("H1.smo.sw",)           # SMO_STA has no HFI loop
    assert {rel.key for rel in c.relations} == {"H1.10.sw", "H1.50.sw"}
    c0 = bw.claim_at(CLAIMS["H1"], bw.HFI_BW, 2.0, 0.0)      # at 0 % residual: both runs copied
    runs0 = {q.key: q.runs for q in c0.quantities}
    assert runs0["H1.hfi.10.sw"] == ("bw.hfi_bwx2.r0.H1.hfi.sw",)
    assert runs0["H1.smo.10.sw"] == ("r0.H1.smo.sw",)
    assert all(not q.diagnostic for q in c.quantities)
    assert len(base_runs(CLAIMS["Y8"])) == 5


def test_variant_runs_meet_their_own_conditions_and_send_the_scaled_value():
    """The report checks each point's recording against the point's own run; its CONFIG is
    the scaled bandwidth (also where the scenario left it to the controller's default)."""
    from hil_bench.papers.conditions import expected
    conv = CLAIMS["Y1"].run("Y1.conventional")
    v = bw.variant(conv, bw.PLL, 0.25)
    ctl = expected(v).controller
    assert ctl["PLL_KI"] == pytest.approx(37.5 ** 2) and ctl["PLL_KP"] == pytest.approx(75.0)
    assert "PLL_KP" not in expected(conv).controller
    one = expected(bw.variant(conv, bw.PLL, 1.0)).controller
    assert one["PLL_KP"] == pytest.approx(300.0) and one["PLL_KI"] == pytest.approx(22500.0)
    imp = bw.variant(CLAIMS["Y1"].run("Y1.improved"), bw.SMO_WC, 4.0)
    assert expected(imp).controller["SMO_WC_RAD_S"] == pytest.approx(
        4.0 * bw.chosen(CLAIMS["Y1"].run("Y1.improved"), bw.SMO_WC))
    assert "PLL wn 37.5 rad/s (0.25 x the chosen 150, zeta 1)" in v.label


def test_a_points_recording_carries_the_scaled_bandwidth(tmp_path: Path):
    """One real 20 ms run of a point: the recording's CONFIG (what the controller was sent) and
    the report's settings line say the scaled PLL."""
    from hil_bench.claims.model import Run
    from hil_bench.papers.report import _run_one, estimator_settings
    from hil_bench.record.recording import read_header
    v = bw.variant(CLAIMS["Y1"].run("Y1.conventional"), bw.PLL, 2.0)
    short = Run(v.id, v.scenario, v.overrides + (("scenario.duration_s", 0.02),
                                                 ("metrics.window_s", [0.0, 0.02]),
                                                 ("events", [])), v.label)
    out = tmp_path / "p.mcap"
    ok, err, _wall, cycles = _run_one(short, str(out))
    assert ok, err
    params = json.loads(read_header(out).run["controller_params"])
    assert params["PLL_KP"] == pytest.approx(600.0) and params["PLL_KI"] == pytest.approx(90000.0)
    assert "PLL bandwidth wn 300 rad/s, zeta 1" in estimator_settings(out)
    assert bw.recorded_value(out, bw.PLL) == pytest.approx(300.0)
    assert bw.recorded_value(out, bw.SMO_WC) == pytest.approx(1000.0)     # not sent: default
    assert bw.recorded_value(tmp_path / "missing.mcap", bw.PLL) is None


def _scale_of(run_id: str) -> float:
    """The scale of a point's run id: 'bw.hfi_bwx0.5.H1.hfi' -> 0.5."""
    m = re.match(r"^bw\.[a-z_]+x([0-9]+(?:\.[0-9]+)?)\.(?:r[0-9.]+?\.)?(?=[A-Z])", run_id)
    assert m, run_id
    return float(m.group(1))


def _pts(verdicts):
    return [bw.Point(s, v, []) for s, v in verdicts]


def test_holds_range_is_the_stretch_around_the_chosen_value():
    pts = _pts([(0.25, "FAIL"), (0.5, "PASS"), (1.0, "PASS"), (2.0, "COMPARED"), (4.0, "FAIL")])
    assert bw.holds_range(pts) == (0.5, 2.0)
    # a holding point beyond a failure does not widen it
    assert bw.holds_range(_pts([(0.25, "PASS"), (0.5, "FAIL"), (1.0, "PASS"), (2.0, "PASS")])) \
        == (1.0, 2.0)
    assert bw.holds_range(_pts([(0.5, "PASS"), (1.0, "FAIL"), (2.0, "PASS")])) is None
    assert bw.holds_range(_pts([(0.5, "PASS"), (2.0, "PASS")])) is None     # 1 x not run
    assert bw.holds_range(_pts([(1.0, "INVALID")])) is None


def test_holds_text_names_the_bandwidths_in_rad_s():
    sw = bw.Sweep("Y1", "pll", [0.25, 0.5, 1.0, 2.0, 4.0], {"Y1.improved": 150.0,
                                                           "Y1.conventional": 150.0})
    pts = _pts([(0.25, "PASS"), (0.5, "PASS"), (1.0, "PASS"), (2.0, "FAIL"), (4.0, "FAIL")])
    t = bw.holds_text(sw, pts)
    assert t.startswith("holds for PLL wn in [37.5, 150] rad/s (0.25 .. 1 x the chosen)")
    assert "lowest" in t
    fails = bw.holds_text(sw, _pts([(0.5, "PASS"), (1.0, "FAIL"), (2.0, "FAIL")]))
    assert fails == "does not hold at the chosen value (holds at 0.5 x)"
    two = bw.Sweep("Y1", "smo_wc", [0.5, 1.0, 2.0], {"Y1.improved": 2000.0,
                                                     "Y1.conventional": 1000.0})
    t2 = bw.holds_text(two, _pts([(0.5, "FAIL"), (1.0, "PASS"), (2.0, "FAIL")]))
    assert "Y1.improved [2000, 2000]; Y1.conventional [1000, 1000] rad/s" in t2


def _row(key, value, verdict, paper="1.5 rpm", relation=False):
    return Row("Y1", key, key + " what", paper, f"{value:g} rpm", "rpm", "", "", verdict,
               value=value, is_relation=relation)


def test_the_report_section_tables_each_sweep(tmp_path: Path):
    from hil_bench.papers.report import _img

    (tmp_path / "plots").mkdir()
    pl = bw.plan(["H1"], (0.5, 1.0, 2.0), residuals=(None,))
    err = {0.5: 2.5, 1.0: 1.2, 2.0: 0.8}

    def judge(claim, outcomes):
        s = next(_scale_of(r.id) for r in claim.runs if r.id.startswith("bw."))
        verdict = "COMPARED" if err[s] < 2.0 else "FAIL"
        return verdict, [_row("H1.hfi.10", err[s], "COMPARED"),
                         _row("H1.10", err[s], "PASS" if err[s] < 2 else "FAIL", relation=True)]

    rep = SimpleNamespace(out_dir=tmp_path, outcomes={})
    rep.bandwidth = bw.evaluate(pl, rep, judge)
    assert len(rep.bandwidth["plots"]) == 2
    assert all(p.exists() and p.stat().st_size > 10_000 for p in rep.bandwidth["plots"])
    md = "\n".join(bw.markdown(rep))
    assert "## Estimator-bandwidth sweeps" in md
    assert ("### H1 vs HFI tracking bandwidth at the scenarios' residual (chosen: 300 rad/s)"
            in md)
    assert "H1 holds for HFI tracking bandwidth in [300, 600] rad/s (1 .. 2 x the chosen)" in md
    assert "| HFI tracking bandwidth (x chosen) | 150 rad/s (0.5 x) | 300 rad/s (1 x) | " \
           "600 rad/s (2 x) |" in md
    assert "| claim verdict | FAIL | COMPARED | COMPARED |" in md
    assert "| as recorded (CONFIG) | not recorded | not recorded | not recorded |" in md
    assert "| relation: H1.10 what | 2.5 rpm FAIL | 1.2 rpm PASS | 0.8 rpm PASS |" in md
    assert "![bandwidth_H1_hfi_bw](plots/bandwidth_H1_hfi_bw.png)" in md
    html = "\n".join(bw.html_section(rep, _img))
    assert "<td class='FAIL'>2.5 rpm FAIL</td>" in html and "data:image/png;base64" in html
    data = bw.to_json(rep.bandwidth)
    assert data["H1.hfi_bw"]["holds_scales"] == [1.0, 2.0]
    assert data["H1.hfi_bw"]["chosen_rad_s"] == {"H1.hfi.sw": 300.0}
    # at 0 % residual the sweep has its own key, plot and heading
    pl0 = bw.plan(["H1"], (0.5, 1.0, 2.0), sweeps=(("H1", "hfi_bw"),), residuals=(0.0,))
    assert [s.key for s in pl0.sweeps] == ["H1.hfi_bw.r0"] and "at 0 % residual" in \
        bw._sweep_title(pl0.sweeps[0])
    json.dumps(data)


def test_the_cli_and_the_command_line_carry_the_flag():
    from hil_bench.cli import build_parser
    from hil_bench.papers.report import command_of
    args = build_parser().parse_args(["claims", "--run", "--no-bandwidth", "--only", "Y1"])
    assert args.no_bandwidth
    assert command_of(Path("o"), ["Y1"], 2, False, False, False, None, False, False).endswith(
        "--no-residual --no-bandwidth")


def test_a_cell_says_why_a_figure_is_not_the_papers_operating_point():
    held_not = Row("Y1", "Y1.improved.50", "w", "3 rpm", "0.4839 rpm", "rpm", "", "", "FAIL",
                   note="the drive did not hold 50 rpm: true speed 0.235 rpm in the window "
                        "(range 0.214..0.257; bench definition: ...)", value=0.4839)
    assert bw._cell(held_not) == "0.4839 rpm FAIL (not at 50 rpm: true speed 0.235 rpm)"
    assert bw._verdict_class(bw._cell(held_not)) == "FAIL"
    fault = Row("H1", "H1.hfi.10", "w", "1.5 rpm", "no value: ...", "rpm", "", "", "FAIL",
                note="the run ended early: at cycle 1726 (t = 0.1726 s): controller fault: "
                     "controller reported fault OVERCURRENT at seq 1726 (detail 2) [...]")
    assert bw._cell(fault) == "no value: OVERCURRENT at t = 0.173 s FAIL"
    ok = Row("H1", "H1.hfi.10", "w", "1.5 rpm", "5.193 rpm", "rpm", "", "", "COMPARED",
             value=5.193)
    assert bw._cell(ok) == "5.193 rpm COMPARED" and bw._verdict_class("5.193 rpm COMPARED") \
        == "COMPARED"
