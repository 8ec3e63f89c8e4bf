"""The drive's firmware under hil-bench: the papers' claims and the team's own limits.

CI runs these against hil-bench's bundled C firmware stub (``pytest``); on the bench the same
tests run against the drive (``pytest --hil-link serial:/dev/ttyUSB0@3000000``). Every run is
recorded; a failed test names its recording, and ``--junitxml`` carries the measured values.
"""
from __future__ import annotations

import numpy as np

import hil_bench


def test_sensorless_startup_reproduces_gong_g2(hil_run):
    """Standstill -> 500 rpm with Gong's tanh SMO: the paper's figures (claim G2) hold."""
    result = hil_run("gong_g2_500rpm")
    result.assert_claims()          # on failure: the paper-vs-measured table and the recording


def test_1000rpm_meets_our_speed_and_angle_limits(hil_run):
    """Our own requirement at 1000 rpm, no load: speed within 1 % of the reference and the
    estimated angle within 0.05 rad of the true one over the last 0.5 s (measured on the
    bundled stub: -0.37 %..+0.15 % and 0.0215 rad). Not a paper's claim: the scenario is G2's
    with two values changed, and the limits are checked here on the recording itself."""
    result = hil_run("gong_g2_500rpm", overrides={"controller.speed_ref_rpm": 1000,
                                                  "scenario.claims": []})
    assert result.integrity.ok, result.summary()
    rec = hil_bench.load_recording(result.recording,
                                   channels=["/plant/state", "/controller/telemetry"])
    state, telem = rec["/plant/state"], rec["/controller/telemetry"]
    settled = state.loc[1.0:]                           # indexed by the plant's time t_s [s]
    speed_error = (settled.speed_rpm - 1000.0) / 1000.0
    assert np.abs(speed_error).max() < 0.01, f"speed error up to {speed_error.abs().max():.2%}"
    angle_error = telem.loc[1.0:].pee_rad              # estimated minus true, wrapped [rad]
    assert np.abs(angle_error).max() < 0.05, f"angle error up to {angle_error.abs().max():.4f} rad"


def test_link_and_recording_are_clean(hil_run, hil_link):
    """Every cycle ran, no frame was lost or damaged, the recording is whole."""
    result = hil_run("gong_g2_500rpm", overrides={"scenario.duration_s": 0.3,
                                                  "metrics.window_s": [0.1, 0.3],
                                                  "scenario.claims": []})
    assert result.integrity.ok, result.summary()
    assert result.run.cycles_done == result.run.cycles_planned == 3000
    counters = result.integrity.counters
    assert counters["crc_errors"] == counters["missed_duty"] == counters["rows_dropped"] == 0
    assert result.run.link == hil_link.spec
