"""Python API of the plant: construction and overrides, snapshot layout and copies, timing
contract, conventions, reset/initial/load, the missing-module error (per-call overhead: bench/perf/plant_step.py, a benchmark)."""
from __future__ import annotations

import dataclasses
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from hil_bench.plant_rt.plant import (
    SNAPSHOT_DTYPE,
    SNAPSHOT_FIELDS,
    SNAPSHOT_SIZE,
    Plant,
    ffi,
    lib,
    snapshot_array,
    snapshot_buffer,
)
from hil_bench.plant_rt.profile import ProfileError, load_profile

ROOT = Path(__file__).resolve().parents[1]


def test_from_profile_and_params_view():
    plant = Plant.from_profile("gong2020")
    prof = load_profile("gong2020")
    assert plant.params.as_dict() == prof.plant_params()
    with pytest.raises(dataclasses.FrozenInstanceError):
        plant.params.ld_h = 1.0  # type: ignore[misc]
    assert plant.profile.name == "gong2020"
    assert plant.t_s == 0.0


def test_overrides_are_applied_and_validated():
    plant = Plant.from_profile("hou2021", t_delay_s=0.0, substeps=2, v_dc_v=310)
    assert plant.params.t_delay_s == 0.0 and plant.params.substeps == 2
    assert plant.params.v_dc_v == 310.0 and isinstance(plant.params.v_dc_v, float)
    with pytest.raises(ProfileError, match=r"^plant_rt/profiles/gong2020\.toml \(with overrides\): "
                                           r"motor\.ld_h: must be > 0, got -0\.002$"):
        Plant.from_profile("gong2020", ld_h=-0.002)
    with pytest.raises(ProfileError, match=r"drive\.t_delay_s: must be <= ts_s"):
        Plant.from_profile("gong2020", t_delay_s=2e-4)
    with pytest.raises(ProfileError, match=r"overrides\.ld: unknown key \(did you mean 'ld_h'\?\)"):
        Plant.from_profile("gong2020", ld=1e-3)
    with pytest.raises(ProfileError, match=r"simulation\.substeps: must be an integer"):
        Plant.from_profile("gong2020", substeps=2.5)
    with pytest.raises(ProfileError, match=r"mechanics\.j_kgm2: must be > 0"):
        Plant.from_profile("gong2020", j_kgm2=0)


BASE_SNAPSHOT_FIELDS = (  # the original 27 fields: names and order are part of the API
    "t_s", "i_a_a", "i_b_a", "i_c_a", "i_alpha_a", "i_beta_a", "i_d_a", "i_q_a",
    "omega_m_rad_s", "omega_e_rad_s", "theta_e_rad", "theta_m_rad", "torque_e_nm", "torque_load_nm",
    "e_alpha_v", "e_beta_v", "v_dc_v", "v_a_v", "v_b_v", "v_c_v", "v_alpha_v", "v_beta_v",
    "v_d_v", "v_q_v", "duty_a", "duty_b", "duty_c")


def test_snapshot_dtype_matches_c_layout():
    assert SNAPSHOT_DTYPE.itemsize == SNAPSHOT_SIZE == 30 * 8
    assert SNAPSHOT_FIELDS[:27] == BASE_SNAPSHOT_FIELDS     # appended fields only
    assert SNAPSHOT_FIELDS[27:] == ("psi_alpha_wb", "psi_beta_wb", "torque_friction_nm")
    assert "theta_e_rad" in SNAPSHOT_FIELDS and "v_q_v" in SNAPSHOT_FIELDS
    plant = Plant.from_profile("gong2020")
    plant.set_initial(1.0, 30.0)
    for _ in range(5):
        plant.step(0.6, 0.45, 0.5)
    live = plant.snapshot()
    rec = snapshot_array(3)
    buf = snapshot_buffer(rec)
    plant.snapshot_to(buf, 1)
    ffi.memmove(buf + 2, live, SNAPSHOT_SIZE)
    d = plant.snapshot_dict()
    assert tuple(d) == SNAPSHOT_FIELDS
    for name in SNAPSHOT_FIELDS:
        assert rec[1][name] == d[name] == getattr(live, name) == rec[2][name], name
    assert rec[0]["t_s"] == 0.0
    with pytest.raises(ValueError):
        snapshot_buffer(np.zeros(3))


