"""The C plant against the independent solve_ivp reference (plant_rt/verify/reference.py).

Tolerances come from the measured RK4 error bound (plant_rt/verify/error_study.py, see
plant_rt/README.md): at the default substeps = 4, the worst case over the three profiles at
2x rated speed (t_delay = 0, the longest steps) was
    current 1.13e-6 x rated current, speed 1.0e-6 rad/s, electrical angle 1.1e-8 rad.
The tolerances below are 10x those bounds. The open-loop scenarios here run far slower than
2x rated speed, so their true error is orders of magnitude smaller (measured ~4e-11 x rated);
a modelling error shows up above these levels: moving the delay instant by just 0.1 us (0.3 %)
changes the spin-up currents by 2.6e-5 x rated (test_wrong_delay_would_be_caught), a transform
or sign slip by amperes.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from hil_bench.plant_rt.plant import Plant, snapshot_array, snapshot_buffer
from hil_bench.plant_rt.profile import load_profile
from hil_bench.plant_rt.verify import openloop, reference
from hil_bench.plant_rt.verify.error_study import build_scenario, compare, plant_errors

CURRENT_TOL_REL = 1e-5    # x rated current (10x the measured 1.13e-6 worst case)
SPEED_TOL_RAD_S = 1e-5    # 10x the measured 1.0e-6 rad/s
ANGLE_TOL_RAD = 1e-7      # electrical and mechanical angle; 10x the measured 1.1e-8 rad
# the requirement the default substeps was chosen for
REQUIRED_CURRENT_REL = 1e-4

# open-loop spin-up (V/f ramp) + load step, per profile:
# (final electrical frequency [Hz], ramp [s], boost [V], periods, load-step period, load [N m])
SPIN_UP = {
    "gong2020": (15.0, 0.2, 6.0, 3000, 2500, 1.0),   # SPMSM, Ld = Lq, J = 0.013
    "hou2021": (25.0, 0.1, 4.0, 2000, 1500, 2.0),    # IPMSM, Ld != Lq, J = 0.00107
}


def _run_plant(plant: Plant, duties: np.ndarray, load_step_k: int, load_nm: float) -> np.ndarray:
    """Step the plant like a bench would: one call per period, load step between periods."""
    out = snapshot_array(len(duties))
    buf = snapshot_buffer(out)
    for k, (a, b, c) in enumerate(duties):
        if k == load_step_k:
            plant.set_load_torque(load_nm)
        plant.step(a, b, c)
        plant.snapshot_to(buf, k)
    return out


@pytest.mark.parametrize("name", sorted(SPIN_UP))
def test_spin_up_with_load_step_matches_reference(name):
    prof = load_profile(name)
    f_hz, t_ramp, boost, n, k_load, load = SPIN_UP[name]
    duties = openloop.vf_ramp(prof, n, f_final_hz=f_hz, t_ramp_s=t_ramp, v_boost_v=boost)
    load_per_period = np.where(np.arange(n) >= k_load, load, 0.0)
    ref = reference.simulate(prof, duties, load_torque_nm=load_per_period)
    out = _run_plant(Plant(prof), duties, k_load, load)

    # the scenario does what it says: spins up to ~synchronous speed, the load step bites
    w_sync = 2 * math.pi * f_hz / prof.pole_pairs
    assert ref.omega_m_rad_s[k_load] > 0.7 * w_sync
    assert ref.omega_m_rad_s[k_load:k_load + 200].min() < ref.omega_m_rad_s[k_load] - 0.5
    assert np.abs(ref.i_abc_a).max() > 0.5 * prof.rated["current_a"]

    err = compare(out, ref, prof.rated["current_a"])
    assert err["current_rel"] < CURRENT_TOL_REL, err
    assert err["speed_rad_s"] < SPEED_TOL_RAD_S, err
    assert err["theta_e_rad"] < ANGLE_TOL_RAD, err
    assert err["theta_m_rad"] < ANGLE_TOL_RAD, err
    # dq currents too (Park with the plant's own angle)
    assert np.abs(out["i_d_a"] - ref.i_d_a[1:]).max() < CURRENT_TOL_REL * prof.rated["current_a"]
    assert np.abs(out["i_q_a"] - ref.i_q_a[1:]).max() < CURRENT_TOL_REL * prof.rated["current_a"]
    # and the torque the mechanics saw
    assert np.abs(out["torque_e_nm"] - ref.torque_e_nm[1:]).max() < 1e-4 * prof.rated["torque_nm"]


def test_reference_frames_agree():
    """The reference's two formulations (stationary flux linkage vs dq currents) agree."""
    prof = load_profile("hou2021")
    duties = openloop.vf_ramp(prof, 400, f_final_hz=25.0, t_ramp_s=0.02, v_boost_v=4.0)
    a = reference.simulate(prof, duties)
    b = reference.simulate(prof, duties, frame="dq")
    assert np.abs(a.i_abc_a - b.i_abc_a).max() < 1e-9
    assert np.abs(a.omega_m_rad_s - b.omega_m_rad_s).max() < 1e-9
    assert np.abs(a.theta_m_rad - b.theta_m_rad).max() < 1e-10


