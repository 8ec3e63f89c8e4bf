"""The switching-inverter rows of the claims registry (bench/papers/claims.py SWITCHING_ROWS):
each twin is its averaged row on the same run with the switching overrides, nothing else changed;
the G1 study on the switching trajectory gives the keys the registry reads."""
from __future__ import annotations

import pytest

from hil_bench.papers import claims, studies


def test_every_twin_is_its_averaged_row_on_the_switching_plant():
    for spec in claims.SWITCHING_ROWS:
        c = claims.CLAIMS[spec.claim]
        for rid in spec.runs:
            base, twin = c.run(rid), c.run(rid + ".sw")
            assert twin.scenario == base.scenario
            assert twin.overrides == base.overrides + claims.SWITCHING_OVERRIDES
        by_key = {q.key: q for q in c.quantities}
        twins = [q for q in c.quantities if q.key.endswith(".sw") and not q.study]
        assert twins, spec.claim
        for q in twins:
            orig = by_key[q.key[:-3]]
            assert q.runs == tuple(r + ".sw" for r in orig.runs)
            assert (q.metric, q.rule, q.paper_value, q.window_s, q.params, q.source) == \
                   (orig.metric, orig.rule, orig.paper_value, orig.window_s, orig.params, orig.source)
            assert q.diagnostic == (orig.diagnostic or spec.diagnostic)
            lifted = orig.not_reproducible in spec.lifts
            assert q.not_reproducible == ("" if lifted else orig.not_reproducible)
        rel_keys = {r.key for r in c.relations}
        for r in c.relations:
            if r.key.endswith(".sw") and r.key[:-3] in rel_keys:
                assert all(k in by_key for k in r.keys if not k.startswith("#"))


def test_g5_counts_on_the_switching_plant_and_g2_shows_it_beside():
    g5 = {q.key: q for q in claims.CLAIMS["G5"].quantities}
    assert g5["G5.td"].not_reproducible == claims.G5_PLANT         # the averaged row: unchanged
    assert not g5["G5.td.sw"].not_reproducible and not g5["G5.td.sw"].diagnostic
    assert g5["G5.td.sw.shadow"].diagnostic
    g2 = {q.key: q for q in claims.CLAIMS["G2"].quantities}
    assert g2["G2.sf.sw"].diagnostic and not g2["G2.sf"].diagnostic


def test_g1_switching_study_gives_the_registry_its_keys():
    """A short trajectory (the registry's full study settles 0.1 s and keeps two electrical
    periods): the 1 us rows' keys are there, and the PWM ripple reaches the estimated EMF more
    for the steeper tanh (larger m), as Gong's THDs rise with m."""
    out = studies.g1_switching(sub_steps_us=(1.0,), settle_s=0.02, periods=1)
    g1 = claims.CLAIMS["G1"]
    keys = [dict(q.params)["key"] for q in g1.quantities if q.study == "G1.sw"]
    assert "G1.sw" in g1.studies
    for k in keys:
        if k.startswith("sw1."):
            assert k in out, k
    assert out["sw1.cmd.m1.thd"] > out["sw1.cmd.m0.01.thd"] > 1.0
    assert out["sw1.sw.m0.01.thd"] < 0.1 * out["sw1.cmd.m0.01.thd"]  # the switched voltage: no ripple error
    assert out["sw1.cmd.m1.amp"] > out["sw1.cmd.m0.01.amp"]
    with pytest.raises(ValueError, match="does not divide"):
        studies.g1_switching(sub_steps_us=(3.0,))
