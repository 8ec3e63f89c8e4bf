"""Scenario files: the bundled ones load; every kind of bad input names the file and field."""
from pathlib import Path

import pytest

from bench.scenario import SCENARIO_DIR, ScenarioError, load_scenario, speed_ref_at
from protocol.messages import Estimator, Param

GOOD = """
[scenario]
name = "t"
profile = "gong2020"
duration_s = 0.5
claims = ["G2"]
[controller]
estimator = "SMO_SIGN"
speed_ref_rpm = 500
[controller.params]
SMO_K_V = 40
[[events]]
t_s = 0.2
speed_ref_rpm = 600
[metrics]
window_s = [0.3, 0.5]
"""


def write(tmp_path: Path, text: str) -> Path:
    p = tmp_path / "s.toml"
    p.write_text(text)
    return p


@pytest.mark.parametrize("path", sorted(SCENARIO_DIR.glob("*.toml")), ids=lambda p: p.stem)
def test_bundled_scenarios_load(path):
    scn = load_scenario(path)
    assert scn.duration_s > 0
    assert scn.metrics_window_s[1] <= scn.duration_s


def test_good_scenario_fields(tmp_path):
    scn = load_scenario(write(tmp_path, GOOD))
    assert scn.estimator is Estimator.SMO_SIGN
    assert scn.controller_params == {Param.SMO_K_V: 40.0}
    assert speed_ref_at(scn, 0.1) == pytest.approx(500 * 2 * 3.141592653589793 / 60)
    assert speed_ref_at(scn, 0.3) == pytest.approx(600 * 2 * 3.141592653589793 / 60)


def test_bundled_name_resolves():
    assert load_scenario("gong_g2_500rpm").name == "gong_g2_500rpm"


@pytest.mark.parametrize("edit, field", [
    (lambda t: t.replace('profile = "gong2020"\n', ""), "scenario.profile: missing"),
    (lambda t: t.replace("duration_s = 0.5", "duration_s = -1"), "scenario.duration_s: must be > 0"),
    (lambda t: t.replace("duration_s = 0.5", 'duration_s = "long"'), "scenario.duration_s: must be a number"),
    (lambda t: t.replace('estimator = "SMO_SIGN"', 'estimator = "MAGIC"'), "controller.estimator: unknown estimator"),
    (lambda t: t.replace("SMO_K_V = 40", "SMO_K = 40"), "controller.params.SMO_K: unknown controller parameter"),
    (lambda t: t.replace("t_s = 0.2", "t_s = 9.0"), "events[0].t_s: 9 s is after the end"),
    (lambda t: t.replace("speed_ref_rpm = 600", "speed_rpm = 600"), "events[0].speed_rpm: unknown key"),
    (lambda t: t.replace("window_s = [0.3, 0.5]", "window_s = [0.4, 0.3]"), "metrics.window_s: must satisfy"),
    (lambda t: t + "\n[plantt]\nx = 1\n", "plantt: unknown key"),
    (lambda t: t.replace("[metrics]", "[metrics"), "not valid TOML"),
    (lambda t: t + "\n[reference]\nestimators = [\"SMO_SIGN\"]\n[reference.SMO_TANH]\nm = 1\n",
     "reference.SMO_TANH: configuration for an estimator not listed"),
    (lambda t: t + "\n[reference]\nestimators = [\"SMO_SIGN\"]\n[reference.SMO_SIGN]\nk_v = \"x\"\n",
     "reference.SMO_SIGN.k_v: must be a number"),
])
def test_bad_scenarios_name_field(tmp_path, edit, field):
    with pytest.raises(ScenarioError) as exc:
        load_scenario(write(tmp_path, edit(GOOD)))
    assert "s.toml" in str(exc.value)
    assert field in str(exc.value)


def test_missing_file_names_path():
    with pytest.raises(ScenarioError, match="no such scenario file"):
        load_scenario("/nonexistent/dir/x.toml")