def test_snapshot_is_live_object():
    plant = Plant.from_profile("gong2020")
    s = plant.snapshot()
    plant.step(0.7, 0.3, 0.5)
    assert plant.snapshot() is s  # same cdata, refreshed
    assert s.t_s == pytest.approx(1e-4)


def test_run_equals_step_loop():
    duties = np.array([[0.6, 0.4, 0.5], [0.62, 0.38, 0.5], [-1.0, 0.4, 0.6], [0.5, 0.5, 0.5]])
    a = Plant.from_profile("hou2021")
    b = Plant.from_profile("hou2021")
    for p in (a, b):
        p.set_initial(0.3, 20.0)
    out = a.run(duties)
    for k, row in enumerate(duties):
        b.step(*row)
        snap = b.snapshot_dict()
        for name in SNAPSHOT_FIELDS:
            assert out[k][name] == snap[name], (k, name)
    with pytest.raises(ValueError):
        a.run(np.zeros((4, 2)))


def test_timing_contract_and_duty_report():
    """Snapshot after step k is at t_{k+1}; new duties act from t_delay on; disabled = -1."""
    plant = Plant.from_profile("gong2020", j_kgm2=1e9)
    p = plant.params
    plant.step(0.8, 0.5, 0.2)  # v_a = 0.3 V_dc after the delay, v_c = -0.3 V_dc
    s = plant.snapshot()
    assert s.t_s == pytest.approx(p.ts_s, rel=1e-15)
    assert s.v_a_v == pytest.approx(0.3 * p.v_dc_v * (p.ts_s - p.t_delay_s) / p.ts_s, rel=1e-12)
    assert (s.duty_a, s.duty_b, s.duty_c) == (0.8, 0.5, 0.2)
    plant.step(1.7, float("nan"), -0.2)
    s = plant.snapshot()
    assert (s.duty_a, s.duty_b, s.duty_c) == (1.0, -1.0, -1.0)
    for _ in range(8):
        plant.step(0.5, 0.5, 0.5)
    assert plant.t_s == pytest.approx(10 * p.ts_s, rel=1e-15)


def test_conventions_emf_torque_and_load_sign():
    plant = Plant.from_profile("gong2020")
    plant.set_initial(-0.4, 50.0)
    s = plant.snapshot()
    th = 2 * math.pi - 0.4
    we = 4 * 50.0
    assert s.theta_e_rad == pytest.approx(th)
    assert s.e_alpha_v == pytest.approx(-we * 0.085 * math.sin(th))
    assert s.e_beta_v == pytest.approx(we * 0.085 * math.cos(th))
    # positive load at standstill drives the rotor backwards (active load, opposes + rotation)
    plant.reset()
    plant.set_load_torque(0.5)
    for _ in range(100):
        plant.step(0.5, 0.5, 0.5)
    s = plant.snapshot()
    assert s.omega_m_rad_s < 0.0 and s.torque_load_nm == 0.5
    # a voltage on the q axis at standstill gives positive i_q, positive torque, forward motion
    plant.reset()
    plant.set_initial(0.0, 0.0)  # d axis on alpha -> q axis on beta: v_beta > 0
    m = 0.02
    for _ in range(200):
        plant.step(0.5, 0.5 + m * math.sqrt(3) / 2, 0.5 - m * math.sqrt(3) / 2)
    s = plant.snapshot()
    assert s.i_q_a > 0.5 and s.torque_e_nm > 0.0 and s.omega_m_rad_s > 0.0
    assert s.i_alpha_a == pytest.approx(s.i_a_a)
    assert s.i_beta_a == pytest.approx((s.i_a_a + 2 * s.i_b_a) / math.sqrt(3))
    assert s.i_a_a + s.i_b_a + s.i_c_a == pytest.approx(0.0, abs=1e-12)


