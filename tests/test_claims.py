"""The claims registry (bench/claims/: the data and its definitions; bench/papers/claims.py: the
evaluation): all 19 claims, every rule with a source and none of the old unsourced '~'
tolerances, every run's scenario loads, every window inside its run, relations
over existing quantities (labels agreeing with their operators, ties below one telemetry LSB not
resolved); the fault diagnosis and the over-current trip below every ADC's full scale; three
short runaway runs end as named over-currents; and the TOML writer behind derived scenarios."""
import math
import tomllib

import numpy as np
import pytest

from hil_bench.claims import expand, model, registry
from hil_bench.papers import claim_metrics
from hil_bench.papers import claims as cl
from hil_bench.papers.report import scenario_for
from hil_bench.scenario import tomlw

PAPER_IDS = [f"Y{i}" for i in range(1, 9)] + ["H1", "H2", "H3"] + [f"G{i}" for i in range(1, 9)]


def test_every_paper_claim_is_registered():
    assert list(registry.CLAIMS) == PAPER_IDS


@pytest.mark.parametrize("cid", PAPER_IDS)
def test_claim_is_consistent(cid):
    c = registry.CLAIMS[cid]
    assert c.quantities
    run_ids = {r.id for r in c.runs}
    keys = [q.key for q in c.quantities]
    assert len(keys) == len(set(keys))
    for q in c.quantities:
        assert q.rule.kind in ("at_most", "within", "compared")
        assert q.rule.source.strip(), q.key                   # every rule says where it comes from
        if q.rule.kind == "within":
            assert q.rule.lo < q.rule.hi
        assert q.metric in claim_metrics.METRICS or q.metric in ("study", "derived"), q.key
        assert set(q.runs) <= run_ids, (q.key, q.runs)
        if q.study:
            assert q.study in c.studies
        assert q.paper_value is not None and str(q.paper_value) != ""   # both numbers shown
    for rel in c.relations:
        for k in rel.keys:
            assert k.startswith("#") or k in keys, (rel.key, k)


def test_no_unsourced_percent_tolerances_remain():
    text = "".join((registry.HERE / f).read_text() for f in registry.FILES)
    text += open(expand.__file__).read()
    assert '"~"' not in text and "tolerance" not in [f.name for f in
                                                        model.Quantity.__dataclass_fields__.values()]


@pytest.mark.parametrize("run", list(registry.all_runs().values()), ids=lambda r: r.id)
def test_every_run_builds_and_its_windows_fit(run):
    scn = scenario_for(run)
    assert scn.name == run.name
    for c in registry.CLAIMS.values():
        for q in c.quantities:
            if run.id in q.runs and q.window_s is not None:
                assert 0 <= q.window_s[0] < q.window_s[1] <= scn.duration_s + 1e-9, (q.key, run.id)


def test_derived_scenario_keeps_everything_else_and_names_the_override():
    run = registry.CLAIMS["H3"].run("H3.bias.45deg.nodt")
    scn = scenario_for(run)
    assert scn.plant_overrides["inverter_nonlinear"] == 0
    assert scn.initial_theta_e_rad == pytest.approx(math.radians(45))
    assert scn.controller_params[cl_param("HFI_POL_BIAS_A")] == 2.4
    assert scn.text.startswith("# derived from bench/scenarios/hou_h3_ipd.toml")
    assert scn.profile == "hou2021" and scn.claims == ("H3",)


def cl_param(name):
    from hil_bench.protocol.messages import Param
    return Param[name]


def test_toml_writer_round_trips():
    doc = {"scenario": {"name": "x@y", "duration_s": 1.5, "claims": ["G1"]},
           "plant": {"saturation": True, "load_table_nm": [0.0, 1.5]},
           "reference": {"estimators": ["SMO_TANH:m1"], "SMO_TANH:m1": {"m_per_a": 1.0}},
           "events": [{"t_s": 0.1, "speed_ref_rpm": -50.0, "label": 'a "quoted" label'},
                      {"t_s": 0.2, "load_torque_nm": 2}]}
    assert tomllib.loads(tomlw.dumps(doc)) == doc
    assert tomlw.set_dotted(doc, "plant.adc_model", False)["plant"]["adc_model"] is False
    assert "adc_model" not in doc["plant"]                   # a copy, not in place
    with pytest.raises(ValueError):
        tomlw.dumps({"x": math.nan})


