"""A claim applies because of what ran, never because of a file's name (issue 19, point 1;
bench/papers/conditions.py): every claim run is told apart from its claim's other runs by what its
recording says (the estimator the controller reported, the plant, the compensation, the
operating point and window); every bundled claim scenario meets its claims' conditions; a
condition not met is named with what ran instead; and end to end, an encoder drive in a file
named like G2's scenario is INVALID under --strict, while a renamed copy of G2's scenario gets
G2's verdicts."""
import dataclasses
import json
from pathlib import Path

import pytest

from hil_bench.claims.registry import CLAIMS
from hil_bench.cli import main as cli_main
from hil_bench.loop.runner import Runner
from hil_bench.papers import conditions as cond
from hil_bench.scenario import load_scenario

SCENARIOS = Path(__file__).resolve().parents[1] / "bench" / "scenarios"


class _Recording:
    """What a recording of ``scn`` would say about itself: the runner's own metadata (nothing
    runs) and the estimator its controller reports in every cycle (``reported``)."""

    def __init__(self, scn, reported: str | None = None):
        r = Runner(scn, "stub", out_path=None, progress=False, realtime=False, record=False)
        self.run = {"profile": r.profile.name, "estimator": scn.estimator.name,
                    "plant_params": json.dumps(r.plant.params.as_dict()),
                    "controller_params": json.dumps({p.name: v for p, v in
                                                     r.controller_params().items()}),
                    "inverter_comp": json.dumps(r.inverter_comp_metadata())}
        from hil_bench.protocol.messages import Estimator
        self.estimator_counts = {int(Estimator[reported or scn.estimator.name]): 15000}


def _claim_runs():
    return [(c.id, r) for c in CLAIMS.values() for r in c.runs]


def test_every_claim_run_is_recognised_by_what_it_records_whatever_its_name():
    """Each run of each claim (the report's runs) meets its own conditions and no other run of
    the claim meets them, under another scenario name: the verdict cannot rest on the name."""
    wrong = []
    for cid, run in _claim_runs():
        scn = cond.scenario_for(run)
        renamed = dataclasses.replace(scn, name="a_users_file")
        m = cond.match(CLAIMS[cid], _Recording(scn), renamed)
        if not (m.ok and m.run.id == run.id):
            wrong.append((cid, run.id, m.run.id, m.note() if not m.ok else ""))
        others = [r.id for r in CLAIMS[cid].runs if r.id != run.id
                  and not cond.failed(r, _Recording(scn), renamed, CLAIMS[cid])] \
            if run is CLAIMS[cid].runs[0] else []
        assert not others, (cid, run.id, others)
    assert not wrong, wrong


@pytest.mark.parametrize("path", sorted(SCENARIOS.glob("*.toml")), ids=lambda p: p.stem)
def test_every_bundled_claim_scenario_meets_its_claims(path):
    scn = load_scenario(path)
    for cid in scn.claims:
        m = cond.match(CLAIMS[cid], _Recording(scn), scn)
        assert m is not None and m.ok, m.note()


def _y1():
    run = CLAIMS["Y1"].run("Y1.improved")
    return run, cond.scenario_for(run)


@pytest.mark.parametrize("duty_update", ["on_arrival", "next_period"])
def test_a_real_time_run_of_a_claims_scenario_is_not_a_run_of_the_claim(duty_update):
    """Gong's G2 runs in lockstep: the duties act at the emulated computation delay. A real-time
    run of the same scenario (bench run gong_g2_500rpm --realtime) has the link's round trip as its
    delay (on_arrival) or a whole period (next_period): its G2 rows are not G2's, whatever its
    plant and CONFIG say (found by the real-drive guide: the conditions did not look at the mode)."""
    scn = load_scenario("gong_g2_500rpm")
    rec = _Recording(scn)
    assert not cond.failed(CLAIMS["G2"].run("G2"), rec, scn, CLAIMS["G2"])
    rec.run.update(mode="realtime", duty_update=duty_update)
    (f,) = cond.failed(CLAIMS["G2"].run("G2"), rec, scn, CLAIMS["G2"])
    assert f.name == "timing" and f.text() == (f"timing: the claim's run runs lockstep; this run: "
                                               f"realtime ({duty_update})")


