"""The claims registry (bench/claims.py) without running anything: all 19 claims, every rule
with a source and none of the old unsourced '~' tolerances, every run's scenario loads, every
window inside its run, relations over existing quantities; and the TOML writer behind derived
scenarios."""
import math
import tomllib

import pytest

from bench import claims as cl
from bench import tomlw
from bench.report import scenario_for

PAPER_IDS = [f"Y{i}" for i in range(1, 9)] + ["H1", "H2", "H3"] + [f"G{i}" for i in range(1, 9)]


def test_every_paper_claim_is_registered():
    assert list(cl.CLAIMS) == PAPER_IDS


@pytest.mark.parametrize("cid", PAPER_IDS)
def test_claim_is_consistent(cid):
    c = cl.CLAIMS[cid]
    assert c.quantities
    run_ids = {r.id for r in c.runs}
    keys = [q.key for q in c.quantities]
    assert len(keys) == len(set(keys))
    for q in c.quantities:
        assert q.rule.kind in ("at_most", "within", "compared")
        assert q.rule.source.strip(), q.key                   # every rule says where it comes from
        if q.rule.kind == "within":
            assert q.rule.lo < q.rule.hi
        assert q.metric in cl.METRICS or q.metric in ("study", "derived"), q.key
        assert set(q.runs) <= run_ids, (q.key, q.runs)
        if q.study:
            assert q.study in c.studies
        assert q.paper_value is not None and str(q.paper_value) != ""   # both numbers shown
    for rel in c.relations:
        for k in rel.keys:
            assert k.startswith("#") or k in keys, (rel.key, k)


def test_no_unsourced_percent_tolerances_remain():
    text = open(cl.__file__).read()
    assert '"~"' not in text and "tolerance" not in [f.name for f in
                                                        cl.Quantity.__dataclass_fields__.values()]


@pytest.mark.parametrize("run", list(cl.all_runs().values()), ids=lambda r: r.id)
def test_every_run_builds_and_its_windows_fit(run):
    scn = scenario_for(run)
    assert scn.name == run.name
    for c in cl.CLAIMS.values():
        for q in c.quantities:
            if run.id in q.runs and q.window_s is not None:
                assert 0 <= q.window_s[0] < q.window_s[1] <= scn.duration_s + 1e-9, (q.key, run.id)


def test_derived_scenario_keeps_everything_else_and_names_the_override():
    run = cl.CLAIMS["H3"].run("H3.bias.45deg.nodt")
    scn = scenario_for(run)
    assert scn.plant_overrides["inverter_nonlinear"] == 0
    assert scn.initial_theta_e_rad == pytest.approx(math.radians(45))
    assert scn.controller_params[cl_param("HFI_POL_BIAS_A")] == 2.4
    assert scn.text.startswith("# derived from bench/scenarios/hou_h3_ipd.toml")
    assert scn.profile == "hou2021" and scn.claims == ("H3",)


def cl_param(name):
    from protocol.messages import Param
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
    rel = cl.Relation("r", "falls", ("a", "b", "c"), ">", "", "src")
    assert cl.relate(rel, {"a": 3.0, "b": 2.0, "c": 1.0})[1] == "PASS"
    assert cl.relate(rel, {"a": 3.0, "b": 2.0, "c": 2.5})[1] == "FAIL"
    assert cl.relate(rel, {"a": 3.0, "b": 2.0})[1] == "FAIL"            # missing: not a pass
    assert cl.relate(rel, {"a": 3.0, "b": 2.0, "c": 1.0}, frozenset({"b"}))[1] == \
        "NOT REPRODUCIBLE"
    eq = cl.Relation("e", "equal", ("a", "b"), "=", "", "src", tol=0.005)
    assert cl.relate(eq, {"a": 4.081, "b": 4.084})[1] == "PASS"
    assert cl.relate(eq, {"a": 4.08, "b": 4.09})[1] == "FAIL"
    zero = cl.Relation("z", "positive", ("#0", "a"), "<", "", "src")
    assert cl.relate(zero, {"a": -20.0})[1] == "FAIL"
    q = cl.Quantity("d", "", "derived", 1.0, cl.compared("s"),
                    params=(("op", "pct"), ("a", "on"), ("b", "off")))
    assert cl.derive(q, {"on": 1.08, "off": 1.15}) == pytest.approx(-6.087, abs=1e-3)


def test_rules():
    assert cl.at_most(0.1, "s").verdict(0.1) == "PASS"
    assert cl.at_most(0.1, "s").verdict(0.11) == "FAIL"
    assert cl.at_most(0.1, "s").verdict(math.nan) == "FAIL"
    w = cl.within(1.5, 2.5, "s")
    assert (w.verdict(1.5), w.verdict(2.5), w.verdict(1.46)) == ("PASS", "FAIL", "FAIL")
    assert cl.compared("s").verdict(123.0) == "COMPARED"