def test_relations_and_derived_values():
    rel = model.Relation("r", "falls", ("a", "b", "c"), ">", "", "src")
    assert cl.relate(rel, {"a": 3.0, "b": 2.0, "c": 1.0})[1] == "PASS"
    assert cl.relate(rel, {"a": 3.0, "b": 2.0, "c": 2.5})[1] == "FAIL"
    assert cl.relate(rel, {"a": 3.0, "b": 2.0})[1] == "FAIL"            # missing: not a pass
    assert cl.relate(rel, {"a": 3.0, "b": 2.0, "c": 1.0}, frozenset({"b"}))[1] == \
        "NOT REPRODUCIBLE"
    eq = model.Relation("e", "equal", ("a", "b"), "=", "", "src", tol=0.005)
    assert cl.relate(eq, {"a": 4.081, "b": 4.084})[1] == "PASS"
    assert cl.relate(eq, {"a": 4.08, "b": 4.09})[1] == "FAIL"
    zero = model.Relation("z", "positive", ("#0", "a"), "<", "", "src")
    assert cl.relate(zero, {"a": -20.0})[1] == "FAIL"
    q = model.Quantity("d", "", "derived", 1.0, model.compared("s"),
                    params=(("op", "pct"), ("a", "on"), ("b", "off")))
    assert cl.derive(q, {"on": 1.08, "off": 1.15}) == pytest.approx(-6.087, abs=1e-3)


def test_rules():
    assert model.at_most(0.1, "s").verdict(0.1) == "PASS"
    assert model.at_most(0.1, "s").verdict(0.11) == "FAIL"
    assert model.at_most(0.1, "s").verdict(math.nan) == "FAIL"
    w = model.within(1.5, 2.5, "s")
    assert (w.verdict(1.5), w.verdict(2.5), w.verdict(1.46)) == ("PASS", "FAIL", "FAIL")
    assert model.compared("s").verdict(123.0) == "COMPARED"


def test_relation_label_must_match_its_operator():
    with pytest.raises(ValueError, match="does not match"):
        model.Relation("x", "with <= without", ("a", "b"), "<", "", "src")
    model.Relation("x", "with < without", ("a", "b"), "<", "", "src")       # fine


def test_relation_below_one_lsb_is_not_resolved():
    """A tie (or any difference under one LSB of what the values came from) cannot decide an
    ordering: NOT RESOLVED, never FAIL; one LSB or more decides it."""
    lsb = claim_metrics.speed_lsb_rpm(4)
    assert lsb == pytest.approx(0.1 / 4 * 60 / (2 * math.pi))           # 0.239 rpm
    assert claim_metrics.speed_lsb_rpm(3) == pytest.approx(0.3183, abs=1e-4)
    rel = model.Relation("r", "with < without", ("on", "off"), "<", "", "src")
    res = {"on": lsb, "off": lsb}
    assert cl.relate(rel, {"on": 0.3773, "off": 0.3773}, resolutions=res)[1] == "NOT RESOLVED"
    assert cl.relate(rel, {"on": 0.30, "off": 0.3773}, resolutions=res)[1] == "NOT RESOLVED"
    assert cl.relate(rel, {"on": 1.049 + lsb, "off": 1.049}, resolutions=res)[1] == "FAIL"
    assert cl.relate(rel, {"on": 1.049, "off": 1.049 + lsb}, resolutions=res)[1] == "PASS"
    assert cl.relate(rel, {"on": 0.3773, "off": 0.3773})[1] == "FAIL"      # exact values: a tie
    chain = model.Relation("c", "falls", ("a", "b", "c"), ">", "", "src")
    r = {"a": 0.1, "b": 0.1, "c": 0.1}
    # one pair resolved and wrong outweighs an unresolved one
    assert cl.relate(chain, {"a": 3.0, "b": 3.05, "c": 1.0}, resolutions=r)[1] == "NOT RESOLVED"
    assert cl.relate(chain, {"a": 3.0, "b": 3.05, "c": 3.5}, resolutions=r)[1] == "FAIL"