def test_the_estimator_is_what_the_controller_reported_not_what_was_asked():
    run, scn = _y1()
    (f,) = cond.failed(run, _Recording(scn, reported="ENCODER"), scn, CLAIMS["Y1"])
    assert f.name == "estimator"
    assert "SMO_SIGMOID" in f.text() and "reported ENCODER in 15000 of 15000 cycles" in f.text()
    rec = _Recording(scn)
    rec.estimator_counts = {}
    (f,) = cond.failed(run, rec, scn, CLAIMS["Y1"])
    assert f.name == "estimator" and "no telemetry" in f.text()


@pytest.mark.parametrize("key, value, named", [
    ("controller.inverter_comp.residual", 0.2, "inverter_comp"),
    ("plant.inverter_nonlinear", False, "plant.inverter_nonlinear"),
    ("plant.adc_noise_a_rms", 0.05, "plant.adc_noise_a_rms"),
    ("controller.speed_ref_rpm", 20.0, "speed reference"),
    ("controller.params.SMO_K_V", 40.0, "controller parameters"),
    ("scenario.duration_s", 4.0, "window"),
    ("scenario.profile", "gong2020", "profile"),
])
def test_a_condition_not_met_is_named_with_what_ran(key, value, named):
    from hil_bench.scenario import derive_scenario
    run, _ = _y1()
    extra = (("metrics.window_s", [3.0, 3.5]),) if key == "scenario.duration_s" else ()
    other = derive_scenario(run.scenario, "not_y1", run.overrides + ((key, value),) + extra)
    names = [f.name for f in cond.failed(run, _Recording(other), other, CLAIMS["Y1"])]
    assert named in names, names
    m = cond.match(CLAIMS["Y1"], _Recording(other), other)
    if key == "plant.inverter_nonlinear":      # that is the claim's dead-time-off diagnostic run
        assert m.ok and m.run.id == "Y1.improved.nodt"
    else:
        assert not m.ok and named in m.short() and "Y1" in m.note()


def test_the_residual_study_runs_meet_their_own_conditions():
    """The report checks each recording against the run it was made for: the residual study's
    variants (another residual) are their own runs, not a failed condition."""
    from hil_bench.papers import residual as rs
    c = rs.claim_at(CLAIMS["Y1"], 0.2)
    for run in c.runs:
        scn = cond.scenario_for(run)
        assert not cond.failed(run, _Recording(scn), scn, c)
        assert cond.failed(CLAIMS["Y1"].run(run.id.split(".", 1)[1]), _Recording(scn), scn,
                           CLAIMS["Y1"])


# ---- end to end ---------------------------------------------------------------------------------

def _g2_copy(tmp_path: Path, name: str, estimator: str) -> Path:
    text = (SCENARIOS / "gong_g2_500rpm.toml").read_text()
    text = text.replace('name = "gong_g2_500rpm"', f'name = "{name}"')
    text = text.replace('estimator = "SMO_TANH"', f'estimator = "{estimator}"')
    p = tmp_path / f"{name}.toml"
    p.write_text(text)
    return p


def test_an_encoder_drive_named_like_g2_is_invalid_under_strict(tmp_path, capsys):
    """issue 19.1: a user's file named gong_g2_500rpm whose controller closes on the encoder
    PASSed G2's position-estimation claim under --strict."""
    scn = _g2_copy(tmp_path, "gong_g2_500rpm", "ENCODER")
    out = tmp_path / "enc.mcap"
    assert cli_main(["run", str(scn), "--strict", "--no-progress", "--out", str(out)]) == 1
    text = capsys.readouterr().out
    assert "PASS" not in text and "INVALID" in text
    assert "G2: INVALID, not the set-up the claim is about" in text
    assert "closes the loop with SMO_TANH" in text and "reported ENCODER" in text
    assert cli_main(["check", str(out), "--strict"]) == 1


def test_a_renamed_copy_of_g2_gets_g2s_verdicts(tmp_path, capsys):
    """issue 19.1: a differently named copy with claims = ["G2"] printed no claim table."""
    scn = _g2_copy(tmp_path, "my_drive_at_500rpm", "SMO_TANH")
    out = tmp_path / "copy.mcap"
    assert cli_main(["run", str(scn), "--strict", "--no-progress", "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "paper claims" in text and "PASS" in text and "INVALID" not in text
    from hil_bench.papers.check import check_recording
    report = check_recording(out)
    verdicts = {r.quantity.key: r.verdict for r in report.results}
    assert verdicts["G2.pee"] == "PASS" and verdicts["G2.sf"] == "PASS", verdicts
    assert all(r.setup.run.id == "G2" and r.setup.ok for r in report.results)
