"""Every back-EMF estimator of the library closes the loop on the C stub's firmware (in the
engine's process: --link sil, the stub's rows, tests/test_sil.py): standstill -> 500 rpm
on Gong's motor (Table I), held. The scenario is gong_g2_500rpm with the estimator swapped and its
gains left to the library's rules (firmware_stub/est_smo.py), which the bench sends over CONFIG."""
import numpy as np
import pytest

from hil_bench.loop.runner import run_scenario
from hil_bench.record import channels as ch
from hil_bench.record.recording import load_recording
from hil_bench.scenario import derive_scenario

PARAMS = dict(IQ_MAX_A=6.0, ALIGN_I_A=3.0, ALIGN_TIME_S=0.2, IF_I_A=3.0, IF_ACCEL_RAD_S2=60.0,
              HANDOVER_SPEED_RAD_S=20.0)


def scenario_for(estimator: str):
    """gong_g2_500rpm with the estimator swapped; the sign SMO keeps its hand-picked gains
    (k 25 V, wc 300 rad/s), the others take the library's rules (the bench sends the controller
    exactly the settings the host reference gets: runner.estimator_defaults)."""
    params = dict(PARAMS)
    ref_cfg: dict = {}
    if estimator == "SMO_SIGN":
        params.update(SMO_K_V=25.0, SMO_WC_RAD_S=300.0)
        ref_cfg = {"k_v": 25.0, "wc_rad_s": 300.0}
    reference = {"estimators": [estimator]}
    if ref_cfg:
        reference[estimator] = ref_cfg
    return derive_scenario("gong_g2_500rpm", f"gong_500rpm_{estimator}",
                           (("controller.estimator", estimator), ("controller.params", params),
                            ("reference", reference)))


@pytest.mark.parametrize("estimator, pee_rms_max_rad", [
    ("SMO_SIGN", 0.1),
    # eq. 15 as printed leaves atan(2w/wc) - atan(w/wc) = 0.10 rad uncompensated at 500 rpm
    # (docs/estimators_smo.md); the loop holds speed with it
    ("SMO_SIGMOID", 0.15),
    ("SMO_TANH", 0.05),
])
def test_each_back_emf_estimator_closes_the_loop_at_500rpm(tmp_path, estimator, pee_rms_max_rad):
    out = tmp_path / f"{estimator}.mcap"
    result = run_scenario(scenario_for(estimator), link_spec="sil", out_path=out, progress=False)
    assert result.ok, result.error
    rec = load_recording(out)
    state = rec.topic(ch.PLANT_STATE)
    telem = rec.topic(ch.CONTROLLER_TELEMETRY)
    late = state["t_s"] >= 1.0
    assert np.all(np.abs(state["speed_rpm"][late] - 500.0) < 5.0)
    assert np.all(telem["state"][late] == 3)            # CLOSED_LOOP on the estimator
    assert np.all(telem["estimator"][late] == {"SMO_SIGN": 1, "SMO_SIGMOID": 2,
                                               "SMO_TANH": 3}[estimator])
    assert np.sqrt(np.mean(telem["pee_rad"][late] ** 2)) < pee_rms_max_rad
    # the host reference of the same estimator sits on the controller's angle
    ref = rec.topic(ch.REFERENCE_PREFIX + estimator)
    idx = np.searchsorted(telem["t_s"], ref["t_s"])
    r_late = ref["t_s"] >= 1.0
    diff = np.angle(np.exp(1j * (ref["theta_hat_rad"][r_late] - telem["theta_hat_rad"][idx][r_late])))
    assert np.sqrt(np.mean(diff ** 2)) < 0.01