def test_derived_ratio_and_rule_on_derived_rows():
    q = model.Quantity("d", "", "derived", "1/3", model.compared("s"),
                    params=(("op", "ratio"), ("a", "g"), ("b", "s")))
    assert cl.derive(q, {"g": 7.0, "s": 23.0}) == pytest.approx(7 / 23)
    faster = registry.CLAIMS["Y5"].quantities[[q.key for q in registry.CLAIMS["Y5"].quantities]
                                        .index("Y5.faster")]
    # 'approximately 2-3 cycles', as the same page's 'approximately two / five': compared
    assert faster.verdict(3.34) == "COMPARED" and "approximately" in faster.rule.source


def test_papers_words_decide_the_rules():
    """issue 16.5 and 27.2: Y6 judged on the operations of the paper's recursions, with the
    library's instructions beside (diagnostic relation); one reading of the papers' words: G7's
    'slightly better' is an ordering checked like every other, H1's 'about +-3 rpm' a band
    (bound) like Gong's '+-7.5 rpm', Y4's 'significantly decrease from 8.06 % to 6.01 %' judged
    on its size; G1/G5 say what the averaged plant cannot test."""
    from hil_bench.papers import studies
    ops = studies.y6_ops()
    assert (ops["sdft_mul"], ops["sdft_add"]) == (16, 11)      # 5th + 7th, comb shared
    assert (ops["gsdft_mul"], ops["gsdft_add"]) == (16, 12)    # one add more: (1, -1, 1) comb
    assert ops["saving_ops"] == pytest.approx(100 * (1 - 28 / 27))
    assert np.allclose(studies.y6_comb_taps(24)[[0, 4, 8]], [1, -1, 1])
    y6 = registry.CLAIMS["Y6"]
    rel = {r.key: r for r in y6.relations}
    assert rel["Y6.rel"].keys == ("#0", "Y6.saving.ops") and not rel["Y6.rel"].diagnostic
    assert rel["Y6.rel.protected"].diagnostic
    assert cl.relate(rel["Y6.rel"], {"Y6.saving.ops": ops["saving_ops"]})[1] == "FAIL"
    g7 = [r for r in registry.CLAIMS["G7"].relations if not r.diagnostic]
    assert g7 and not any(r.compared for r in g7)
    assert cl.relate(g7[0], {g7[0].keys[0]: 1.29, g7[0].keys[1]: 1.05})[1] == "FAIL"
    assert cl.relate(g7[0], {g7[0].keys[0]: 1.0, g7[0].keys[1]: 1.05})[1] == "PASS"
    h1 = {q.key: q for q in registry.CLAIMS["H1"].quantities}
    for k, v in (("H1.hfi.10.sw", 1.5), ("H1.hfi.50.sw", 3.0), ("H1.hfi.10.conclusion.sw", 3.0)):
        assert h1[k].rule.kind == "at_most" and h1[k].rule.hi == v and not h1[k].diagnostic
    assert (h1["H1.hfi.10.sw"].rule.words, registry.CLAIMS["G2"].quantities[0].rule.words) == \
        ("about ±x", "±x")
    y4 = {r.key: r for r in registry.CLAIMS["Y4"].relations}
    thd = y4["Y4.10.THD"]
    assert thd.min_fall == pytest.approx((8.06 - 6.01) / 8.06)    # the smallest fall it names
    assert cl.relate(thd, {"Y4.10.on.THD": 8.35, "Y4.10.off.THD": 8.61})[1] == "FAIL"   # -3 %
    assert cl.relate(thd, {"Y4.10.on.THD": 6.0, "Y4.10.off.THD": 8.06})[1] == "PASS"
    assert cl.relate(thd, {"Y4.10.on.THD": 8.7, "Y4.10.off.THD": 8.6})[1] == "FAIL"    # rises
    g = {q.key: q for c in ("G1", "G5") for q in registry.CLAIMS[c].quantities}
    for k in ("G1.m0.01.thd", "G1.m0.01.amp"):
        assert g[k].not_reproducible.startswith("the bench cannot test this with the averaged "
                                                "plant"), k
    # G5's number measures the bench's sampling chain, on either plant (issue 27, 3)
    assert "sampling chain" in g["G5.td.sw"].not_reproducible
    # m >= 0.1 is unstable at the bench's 10 kHz whatever the plant: that reason stays
    assert "unstable" in g["G1.m1.thd"].not_reproducible


