"""Estimator test inputs from the C plant: what a controller's ISR would see, plus the truth.

``trajectory`` spins the plant at a (nearly) constant speed with a rotor-synchronous voltage
(very large inertia, so the speed stays put), and returns per cycle k: the currents sampled at
t_k, the alpha-beta voltage applied over [t_{k-1}, t_k] (from the duties), and the true angle,
speed and back EMF at t_k.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from hil_bench.plant_rt.plant import Plant
from hil_bench.plant_rt.verify import openloop

RPM = 2.0 * math.pi / 60.0


@dataclass
class Trajectory:
    ts_s: float
    i_alpha_a: np.ndarray
    i_beta_a: np.ndarray
    v_alpha_prev_v: np.ndarray
    v_beta_prev_v: np.ndarray
    theta_e_rad: np.ndarray
    omega_e_rad_s: np.ndarray
    e_alpha_v: np.ndarray
    e_beta_v: np.ndarray

    def __len__(self) -> int:
        return len(self.theta_e_rad)


def duties_to_alphabeta(duties: np.ndarray, v_dc_v: float) -> tuple[np.ndarray, np.ndarray]:
    """The alpha-beta voltage an averaged inverter realises from (n, 3) duties."""
    v = duties * v_dc_v
    v = v - v.mean(axis=1, keepdims=True)
    return (2 * v[:, 0] - v[:, 1] - v[:, 2]) / 3.0, (v[:, 1] - v[:, 2]) / math.sqrt(3.0)


def trajectory(profile: str = "gong2020", speed_rpm: float = 500.0, n: int = 5000,
               i_q_a: float = 1.0, i_d_a: float = 0.0, theta0_rad: float = 0.3,
               **plant_overrides) -> Trajectory:
    plant = Plant.from_profile(profile, j_kgm2=1e3, **plant_overrides)
    p = plant.params
    w_m = speed_rpm * RPM
    w_e = w_m * p.pole_pairs
    v_d, v_q = openloop.operating_point_voltage(p, w_e, i_d_a, i_q_a)
    duties = openloop.synchronous(p, n, theta_e0_rad=theta0_rad, omega_e_rad_s=w_e, v_d_v=v_d,
                                  v_q_v=v_q)
    plant.set_initial(theta0_rad, w_m)
    plant.set_load_torque(1.5 * p.pole_pairs * p.psi_f_wb * i_q_a)   # hold the speed
    snaps = plant.run(duties)   # snapshot after each period: the state at t_{k+1}
    first = plant  # the state before the first step is the initial one
    cols = {f: np.empty(n) for f in ("i_alpha_a", "i_beta_a", "theta_e_rad", "omega_e_rad_s",
                                     "e_alpha_v", "e_beta_v")}
    # sample k is the state at t_k: t_0 is the initial state, t_k (k >= 1) follows step k-1
    for f in cols:
        cols[f][1:] = snaps[f][:-1]
    cols["i_alpha_a"][0] = cols["i_beta_a"][0] = 0.0
    cols["theta_e_rad"][0] = theta0_rad
    cols["omega_e_rad_s"][0] = w_e
    cols["e_alpha_v"][0] = -w_e * p.psi_f_wb * math.sin(theta0_rad)
    cols["e_beta_v"][0] = w_e * p.psi_f_wb * math.cos(theta0_rad)
    del first
    va, vb = duties_to_alphabeta(duties, p.v_dc_v)
    # the voltage applied over [t_{k-1}, t_k] is the one commanded at k-1 (none before k = 0)
    v_alpha_prev = np.concatenate([[0.0], va[:-1]])
    v_beta_prev = np.concatenate([[0.0], vb[:-1]])
    return Trajectory(p.ts_s, cols["i_alpha_a"], cols["i_beta_a"], v_alpha_prev, v_beta_prev,
                      cols["theta_e_rad"], cols["omega_e_rad_s"], cols["e_alpha_v"],
                      cols["e_beta_v"])


def wrap_pi(x):
    return (np.asarray(x) + math.pi) % (2 * math.pi) - math.pi
