"""[controller.inverter_comp]: the drive's inverter-error feed-forward as a scenario setting.

The residual (the fraction of the plant's dead time and drops the drive's estimate leaves) turns
into the INV_COMP_* CONFIG parameters from the plant's own values, is refused beside explicit
INV_COMP_* parameters, every bad value names the file, line and field, and a recording carries
the plant's truth, the drive's estimate and the residual in its metadata.
"""
from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from hil_bench.loop.runner import Runner, inverter_comp_settings, run_scenario
from hil_bench.protocol.messages import Param
from hil_bench.record.recording import load_recording
from hil_bench.scenario import ScenarioError, derive_scenario, load_scenario

BASE = """
[scenario]
name = "t"
profile = "yuan2020"
duration_s = 0.05
[plant]
inverter_nonlinear = true
[controller]
estimator = "ENCODER"
speed_ref_rpm = 10
{extra}
[metrics]
window_s = [0.02, 0.05]
"""


def _scn(tmp_path: Path, extra: str):
    p = tmp_path / "s.toml"
    p.write_text(BASE.format(extra=extra))
    return load_scenario(p)


def test_residual_becomes_the_drives_estimate(tmp_path):
    scn = _scn(tmp_path, "[controller.inverter_comp]\nresidual = 0.05\n")
    assert scn.inverter_comp.residual == 0.05 and scn.inverter_comp.current == "vector"
    params = Runner(scn, progress=False, record=False).controller_params()
    assert params[Param.INV_COMP_ENABLE] == 4.0 and params[Param.INV_COMP_SHAPE] == 1.0
    assert params[Param.INV_COMP_DEAD_TIME_S] == pytest.approx(0.95 * 1.78e-6)
    assert params[Param.INV_COMP_V_SWITCH_V] == pytest.approx(0.95 * 0.8)
    assert params[Param.INV_COMP_V_DIODE_V] == pytest.approx(0.95 * 0.9)
    assert params[Param.INV_COMP_R_SWITCH_OHM] == pytest.approx(0.95 * 0.035)
    assert params[Param.INV_COMP_BAND_A] == pytest.approx(0.155)   # the plant's i_cap_band_a


def test_off_by_default_and_nothing_to_compensate_on_an_ideal_inverter(tmp_path):
    scn = _scn(tmp_path, "")
    params = Runner(scn, progress=False, record=False).controller_params()
    assert not any(p.name.startswith("INV_COMP_") for p in params)
    p, meta = inverter_comp_settings(load_scenario(tmp_path / "s.toml").inverter_comp, {})
    assert p == {} and meta == {"on": False}
    scn = _scn(tmp_path, "[controller.inverter_comp]\nresidual = 0.0\n")
    params, meta = inverter_comp_settings(scn.inverter_comp, {"inverter_nonlinear": False,
                                                               "dead_time_s": 1.78e-6,
                                                               "v_switch_drop_v": 0.8,
                                                               "r_switch_ohm": 0.035,
                                                               "v_diode_drop_v": 0.9,
                                                               "r_diode_ohm": 0.035,
                                                               "i_cap_band_a": 0.155})
    assert params[Param.INV_COMP_DEAD_TIME_S] == 0.0 and meta["plant_inverter_nonlinear"] is False


@pytest.mark.parametrize("extra, field, why", [
    ("[controller.inverter_comp]\nresidual = 1.5\n", "controller.inverter_comp.residual", "-1 .. 1"),
    ("[controller.inverter_comp]\nresidual = 0.1\ncurrent = \"psychic\"\n",
     "controller.inverter_comp.current", "must be one of"),
    ("[controller.inverter_comp]\nresidual = 0.1\nshape = \"round\"\n",
     "controller.inverter_comp.shape", "must be one of"),
    ("[controller.inverter_comp]\nresidual = 0.1\ncurrent = \"sampled\"\ncurrent_bw_rad_s = 100\n",
     "controller.inverter_comp.current_bw_rad_s", "only with current"),
    ("[controller.inverter_comp]\nresidual = 0.1\nband = 0.2\n", "controller.inverter_comp.band",
     "unknown key"),
    ("[controller.inverter_comp]\nresidual = 0.1\n[controller.params]\nINV_COMP_DEAD_TIME_S = 1e-6\n",
     "controller.inverter_comp.residual", "given twice"),
    ("[controller.params]\nINV_COMP_ENABLE = 5\n", "controller.params.INV_COMP_ENABLE",
     "must be one of"),
])
def test_bad_values_name_the_field(tmp_path, extra, field, why):
    with pytest.raises(ScenarioError) as e:
        _scn(tmp_path, extra)
    msg = str(e.value)
    assert "s.toml:" in msg and field in msg and why in msg, msg


def test_recording_states_truth_estimate_and_residual(tmp_path):
    scn = derive_scenario("hou_h3_ipd", "h3_comp", (("controller.inverter_comp.residual", 0.1),
                                                     ("scenario.duration_s", 0.02),
                                                     ("metrics.window_s", [0.0, 0.02])))
    out = tmp_path / "r.mcap"
    res = run_scenario(scn, link_spec="sil", out_path=out, progress=False)
    assert res.cycles_done == 200, res.error
    meta = json.loads(load_recording(out).run["inverter_comp"])
    assert meta["on"] and meta["residual"] == 0.1 and meta["current"] == "vector"
    assert meta["plant"]["dead_time_s"] == pytest.approx(1.78e-6)
    assert meta["drive"]["dead_time_s"] == pytest.approx(0.9 * 1.78e-6)
    ctrl = json.loads(load_recording(out).run["controller_params"])
    assert ctrl["INV_COMP_ENABLE"] == 4.0
    assert math.isclose(ctrl["INV_COMP_V_DIODE_V"], 0.9 * 0.9, rel_tol=1e-9)
