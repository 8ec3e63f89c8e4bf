"""The plant against gym-electric-motor's PMSM (an independent, widely used model): same motor
parameters and dq voltages -> currents and speed agree within 1 % (of each signal's peak over
the run). Measured: i_d 1.2e-3, i_q 1.6e-4, speed 2e-5, torque 1.6e-4 (gong2020 and hou2021):
what remains is the within-period shape of u_dq (GEM holds u_dq, the plant holds u_alpha_beta;
plant_rt/verify/gem_compare.py)."""
from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("gym_electric_motor")

from hil_bench.plant_rt.profile import load_profile  # noqa: E402
from hil_bench.plant_rt.verify.gem_compare import run_gem, run_plant, voltage_program  # noqa: E402

TOL = 0.01
N = 3000


def _rel_err(a, b):
    return np.abs(a - b).max() / np.abs(a).max()


@pytest.mark.parametrize("name", ["gong2020", "hou2021"])
def test_currents_and_speed_agree_with_gem(name):
    prof = load_profile(name)
    u = voltage_program(prof, N)
    gem = run_gem(prof, u)
    plant = run_plant(prof, u)
    # the run covers the motor's range: rated-level currents, a good part of rated speed
    assert np.abs(gem["i_q_a"]).max() > prof.rated["current_a"]
    assert gem["omega_m_rad_s"].max() > 0.3 * prof.rated["speed_rad_s"]
    for key in ("i_d_a", "i_q_a", "omega_m_rad_s", "torque_e_nm"):
        assert _rel_err(gem[key], plant[key]) < TOL, key


def test_the_comparison_can_fail():
    """A 5 % error in one parameter (Rs) moves the trajectories by more than the 1 % criterion."""
    prof = load_profile("gong2020")
    u = voltage_program(prof, N)
    gem = run_gem(prof, u)
    import dataclasses

    wrong = dataclasses.replace(prof, rs_ohm=1.05 * prof.rs_ohm)
    plant = run_plant(wrong, u)
    assert max(_rel_err(gem[k], plant[k]) for k in ("i_d_a", "i_q_a", "omega_m_rad_s")) > TOL