def test_reset_and_set_initial():
    plant = Plant.from_profile("gong2020")
    plant.set_initial(7.0, 12.0)  # wrapped
    s = plant.snapshot()
    assert s.theta_e_rad == pytest.approx(7.0 - 2 * math.pi)
    assert s.theta_m_rad == pytest.approx((7.0 - 2 * math.pi) / 4)
    for _ in range(10):
        plant.step(0.55, 0.5, 0.45)
    plant.reset()
    d = plant.snapshot_dict()
    for name in SNAPSHOT_FIELDS:
        if name.startswith("duty_"):
            assert d[name] == 0.5
        elif name == "psi_alpha_wb":  # theta_e = 0, no current: the PM flux on alpha
            assert d[name] == plant.params.psi_f_wb
        elif name != "v_dc_v":
            assert d[name] == 0.0, name
    assert plant.events == 0


def test_energy_bookkeeping_from_python():
    plant = Plant.from_profile("hou2021")
    for k in range(300):
        ang = 2 * math.pi * k / 150
        plant.step(0.5 + 0.05 * math.cos(ang), 0.5 + 0.05 * math.cos(ang - 2.094), 0.5 + 0.05 * math.cos(ang + 2.094))
    e = plant.energy()
    stored = e["magnetic_j"] + e["kinetic_j"]
    losses = e["copper_loss_j"] + e["viscous_loss_j"] + e["load_work_j"]
    assert e["electrical_in_j"] > 0.01
    assert e["electrical_in_j"] == pytest.approx(stored + losses, rel=1e-9)


def test_missing_compiled_module_says_make_build():
    code = (
        "import sys, importlib.abc\n"
        "class Block(importlib.abc.MetaPathFinder):\n"
        "    def find_spec(self, name, path, target=None):\n"
        "        if name == 'hil_bench.plant_rt._plant_c':\n"
        "            raise ImportError('blocked for the test')\n"
        "sys.meta_path.insert(0, Block())\n"
        "try:\n"
        "    import hil_bench.plant_rt.plant\n"
        "except ImportError as e:\n"
        "    print(e)\n"
        "    sys.exit(3)\n"
    )
    res = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=60)
    assert res.returncode == 3, res.stderr
    assert "make build" in res.stdout




# ------------------------------------------------------------------------------------------------
# non-idealities in the Python API

def test_new_parameters_are_flat_overridable_and_visible():
    plant = Plant.from_profile("yuan2020", inverter_nonlinear=True, dead_time_s=1.5e-6, adc_model=True,
                               adc_seed=3, load_profile="step", load_t0_s=0.01, load_torque1_nm=0.4)
    prm = plant.params
    assert prm.inverter_nonlinear is True and prm.dead_time_s == 1.5e-6
    assert prm.adc_model is True and prm.adc_seed == 3 and prm.load_profile == "step"
    assert prm.v_switch_drop_v == load_profile("yuan2020").v_switch_drop_v   # the profile's value
    d = prm.as_dict()
    assert list(d)[:11] == ["rs_ohm", "ld_h", "lq_h", "psi_f_wb", "pole_pairs", "j_kgm2", "b_nms",
                            "v_dc_v", "ts_s", "t_delay_s", "substeps"]
    assert d["dead_time_s"] == 1.5e-6
    prof = load_profile("yuan2020")
    assert prof.dead_time_s == prof.nonideal["dead_time_s"]           # attribute access on profiles
    with pytest.raises(AttributeError):
        prof.no_such_field  # noqa: B018


def test_sample_is_live_and_dyno_and_load_api():
    plant = Plant.from_profile("gong2020", dual_sampling=True, load_profile="ramp", load_t0_s=0.0,
                               load_t1_s=1.0, load_torque1_nm=2.0)
    m = plant.sample()
    plant.step(0.55, 0.5, 0.45)
    assert plant.sample() is m and m.t_s == pytest.approx(1e-4) and m.dual_valid == 1
    assert plant.load_torque_at(0.5) == pytest.approx(1.0)
    plant.set_load_torque(0.25)
    assert plant.load_torque_at(0.5) == pytest.approx(1.25)
    dyno = Plant.from_profile("gong2020", dyno=True, dyno_speed_rad_s=5.0)
    dyno.set_dyno_speed(7.0)
    dyno.step(0.5, 0.5, 0.5)
    assert dyno.snapshot().omega_m_rad_s == 7.0
