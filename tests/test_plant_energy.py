"""Energy balance over a run, for every non-ideality and all together:

    dc_bus_in      = electrical_in + inverter_loss                     (bookkeeping, to rounding)
    electrical_in  = copper + viscous + coulomb + load_work + d(magnetic + kinetic)

The second identity holds for the exact solution; the integrator keeps it to its truncation
error. Tolerance (plant_rt/README.md "Verification"): 1e-7 of the energy moved (the sum of the
magnitudes of every term). Measured on the runs below: ideal 2.0e-10, saturation 3.1e-10,
Coulomb 2.0e-10, load table 1.9e-10, inverter non-linearity 2.0e-9 / 2.8e-9 (the kinks of |i|
and the C1 capacitance sign cost RK4 order), everything together 9.7e-9; the C test's hardest
case (tests/c/test_plant_nonideal.c, an IPMSM spin-up with every effect) 2.8e-8.
"""
from __future__ import annotations

import math

import pytest

from hil_bench.plant_rt.plant import Plant
from hil_bench.plant_rt.profile import load_profile

TOL_REL = 1e-7


def _vf_run(plant: Plant, n=4000, f_hz=30.0, t_ramp=0.2, boost=8.0, load_at=None, load_nm=0.0):
    p = plant.params
    for k in range(n):
        t = k * p.ts_s
        th = 2 * math.pi * f_hz * (t * t / (2 * t_ramp) if t < t_ramp else t - 0.5 * t_ramp)
        vmag = boost + 2 * math.pi * f_hz * min(t / t_ramp, 1.0) * p.psi_f_wb
        if load_at is not None and k == load_at:
            plant.set_load_torque(load_nm)
        plant.step(*(0.5 + vmag / p.v_dc_v * math.cos(th + 0.5 * math.pi - 2 * math.pi / 3 * x) for x in range(3)))


def _residuals(plant: Plant, kinetic0: float = 0.0):
    e = plant.energy()
    machine = e["electrical_in_j"] - (e["copper_loss_j"] + e["viscous_loss_j"] + e["coulomb_loss_j"]
                                      + e["load_work_j"] + e["magnetic_j"] + e["kinetic_j"] - kinetic0)
    dc = e["dc_bus_in_j"] - (e["electrical_in_j"] + e["inverter_loss_j"])
    moved = sum(abs(e[k]) for k in ("copper_loss_j", "viscous_loss_j", "coulomb_loss_j", "load_work_j",
                                    "magnetic_j", "kinetic_j", "inverter_loss_j"))
    return machine, dc, moved, e


CASES = {
    "ideal": ("hou2021", {}),
    "inverter": ("hou2021", dict(inverter_nonlinear=True)),
    "saturation": ("hou2021", dict(saturation=True)),
    "coulomb": ("hou2021", dict(coulomb_nm=0.1, coulomb_band_rad_s=0.5)),
    "load_table": ("hou2021", dict(load_profile="table", load_table_t_s=[0.25, 0.3, 0.35],
                                   load_table_nm=[0.0, 2.0, 1.0])),
    "everything": ("hou2021", dict(inverter_nonlinear=True, saturation=True, coulomb_nm=0.1,
                                   coulomb_band_rad_s=0.5, load_profile="ramp", load_t0_s=0.25,
                                   load_t1_s=0.3, load_torque1_nm=1.5, full_period_delay=True,
                                   adc_model=True, dual_sampling=True)),
    "yuan_inverter": ("yuan2020", dict(inverter_nonlinear=True)),
}


@pytest.mark.parametrize("name", sorted(CASES))
def test_energy_balance(name):
    prof_name, ov = CASES[name]
    plant = Plant(load_profile(prof_name), **ov)
    _vf_run(plant, boost=12.0 if prof_name == "yuan2020" else 8.0, load_at=3000, load_nm=0.5)
    machine, dc, moved, e = _residuals(plant)
    assert moved > 5.0
    assert abs(machine) < TOL_REL * moved, (machine, moved)
    assert abs(dc) < 1e-13 * moved
    if ov.get("inverter_nonlinear"):
        assert e["inverter_loss_j"] > 0.01
    else:
        assert e["inverter_loss_j"] == 0.0
    if ov.get("coulomb_nm"):
        assert e["coulomb_loss_j"] > 0.01


def test_energy_balance_dyno():
    prof = load_profile("gong2020")
    plant = Plant(prof, dyno=True, dyno_speed_rad_s=20.0, dyno_accel_rad_s2=100.0, inverter_nonlinear=True,
                  coulomb_nm=0.05, coulomb_band_rad_s=0.5)
    for k in range(3000):
        if k == 1000:
            plant.set_dyno_speed(40.0)
        if k == 2000:
            plant.set_dyno_speed(-10.0)
        th = 4 * 30.0 * k * prof.ts_s
        plant.step(*(0.5 + 0.04 * math.cos(th - 2 * math.pi / 3 * x) for x in range(3)))
    machine, dc, moved, e = _residuals(plant, kinetic0=0.5 * prof.j_kgm2 * 400.0)
    assert abs(machine) < TOL_REL * moved, (machine, moved)
    assert e["load_work_j"] != 0.0


def test_balance_would_catch_a_missing_term():
    """Sanity of the tolerance: leaving the inverter loss out of the DC balance, or the Coulomb
    loss out of the machine balance, misses by orders of magnitude more than TOL_REL."""
    plant = Plant(load_profile("hou2021"), inverter_nonlinear=True, coulomb_nm=0.1, coulomb_band_rad_s=0.5)
    _vf_run(plant)
    machine, dc, moved, e = _residuals(plant)
    assert abs(machine + e["coulomb_loss_j"]) > 1e3 * TOL_REL * moved
    assert abs(e["dc_bus_in_j"] - e["electrical_in_j"]) > 1e3 * TOL_REL * moved
