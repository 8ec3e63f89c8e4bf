"""The switching-inverter rows of the claims registry (``[ID.switching]`` in bench/claims/*.toml,
written by bench/claims/expand.py ``switching``): each twin is its averaged row on the same run
with the switching overrides, nothing else changed; a bad switching table is refused naming where;
the G1 study on the switching trajectory gives the keys the registry reads."""
from __future__ import annotations

import shutil
import tomllib

import pytest

from hil_bench.claims import expand, registry
from hil_bench.papers import studies


def _switching_tables() -> dict[str, dict]:
    out = {}
    for name in registry.FILES:
        for cid, t in tomllib.loads((registry.HERE / name).read_text()).items():
            if isinstance(t, dict) and "switching" in t:
                out[cid] = t["switching"]
    return out


def test_the_claims_with_switching_rows():
    """Every claim the papers measured on hardware is decided on the switching plant (Yuan
    IV.B-C, Hou 4, Gong's G5-G8; Y4's calibration and Y7 stay averaged: docs/claims.md, 'One
    inverter policy'); Gong's simulation claims show the twins beside."""
    tables = _switching_tables()
    assert sorted(tables) == ["G1", "G2", "G3", "G5", "G6", "G7", "G8", "H1", "H2", "H3", "Y1",
                              "Y2", "Y3", "Y4", "Y8"]
    decides = sorted(c for c, t in tables.items() if t.get("decides"))
    assert decides == ["G5", "G6", "G7", "G8", "H1", "H2", "H3", "Y1", "Y2", "Y3", "Y8"]


def test_every_twin_is_its_averaged_row_on_the_switching_plant():
    for cid, spec in _switching_tables().items():
        c = registry.CLAIMS[cid]
        lifts = set(spec.get("lifts", ()))
        for rid in spec["runs"]:
            base, twin = c.run(rid), c.run(rid + ".sw")
            assert twin.scenario == base.scenario
            assert twin.overrides == base.overrides + expand.SWITCHING_OVERRIDES
        by_key = {q.key: q for q in c.quantities}
        decides = spec.get("decides", False)
        diag = spec.get("diagnostic", not decides)
        twins = [q for q in c.quantities if q.key.endswith(".sw") and not q.study
                 and q.metric != "derived"]
        assert twins, cid
        for q in twins:
            orig = by_key[q.key[:-3]]
            assert q.runs == tuple(r + ".sw" for r in orig.runs)
            assert (q.metric, q.rule, q.paper_value, q.window_s, q.params, q.source,
                    q.at_speed_rpm, q.aggregate, q.comparator) == \
                   (orig.metric, orig.rule, orig.paper_value, orig.window_s, orig.params,
                    orig.source, orig.at_speed_rpm, orig.aggregate, orig.comparator)
            if decides:        # the twin decides where its row did; the averaged row is shown
                assert orig.diagnostic
                assert q.diagnostic == (not orig.what.endswith(expand.AVERAGED_TAG))
            else:
                assert q.diagnostic == (orig.diagnostic or diag)
            assert q.not_reproducible == ("" if orig.key in lifts else orig.not_reproducible)
        # every averaged row on the listed runs has its twin, and every relation over them
        on_runs = [q for q in c.quantities if not q.study and q.runs
                   and set(q.runs) <= set(spec["runs"])]
        assert {q.key + ".sw" for q in on_runs} == {q.key for q in twins}
        twin_keys = {q.key for q in twins}
        rels = {r.key: r for r in c.relations}
        twin_rels = {k: r for k, r in rels.items() if k.endswith(".sw") and k[:-3] in rels}
        for k, rel in twin_rels.items():
            orig = rels[k[:-3]]
            assert rel.keys == tuple(x if x.startswith("#") else x + ".sw" for x in orig.keys)
            assert (rel.op, rel.paper, rel.source, rel.tol, rel.words, rel.min_fall) == \
                   (orig.op, orig.paper, orig.source, orig.tol, orig.words, orig.min_fall)
            if decides:
                assert orig.diagnostic
            else:
                assert rel.diagnostic == (orig.diagnostic or diag)
        assert set(twin_rels) == {r.key + ".sw" for r in c.relations if r.key not in twin_rels
                                  and all(k + ".sw" in twin_keys for k in r.keys
                                          if not k.startswith("#"))}
        assert expand.SWITCHING_SETUP in c.setup