def test_calibration_input_has_no_verdict():
    y4 = {q.key: q for q in registry.CLAIMS["Y4"].quantities}
    assert y4["Y4.10.off.THD"].verdict(8.61) == "CALIBRATION"
    calibrated = [k for k, q in y4.items() if q.calibration]
    assert calibrated == ["Y4.10.off.THD"]      # every other Y4 row is the check


def test_diagnose_fault_names_a_clipped_overcurrent_not_a_sensor_fault():
    """A runaway whose currents pass the ADC's full scale: the clipped readings stop summing to
    zero and the sum check trips SENSOR_FAULT. The diagnosis must say over-current."""
    t = np.arange(200) * 1e-4
    true = np.stack([14.0 * np.sin(300 * t + k * 2 * np.pi / 3) for k in range(3)])
    read = np.clip(true, -10.0, 10.0 - 10.0 / 2048)
    why = cl.diagnose_fault("SENSOR_FAULT", true, read, 10.0, 565.0, 10.0, 899.0)
    assert why.startswith("not a sensor fault: an over-current beyond the ADC full scale")
    assert "lost its operating point" in why and "14 A" in why
    # inside the range: a real plausibility trip, said as such
    small = 0.5 * true / 14.0
    assert cl.diagnose_fault("SENSOR_FAULT", small, small + 0.4, 10.0, 10.0, 10.0, 10.2) \
        .startswith("sensor plausibility trip")
    oc = cl.diagnose_fault("OVERCURRENT", true, read, 10.0, -273.0, 10.0, 158.0, 10009854)
    assert oc.startswith("over-current: the drive had lost its operating point and its estimate")
    assert oc.endswith("phase b read 9.854 A at the trip")           # FAULT_CTRL detail
    assert cl.diagnose_fault("STARTUP_FAILED", true, read, 10.0, 0.0, 10.0, 0.0) == ""


def _plan_runs():
    from hil_bench.papers.beyond import plan
    runs = dict(registry.all_runs())
    runs.update({r.id: r for r in plan(quick=True).runs})
    return list(runs.values())


def _ctrl_default_trip_a() -> float:
    from hil_bench.firmware_stub._binding import ffi, lib
    cfg = ffi.new("ctrl_config_t *")
    lib.ctrl_config_defaults(cfg)
    return float(cfg.i_trip_a)


@pytest.mark.parametrize("run", _plan_runs(), ids=lambda r: r.id)
def test_overcurrent_trips_before_the_adc_clips(run):
    """No claim run's verdict may rest on an unexplained SENSOR_FAULT: where the plant's ADC is
    on, the over-current trip sits below its full scale, so a current the ADC cannot read (a
    clipped reading, which no longer sums to zero with the others) trips OVERCURRENT on that
    very sample, before the sum check's 5 ms filter can call it a sensor fault."""
    from hil_bench.plant_rt.plant import Plant
    from hil_bench.plant_rt.profile import load_profile
    from hil_bench.protocol.messages import Param
    scn = scenario_for(run)
    p = Plant(load_profile(scn.profile), **scn.plant_overrides).params
    if not p.adc_model:
        return
    trip = scn.controller_params.get(Param.I_MAX_TRIP_A, _ctrl_default_trip_a())
    assert trip < p.adc_full_scale_a, (run.id, trip, p.adc_full_scale_a)
    # and above what the scenario commands (I-f, alignment, the speed loop's limit)
    asked = max(scn.controller_params.get(Param[k], 0.0) for k in ("IQ_MAX_A", "IF_I_A",
                                                                    "ALIGN_I_A"))
    assert asked < trip, (run.id, asked, trip)