@pytest.mark.parametrize("name", ["gong2020", "hou2021", "yuan2020"])
@pytest.mark.parametrize("t_delay_s", [None, 0.0])
def test_default_substeps_meets_the_requirement_at_2x_rated_speed(name, t_delay_s):
    """The error-study scenario (2x rated speed, zero-current start) at the profile's substeps."""
    prof = load_profile(name)
    sc = build_scenario(prof, 200, t_delay_s)
    err = plant_errors(sc, prof.substeps)
    assert err["current_rel"] < CURRENT_TOL_REL, err      # within the stated bound x10 ...
    assert err["current_rel"] < REQUIRED_CURRENT_REL, err  # ... and the requirement


def test_rk4_converges_with_fourth_order():
    """Halving the step divides the error by ~16 (t_delay = 0: every step is Ts/substeps).
    Catches anything that would break the order, e.g. a duty switch inside a step."""
    sc = build_scenario(load_profile("gong2020"), 200, 0.0)
    e2 = plant_errors(sc, 2)["current_a"]
    e4 = plant_errors(sc, 4)["current_a"]
    e8 = plant_errors(sc, 8)["current_a"]
    assert 12.0 < e2 / e4 < 20.0, (e2, e4)
    assert 12.0 < e4 / e8 < 20.0, (e4, e8)


def test_delay_split_is_exact_with_any_substeps():
    """With the delay 0.341 Ts, every substeps splits exactly at the delay instant: the error
    keeps decreasing monotonically and substeps=1 is already accurate (2 RK4 steps)."""
    sc = build_scenario(load_profile("gong2020"), 200)
    errs = [plant_errors(sc, n)["current_rel"] for n in (1, 2, 4, 8)]
    assert errs == sorted(errs, reverse=True)
    assert errs[0] < 1e-3


def test_wrong_delay_would_be_caught():
    """Sanity check of the tolerance: a plant whose delay is off by only 0.1 us fails it."""
    prof = load_profile("gong2020")
    f_hz, t_ramp, boost, _, _, _ = SPIN_UP["gong2020"]
    duties = openloop.vf_ramp(prof, 500, f_final_hz=f_hz, t_ramp_s=t_ramp, v_boost_v=boost)
    ref = reference.simulate(prof, duties)
    good = compare(Plant(prof).run(duties), ref, prof.rated["current_a"])
    bad = compare(Plant(prof, t_delay_s=prof.t_delay_s + 0.1e-6).run(duties), ref, prof.rated["current_a"])
    assert good["current_rel"] < CURRENT_TOL_REL
    assert bad["current_rel"] > 2 * CURRENT_TOL_REL
    assert good["current_rel"] < 1e-3 * CURRENT_TOL_REL  # the true error is far below the tolerance
