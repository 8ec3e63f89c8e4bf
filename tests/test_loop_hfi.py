"""HF injection + SDFT (Hou) closing the loop on the IPMSM profile, with the plant's d-axis
saturation and 12-bit ADC model on: the standstill initial-position procedure finds the angle and
the N/S polarity from five starting angles (both polarity tests), the dead time defeats Hou's
test, and the drive then holds 10 rpm and 50 rpm under full load."""
import math

import numpy as np
import pytest

from hil_bench.loop.runner import run_scenario
from hil_bench.papers.metrics import wrap_pi
from hil_bench.record import channels as ch
from hil_bench.record.recording import load_recording
from hil_bench.scenario import derive_scenario, load_scenario

#: the metrics window of hou_h3_ipd: after the initial-position procedure has ended
WINDOW_START_S = load_scenario("hou_h3_ipd").metrics_window_s[0]


def h3(angle_deg, dead_time, bias_a=0.0, residual=None):
    """hou_h3_ipd from angle_deg; ``residual``: the drive's compensation residual (1.0: none, the
    drive blind to its inverter; None: the scenario's own)."""
    comp = () if residual is None else (("controller.inverter_comp.residual", residual),)
    return derive_scenario("hou_h3_ipd", f"h3_{angle_deg}_{dead_time}_{bias_a}",
                           (("plant.initial_theta_e_rad", math.radians(angle_deg)),
                            ("plant.inverter_nonlinear", dead_time),
                            ("controller.params.HFI_POL_BIAS_A", bias_a)) + comp)


@pytest.mark.parametrize("angle_deg", [0, 45, 90, 135, 180])
@pytest.mark.parametrize("bias_a", [0.0, 2.4])
def test_initial_position_and_polarity_from_standstill(tmp_path, angle_deg, bias_a):
    """Both polarity tests (Hou's HF-only one and the d-bias option) on the plant with
    saturation and the ADC, without dead time (with it: the next test)."""
    out = tmp_path / "h3.mcap"
    result = run_scenario(h3(angle_deg, False, bias_a), link_spec="sil", out_path=out,
                          progress=False)
    assert result.ok, result.error
    rec = load_recording(out)
    telem, state = rec.topic(ch.CONTROLLER_TELEMETRY), rec.topic(ch.PLANT_STATE)
    late = state["t_s"] >= WINDOW_START_S
    assert np.all(telem["state"][late] == 3)                 # procedure done, loop closed
    err = np.abs(wrap_pi(telem["theta_hat_rad"][late] - state["theta_e_rad"][late]))
    # polarity right (a wrong one reads pi) and the angle within 2 deg (Hou: 1 deg for the
    # estimate; here every sample of the window, ADC noise included: docs/claims.md H3)
    assert err.max() < math.radians(2.0), math.degrees(err.max())
    assert np.all(np.abs(state["speed_rpm"][late]) < 10.0)   # the rotor stayed put


@pytest.mark.parametrize("angle_deg", [0, 135, 180])
def test_hous_polarity_test_with_the_scenarios_compensation(tmp_path, angle_deg):
    """Issue 16's done-when for H3: with Hou's set-up (dead time and drops, the drive's
    feed-forward at the scenario's 5 % residual) Hou's HF-only test finds the polarity at 0, 135
    and 180 deg. Before the sequential test (est_hfi.h) it did at 0 deg only: one 20 ms look at
    the per-period peaks, whose ADC noise (sd 0.011 per period) buried the 0.0016 signal
    (135, 180 deg: STARTUP_FAILED, undecided)."""
    out = tmp_path / "h3.mcap"
    result = run_scenario(h3(angle_deg, True), link_spec="sil", out_path=out, progress=False)
    assert result.ok, result.error
    rec = load_recording(out)
    telem, state = rec.topic(ch.CONTROLLER_TELEMETRY), rec.topic(ch.PLANT_STATE)
    late = state["t_s"] >= WINDOW_START_S
    assert np.all(telem["state"][late] == 3)                 # procedure done, loop closed
    err = wrap_pi(telem["theta_hat_rad"][late] - state["theta_e_rad"][late])
    assert abs(np.mean(err)) < math.pi / 2, math.degrees(np.mean(err))   # polarity right
    # the angle: the compensation's residual at the injection frequency tilts the ellipse
    # (measured +1.1 .. +2.4 deg at 5 %, Hou's +-1 deg is not met: docs/claims.md, H3)
    assert abs(np.mean(err)) < math.radians(5.0), math.degrees(np.mean(err))
    assert np.all(np.abs(state["speed_rpm"][late]) < 10.0)   # the rotor stayed put


def test_dead_time_defeats_hous_polarity_test_and_tilts_the_ellipse(tmp_path):
    """Uncompensated (residual 1: the drive's feed-forward knows nothing of its inverter; the
    scenario's own 5 % residual is test_inverter_comp_scenario's), with the inverter's dead time
    the 0.3 A HF current lives inside the node-capacitance band
    (i_c = 0.27 A), where the dead time acts as a resistance delta V_dc / (2 i_c) ~ 18 ohm: the
    HF-only polarity test cannot decide (the controller faults, never guesses), and the d-bias
    test decides right but the angle is off by ~13 deg (docs/claims.md, H3)."""
    out = tmp_path / "pure.mcap"
    result = run_scenario(h3(135, True, 0.0, residual=1.0), link_spec="sil", out_path=out,
                          progress=False)
    assert not result.ok and "STARTUP_FAILED" in result.error
    out = tmp_path / "bias.mcap"
    result = run_scenario(h3(135, True, 2.4, residual=1.0), link_spec="sil", out_path=out,
                          progress=False)
    assert result.ok, result.error
    rec = load_recording(out)
    telem, state = rec.topic(ch.CONTROLLER_TELEMETRY), rec.topic(ch.PLANT_STATE)
    late = state["t_s"] >= WINDOW_START_S
    err = wrap_pi(telem["theta_hat_rad"][late] - state["theta_e_rad"][late])
    assert abs(np.mean(err)) < math.pi / 2                    # polarity right
    assert math.radians(8.0) < abs(np.mean(err)) < math.radians(20.0)


def test_hfi_holds_10_and_50_rpm_under_full_load(tmp_path):
    """hou_h1_hfi without dead time (with it Hou's polarity test does not start: above)."""
    out = tmp_path / "h1.mcap"
    scn = derive_scenario("hou_h1_hfi", "h1_nodt", (("plant.inverter_nonlinear", False),))
    result = run_scenario(scn, link_spec="sil", out_path=out, progress=False)
    assert result.ok, result.error
    rec = load_recording(out)
    state, telem = rec.topic(ch.PLANT_STATE), rec.topic(ch.CONTROLLER_TELEMETRY)
    for (t0, t1), ref_rpm, band_rpm in (((2.0, 2.4), 10.0, 3.0), ((2.8, 3.2), 50.0, 5.0)):
        m = (state["t_s"] > t0) & (state["t_s"] < t1)
        assert np.all(telem["state"][m] == 3)
        assert np.all(np.abs(state["speed_rpm"][m] - ref_rpm) < band_rpm), ref_rpm
        # full load: the brake's 6.5 N m needs the rated 4.77 A
        assert np.mean(state["i_q_a"][m]) == pytest.approx(4.77, abs=0.1)
        assert np.max(np.abs(telem["pee_rad"][m])) < math.radians(5.0)