@pytest.mark.parametrize("run_id", ["H2.smo", "H2.smo.nodt", "H1.smo.nodt"])
def test_runaways_end_as_named_overcurrents(tmp_path, run_id):
    """Runs that ended in SENSOR_FAULT before the trip level was set below the ADC's full scale
    (the drive ran away, the currents clipped): they now end in OVERCURRENT, and the report's
    note names what the plant shows."""
    from hil_bench.loop.runner import run_scenario
    from hil_bench.papers.check import build_context
    from hil_bench.record.recording import load_recording
    from hil_bench.scenario import scenario_of
    run = registry.all_runs()[run_id]
    out = tmp_path / f"{run_id}.mcap"
    res = run_scenario(scenario_for(run), out_path=out, progress=False)
    assert not res.ok and "fault OVERCURRENT" in res.error, res.error
    rec = load_recording(out)
    ctx = build_context(rec, scenario_of(rec))
    kind, why = cl.run_failure(rec, ctx.speed_ref_at)
    assert kind == "FAIL" and "[over-current" in why and "phase current up to" in why, why
    assert "(reference 10)" in why and "read" in why, why       # the scenario's reference
    claim = next(c for c in registry.CLAIMS.values() if any(r.id == run_id for r in c.runs))
    for q in claim.quantities:
        if run_id in q.runs and not q.study and not q.aggregate:
            _, verdict, note = cl.measure(q, ctx)
            assert "SENSOR_FAULT" not in note and "over-current" in note, (q.key, note)


def _speed_recording(speed_rpm, ts=1e-4):
    from pathlib import Path

    from hil_bench.record import channels as ch
    from hil_bench.record.recording import Recording
    t = np.arange(speed_rpm.size) * ts
    return Recording(Path("synthetic.mcap"), metadata={"run": {"plant_params": "{}"}}, topics={
        ch.PLANT_STATE: {"t_s": t, "speed_rpm": speed_rpm},
        ch.CONTROLLER_TELEMETRY: {"t_s": t, "speed_hat_rpm": speed_rpm + 0.5}})


def test_a_comparator_off_its_point_is_untested_and_so_are_its_relations():
    """issue 27, 4: a row on the bench's reconstruction of a cited method that did not hold its
    operating point is UNTESTED, not FAIL, and so is every relation over it; a row of the paper's
    own method off its point still FAILs the relation."""
    import dataclasses

    from hil_bench.claims.model import Quantity, Relation, at_most
    from hil_bench.papers.claim_metrics import Context
    stalled = _speed_recording(np.full(5000, 0.3))       # a 10 rpm run stalled at 0.3 rpm
    ctx = Context(stalled, (0.1, 0.5), 10.0, 4, 1e-4)
    q = Quantity("X.conv.10", "w", "speed_est_error_rpm", 4.0, at_most(4.0, "s", "within ±x"),
                 "X.conv", at_speed_rpm=10.0)
    assert cl.measure(q, ctx)[1] == "FAIL"
    comp = dataclasses.replace(q, comparator="the bench's sign SMO")
    v, verdict, note = cl.measure(comp, ctx)
    assert verdict == "UNTESTED" and "the bench's sign SMO" in note and "did not hold" in note
    rel = Relation("X.10", "improved < conventional", ("X.imp.10", "X.conv.10"), "<", "1.5 < 4",
                   "s", words="better / faster / less / falls")
    vals = {"X.imp.10": 1.0, "X.conv.10": 0.5}
    off = frozenset({"X.conv.10"})
    assert cl.relate(rel, vals, off_point=off, untested={"X.conv.10": "why"})[1] == "UNTESTED"
    assert cl.relate(rel, vals, off_point=off)[1] == "FAIL"
    both = frozenset({"X.imp.10", "X.conv.10"})          # the paper's own method off: FAIL
    assert cl.relate(rel, vals, off_point=both, untested={"X.conv.10": "why"})[1] == "FAIL"