def test_g5_counts_on_the_switching_plant_and_g2_shows_it_beside():
    g5 = {q.key: q for q in registry.CLAIMS["G5"].quantities}
    assert g5["G5.td"].not_reproducible and g5["G5.td"].diagnostic  # the averaged row: beside
    # the twin decides, and says the number measures the bench's sampling chain (issue 27, 3)
    assert not g5["G5.td.sw"].diagnostic
    assert g5["G5.td.sw"].not_reproducible == g5["G5.td"].not_reproducible
    assert "sampling chain" in g5["G5.td.sw"].not_reproducible
    shadow = g5["G5.td.sw.shadow"]
    assert shadow.diagnostic and shadow.run == "G5.sw.shadow"
    assert registry.CLAIMS["G5"].run("G5.sw.shadow").overrides == expand.SHADOW_OVERRIDES
    assert g5["G5.exact.td.sw"].diagnostic
    g2 = {q.key: q for q in registry.CLAIMS["G2"].quantities}
    assert g2["G2.sf.sw"].diagnostic and not g2["G2.sf"].diagnostic
    # G1: the 10 kHz twins keep the averaged plant's reason (the observer is unstable on both)
    g1 = {q.key: q for q in registry.CLAIMS["G1"].quantities}
    assert g1["G1.m1.thd.sw"].not_reproducible == g1["G1.m1.thd"].not_reproducible != ""


def _copy(tmp_path):
    for name in registry.FILES:
        shutil.copy(registry.HERE / name, tmp_path / name)
    return tmp_path


@pytest.mark.parametrize("old, new, message", [
    ('runs = ["G5", "G5.exact"]', 'runs = ["G5", "G5.exakt"]',
     "gong2020.toml [G5].switching.runs: no run G5.exakt in the claim"),
    ('lifts = ["G1.m0.01.thd", "G1.m0.01.amp"]', 'lifts = ["G1.m0.01.thd", "G1.m0.01.x"]',
     "gong2020.toml [G1].switching.lifts: G1.m0.01.x is no not-reproducible row"),
    ('shadow = ["G5"]', 'shadow = ["G2"]', "gong2020.toml [G5].switching.shadow: G2 not among"),
    ('shadow = ["G5"]', 'shadow = ["G5"]\nlift = ["G5.td"]',
     "gong2020.toml [G5].switching: unknown field(s) lift"),
    ('runs = ["G5", "G5.exact"]\ndecides = true', 'runs = ["G5", "G5.exact"]\ndecides = 0',
     "gong2020.toml [G5].switching.diagnostic / decides: true or false"),
    ('runs = ["G5", "G5.exact"]\ndecides = true',
     'runs = ["G5", "G5.exact"]\ndecides = true\ndiagnostic = true',
     "gong2020.toml [G5].switching: decides = true and diagnostic = true contradict"),
    ('{ step_us = 10.0, voltage = "cmd"', '{ step_us = 10.0, voltage = "pwm"',
     "gong2020.toml [G1].boundary_layer_table.switching_study[3]: needs step_us, voltage"),
])
def test_a_bad_switching_table_is_refused_naming_where(tmp_path, old, new, message):
    folder = _copy(tmp_path)
    p = folder / "gong2020.toml"
    text = p.read_text()
    assert text.count(old) == 1, old
    p.write_text(text.replace(old, new))
    with pytest.raises(registry.RegistryError) as exc:
        registry.load(folder)
    assert message in str(exc.value)


def test_g1_switching_study_gives_the_registry_its_keys():
    """A short trajectory (the registry's full study settles 0.1 s and keeps two electrical
    periods): the 1 us rows' keys are there, and the PWM ripple reaches the estimated EMF more
    for the steeper tanh (larger m), as Gong's THDs rise with m."""
    out = studies.g1_switching(sub_steps_us=(1.0,), settle_s=0.02, periods=1)
    g1 = registry.CLAIMS["G1"]
    keys = [dict(q.params)["key"] for q in g1.quantities if q.study == "G1.sw"]
    assert "G1.sw" in g1.studies
    assert len(keys) == 4 * 5 and "sw10.cmd.m1.thd" in keys
    for k in keys:
        if k.startswith("sw1."):
            assert k in out, k
    assert out["sw1.cmd.m1.thd"] > out["sw1.cmd.m0.01.thd"] > 1.0
    assert out["sw1.sw.m0.01.thd"] < 0.1 * out["sw1.cmd.m0.01.thd"]  # the switched voltage: no ripple error
    assert out["sw1.cmd.m1.amp"] > out["sw1.cmd.m0.01.amp"]
    with pytest.raises(ValueError, match="does not divide"):
        studies.g1_switching(sub_steps_us=(3.0,))
