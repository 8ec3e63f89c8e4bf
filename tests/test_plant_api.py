"""Python API of the plant: construction and overrides, snapshot layout and copies, timing
contract, conventions, reset/initial/load, the missing-module error (per-call overhead: plant_rt/bench_step.py, a benchmark)."""
from __future__ import annotations

import dataclasses
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from plant_rt.plant import (
    SNAPSHOT_DTYPE,
    SNAPSHOT_FIELDS,
    SNAPSHOT_SIZE,
    Plant,
    ffi,
    lib,
    snapshot_array,
    snapshot_buffer,
)
from plant_rt.profile import ProfileError, load_profile

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


def test_snapshot_dtype_matches_c_layout():
    assert SNAPSHOT_DTYPE.itemsize == SNAPSHOT_SIZE == 27 * 8
    assert SNAPSHOT_FIELDS[0] == "t_s" and SNAPSHOT_FIELDS[-1] == "duty_c"
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
        "        if name == 'plant_rt._plant_c':\n"
        "            raise ImportError('blocked for the test')\n"
        "sys.meta_path.insert(0, Block())\n"
        "try:\n"
        "    import plant_rt.plant\n"
        "except ImportError as e:\n"
        "    print(e)\n"
        "    sys.exit(3)\n"
    )
    res = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=60)
    assert res.returncode == 3, res.stderr
    assert "make build" in res.stdout