def test_a_steady_state_row_on_a_settling_window_is_not_measured_as_steady():
    """issue 27, 1: a window that still holds a settling transient is flagged, not used: the
    row fails as a drive that did not hold a steady speed (COMPARED rows keep their verdict and
    say so); a transient row is exempt."""
    import dataclasses

    from hil_bench.claims.model import Quantity, at_most, compared
    from hil_bench.papers.claim_metrics import Context
    t = np.arange(5000) * 1e-4
    settling = _speed_recording(2000 + 9.0 * np.exp(-t / 0.03))
    ctx = Context(settling, (0.0, 0.5), 2000.0, 4, 1e-4)
    q = Quantity("X.sf", "w", "speed_band_hat_rpm", 24.0, at_most(24.0, "s", "±x"), "X",
                 at_speed_rpm=2000.0)
    v, verdict, note = cl.measure(q, ctx)
    assert verdict == "FAIL" and "did not hold a steady speed" in note and v < 24.0
    c = dataclasses.replace(q, rule=compared("s", "x"))
    assert cl.measure(c, ctx)[1] == "COMPARED"
    assert cl.measure(dataclasses.replace(q, transient=True), ctx)[1] == "PASS"
    later = Context(settling, (0.3, 0.5), 2000.0, 4, 1e-4)    # after the tail: steady
    assert cl.measure(q, later)[1] == "PASS"


def test_a_comparator_that_faulted_before_its_window_is_untested():
    """H2's super-twisting comparator trips over-current before the load step: no value at all,
    UNTESTED (the paper's own method faulting stays FAIL)."""
    import dataclasses

    from hil_bench.claims.model import Quantity, compared
    from hil_bench.papers.claim_metrics import Context
    rec = _speed_recording(np.full(3000, 10.0))
    rec.metadata["run_result"] = {"error": "at cycle 3000: controller fault: controller reported "
                                           "fault OVERCURRENT at seq 3000 (detail 9995)"}
    ctx = Context(rec, (0.6, 1.2), 10.0, 3, 1e-4)           # the window after the recording ends
    q = Quantity("X.smo.resp", "w", "response_time_ms", 6.5, compared("s", "x"), "X.smo",
                 params=(("t_event_s", 0.8),))
    assert cl.measure(q, ctx)[1] == "FAIL"
    v, verdict, note = cl.measure(dataclasses.replace(q, comparator="the bench's STA"), ctx)
    assert verdict == "UNTESTED" and "OVERCURRENT" in note and "the bench's STA" in note


def test_a_relation_over_a_run_cut_short_never_holds():
    """Review of issue 27: G6's i_q rows on a run the controller ended early (STALL after the
    window) read COMPARED, and the relation over them PASSed. A row whose run ended early makes
    its relations FAIL (the controller faulted) or INVALID (the bench broke)."""
    import dataclasses
    from pathlib import Path

    from hil_bench.claims.registry import CLAIMS
    from hil_bench.papers.claim_metrics import Context
    from hil_bench.record import channels as ch
    from hil_bench.record.recording import Recording
    t = np.arange(0, 1.0, 1e-4)
    w = 2000 / 60 * 2 * math.pi * 4

    def rec(iq, err):
        return Recording(Path("x.mcap"), metadata={"run": {}, "run_result": {"error": err}},
                         topics={ch.PLANT_STATE: {"t_s": t, "theta_e_rad": w * t,
                                                  "speed_rpm": np.full(t.size, 2000.0),
                                                  "i_q_a": np.full(t.size, iq)}})
    c = CLAIMS["G6"]
    rel = next(r for r in c.relations if r.key == "G6.iq2000.sw")
    values, notes = {}, {}
    for key, iq in zip(rel.keys, (1.0, 1.1)):
        q = next(q for q in c.quantities if q.key == key)
        q = dataclasses.replace(q, metric="iq_mean_a", window_s=(0.5, 0.9), at_speed_rpm=None)
        ctx = Context(rec(iq, "controller reported fault STALL at seq 9500"), (0.5, 0.9),
                      2000.0, 4, 1e-4)
        values[key], verdict, notes[key] = cl.measure(q, ctx)
        assert verdict == "COMPARED" and "the run ended early" in notes[key]
    assert cl.relate(rel, values)[1] == "PASS"                 # the values alone would hold
    ended = {k: "FAIL" for k in rel.keys}
    v, verdict, note = cl.relate(rel, values, ended=ended)
    assert verdict == "FAIL" and "ended early" in note
    assert cl.relate(rel, values, ended={rel.keys[0]: "INVALID"})[1] == "INVALID"
