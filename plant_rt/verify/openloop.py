"""Open-loop duty sequences (no controller) for plant tests, the integrator error study and
cross-checks against other models. Everything is precomputed: the same (n, 3) array can be fed
to Plant.run and to hil_bench.plant_rt.verify.reference.simulate.
"""
from __future__ import annotations

import math
from typing import Any

import numpy as np

_S3 = math.sqrt(3.0)


def duties_from_alphabeta(v_alpha_v: np.ndarray, v_beta_v: np.ndarray, v_dc_v: float,
                          clip: bool = True) -> np.ndarray:
    """(n, 3) center-aligned duties realising phase voltages (v_alpha, v_beta) [V] on v_dc_v.

    Min-max (common-mode) injection, i.e. SVPWM: linear up to |v| = v_dc/sqrt(3). Outside that
    the duties are clipped to [0, 1] if clip, else a ValueError is raised.
    """
    va = np.asarray(v_alpha_v, dtype=float)
    vb = np.asarray(v_beta_v, dtype=float)
    v = np.stack([va, -0.5 * va + 0.5 * _S3 * vb, -0.5 * va - 0.5 * _S3 * vb], axis=-1)
    v -= 0.5 * (v.max(axis=-1, keepdims=True) + v.min(axis=-1, keepdims=True))
    d = 0.5 + v / v_dc_v
    if not clip and (d.min() < 0.0 or d.max() > 1.0):
        raise ValueError("voltage beyond the linear modulation range")
    return np.clip(d, 0.0, 1.0)


def vf_ramp(params: Any, n: int, *, f_final_hz: float, t_ramp_s: float, v_boost_v: float,
            v_per_rad_s: float | None = None, lead_rad: float = 0.5 * math.pi,
            theta0_rad: float = 0.0) -> np.ndarray:
    """V/f start-up: a voltage vector rotating at an electrical frequency that ramps linearly
    from 0 to f_final_hz over t_ramp_s, then holds. Amplitude v_boost_v + v_per_rad_s * omega_e
    (default v_per_rad_s = psi_f, i.e. the back EMF), placed lead_rad ahead of the ideal
    rotor angle (pi/2: on the q axis if the rotor follows). params: a MotorProfile/PlantParams.
    The vector for period k is evaluated at the middle of the interval it acts on.
    """
    ts, td = params.ts_s, params.t_delay_s
    kv = params.psi_f_wb if v_per_rad_s is None else v_per_rad_s
    t_mid = np.arange(n) * ts + td + 0.5 * ts
    w_final = 2.0 * math.pi * f_final_hz
    w = w_final * np.minimum(t_mid / t_ramp_s, 1.0)
    theta = np.where(t_mid < t_ramp_s, 0.5 * w_final * t_mid**2 / t_ramp_s,
                     w_final * (t_mid - 0.5 * t_ramp_s))
    amp = v_boost_v + kv * w
    ang = theta0_rad + theta + lead_rad
    return duties_from_alphabeta(amp * np.cos(ang), amp * np.sin(ang), params.v_dc_v)


def synchronous(params: Any, n: int, *, theta_e0_rad: float, omega_e_rad_s: float,
                v_d_v: float, v_q_v: float, v_dc_v: float | None = None) -> np.ndarray:
    """Rotor-synchronous voltage (v_d, v_q) [V] for a rotor turning at a constant omega_e from
    theta_e0; the vector of period k is placed at the rotor angle of the middle of the interval
    it acts on (t_k + t_delay + Ts/2)."""
    ts, td = params.ts_s, params.t_delay_s
    vdc = params.v_dc_v if v_dc_v is None else v_dc_v
    th = theta_e0_rad + omega_e_rad_s * (np.arange(n) * ts + td + 0.5 * ts)
    va = v_d_v * np.cos(th) - v_q_v * np.sin(th)
    vb = v_d_v * np.sin(th) + v_q_v * np.cos(th)
    return duties_from_alphabeta(va, vb, vdc, clip=False)


def operating_point_voltage(params: Any, omega_e_rad_s: float, i_d_a: float,
                            i_q_a: float) -> tuple[float, float]:
    """Steady-state dq voltages [V] for constant currents at a constant electrical speed."""
    v_d = params.rs_ohm * i_d_a - omega_e_rad_s * params.lq_h * i_q_a
    v_q = params.rs_ohm * i_q_a + omega_e_rad_s * (params.ld_h * i_d_a + params.psi_f_wb)
    return v_d, v_q
